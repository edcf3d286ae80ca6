"""Reading each connected component: seeds, matches and walks, piece by piece.

Each component large enough to hold the code is read on its own (:func:`_read_components`): its
seed windows are matched (:mod:`meshwm.gim.recover.matching`), the matches walked and verified
in order of trust (:func:`_walk_matches`), and the parts of it connected to the rest only across
a welded seam are seeded again with N and winding known (:func:`_read_component`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.recover.adjacency import _Mesh
from meshwm.gim.recover.matching import (
    _TRANSFORMS,
    _Code,
    _Match,
    _match_sparse,
    _match_windows,
    _seed_samples,
)
from meshwm.gim.recover.propagate import _walk
from meshwm.gim.recover.seeds import (
    _SEEDS,
    _WINDOW,
    _WINDOW_PIECE,
    _choose_seeds,
    _read_windows,
    _signature_seeds,
)
from meshwm.gim.recover.table import _grid_table
from meshwm.gim.recover.verify import _consistent, _explained

_MIN_BITS_PIECE = 24  # code bits a later piece's window must agree on
_MIN_CELLS_PIECE = 4  # flipped code cells left unread for another piece to be looked for
_MAX_WALKS = 8  # full propagations tried per piece
_MAX_PIECES = 6  # pieces read per component (parts connected only across a welded seam)


class _Reading(NamedTuple):
    """What was read of one component (``index`` None: no piece verified)."""

    n: int
    index: NDArray[np.int64] | None  # type: ignore[assignment]  # shadows tuple.index
    faces: int  # faces explained
    hypotheses: int
    seeds: int


def _walk_matches(
    mesh: _Mesh,
    seeds: NDArray[np.int64],
    matches: list[_Match],
    base: NDArray[np.int64] | None,
    min_faces: int,
) -> tuple[NDArray[np.int64], NDArray[np.int64], int, bool] | None:
    """The first match whose walk verifies: (index, explained faces, N, reversed), or None.

    Clean matches nearest the grid centre are tried first, and before them all the clean
    matches that agree with the best one on N and winding together (many sources make the walk
    short).  A walk verifies if it meets no contradiction (with itself or with ``base``, the
    pieces of the component read before), explains no face twice, leaves no face between
    three interior samples unexplained, and explains at least ``min_faces`` new faces.
    """
    done = 0 if base is None else None
    mine = sorted(
        matches,
        key=lambda m: (m.disagree > 0, abs(2 * m.i0 - m.n // 2) + abs(2 * m.j0 - m.n // 2), m.n),
    )
    attempts = [[m] for m in mine]
    if mine:
        best = mine[0]
        group = [
            m
            for m in mine
            if m.disagree == 0 and m.n == best.n and (m.transform >= 4) == (best.transform >= 4)
        ]
        if len(group) > 1:
            attempts.insert(0, group)
    tried: list[tuple[int, bool, NDArray[np.int64]]] = []
    for group in attempts:
        m = group[0]
        samples = np.concatenate([_seed_samples(g) for g in group])
        start = np.concatenate([seeds[g.seed] for g in group])
        reverse = m.transform >= 4
        if any(
            tn == m.n and tr == reverse and np.array_equal(ti[samples], start)
            for tn, tr, ti in tried
        ):
            continue  # the same reading from another seed
        if len(tried) >= _MAX_WALKS:
            break
        table = _grid_table(m.n)
        lookup = mesh.lookup_for(reverse)
        index = _walk(table, lookup, samples, start, base, mesh.plain)
        if index is None:
            continue
        tried.append((m.n, reverse, index))
        found = _explained(index, table, lookup)
        if found is None or not _consistent(index, table, mesh.faces, found):
            continue
        if done is None:
            assert base is not None  # done is only unknown when pieces were read before
            before = _explained(base, table, lookup)
            assert before is not None  # base was verified: no face explained twice
            done = len(before)
        if len(found) - done >= min_faces:
            return index, found, m.n, reverse
    return None


def _read_component(
    mesh: _Mesh,
    cells: NDArray[np.int64],
    seeds: NDArray[np.int64],
    codes: list[_Code],
    min_faces: int,
) -> _Reading:
    """Read one connected component, piece by piece.

    A crop can leave parts of the grid that are connected to each other only across a welded
    seam, which the walk cannot cross (it does not know which border samples are welded).
    After the first piece, the seed cells not yet read are seeded again (same N and winding),
    until no piece of at least ``min_faces`` faces is left to read.
    """
    index, found = None, np.zeros(0, dtype=np.int64)
    n, reverse = 0, False
    hypotheses = seeded = 0
    for _ in range(_MAX_PIECES):
        if index is not None:
            assigned = np.zeros(mesh.n_vertices, dtype=bool)
            assigned[index[index >= 0]] = True
            cells = cells[~assigned[cells].any(axis=1)]
            if len(cells) < _MIN_CELLS_PIECE:
                break
            seeds = _choose_seeds(mesh, cells, _SEEDS)
            codes = [code for code in codes if code.n == n]
        hypotheses += len(seeds) * len(_TRANSFORMS) * len(codes)
        seeded += len(seeds)
        if index is None:
            states = _read_windows(mesh, seeds, _WINDOW)
            matches = _match_windows(states, codes, _WINDOW)
            piece = _walk_matches(mesh, seeds, matches, None, min_faces)
        else:
            # A later piece: N and winding known, so fewer bits tell where it is; a wider
            # window collects them along a strip.
            states = _read_windows(mesh, seeds, _WINDOW_PIECE)
            turns = range(4, 8) if reverse else range(4)
            matches = _match_sparse(states, codes[0], _WINDOW_PIECE, turns, _MIN_BITS_PIECE)
            piece = _walk_matches(mesh, seeds, matches, index, 8 * _MIN_BITS_PIECE)
        if piece is None:
            break
        index, found, n, reverse = piece
    return _Reading(n, index, len(found), hypotheses, seeded)


def _read_components(mesh: _Mesh, codes: list[_Code], min_faces: int) -> list[tuple[int, _Reading]]:
    """Each component with ``min_faces`` faces and a seed cell, read on its own, largest first
    (ties: more vertices, then more seed cells: order-free keys)."""
    comp_faces = np.bincount(mesh.label[mesh.faces[:, 0]], minlength=mesh.n_components)
    comp_vertices = np.bincount(mesh.label, minlength=mesh.n_components)
    cells = _signature_seeds(mesh)
    cell_label = mesh.label[cells[:, 0]]
    seeds_in = np.bincount(cell_label, minlength=mesh.n_components)
    comps = [
        c
        for c in np.lexsort((-seeds_in, -comp_vertices, -comp_faces)).tolist()
        if comp_faces[c] >= min_faces and seeds_in[c]
    ]
    out = []
    for c in comps:
        mine = cells[cell_label == c]
        first = _choose_seeds(mesh, mine, _SEEDS)
        out.append((c, _read_component(mesh, mine, first, codes, min_faces)))
    return out
