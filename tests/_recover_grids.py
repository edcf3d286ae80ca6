"""Helpers shared by the tests of :mod:`meshwm.gim.recover`: meshes meshwm writes, and what a
reading of them must be.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_array_equal

SIZE = 128
MESHES = ["spot_mesh", "kitten_mesh", "plane_mesh"]


def synthetic_gim(n: int) -> np.ndarray:
    """A bumpy sheet whose samples are all distinct."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return np.stack([i / n, j / n, 0.1 * np.sin(i / 5.0) * np.cos(j / 7.0)], axis=-1)


def border(n: int) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return (i == 0) | (j == 0) | (i == n - 1) | (j == n - 1)


def shuffle(v, f, seed):
    """Random vertex order, face order and cyclic rotation of each face's corners."""
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(v))
    inverse = np.argsort(perm)
    f2 = inverse[f][rng.permutation(len(f))]
    shift = rng.integers(0, 3, size=len(f2))
    f2 = np.take_along_axis(f2, (np.arange(3) + shift[:, None]) % 3, axis=1)
    return v[perm], f2, inverse


def cell_faces(n: int, i: int, j: int) -> slice:
    cell = i * (n - 1) + j
    return slice(2 * cell, 2 * cell + 2)


def plain_cell(n: int, i: int, j: int) -> np.ndarray:
    """The two triangles of cell (i, j) with the 4-8 diagonal (as if not a flipped code cell)."""
    p00 = i * n + j
    p01, p10, p11 = p00 + 1, p00 + n, p00 + n + 1
    if (i + j) % 2 == 0:
        return np.array([[p00, p01, p11], [p00, p11, p10]])
    return np.array([[p00, p01, p10], [p01, p11, p10]])


def unflip(f: np.ndarray, n: int, cells) -> np.ndarray:
    f = f.copy()
    for i, j in cells:
        f[cell_faces(n, i, j)] = plain_cell(n, i, j)
    return f


def source_of(full_v: np.ndarray, part_v: np.ndarray) -> np.ndarray:
    """Index in ``full_v`` of each vertex of ``part_v`` (a crop keeps positions exactly)."""
    where = {tuple(p): k for k, p in enumerate(full_v.tolist())}
    assert len(where) == len(full_v)  # positions identify vertices
    return np.array([where[tuple(p)] for p in part_v.tolist()], dtype=np.int64)


def expected_index(full_index: np.ndarray, full_v, part_v) -> np.ndarray:
    """(N, N) vertex of ``part_v`` that each sample must read as, -1 where it is gone."""
    remap = np.full(len(full_v), -1, dtype=np.int64)
    remap[source_of(full_v, part_v)] = np.arange(len(part_v))
    return remap[full_index]


def check_partial(grid, expected: np.ndarray, n_vertices: int) -> float:
    """No false sample; returns the fraction of the piece's vertices that were read."""
    assert grid.index.shape == expected.shape
    found = grid.index >= 0
    assert_array_equal(grid.index[found], expected[found])  # nothing false
    assert np.all(np.isnan(grid.gim[~found]))
    assert grid.coverage == pytest.approx(found.mean())
    return len(np.unique(grid.index[found])) / n_vertices


def away_from_cuts(n_vertices: int, f: np.ndarray, min_faces: int = 400) -> np.ndarray:
    """Vertices with a closed fan (no face of theirs was removed, none on the grid's own open
    border) in a component of at least ``min_faces`` faces (enough to hold the code)."""
    directed = {
        (int(a), int(b)) for a, b in np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    }
    closed = np.ones(n_vertices, dtype=bool)
    for a, b in directed:
        if (b, a) not in directed:
            closed[a] = closed[b] = False
    mesh = trimesh.Trimesh(np.zeros((n_vertices, 3)), f, process=False)
    big = np.zeros(n_vertices, dtype=bool)
    for part in trimesh.graph.connected_components(mesh.face_adjacency, nodes=np.arange(len(f))):
        if len(part) >= min_faces:
            big[np.unique(f[part])] = True
    return closed & big


def check_cut(grid, expected: np.ndarray, v: np.ndarray, f: np.ndarray) -> None:
    """No false sample, and every vertex away from the cuts is read (at a cut, border samples
    whose neighbours lost faces may stay unread: a fold could not be ruled out there)."""
    check_partial(grid, expected, len(v))
    read = np.zeros(len(v), dtype=bool)
    read[grid.index[grid.index >= 0]] = True
    away = away_from_cuts(len(v), f)
    assert away.sum() > 0.5 * len(v)
    assert np.all(read[away])


def compact(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    return v[used], (np.cumsum(used) - 1)[f]
