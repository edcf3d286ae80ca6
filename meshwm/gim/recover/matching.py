"""The position code of each N, and matching a seed window against it.

A window read around a seed (:func:`meshwm.gim.recover.seeds._read_windows`) is looked up in the
code of each candidate N, in the 8 symmetries of the square, by exact keys of 5 x 5 code cells
(:func:`_match_windows`), or, for the later pieces of a component whose N and winding are known,
by the code cells nearest the seed compared at every flipped code cell (:func:`_match_sparse`).
A candidate is kept when enough agreeing code cells are connected to the seed cell
(:func:`_check`); a match gives the seed's grid samples (:func:`_seed_samples`).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from meshwm.gim.code import code_cells, flipped_cells
from meshwm.gim.recover.seeds import _window

_KEY = 5  # side of the exactly matched key block (25 bits)
_KEYS = 6  # key blocks tried per window
_SPARSE = 16  # read code cells nearest the seed compared everywhere for a later piece
_MIN_BITS = 40  # code bits a window must agree on (all code cells on grids with fewer)

# The 8 symmetries of the square acting on (row, column) offsets: 4 rotations, then the 4
# rotations of the transpose (determinant -1: the mesh's winding is reversed).
_ROT = [np.array([[1, 0], [0, 1]]), np.array([[0, -1], [1, 0]])]
_ROT += [_ROT[1] @ _ROT[1], _ROT[1] @ _ROT[1] @ _ROT[1]]
_TRANSFORMS = [*_ROT, *[r @ np.array([[0, 1], [1, 0]]) for r in _ROT]]


class _Code(NamedTuple):
    """The code of one N: per cell, and on the lattice of cells (2I, 2J) with its border."""

    n: int
    cells: NDArray[np.int8]  # (N - 1, N - 1): 1 for a flipped cell
    bits: NDArray[np.int8]  # (H, H), H = N / 2: cell (2I, 2J), 0 on the border ring
    keys: NDArray[np.int64]  # sorted keys of every _KEY x _KEY block of ``bits``
    where: NDArray[np.int64]  # flat top-left (I * H + J) of each key
    min_bits: int


@functools.lru_cache(maxsize=8)
def _code(n: int) -> _Code:
    """The code of an N-grid (:func:`meshwm.gim.code.flipped_cells`) and its key index."""
    h = n // 2
    flip = flipped_cells(n)
    cells = np.zeros((n - 1, n - 1), dtype=np.int8)
    cells[flip[:, 0], flip[:, 1]] = 1
    bits = np.zeros((h, h), dtype=np.int8)
    bits[flip[:, 0] // 2, flip[:, 1] // 2] = 1
    # Key of the block with top-left (i, j): bit (i + a, j + b) at position _KEY * a + b.
    span = h - _KEY + 1
    wide = bits.astype(np.int64)
    row = np.zeros((h, span), dtype=np.int64)
    for b in range(_KEY):
        row += wide[:, b : b + span] << b
    block = np.zeros((span, span), dtype=np.int64)
    for a in range(_KEY):
        block += row[a : a + span] << (_KEY * a)
    keys = block.ravel()
    order = np.argsort(keys, kind="stable")
    i, j = np.divmod(np.arange(span * span), span)
    where = (i * h + j)[order]
    return _Code(n, cells, bits, keys[order], where, min(_MIN_BITS, len(code_cells(n))))


class _Match(NamedTuple):
    """A placement of a seed window in the code: N, orientation, position, and its bits."""

    disagree: int
    agree: int
    n: int
    transform: int
    i0: int  # code-lattice cell of the seed cell
    j0: int
    seed: int


def _key_centres(bits: NDArray[np.int8], k: int, count: int) -> list[tuple[int, int]]:
    """Centres of up to ``count`` fully read key blocks: the one nearest the seed, then each
    farthest from those taken (so that a part of the window that is wrong, across a seam, does
    not lose the window)."""
    full = np.lib.stride_tricks.sliding_window_view(bits >= 0, (_KEY, _KEY)).all(axis=(2, 3))
    r, c = np.nonzero(full)
    if not len(r):
        return []
    h = _KEY // 2
    r, c = r + h, c + h
    first = int(np.lexsort((c, r, (r - k) ** 2 + (c - k) ** 2))[0])
    taken = [first]
    gap = np.maximum(abs(r - r[first]), abs(c - c[first]))
    while len(taken) < count:
        nxt = int(np.argmax(gap))
        if gap[nxt] <= h:
            break
        taken.append(nxt)
        gap = np.minimum(gap, np.maximum(abs(r - r[nxt]), abs(c - c[nxt])))
    return [(int(r[t]), int(c[t])) for t in taken]


def _check(
    code: _Code,
    bits: NDArray[np.int8],
    cells: NDArray[np.int64],
    i0: int,
    j0: int,
    k: int,
    min_bits: int,
) -> tuple[int, int] | None:
    """(agreeing bits, disagreeing bits) of a placement if it is accepted, else None.

    ``bits`` is the window on the code lattice, ``cells`` its code cells turned into place
    (offsets from the seed cell).  The bits counted are the code cells that agree with the code
    and are connected to the seed cell through agreeing code cells: the local walk may have
    crossed a welded seam and come back into the grid elsewhere, and what it read there
    disagrees with the code half the time, so it neither counts nor spoils the rest.
    """
    n = code.n
    ci, cj = 2 * (cells[:, 0] + i0), 2 * (cells[:, 1] + j0)
    inside = (ci >= 2) & (cj >= 2) & (ci <= n - 4) & (cj <= n - 4)
    w = 2 * k + 1
    agree = np.zeros((w, w), dtype=bool)
    known = np.flatnonzero(bits.ravel() >= 0)
    same = np.zeros(len(known), dtype=bool)
    same[inside] = code.cells[ci[inside], cj[inside]] == bits.ravel()[known[inside]]
    agree.ravel()[known[same]] = True
    if not agree[k, k]:
        return None
    labels, _ = ndimage.label(agree)
    count = int(np.count_nonzero(labels == labels[k, k]))
    if count < min_bits:
        return None
    return count, int(np.count_nonzero(inside & ~same))


def _match_windows(states: NDArray[np.int8], codes: list[_Code], k: int) -> list[_Match]:
    """Every (N, orientation, position) at which a window agrees with the code.

    Candidates come from exact keys: blocks of _KEY x _KEY code cells read in full, the one
    nearest the seed and others spread over the window.  Each candidate is then checked on the
    whole window (see :func:`_check`).
    """
    win = _window(k)
    w = 2 * k + 1
    code_cell = win.code_slot >= 0
    r, c = np.divmod(np.arange(w * w), w)
    weights = 1 << np.arange(_KEY * _KEY, dtype=np.int64)
    h = _KEY // 2
    out = []
    for s in range(len(states)):
        flat_bits = np.full(w * w, -1, dtype=np.int8)
        flat_bits[win.code_slot[code_cell]] = states[s][code_cell]
        bits = flat_bits.reshape(w, w)
        centres = _key_centres(bits, k, _KEYS)
        known = np.flatnonzero(bits.ravel() >= 0)
        seen = set()
        for t, rot in enumerate(_TRANSFORMS):
            # Code-lattice offsets from the seed cell, turned: the window as it lies in the code.
            turned_cells = np.stack([r[known] - k, c[known] - k], axis=1) @ rot.T
            turned = np.full((w, w), -1, dtype=np.int8)
            turned[turned_cells[:, 0] + k, turned_cells[:, 1] + k] = bits.ravel()[known]
            for centre in centres:
                cr, cc = rot @ np.array([centre[0] - k, centre[1] - k])
                block = turned[cr + k - h : cr + k + h + 1, cc + k - h : cc + k + h + 1]
                key = int((block.ravel().astype(np.int64) * weights).sum())
                for code in codes:
                    hh = code.n // 2
                    lo, hi = np.searchsorted(code.keys, [key, key + 1])
                    for top in code.where[lo:hi].tolist():
                        ti, tj = divmod(top, hh)
                        i0, j0 = ti + h - cr, tj + h - cc
                        if (code.n, t, i0, j0) in seen:
                            continue
                        seen.add((code.n, t, i0, j0))
                        found = _check(code, bits, turned_cells, i0, j0, k, code.min_bits)
                        if found is not None:
                            out.append(_Match(found[1], found[0], code.n, t, i0, j0, s))
    return out


def _match_sparse(
    states: NDArray[np.int8], code: _Code, k: int, transforms: range, min_bits: int
) -> list[_Match]:
    """Like :func:`_match_windows` for one N and winding, without a full key block.

    For the later pieces of a component (N and winding known), often thin strips along a
    seam: the key is the _SPARSE read code cells nearest the seed, whatever their shape, and
    it is compared at every flipped code cell (the seed cell is one) in each rotation.
    """
    win = _window(k)
    w = 2 * k + 1
    code_cell = win.code_slot >= 0
    r, c = np.divmod(np.arange(w * w), w)
    flipped = np.argwhere(code.bits[1:-1, 1:-1] == 1) + 1  # code-lattice cells of the code
    out = []
    for s in range(len(states)):
        flat_bits = np.full(w * w, -1, dtype=np.int8)
        flat_bits[win.code_slot[code_cell]] = states[s][code_cell]
        known = np.flatnonzero(flat_bits >= 0)
        off = np.stack([r[known] - k, c[known] - k], axis=1)
        if len(known) < min_bits:
            continue
        near = np.argsort((off**2).sum(axis=1), kind="stable")[1 : _SPARSE + 1]
        bits = flat_bits.reshape(w, w)
        for t in transforms:
            rot = _TRANSFORMS[t]
            turned_cells = off @ rot.T
            key = turned_cells[near]
            ii = flipped[:, :1] + key[:, 0]
            jj = flipped[:, 1:] + key[:, 1]
            h = code.n // 2
            inside = (ii >= 0) & (ii < h) & (jj >= 0) & (jj < h)
            got = code.bits[np.clip(ii, 0, h - 1), np.clip(jj, 0, h - 1)]
            hit = np.all(inside & (got == bits.ravel()[known[near]]), axis=1)
            for i0, j0 in flipped[hit].tolist():
                found = _check(code, bits, turned_cells, i0, j0, k, min_bits)
                if found is not None:
                    out.append(_Match(found[1], found[0], code.n, t, i0, j0, s))
    return out


def _seed_samples(m: _Match) -> NDArray[np.int64]:
    """Grid samples (flat) of the seed cell's local (0, 0), (0, 1), (1, 0) under a match."""
    rot = _TRANSFORMS[m.transform]
    local = np.array([[0, 0], [0, 1], [1, 0]])
    # Cell centres map to cell centres: local (a, b) -> rot (a - 1/2, b - 1/2) + centre.
    shift = (1 - rot.sum(axis=1)) // 2
    ij = local @ rot.T + shift + 2 * np.array([m.i0, m.j0])
    return ij[:, 0] * m.n + ij[:, 1]
