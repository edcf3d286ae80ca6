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
   any other non-manifold edge (a fin standing on a surface, a wall inside a box, a fan of
   three faces) is opened: the most faces that can be paired so are, faces of one sheet first,
   then the flattest pairs, and each face left over gets the edge as a border of its own (the
   fin comes off whole; nothing moves, no face is dropped);
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
from collections.abc import Iterator
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm._digest import LastResult, arrays_key, is_frozen
from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm._vector import face_cross, row_norm
from meshwm.errors import MeshError
from meshwm.mesh.edges import (
    _hashed_groups,
    distinct_rows,
    edge_topology_counts,
    euler_characteristic,
    uniform_smoothing_operator,
    unique_edges,
)
from meshwm.mesh.manifold import face_components, structure

_SHARED: contextvars.ContextVar[dict | None] = contextvars.ContextVar("cleaning", default=None)

__all__ = [
    "CleanMesh",
    "clean_mesh",
    "edge_topology_counts",
    "euler_characteristic",
    "largest_component",
    "shared_cleaning",
    "shared_memo",
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
    source : (n,) int64 ndarray
        For each of ``vertices``, an input vertex it is a copy of (bit for bit).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    other_vertices: NDArray[np.float64]
    other_faces: NDArray[np.int64]
    report: dict
    source: NDArray[np.int64]


def _merge_exact_duplicates(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Merge vertices with bit-identical positions; keep the first occurrence's order.

    Returns the vertices, the faces and the input index of each vertex kept."""
    # -0.0 and 0.0 are the same position: normalise before comparing bytes.
    # (Only where there is one: the array as given otherwise, whose digest may be kept.)
    zero = vertices == 0
    v = vertices + 0.0 if zero.any() and np.signbit(vertices[zero]).any() else vertices
    # Numbered in order of first appearance, so the result keeps the input order.
    first, inverse = distinct_rows(v)
    if len(first) == len(v):
        return vertices, faces, np.arange(len(v))
    return vertices[first], inverse[faces], np.asarray(first, dtype=np.int64)


def _drop_bad_faces(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.int64], dict, NDArray[np.float64]]:
    """The faces kept, the counts of those dropped, and the kept faces' areas."""
    repeated = (
        (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    )
    cross = face_cross(vertices, faces)
    cx, cy, cz = cross
    zero_area = ~repeated & (cx == 0) & (cy == 0) & (cz == 0)
    keep = ~(repeated | zero_area)
    every = bool(keep.all())
    f = faces if every else faces[keep]
    # Exact duplicate faces (same three vertices, either winding): keep the first.
    first = _first_of_faces(f)
    dup = len(f) - len(first)
    area = 0.5 * row_norm(cross)
    if not every:
        area = area[keep]
    if dup:
        f, area = f[first], area[first]
    return (
        f,
        {
            "faces_repeated_vertex": int(repeated.sum()),
            "faces_zero_area": int(zero_area.sum()),
            "faces_duplicate": int(dup),
        },
        area,
    )


#: The last faces' first-of-each-face indices: an embedding cleans its input and then its
#: output, the same faces over moved positions (2.1M vertices: 1 s a call).
_FIRST_FACES = LastResult()


def _first_of_faces(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """The index of the first of each group of faces with the same three vertices (either
    winding), increasing."""
    key = arrays_key(faces)
    found: NDArray[np.int64] | None = _FIRST_FACES.get(key)
    if found is None:
        found, _ = _hashed_groups(np.sort(faces, axis=1).astype(np.int64))
        found.flags.writeable = False
        _FIRST_FACES.put(key, found)
    return found


def _drop_unreferenced(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], int]:
    v, f, kept = _referenced(vertices, faces)
    return v, f, len(vertices) - len(kept)


def _referenced(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """The vertices the faces use, the faces renumbered, and the index of each kept vertex."""
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    if used.all():
        return vertices, faces, np.arange(len(vertices))
    remap = np.cumsum(used) - 1
    return vertices[used], remap[faces], np.flatnonzero(used)


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
    labels = face_components(len(v), f)
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


def shared_memo() -> dict | None:
    """The memo of the enclosing :func:`shared_cleaning` (None outside one), for the other
    pure results of one mesh its readers share (the surface reader's smoothing undone)."""
    return _SHARED.get()


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
        Bad arrays (see :func:`meshwm._validate.check_mesh`), a non-orientable surface, or
        nothing left after dropping degenerate faces.

    Notes
    -----
    Within :func:`shared_cleaning` the result for the same arrays is computed once (its arrays
    are then read-only).

    No vertex is moved: positions are merged only when bit-identical and copied when split.
    """
    memo = _SHARED.get()
    if memo is None:
        return _clean_mesh(vertices, faces, max_faces=max_faces, min_faces=min_faces)
    v, f = check_mesh(vertices, faces, max_faces=max_faces, frozen=True)
    key = (*arrays_key(v, f), int(max_faces), int(min_faces))
    if key not in memo:
        out = _clean_mesh(v, f, max_faces=max_faces, min_faces=min_faces)
        for a in (out.vertices, out.faces, out.other_vertices, out.other_faces, out.source):
            a.flags.writeable = False
        memo[key] = out
    found: CleanMesh = memo[key]
    return found._replace(report=dict(found.report))


def _clean_mesh(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES, min_faces: int = 4
) -> CleanMesh:
    """:func:`clean_mesh`, computed.

    A step that changes nothing hands on the arrays it was given.  Arrays given read-only
    (:func:`meshwm._digest.freeze`: a pipeline's, such as the kept embedding's) are not
    copied: a clean mesh then comes out as the input's arrays themselves, whose digests the
    memoised steps after it find kept.  Others are copied first, so the result is the
    caller's to change without reaching the input.
    """
    frozen = is_frozen(vertices) and is_frozen(faces)
    v, f = check_mesh(vertices, faces, max_faces=max_faces, frozen=frozen)
    report: dict = {"vertices_in": len(v), "faces_in": len(f)}
    n_in = len(v)
    v, f, source = _merge_exact_duplicates(v, f)  # source: each vertex's input vertex
    report["vertices_merged"] = n_in - len(source)
    # The connectivity's work (depending on the faces alone) beside the positions' check of
    # the faces: it is this mesh's unless a face is dropped or a vertex left unused.
    with beside(structure, v, f) as ahead:
        merged_faces = f
        f, dropped, area = _drop_bad_faces(v, f)
        report.update(dropped)
        if len(f) == 0:
            raise MeshError("mesh has no faces of non-zero area")
        n_merged = len(v)
        v, f, kept = _referenced(v, f)
        source = source[kept]
        report["vertices_unreferenced"] = n_merged - len(kept)
        same = len(f) == len(merged_faces) and len(kept) == n_merged
        copied, f, labels, counts = ahead.result() if same else structure(v, f)
    if len(copied) != len(v) or not np.array_equal(copied, np.arange(len(v))):
        v = v[copied]  # vertices split where the surface was pinched
        source = source[copied]
    report.update(counts)
    # Largest component by area; ties by face count, then by smallest vertex position.  The
    # areas are the oriented faces': where one was turned over, from its new corner order
    # (other bits than the bad-face check's).
    if counts["faces_reoriented"]:
        area = 0.5 * row_norm(face_cross(v, f))
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
    # One component: its faces are the connectivity step's (read-only), handed on as they are
    # where the input was read-only too, else copied (the caller's to change).
    mv, mf, kept = _referenced(v, f if n_comp == 1 and frozen else f[main])
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
    return CleanMesh(mv, mf, ov, of, report, source[kept])
