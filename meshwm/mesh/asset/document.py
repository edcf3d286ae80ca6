"""The asset document: a file as named meshes to mark, everything else carried as it came.

A studio's file is more than one triangle mesh: UVs, normals, colours, materials, polygons,
several objects, a scene graph.  An :class:`Asset` holds the file's bytes as read and, parsed
out of them, only what marking needs: the file's **position table** (every stored vertex
position, in file order: OBJ ``v`` records, PLY vertex rows, STL corners, glTF ``POSITION``
elements) and the meshes (:class:`AssetMesh`), each a set of rows of that table with the
triangles over them.  :meth:`Asset.with_positions` gives a new document whose meshes have new
vertex positions; the format's writer then changes only those positions in the original bytes
and keeps every other byte (:mod:`meshwm.mesh.asset`).

Within a mesh, rows that hold exactly the same position are one vertex (an STL corner, an OBJ
``v`` written twice, a glTF vertex split at a UV seam): they are handed to the marker once and
move together, so no seam opens.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import MeshError
from meshwm.mesh.edges import distinct_rows

__all__ = ["Asset", "AssetMesh", "Summary", "fan_triangles", "group_sections", "weld_rows"]


@dataclass(frozen=True, eq=False)
class AssetMesh:
    """One mesh of an asset: rows of the position table and the triangles over them.

    Attributes
    ----------
    name : str
        The mesh's name in the file (OBJ object or group, glTF node or mesh, STL solid), unique
        within the asset; ``"mesh"`` when the file names none.
    rows : (k,) int64 ndarray
        The rows of the asset's position table this mesh uses, ascending.
    vertex_of_row : (k,) int64 ndarray
        For each of ``rows``, the mesh vertex it is (rows with equal positions share one).
    faces : (m, 3) int64 ndarray
        Triangles over the mesh vertices (polygons fanned from their first corner).
    polygons : int
        Faces as the file stores them (a quad counts once).
    reason : str or None
        Why this mesh cannot be marked (points or lines only, compressed positions), or None.
    """

    name: str
    rows: NDArray[np.int64]
    vertex_of_row: NDArray[np.int64]
    faces: NDArray[np.int64]
    polygons: int
    reason: str | None = None

    @property
    def n_vertices(self) -> int:
        """Distinct vertex positions of the mesh."""
        return int(self.vertex_of_row.max()) + 1 if len(self.vertex_of_row) else 0


@dataclass(frozen=True)
class Summary:
    """What a file carries, counted: the before/after table of ``scripts/check_assets.py``.

    ``vertices`` counts the position table's rows, ``faces`` the faces as stored (polygons
    count once), ``polygons`` those with more than three corners; ``uvs``, ``normals`` and
    ``colors`` count the stored elements of each kind (OBJ ``vt``/``vn`` records, PLY
    properties per vertex, glTF accessor elements); ``materials`` the materials used or
    defined; ``dtype`` how positions are stored; ``extra`` anything else worth naming (other
    PLY properties, glTF nodes and textures, OBJ material libraries), as ``name=value``.
    """

    meshes: int
    vertices: int
    faces: int
    triangles: int
    polygons: int = 0
    uvs: int = 0
    normals: int = 0
    colors: int = 0
    materials: int = 0
    dtype: str = ""
    extra: tuple[str, ...] = ()

    def changes_from(self, before: Summary) -> list[str]:
        """The counts that differ from ``before``, as ``"name a -> b"`` (empty: all kept)."""
        out = []
        for f in dataclasses.fields(self):
            old, new = getattr(before, f.name), getattr(self, f.name)
            if old != new:
                if f.name == "extra":
                    lost = [e for e in old if e not in new]
                    out.append(f"{', '.join(lost) or 'extra'} not kept")
                else:
                    out.append(f"{f.name} {old} -> {new}")
        return out


@dataclass(frozen=True, eq=False)
class Asset:
    """A mesh file as read: its bytes, its position table, its meshes (see the module notes).

    Attributes
    ----------
    suffix : str
        The format, as its lower-case suffix (``".obj"``, ``".glb"``, ...).
    data : bytes
        The file's bytes as read.
    original : (N, 3) float64 ndarray
        The position table as read.
    positions : (N, 3) float64 ndarray
        The position table now (:meth:`with_positions`); the writer rewrites the rows that
        differ from ``original``.
    meshes : tuple of AssetMesh
        The meshes, in file order.
    summary : Summary
        What the file carries.
    state : object
        The format's own parse results, opaque to everything but its writer.
    path : pathlib.Path or None
        Where the file was read from (sidecar files are resolved against it).
    """

    suffix: str
    data: bytes
    original: NDArray[np.float64]
    positions: NDArray[np.float64]
    meshes: tuple[AssetMesh, ...]
    summary: Summary
    state: Any = None
    path: Path | None = None
    sidecars: tuple[str, ...] = field(default=())

    def vertices(self, k: int) -> NDArray[np.float64]:
        """The (n, 3) vertex positions of mesh ``k`` (one per distinct position, a copy)."""
        mesh = self.meshes[k]
        out = np.empty((mesh.n_vertices, 3))
        out[mesh.vertex_of_row] = self.positions[mesh.rows]
        return out

    def mesh_index(self, name: str) -> int:
        """The index of the mesh called ``name``; a one-line error lists the names."""
        for k, mesh in enumerate(self.meshes):
            if mesh.name == name:
                return k
        names = ", ".join(repr(m.name) for m in self.meshes)
        raise MeshError(f"no mesh named {name!r}; the meshes are {names}")

    def with_positions(self, vertices: Sequence[NDArray | None]) -> Asset:
        """A new document whose mesh ``k`` has the vertex positions ``vertices[k]``.

        Parameters
        ----------
        vertices : sequence of (n_k, 3) array_like or None
            One entry per mesh, in the order of :attr:`meshes`, shaped like
            :meth:`vertices` of that mesh; None keeps a mesh as it is.

        Returns
        -------
        Asset
            Everything shared with this one but :attr:`positions`.

        Raises
        ------
        ValueError
            The wrong number of entries, a wrong shape, or NaN or infinite values.
        """
        if len(vertices) != len(self.meshes):
            raise ValueError(
                f"need {len(self.meshes)} vertex arrays, one per mesh, got {len(vertices)}"
            )
        positions = self.positions.copy()
        for mesh, new in zip(self.meshes, vertices, strict=True):
            if new is None:
                continue
            array = np.asarray(new, dtype=np.float64)
            if array.shape != (mesh.n_vertices, 3):
                raise ValueError(
                    f"mesh {mesh.name!r} has {mesh.n_vertices} vertices, got an array of shape "
                    f"{array.shape}"
                )
            if not np.isfinite(array).all():
                raise ValueError(f"mesh {mesh.name!r}: positions must be finite")
            positions[mesh.rows] = array[mesh.vertex_of_row]
        return dataclasses.replace(self, positions=positions)

    def changed_rows(self) -> NDArray[np.bool_]:
        """Which rows of the position table differ from the file's (exactly)."""
        return np.any(self.positions != self.original, axis=1)


def weld_rows(
    positions: NDArray[np.float64], rows: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``rows`` sorted and unique, and each one's vertex: equal positions are one vertex.

    Vertices are numbered in the order of their first row, so a file without duplicate
    positions keeps its own vertex order.

    Examples
    --------
    >>> p = np.array([[0.0, 0, 0], [1, 0, 0], [0.0, 0, 0], [2, 0, 0]])
    >>> rows, vertex = weld_rows(p, np.array([3, 0, 2, 1, 0]))
    >>> rows.tolist(), vertex.tolist()
    ([0, 1, 2, 3], [0, 1, 0, 2])
    """
    rows = np.asarray(rows, dtype=np.int64).ravel()
    if len(rows) and rows.min() >= 0:  # a count, not a sort (rows index ``positions``)
        rows = np.flatnonzero(np.bincount(rows, minlength=len(positions)))
    else:
        rows = np.unique(rows)
    if not len(rows):
        return rows, rows.copy()
    # Equal positions by their bits (-0.0 made 0.0 first, as float equality has it), grouped
    # by one sort of a hash of each row: ``np.unique(..., axis=0)`` did the same through a
    # structured view, 0.15 s a 50k-vertex file, most of a batch verify's reading.
    _, vertex = distinct_rows(np.asarray(positions[rows], dtype=np.float64) + 0.0)
    return rows, vertex


def fan_triangles(
    corners: Sequence[int] | NDArray, lengths: Sequence[int] | NDArray
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Polygons fanned from their first corner: the triangles and the polygon of each.

    Parameters
    ----------
    corners : sequence of int
        Every polygon's corners, one polygon after the other.
    lengths : sequence of int
        Each polygon's corner count (at least 3).

    Examples
    --------
    >>> tri, owner = fan_triangles([0, 1, 2, 3, 4, 5, 6], [4, 3])
    >>> tri.tolist(), owner.tolist()
    ([[0, 1, 2], [0, 2, 3], [4, 5, 6]], [0, 0, 1])
    """
    counts = np.asarray(lengths, dtype=np.int64)
    flat = np.asarray(corners, dtype=np.int64)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    n_tri = counts - 2
    owner = np.repeat(np.arange(len(counts), dtype=np.int64), n_tri)
    k = np.arange(int(n_tri.sum()), dtype=np.int64) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    first = start[owner]
    tri = np.stack([flat[first], flat[first + k + 1], flat[first + k + 2]], axis=1)
    return tri.reshape(-1, 3), owner


def _union_find(parent: list[int], a: int) -> int:
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


def group_sections(
    positions: NDArray[np.float64],
    sections: Sequence[tuple[str, NDArray[np.int64], int]],
    *,
    default_name: str = "mesh",
) -> list[AssetMesh]:
    """Meshes from a file's sections (objects, groups, glTF meshes): one per group of them.

    Parameters
    ----------
    positions : (N, 3) float64 ndarray
        The position table.
    sections : sequence of (name, triangles, polygons)
        Each section's name, its triangles as (m, 3) rows of the position table, and its
        face count as stored.  Sections with no triangles are dropped.
    default_name : str, optional
        The name of a mesh whose sections have none.

    Returns
    -------
    list of AssetMesh
        Sections that share a row of the position table are one mesh (a row cannot move
        twice), named by their names joined with ``+``; names are made unique with ``#2``,
        ``#3``.

    Raises
    ------
    MeshError
        A triangle refers to a row outside the table.
    """
    kept = [(name, np.asarray(t, dtype=np.int64).reshape(-1, 3), p) for name, t, p in sections]
    kept = [s for s in kept if len(s[1])]
    for name, tri, _ in kept:
        if tri.min() < 0 or tri.max() >= len(positions):
            raise MeshError(f"mesh {name or default_name!r} refers to a vertex that does not exist")
    parent = list(range(len(kept)))
    owner = np.full(len(positions), -1, dtype=np.int64)
    for k, (_, tri, _) in enumerate(kept):
        used = np.flatnonzero(np.bincount(tri.ravel(), minlength=len(positions)))
        for other in np.unique(owner[used][owner[used] >= 0]).tolist():
            a, b = _union_find(parent, k), _union_find(parent, int(other))
            if a != b:
                parent[max(a, b)] = min(a, b)
        owner[used] = k
    groups: dict[int, list[int]] = {}
    for k in range(len(kept)):
        groups.setdefault(_union_find(parent, k), []).append(k)
    meshes: list[AssetMesh] = []
    seen: dict[str, int] = {}
    for members in groups.values():
        names = list(dict.fromkeys(kept[k][0] for k in members if kept[k][0]))
        name = "+".join(names) or default_name
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            name = f"{name}#{seen[name]}"
        tri = np.concatenate([kept[k][1] for k in members])
        rows, vertex = weld_rows(positions, tri.ravel())
        where = np.empty(len(positions), dtype=np.int64)
        where[rows] = vertex
        local = where[tri]
        polygons = sum(kept[k][2] for k in members)
        meshes.append(AssetMesh(name, rows, vertex, local, polygons))
    return meshes
