"""Attacks that split and weld vertices: UV seams, STL re-welding, trimesh's merging load.

What exporters and loaders do to the vertex list without moving a point: ``split_seams``
duplicates the vertices along a few edge paths as a UV-seam export does, ``weld_stl`` is an
STL round trip re-welded by exact position as a studio tool does, and ``merge_load`` is what
``trimesh.load(path)`` does by default (coincident vertices merged).  Every output position is
one of the input's (``weld_stl``: rounded to float32).  NumPy and SciPy; trimesh for
``merge_load``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import check_mesh
from meshwm.attacks.connectivity import EdgePairs, interior_pairs
from meshwm.attacks.params import Mesh, check_options
from meshwm.attacks.transforms import round_trip

__all__ = [
    "SEAM_ATTEMPTS",
    "SeamResult",
    "material_patches",
    "merge_load",
    "split_seam_paths",
    "split_seams",
    "weld_by_position",
    "weld_stl",
]

#: Start vertices tried per seam before ``split_seams`` gives that seam up.
SEAM_ATTEMPTS = 20


class SeamResult(NamedTuple):
    """Result of :func:`split_seam_paths`.

    Attributes
    ----------
    vertices : (n + c, 3) float64 ndarray
        The input vertices followed by the ``c`` copies (same positions).
    faces : (m, 3) int64 ndarray
        The faces, those on one side of each seam using the copies.
    paths : list of (l + 1,) int64 ndarray
        The vertex path of each seam cut (input vertex ids).
    source : (c,) int64 ndarray
        The input vertex that each copy duplicates: vertex ``n + j`` is a copy of ``source[j]``.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    paths: list[NDArray[np.int64]]
    source: NDArray[np.int64]


def _closed_fan_vertices(n: int, f: NDArray[np.int64], pairs: EdgePairs) -> NDArray[np.bool_]:
    """Referenced vertices all of whose edges are interior pairs (two faces, both directions)."""
    lo, hi = np.minimum(pairs.a, pairs.b), np.maximum(pairs.a, pairs.b)
    bad = ~np.isin(pairs.keys, lo * n + hi)
    allowed = np.zeros(n, dtype=bool)
    allowed[f.ravel()] = True
    allowed[pairs.keys[bad] // n] = False
    allowed[pairs.keys[bad] % n] = False
    return allowed


def _hops(pred: NDArray, source: int) -> NDArray[np.int64]:
    """Edges from ``source`` to each vertex along the predecessor tree (-1: not reached)."""
    n = len(pred)
    parent = np.where(pred >= 0, pred, np.arange(n))
    depth = (pred >= 0).astype(np.int64)
    while True:  # pointer jumping: log2(depth) rounds
        grand = parent[parent]
        if np.array_equal(grand, parent):
            break
        depth, parent = depth + depth[parent], grand
    depth[(parent != source)] = -1
    return depth


def _side(
    f: NDArray[np.int64], around: NDArray, p: int, before: int, after: int
) -> list[int] | None:
    """Faces around ``p`` from the one with ``p -> after`` turning to the one with ``before -> p``.

    These are the faces on the left of the path ``before -> p -> after``; None when the turn
    does not reach ``before`` (``p`` has more than one fan).
    """
    step: dict[int, int] = {}
    for face in around.tolist():
        row = f[face].tolist()
        step[row[(row.index(p) + 1) % 3]] = face
    side: list[int] = []
    face = step.get(after)
    while face is not None and len(side) < len(around):
        side.append(face)
        row = f[face].tolist()
        z = row[(row.index(p) + 2) % 3]
        if z == before:
            return side
        face = step.get(z)
    return None


def _seam(
    v: NDArray[np.float64], f: NDArray[np.int64], length: int, rng: np.random.Generator
) -> tuple[NDArray[np.int64], list[list[int]]] | None:
    """A shortest path of ``length`` edges through closed-fan vertices and its left faces."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import dijkstra

    n = len(v)
    pairs = interior_pairs(n, f)
    allowed = _closed_fan_vertices(n, f, pairs)
    p, q = pairs.keys // n, pairs.keys % n
    inside = allowed[p] & allowed[q]
    p, q = p[inside], q[inside]
    weight = np.maximum(np.linalg.norm(v[p] - v[q], axis=1), np.finfo(float).tiny)
    graph = sp.csr_matrix((weight, (p, q)), shape=(n, n))
    corner_order = np.argsort(f.ravel(), kind="stable")
    starts = np.searchsorted(f.ravel()[corner_order], np.arange(n + 1))
    choices = np.flatnonzero(allowed)
    for _ in range(SEAM_ATTEMPTS if len(choices) else 0):
        source = int(rng.choice(choices))
        _, pred = dijkstra(graph, directed=False, indices=source, return_predecessors=True)
        targets = np.flatnonzero(_hops(pred, source) == length)
        if not len(targets):
            continue
        path = [int(rng.choice(targets))]
        while path[-1] != source:
            path.append(int(pred[path[-1]]))
        sides: list[list[int]] = []
        for before, mid, after in zip(path[:-2], path[1:-1], path[2:], strict=True):
            around = corner_order[starts[mid] : starts[mid + 1]] // 3
            side = _side(f, around, mid, before, after)
            if side is None:
                break
            sides.append(side)
        if len(sides) == len(path) - 2:
            return np.array(path, dtype=np.int64), sides
    return None


def split_seam_paths(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, paths: int = 3, length: int = 20
) -> SeamResult:
    """:func:`split_seams` with what it did: the seam paths and the vertex each copy duplicates.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seed : int
        Start and end vertices of the seams (NumPy ``default_rng``).
    paths : int
        Number of seams wanted, >= 1.
    length : int
        Edges per seam, >= 2.

    Returns
    -------
    SeamResult
        ``len(result.paths)`` seams were cut: ``paths``, or fewer where no path of ``length``
        edges was found from :data:`SEAM_ATTEMPTS` random start vertices.

    Notes
    -----
    Each seam is a shortest path (Euclidean edge lengths) of exactly ``length`` edges from a
    random vertex to a random vertex at that many edges along the shortest-path tree, through
    vertices whose every edge has two consistently oriented faces (the current mesh: a later
    seam does not touch an earlier one's vertices, which are now on a boundary).  Every inner
    vertex of the path gets a copy, appended after the vertices, at the same position; the
    faces on the left of the path use the copies.  The two end vertices are not split, so each
    seam is a slit: ``2 · length`` boundary edges more.  Welding by exact position gives back
    the input's vertices and faces when the input has no two vertices at the same position.
    """
    opts = check_options("split_seams", paths=paths, length=length)
    v, f = check_mesh(vertices, faces)
    rng = np.random.default_rng(seed)
    cut: list[NDArray[np.int64]] = []
    source: list[int] = []
    for _ in range(opts["paths"]):
        found = _seam(v, f, opts["length"], rng)
        if found is None:
            continue
        path, sides = found
        inner = path[1:-1]
        copies = len(v) + np.arange(len(inner))
        for mid, copy, side in zip(inner.tolist(), copies.tolist(), sides, strict=True):
            rows = f[side]
            rows[rows == mid] = copy
            f[side] = rows
        v = np.concatenate([v, v[inner]])
        source += inner.tolist()
        cut.append(path)
    return SeamResult(v, f, cut, np.array(source, dtype=np.int64))


def split_seams(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, paths: int = 3, length: int = 20
) -> Mesh:
    """What a UV-seam export does: vertices duplicated along ``paths`` random edge paths.

    Each seam is a shortest path of ``length`` edges between random vertices; its inner
    vertices are duplicated at exactly the same positions (appended after the vertices) and
    the faces on one side use the copies, so the mesh opens along the seam.  Re-welding by
    exact position restores the input.  See :func:`split_seam_paths` for the details and for
    the number of seams actually cut.
    """
    result = split_seam_paths(vertices, faces, seed=seed, paths=paths, length=length)
    return result.vertices, result.faces


def material_patches(faces: NDArray, *, count: int = 4, seed: int = 0) -> NDArray[np.int64]:
    """Each face's patch: ``count`` patches grown over shared edges from random faces.

    What a material assignment looks like, for separating a mesh into objects by material
    (Blender's Separate by Material, an exporter that writes an object per material): each
    face joins the seed face fewest edge crossings away.

    Examples
    --------
    >>> f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    >>> sorted(np.bincount(material_patches(f, count=2)).tolist())
    [2, 2]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    faces = np.asarray(faces, dtype=np.int64)
    if int(count) != count or not 1 <= count <= len(faces):
        raise ValueError(f"count must be an integer in 1..{len(faces)}, got {count!r}")
    pairs = interior_pairs(int(faces.max()) + 1, faces)
    m = len(faces)
    graph = coo_matrix((np.ones(len(pairs.fa)), (pairs.fa, pairs.fb)), shape=(m, m)).tocsr()
    seeds = np.sort(np.random.default_rng(seed).choice(m, size=int(count), replace=False))
    _, _, source = dijkstra(
        graph, directed=False, indices=seeds, unweighted=True, min_only=True,
        return_predecessors=True,
    )  # fmt: skip
    source[source < 0] = seeds[0]  # a face no seed reaches (another piece): the first patch
    return np.searchsorted(seeds, source).astype(np.int64)


# --- loading and welding ---------------------------------------------------------------------


def weld_by_position(vertices: NDArray, faces: NDArray) -> Mesh:
    """Merge vertices at bit-identical positions (``-0.0`` equals ``0.0``), in first-seen order.

    The merged vertex keeps the position and the place of its first occurrence; faces are
    re-indexed and kept as they are, even where two corners now coincide.

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]])
    >>> w, f = weld_by_position(v, [[0, 1, 2], [3, 4, 2]])
    >>> len(w), f.tolist()
    (4, [[0, 1, 2], [1, 3, 2]])
    """
    v, f = check_mesh(vertices, faces)
    _, first, inverse = np.unique(v + 0.0, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return v[first[order]], rank[inverse.ravel()][f]


def weld_stl(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """An STL round trip re-welded by exact position, as a studio tool's STL import does.

    :func:`~meshwm.attacks.transforms.round_trip` to ``.stl`` gives a triangle soup in float32
    (three vertices per face); :func:`weld_by_position` merges its corners again.  Vertices
    come out in the order they are first used by the faces, at float32 positions; input vertices
    at the same float32 position become one.  ``seed`` is ignored.
    """
    soup_v, soup_f = round_trip(vertices, faces, suffix=".stl")
    return weld_by_position(soup_v, soup_f)


def merge_load(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """What ``trimesh.load(path)`` does by default: ``trimesh.Trimesh(v, f, process=True)``.

    trimesh merges vertices whose positions agree to its merge tolerance (``tol.merge``,
    1e-8) and drops unreferenced ones; the vertex order may change.  ``seed`` is ignored.
    """
    import trimesh

    v, f = check_mesh(vertices, faces)
    mesh = trimesh.Trimesh(vertices=v, faces=f, process=True)
    return np.array(mesh.vertices, dtype=np.float64), np.array(mesh.faces, dtype=np.int64)
