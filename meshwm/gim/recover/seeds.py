"""Seed cells and the local reading of the window around each.

A seed is a flipped code cell found by its valence signature (:func:`_signature_seeds`); a few
are chosen per component, away from unclassed vertices and spread out (:func:`_choose_seeds`).
Around each, a walk that knows nothing of the code lays out a window of code cells and reads
every cell's diagonal (:func:`_read_windows`), for :mod:`meshwm.gim.recover.matching` to look up
in the code.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.recover.adjacency import _DEPTH, _Mesh

_SEEDS = 8  # seeds per component
_WINDOW = 5  # a seed window is 2 * _WINDOW + 1 code cells on a side
_WINDOW_PIECE = 8  # window of the later pieces of a component (N and winding known)


def _signature_seeds(mesh: _Mesh) -> NDArray[np.int64]:
    """(k, 3) vertices (p00, p01, p10) of every flipped code cell found by its valence pattern.

    A flipped cell has triangles (p00, p01, p10) and (p01, p11, p10): p00 and p11 of class E
    with valence 7, p01 and p10 of class O with valence 5.  Each cell is found from both of
    its triangles (the second gives the cell turned by 180 degrees); one is kept.
    """
    f, cls, val = mesh.faces, mesh.cls, mesh.valence
    e7 = (cls == 0) & (val == 7)
    o5 = (cls == 1) & (val == 5)
    found = []
    for k in range(3):
        x, y, z = f[:, k], f[:, (k + 1) % 3], f[:, (k + 2) % 3]
        hit = e7[x] & o5[y] & o5[z]
        x, y, z = x[hit], y[hit], z[hit]
        w, _ = mesh.lookup(z, y)
        keep = (w >= 0) & (x < w)
        keep[keep] &= e7[w[keep]]
        found.append(np.stack([x[keep], y[keep], z[keep]], axis=1))
    return np.concatenate(found)


def _choose_seeds(mesh: _Mesh, cells: NDArray[np.int64], count: int) -> NDArray[np.int64]:
    """Up to ``count`` of the seed cells, away from unclassed vertices and spread out.

    Spread by farthest-point sampling on the vertex positions, starting from the cell nearest
    the centroid of the candidates.  Positions only choose where to look: the grid that is read
    does not depend on them (every correct seed gives the same reading).
    """
    if len(cells) <= count:
        return cells
    good = mesh.depth()[cells].min(axis=1) >= _DEPTH
    if np.count_nonzero(good) >= count:
        cells = cells[good]
    p = mesh.vertices[cells[:, 0]]
    p = np.where(np.isfinite(p), p, 0.0)
    dist = np.linalg.norm(p - p.mean(axis=0), axis=1)
    chosen = [int(np.argmin(dist))]
    dist = np.linalg.norm(p - p[chosen[0]], axis=1)
    for _ in range(count - 1):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(p - p[nxt], axis=1))
    return cells[chosen]


class _Window(NamedTuple):
    """Local layout of a seed window: samples (a, b) for a, b in [-2K, 2K + 1]."""

    lo: int
    side: int  # samples per side
    rows: NDArray[np.int64]  # (r, 4) cell corners A, B, C, D counter-clockwise, every rotation
    parity_a: NDArray[np.int64]  # class of A (0 for a + b even)
    corners: NDArray[np.int64]  # (c, 4) q00, q01, q10, q11 of every cell
    cell_ab: NDArray[np.int64]  # (c, 2) local cell (a, b): its corner q00
    cell_parity: NDArray[np.int64]
    code_slot: NDArray[np.int64]  # flat slot of the cell in the (2K + 1)^2 code window, or -1


@functools.lru_cache(maxsize=2)
def _window(k: int) -> _Window:
    """The layout of a window of 2k + 1 code cells on a side, centred on the seed cell."""
    lo, hi = -2 * k, 2 * k + 1
    side = hi - lo + 1
    grid_a, grid_b = np.meshgrid(np.arange(lo, hi), np.arange(lo, hi), indexing="ij")
    a, b = grid_a.ravel(), grid_b.ravel()
    q00 = (a - lo) * side + (b - lo)
    q01, q10 = q00 + 1, q00 + side
    q11 = q10 + 1
    cycle = [q00, q01, q11, q10]
    rows = np.concatenate(
        [np.stack([cycle[(r + s) % 4] for s in range(4)], axis=1) for r in range(4)]
    )
    ra, ca = np.divmod(rows[:, 0], side)
    parity_a = (ra + ca + 2 * lo) % 2
    code = (a % 2 == 0) & (b % 2 == 0)
    slot = np.where(code, (a // 2 + k) * (2 * k + 1) + (b // 2 + k), -1)
    return _Window(
        lo,
        side,
        rows,
        parity_a,
        np.stack([q00, q01, q10, q11], axis=1),
        np.stack([a, b], axis=1),
        (a + b) % 2,
        slot,
    )


def _read_windows(mesh: _Mesh, seeds: NDArray[np.int64], k: int) -> NDArray[np.int8]:
    """The diagonal of every cell around each seed cell, read without knowing the code.

    Returns ``(s, cells)`` int8: 1 where the cell's diagonal joins its O corners (a flipped
    code cell, or something else if the cell is off the code lattice), 0 where it joins its E
    corners, -1 unread.  Where the walk contradicts itself (a position reached as two vertices,
    a vertex at two positions: the window wrapped around a cone at a cut end) the positions
    involved are dropped and nothing is read or walked through them.
    """
    win = _window(k)
    s, side = len(seeds), win.side
    size = side * side
    lookup, cls = mesh.lookup, mesh.cls
    idx = np.full((s, size), -1, dtype=np.int64)
    bad = np.zeros((s, size), dtype=bool)
    origin = -win.lo * side - win.lo
    idx[:, origin] = seeds[:, 0]
    idx[:, origin + 1] = seeds[:, 1]
    idx[:, origin + side] = seeds[:, 2]
    a_, b_, c_, d_ = win.rows.T
    flat, flat_bad = idx.ravel(), bad.ravel()
    while True:
        ia, ib = idx[:, a_], idx[:, b_]
        need = (ia >= 0) & (ib >= 0) & ((idx[:, c_] < 0) | (idx[:, d_] < 0))
        kk, rr = np.nonzero(need)
        if not len(kk):
            break
        u, v = ia[kk, rr], ib[kk, rr]
        x, _ = lookup(u, v)
        cx = np.where(x >= 0, cls[np.maximum(x, 0)], -1)
        pa = win.parity_a[rr]
        # x of A's class: triangle (A, B, C), and the cell's other one (A, C, D) has A -> C.
        # Otherwise triangle (A, B, D), and the other one (B, C, D) has D -> B.
        to_c = cx == pa
        sel = to_c | (cx == 1 - pa)
        kk, rr, u, v, x, to_c, pa = kk[sel], rr[sel], u[sel], v[sel], x[sel], to_c[sel], pa[sel]
        y, _ = lookup(np.where(to_c, u, x), np.where(to_c, x, v))
        cy = np.where(y >= 0, cls[np.maximum(y, 0)], -1)
        y_ok = (y >= 0) & ((cy < 0) | (cy == np.where(to_c, 1 - pa, pa)))
        kk = np.concatenate([kk, kk[y_ok]])
        target = np.concatenate(
            [np.where(to_c, c_[rr], d_[rr]), np.where(to_c, d_[rr], c_[rr])[y_ok]]
        )
        x = np.concatenate([x, y[y_ok]])
        slot = kk * size + target
        cur = flat[slot]
        flat_bad[slot[(cur >= 0) & (cur != x)]] = True
        new = (cur < 0) & ~flat_bad[slot]
        slot, x = slot[new], x[new]
        order = np.argsort(slot, kind="stable")
        slot, x = slot[order], x[order]
        same = slot[1:] == slot[:-1]
        flat_bad[slot[1:][same & (x[1:] != x[:-1])]] = True
        first = np.ones(len(slot), dtype=bool)
        first[1:] = ~same
        first &= ~flat_bad[slot]
        if not first.any():
            break
        flat[slot[first]] = x[first]
    # A vertex placed twice: drop both places.
    placed = np.flatnonzero(flat >= 0)
    key = (placed // size) * mesh.n_vertices + flat[placed]
    order = np.argsort(key, kind="stable")
    key, placed = key[order], placed[order]
    twice = np.zeros(len(key), dtype=bool)
    twice[1:] = key[1:] == key[:-1]
    twice[:-1] |= twice[1:]
    flat_bad[placed[twice]] = True
    idx[bad] = -1
    # Read the diagonal of every cell whose four corners are placed.
    q = idx[:, win.corners]  # (s, cells, 4)
    q00, q01, q10, q11 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    t1, _ = lookup(q00, q01)
    t2, _ = lookup(q11, q10)
    main = ((t1 == q11) | (t2 == q00)) & (q11 >= 0) & (q00 >= 0)
    anti = ((t1 == q10) | (t2 == q01)) & (q10 >= 0) & (q01 >= 0)
    flipped = np.where(win.cell_parity == 0, anti, main)
    return np.where(main ^ anti, flipped, -1).astype(np.int8)
