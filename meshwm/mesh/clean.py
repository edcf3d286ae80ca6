"""Mesh cleaning: the first stage after reading a file.

A geometry image needs one connected, edge-manifold, consistently oriented triangle mesh.  Files
in the wild are none of these for sure: an STL stores every triangle with its own three corners,
scanned meshes carry degenerate slivers, assets come in several parts.  :func:`clean_mesh` makes
the mesh usable *without* moving a single vertex:

1. merge vertices at exactly the same position (restores the connectivity an STL round trip or an
   un-indexed export throws away; exact, not epsilon, so no geometry is snapped);
2. drop faces that use a vertex twice, exact duplicate faces and faces of zero area;
3. drop unreferenced vertices;
4. rebuild the connectivity from edges: faces are glued along an edge they share; an edge of
   more than two faces that is a *pinch* (an even number of faces, half running each way, as two
   sheets of ``cow.ply`` touching along an edge become once its twin vertices are merged) is
   resolved by pairing the faces in radial order around the edge, so the sheets separate again;
   any other non-manifold edge (a fan of three faces) is refused: the user is told to repair it;
5. split non-manifold vertices (two fans of faces touching in one vertex) into one vertex per
   fan: this changes no position and no face;
6. orient every component consistently (breadth-first over faces); the orientation kept is the
   one most of the input's faces already have, so the output winds like the input;
7. split into connected components and keep the largest (by surface area) for the geometry
   image; the others are returned so the caller can append them unchanged.

Everything here is a pure function of the vertex positions and the face list, and deterministic:
ties are broken by position, never by a random stream.
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import threading
from collections.abc import Iterator
from typing import NamedTuple

import igl
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import MeshError

_SHARED: contextvars.ContextVar[dict | None] = contextvars.ContextVar("cleaning", default=None)

__all__ = [
    "CleanMesh",
    "clean_mesh",
    "edge_topology_counts",
    "euler_characteristic",
    "largest_component",
    "uniform_smoothing_operator",
    "unique_edges",
]


class CleanMesh(NamedTuple):
    """Result of :func:`clean_mesh`.

    Attributes
    ----------
    vertices : (n, 3) float64 ndarray
        Vertices of the largest component.
    faces : (m, 3) int64 ndarray
        Its faces, consistently oriented.
    other_vertices : (p, 3) float64 ndarray
        Vertices of all other components (may be empty).
    other_faces : (q, 3) int64 ndarray
        Their faces, indexing ``other_vertices``.
    report : dict
        What was changed: counts of merged vertices, dropped faces, split vertices, flipped
        faces and dropped components.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    other_vertices: NDArray[np.float64]
    other_faces: NDArray[np.int64]
    report: dict


def _group(key: NDArray, rows: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(first, inverse)`` of the rows grouped by a stable sort of one integer ``key`` per row
    that equal rows share (and, where it is a packed key, only they)."""
    order = np.argsort(key, kind="stable")
    s = key[order]
    new = np.ones(len(rows), dtype=bool)
    new[1:] = s[1:] != s[:-1]
    group = np.cumsum(new) - 1
    inverse = np.empty(len(rows), dtype=np.int64)
    inverse[order] = group
    first = order[new]  # the sort is stable, so this is the first occurrence of each row
    return first, inverse


def _unique_rows(rows: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Index of each distinct row's first occurrence (sorted by row) and row -> distinct index.

    Integer rows are packed into one int64 key per row where the range allows (one stable
    sort instead of ``np.lexsort``'s one per column; ``np.unique(axis=0)`` views rows as opaque
    bytes and is slower still); otherwise, and for other dtypes, a lexicographic sort of the
    columns.
    """
    rows = np.asarray(rows)
    if len(rows) and np.issubdtype(rows.dtype, np.integer):
        low = int(rows.min())
        base = int(rows.max()) - low + 1
        if base ** rows.shape[1] < 2**62:
            key = np.zeros(len(rows), dtype=np.int64)
            for k in range(rows.shape[1]):
                key = key * base + (rows[:, k].astype(np.int64) - low)
            return _group(key, rows)
    order = np.lexsort(rows.T[::-1])
    s = rows[order]
    new = np.ones(len(rows), dtype=bool)
    new[1:] = np.any(s[1:] != s[:-1], axis=1)
    group = np.cumsum(new) - 1
    inverse = np.empty(len(rows), dtype=np.int64)
    inverse[order] = group
    first = order[new]  # lexsort is stable, so this is the first occurrence of each row
    return first, inverse


def _hashed_groups(v: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(first, inverse)`` of bit-identical rows of a float64 or int64 array (-0.0 normalised
    by the caller), the groups in an order that depends on the rows only (not sorted by row).

    One stable sort of a 64-bit hash of each row's bytes instead of a lexicographic sort of
    the columns; rows that share a hash but differ (a collision, never seen) fall back to
    :func:`_unique_rows`.
    """
    if len(v) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    bits = np.ascontiguousarray(v).view(np.uint64)
    mix = np.uint64(0x9E3779B97F4A7C15)
    h = np.zeros(len(v), dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in range(bits.shape[1]):
            h = (h ^ bits[:, k]) * mix
            h ^= h >> np.uint64(29)
    first, inverse = _group(h.view(np.int64), v)
    if not np.array_equal(bits[first][inverse], bits):  # a collision: exact but slower
        return _unique_rows(v)
    return first, inverse


def _merge_exact_duplicates(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], int]:
    """Merge vertices with bit-identical positions; keep the first occurrence's order."""
    # -0.0 and 0.0 are the same position: normalise before comparing bytes.
    v = vertices + 0.0
    first, inverse = _hashed_groups(v)
    if len(first) == len(v):
        return vertices, faces, 0
    # Renumber unique rows in order of first appearance so the result keeps the input order.
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    new_index = rank[inverse]
    return vertices[first[order]], new_index[faces], len(v) - len(first)


def _drop_bad_faces(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.int64], dict]:
    repeated = (
        (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    )
    e1 = vertices[faces[:, 1]] - vertices[faces[:, 0]]
    e2 = vertices[faces[:, 2]] - vertices[faces[:, 0]]
    zero_area = ~repeated & ~np.any(np.cross(e1, e2), axis=1)
    keep = ~(repeated | zero_area)
    f = faces[keep]
    # Exact duplicate faces (same three vertices, either winding): keep the first.
    first, _ = _hashed_groups(np.sort(f, axis=1).astype(np.int64))
    dup = len(f) - len(first)
    f = f[np.sort(first)]
    return f, {
        "faces_repeated_vertex": int(repeated.sum()),
        "faces_zero_area": int(zero_area.sum()),
        "faces_duplicate": int(dup),
    }


def _drop_unreferenced(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], int]:
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    if used.all():
        return vertices, faces, 0
    remap = np.cumsum(used) - 1
    return vertices[used], remap[faces], int((~used).sum())


def unique_edges(faces: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Unique undirected edges and, per face corner-edge (m*3), the index of its edge.

    Corner-edge ``3*f + k`` goes from ``faces[f, k]`` to ``faces[f, (k+1) % 3]``.  The edges
    are ``(low, high)`` pairs in lexicographic order.
    """
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    a = faces.ravel()
    b = faces[:, [1, 2, 0]].ravel()
    low, high = np.minimum(a, b), np.maximum(a, b)
    n = int(high.max()) + 1
    first, inverse = _group(low * n + high, low)
    return np.stack([low[first], high[first]], axis=1), inverse


def edge_topology_counts(faces: NDArray[np.int64]) -> tuple[int, int, int]:
    """Number of unique edges, boundary edges (one face) and non-manifold edges (> 2 faces)."""
    edges, inverse = unique_edges(faces)
    count = np.bincount(inverse, minlength=len(edges))
    return len(edges), int((count == 1).sum()), int((count > 2).sum())


def euler_characteristic(n_vertices: int, faces: NDArray[np.int64]) -> int:
    """Euler characteristic V - E + F of a mesh whose vertices are all referenced."""
    n_edges = edge_topology_counts(faces)[0]
    return int(n_vertices - n_edges + len(faces))


def _radial_pairs(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    edge: NDArray[np.int64],
    corner_edges: NDArray[np.int64],
) -> list[list[tuple[int, int]]] | None:
    """Candidate pairings of the faces around an edge of more than two faces, or None.

    The faces are sorted by angle around the edge and paired without crossing, each face with
    one running the edge the other way.  There are at most two such matchings (pairing across
    the wedges inside the surface, or across those outside); both are returned, and the caller
    keeps the one that pairs faces of the same sheet.  This is how two closed sheets that touch
    along an edge (a pinch) separate again.  Anything else (an odd number of faces, a fan) has
    no manifold reading: None.
    """
    a, b = int(edge[0]), int(edge[1])
    e = vertices[b] - vertices[a]
    norm = np.linalg.norm(e)
    if len(corner_edges) % 2 or norm == 0:
        return None
    e = e / norm
    helper = np.eye(3)[int(np.argmin(np.abs(e)))]
    u = np.cross(e, helper)
    u /= np.linalg.norm(u)
    w = np.cross(e, u)
    fidx = corner_edges // 3
    k = corner_edges % 3
    forward = faces[fidx, k] == a  # runs a -> b
    third = faces[fidx, (k + 2) % 3]
    r = vertices[third] - vertices[a]
    theta = np.arctan2(r @ w, r @ u)
    order = np.lexsort((fidx, theta))
    d = forward[order]
    if d.sum() * 2 != len(d):
        return None
    n = len(order)
    # A non-crossing matching of opposite runs around the circle is a bracket matching; there
    # are at most two families (brackets opening on backward or on forward faces).
    candidates = []
    for opener in (False, True):
        for offset in range(n):
            stack: list[int] = []
            pairs = []
            for step in range(n):
                i = (offset + step) % n
                if d[i] == opener:
                    stack.append(i)
                elif stack:
                    pairs.append(
                        (int(corner_edges[order[stack.pop()]]), int(corner_edges[order[i]]))
                    )
                else:
                    break
            if len(pairs) * 2 == n:
                candidates.append(pairs)
                break
    return candidates or None


def _corner_labels(
    faces: NDArray[np.int64], first: NDArray[np.int64], second: NDArray[np.int64]
) -> tuple[int, NDArray[np.int64]]:
    """Groups of face corners joined through the glued corner-edge pairs (first[k], second[k])."""
    m = len(faces)
    corner_a = np.arange(3 * m)
    corner_b = (np.arange(m)[:, None] * 3 + (np.arange(3)[None, :] + 1) % 3).reshape(-1)
    ca1, cb1, ca2, cb2 = corner_a[first], corner_b[first], corner_a[second], corner_b[second]
    flat = faces.reshape(-1)
    rows, cols = [], []
    for c1 in (ca1, cb1):
        for c2 in (ca2, cb2):
            hit = flat[c1] == flat[c2]
            rows.append(c1[hit])
            cols.append(c2[hit])
    rows_a = np.concatenate(rows)
    cols_a = np.concatenate(cols)
    graph = sp.coo_matrix((np.ones(len(rows_a)), (rows_a, cols_a)), shape=(3 * m, 3 * m)).tocsr()
    return connected_components(graph, directed=False)


def _rebuild_connectivity(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], int, int]:
    """Give each fan of faces around a vertex its own copy of the vertex.

    Face corners at the same vertex are joined when their faces are glued along an edge through
    that vertex.  An edge of two faces glues them; an edge of more faces is resolved by
    :func:`_radial_pairs` or refused.  Each connected group of corners becomes one vertex (the
    group holding a vertex's first corner keeps its index; positions are copied).

    Returns the source of each output vertex (``vertices[source]`` are the output's
    positions), the faces, the number of vertices added and of edges resolved radially.
    """
    m = len(faces)
    edges, inverse = unique_edges(faces)
    count = np.bincount(inverse, minlength=len(edges))
    order = np.argsort(inverse, kind="stable")
    sorted_edge = inverse[order]
    two = count[sorted_edge[:-1]] == 2
    same = (sorted_edge[1:] == sorted_edge[:-1]) & two
    first, second = order[:-1][same], order[1:][same]
    resolved = 0
    heavy = np.flatnonzero(count > 2)
    if len(heavy):
        # Sheets glued along ordinary edges only: a pair of faces of the same sheet shares a
        # corner group at the edge's first vertex.
        _, pre = _corner_labels(faces, first, second)
        flat = faces.reshape(-1)
        starts = np.searchsorted(sorted_edge, heavy)
        extra1, extra2 = [], []
        for edge_id, s in zip(heavy.tolist(), starts.tolist(), strict=True):
            a = int(edges[edge_id][0])
            options = _radial_pairs(vertices, faces, edges[edge_id], order[s : s + count[edge_id]])
            if options is None:
                raise MeshError(
                    f"mesh has {len(heavy)} non-manifold edges (shared by more than two faces, "
                    f"first between vertices {a} and {edges[edge_id][1]}); "
                    "repair it first, e.g. MeshLab 'Repair non Manifold Edges'"
                )

            def corner_at_a(corner_edge: int, a: int = a) -> int:
                base = 3 * (corner_edge // 3)
                return base + int(np.flatnonzero(flat[base : base + 3] == a)[0])

            score = [
                sum(pre[corner_at_a(p)] == pre[corner_at_a(q)] for p, q in pairs)
                for pairs in options
            ]
            for p, q in options[int(np.argmax(score))]:
                extra1.append(p)
                extra2.append(q)
            resolved += 1
        first = np.concatenate([first, np.asarray(extra1, dtype=np.int64)])
        second = np.concatenate([second, np.asarray(extra2, dtype=np.int64)])
    n_groups, labels = _corner_labels(faces, first, second)
    flat = faces.reshape(-1)
    if n_groups == len(vertices):
        return np.arange(len(vertices)), faces, 0, resolved
    group_vertex = np.zeros(n_groups, dtype=np.int64)
    group_vertex[labels] = flat
    group_first = np.full(n_groups, 3 * m, dtype=np.int64)
    np.minimum.at(group_first, labels, np.arange(3 * m))
    order_g = np.lexsort((group_first, group_vertex))
    gv = group_vertex[order_g]
    is_first = np.ones(len(order_g), dtype=bool)
    is_first[1:] = gv[1:] != gv[:-1]
    new_id = np.empty(n_groups, dtype=np.int64)
    new_id[order_g[is_first]] = gv[is_first]
    extra = order_g[~is_first]
    new_id[extra] = len(vertices) + np.arange(len(extra))
    source = np.concatenate([np.arange(len(vertices)), group_vertex[extra]])
    return source, new_id[labels].reshape(-1, 3), len(extra), resolved


def _inconsistent_edges(faces: NDArray[np.int64]) -> int:
    """Number of interior edges that both of their faces traverse in the same direction."""
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    _, inverse = unique_edges(faces)
    forward = directed[:, 0] < directed[:, 1]
    order = np.argsort(inverse, kind="stable")
    sorted_edge = inverse[order]
    same = sorted_edge[1:] == sorted_edge[:-1]
    return int(np.sum(forward[order[:-1][same]] == forward[order[1:][same]]))


def _orient(faces: NDArray[np.int64], labels: NDArray[np.int64]) -> tuple[NDArray[np.int64], int]:
    """Consistently orient each component (breadth-first over faces, ``igl.bfs_orient``).

    Within a component, the winding most input faces already have is kept.  Raises
    :class:`MeshError` for a non-orientable component (a Möbius strip).
    """
    if _inconsistent_edges(faces) == 0:
        return faces, 0
    oriented, _ = igl.bfs_orient(faces)
    if _inconsistent_edges(oriented) != 0:
        raise MeshError("mesh is not orientable (a Möbius-like strip); cannot map it")
    # A face was flipped if its first vertex is no longer followed by the same second vertex.
    pos = np.argmax(oriented == faces[:, :1], axis=1)
    flipped = oriented[np.arange(len(faces)), (pos + 1) % 3] != faces[:, 1]
    n_comp = labels.max() + 1
    invert = np.bincount(labels, weights=flipped, minlength=n_comp) * 2 > np.bincount(
        labels, minlength=n_comp
    )
    oriented = np.where(invert[labels][:, None], oriented[:, ::-1], oriented)
    flipped = flipped ^ invert[labels]
    return oriented, int(flipped.sum())


def _face_components(n_vertices: int, faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Component label per face; faces are joined through shared vertices."""
    m = len(faces)
    rows = np.repeat(np.arange(m), 3)
    graph = sp.coo_matrix(
        (np.ones(3 * m), (rows, faces.reshape(-1))), shape=(m, n_vertices)
    ).tocsr()
    adjacency = sp.bmat([[None, graph], [graph.T, None]]).tocsr()
    _, labels = connected_components(adjacency, directed=False)
    return labels[:m]


def largest_component(vertices: NDArray, faces: NDArray) -> tuple[NDArray, NDArray]:
    """The connected component with the most faces, as it is: nothing merged, moved or dropped.

    Unlike :func:`clean_mesh`, coincident vertices stay distinct.  Blind extraction reads the
    grid from connectivity first this way, because an attack such as coordinate quantisation
    can make distinct vertices coincide without changing the file's connectivity.

    Examples
    --------
    >>> v = np.eye(4)[:, :3]
    >>> f = np.array([[0, 1, 2], [0, 2, 1], [3, 3, 3]])
    >>> largest_component(v, f)[1].tolist()
    [[0, 1, 2], [0, 2, 1]]
    """
    v, f = check_mesh(vertices, faces)
    labels = _face_components(len(v), f)
    counts = np.bincount(labels)
    main = f[labels == int(np.argmax(counts))]
    mv, mf, _ = _drop_unreferenced(v, main)
    return mv, mf


@contextlib.contextmanager
def shared_cleaning(memo: dict | None = None) -> Iterator[None]:
    """Within this context, :func:`clean_mesh` of the same arrays is computed once.

    Several blind readers try one received mesh (:func:`meshwm.readers.read_all`), and each
    cleans it; the cleaning is a pure function of the arrays, so they share it.  The arrays
    handed out are read-only.  ``memo`` (a dict the context fills) shares the cleanings of
    several such contexts: readers run one at a time, when a decoder first needs them.
    """
    token = _SHARED.set({} if memo is None else memo)
    try:
        yield
    finally:
        _SHARED.reset(token)


def clean_mesh(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES, min_faces: int = 4
) -> CleanMesh:
    """Clean a triangle mesh and split off its largest connected component.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Vertex positions (any units).
    faces : (m, 3) array_like of int
        Triangles.
    max_faces : int, optional
        Refuse meshes with more faces than this (default 5 million).
    min_faces : int, optional
        Refuse a largest component with fewer faces than this (default 4: a tetrahedron).

    Returns
    -------
    CleanMesh
        The largest component (oriented, manifold), the other components and a report.

    Raises
    ------
    MeshError
        Bad arrays (see :func:`meshwm._validate.check_mesh`), non-manifold edges, a
        non-orientable surface, or nothing left after dropping degenerate faces.

    Notes
    -----
    Within :func:`shared_cleaning` the result for the same arrays is computed once (its arrays
    are then read-only).

    No vertex is moved: positions are merged only when bit-identical and copied when split.
    """
    memo = _SHARED.get()
    if memo is None:
        return _clean_mesh(vertices, faces, max_faces=max_faces, min_faces=min_faces)
    v, f = check_mesh(vertices, faces, max_faces=max_faces)
    key = (
        v.shape,
        f.shape,
        hashlib.blake2b(np.ascontiguousarray(v).tobytes(), digest_size=16).digest(),
        hashlib.blake2b(np.ascontiguousarray(f).tobytes(), digest_size=16).digest(),
        int(max_faces),
        int(min_faces),
    )
    if key not in memo:
        out = _clean_mesh(v, f, max_faces=max_faces, min_faces=min_faces)
        for a in (out.vertices, out.faces, out.other_vertices, out.other_faces):
            a.flags.writeable = False
        memo[key] = out
    found: CleanMesh = memo[key]
    return found._replace(report=dict(found.report))


#: The last mesh's connectivity work (:func:`_structure`), by a digest of its faces.
_STRUCTURE: dict[tuple, tuple] = {}
_STRUCTURE_LOCK = threading.Lock()


def _structure(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], dict]:
    """Steps 4-6 of :func:`clean_mesh`: fans split, components labelled, faces oriented.

    Returns the source vertex of each output vertex, the oriented faces, each face's
    component and the report's counts.  Unless a non-manifold edge was resolved (by the
    radial order of its faces, which depends on the positions), this depends on the faces
    alone, so the last result is kept for the same faces: the embedder's read-back cleans
    the marked mesh, whose faces are the input's.
    """
    digest = hashlib.blake2b(np.ascontiguousarray(faces).tobytes(), digest_size=16).digest()
    key = (len(vertices), faces.shape, digest)
    with _STRUCTURE_LOCK:
        if key in _STRUCTURE:
            return _STRUCTURE[key]
    source, f, split, resolved = _rebuild_connectivity(vertices, faces)
    labels = _face_components(len(source), f)
    f, flipped = _orient(f, labels)
    counts = {
        "vertices_split_nonmanifold": split,
        "edges_unpinched": resolved,
        "faces_reoriented": flipped,
    }
    found = (source, f, labels, counts)
    for a in found[:3]:
        a.flags.writeable = False
    if resolved == 0:
        with _STRUCTURE_LOCK:
            _STRUCTURE.clear()
            _STRUCTURE[key] = found
    return found


def _clean_mesh(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES, min_faces: int = 4
) -> CleanMesh:
    """:func:`clean_mesh`, computed."""
    v, f = check_mesh(vertices, faces, max_faces=max_faces)
    report: dict = {"vertices_in": len(v), "faces_in": len(f)}
    v, f, merged = _merge_exact_duplicates(v, f)
    report["vertices_merged"] = merged
    f, dropped = _drop_bad_faces(v, f)
    report.update(dropped)
    if len(f) == 0:
        raise MeshError("mesh has no faces of non-zero area")
    v, f, unref = _drop_unreferenced(v, f)
    report["vertices_unreferenced"] = unref
    source, f, labels, counts = _structure(v, f)
    v = v[source]
    report.update(counts)
    # Largest component by area; ties by face count, then by smallest vertex position.
    e1 = v[f[:, 1]] - v[f[:, 0]]
    e2 = v[f[:, 2]] - v[f[:, 0]]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    n_comp = labels.max() + 1
    comp_area = np.bincount(labels, weights=area, minlength=n_comp)
    comp_size = np.bincount(labels, minlength=n_comp)
    best = 0
    if n_comp > 1:
        # Component of each vertex's lexicographically smallest position (order-free tie-break).
        face_of_vertex = np.zeros(len(v), dtype=np.int64)
        face_of_vertex[f.ravel()] = np.repeat(labels, 3)
        lex_rank = np.empty(len(v), dtype=np.int64)
        lex_rank[np.lexsort(v.T[::-1])] = np.arange(len(v))
        comp_first = np.full(n_comp, len(v), dtype=np.int64)
        np.minimum.at(comp_first, face_of_vertex, lex_rank)
        best = int(np.lexsort((comp_first, -comp_size, -comp_area))[0])
    main = labels == best
    mv, mf, _ = _drop_unreferenced(v, f[main])
    if len(mf) < min_faces:
        raise MeshError(
            f"largest connected component has only {len(mf)} faces; need at least {min_faces}"
        )
    if n_comp > 1:
        ov, of, _ = _drop_unreferenced(v, f[~main])
    else:
        ov, of = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    report["components"] = int(n_comp)
    report["components_passed_through"] = int(n_comp - 1)
    return CleanMesh(mv, mf, ov, of, report)


def uniform_smoothing_operator(
    n_vertices: int, faces: NDArray[np.int64]
) -> tuple[sp.csr_matrix, NDArray[np.bool_]]:
    """Row-stochastic neighbour-mean matrix M and the mask of vertices that have neighbours.

    One step of uniform Laplacian smoothing is ``v += lam * (M @ v - v)`` on those vertices
    (:func:`meshwm.attacks.smoothing.laplacian`); the robust decoder undoes it
    (:mod:`meshwm.profiles.robust`).

    An interior vertex averages all its edge neighbours.  A boundary vertex (one on an edge of
    a single face) averages only its neighbours along the boundary, so a border is smoothed as
    a polyline of its own and does not shrink into the surface (MeshLab's "1D boundary
    smoothing", the default of its Laplacian filter).
    """
    edges, inverse = unique_edges(faces)
    edges_used = edges[:, 0] != edges[:, 1]
    border = np.bincount(inverse, minlength=len(edges)) == 1
    edges, border = edges[edges_used], border[edges_used]
    on_border = np.zeros(n_vertices, dtype=bool)
    on_border[edges[border].ravel()] = True
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    keep = ~on_border[rows] | np.concatenate([border, border])
    w = sp.csr_matrix(
        (np.ones(int(keep.sum())), (rows[keep], cols[keep])), shape=(n_vertices, n_vertices)
    )
    degree = np.asarray(w.sum(axis=1)).ravel()
    inv = np.divide(1.0, degree, out=np.zeros(n_vertices), where=degree > 0)
    return (sp.diags(inv) @ w).tocsr(), degree > 0
