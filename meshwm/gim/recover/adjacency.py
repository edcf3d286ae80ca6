"""The mesh side of grid recovery: what the reader needs to know of a received mesh.

An oriented manifold mesh answers "which face has the directed edge u -> v, and what is its third
vertex" (:class:`_Lookup`, in either winding); each vertex has a fan of faces, closed or open, and a
valence, which classes it E (closed, 7 or 8 faces: grid samples with i + j even) or O (closed, 4 or
5: i + j odd) as the 4-8 mesh meshwm writes has them (:func:`_fans`).  :class:`_Mesh` gathers these
tables with the connected components and the depth of each vertex inside classed territory, used
to keep seeds away from cuts and seams.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

_DEPTH = 3  # preferred seeds have this many clean rings of vertices around them


class _Lookup:
    """Directed edge (u, v) -> third vertex of the face that has it, for an oriented mesh."""

    def __init__(self, n_vertices: int, faces: NDArray[np.int64]):
        a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
        keys = np.concatenate([a, b, c]) * n_vertices + np.concatenate([b, c, a])
        third = np.concatenate([c, a, b])
        face = np.tile(np.arange(len(faces)), 3)
        # Stable: fast on the nearly sorted keys of a file as the embedder wrote it.
        order = np.argsort(keys, kind="stable")
        self.keys, self.third, self.face = keys[order], third[order], face[order]
        self.order = order  # position in [a->b of every face, then b->c, then c->a]
        # A directed edge used twice means the mesh is not an oriented manifold there: such
        # edges never answer, so a propagation through them fails verification.
        dup = np.zeros(len(order), dtype=bool)
        dup[1:] = self.keys[1:] == self.keys[:-1]
        dup[:-1] |= dup[1:]
        self.third = np.where(dup, -1, self.third)
        self.n_vertices = n_vertices
        self.reverse = False

    def reversed(self) -> _Lookup:
        """The lookup of the same faces with their winding reversed (corners in reverse order).

        Reversed, the face with the directed edge u -> v is the one that had v -> u, with the
        same third vertex: the same table answers with its arguments swapped.
        """
        other = object.__new__(_Lookup)
        other.__dict__.update(self.__dict__)
        other.reverse = not self.reverse
        return other

    def __call__(
        self, u: NDArray[np.int64], v: NDArray[np.int64]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        if self.reverse:
            u, v = v, u
        pos, hit = self.find(u, v)
        return np.where(hit, self.third[pos], -1), np.where(hit, self.face[pos], -1)

    def find(
        self, u: NDArray[np.int64], v: NDArray[np.int64]
    ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Position of each directed edge u -> v in the sorted table, and whether it is there
        (as given: ``reverse`` is not applied)."""
        key = u * self.n_vertices + v
        pos = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
        hit = (self.keys[pos] == key) & (u >= 0) & (v >= 0)
        return pos, hit


class _Fans(NamedTuple):
    """Per directed edge of a lookup's sorted table, and per vertex: what the fans look like."""

    u: NDArray[np.int64]  # first vertex of each directed edge
    v: NDArray[np.int64]  # second vertex
    back_pos: NDArray[np.int64]  # position of the reverse edge v -> u (where ``back``)
    back: NDArray[np.bool_]  # whether v -> u exists
    first: NDArray[np.bool_]  # first occurrence of each directed edge
    valence: NDArray[np.int64]  # faces per vertex
    closed: NDArray[np.bool_]  # every directed edge at the vertex has its reverse
    cls: NDArray[np.int8]  # 0: E (closed, 7 or 8 faces), 1: O (closed, 4 or 5), -1: other


def _fans(lookup: _Lookup, faces: NDArray[np.int64]) -> _Fans:
    """The fans of ``faces`` (the faces ``lookup`` was built from): see :class:`_Fans`."""
    n = lookup.n_vertices
    keys = lookup.keys
    u, v = np.divmod(keys, n)
    back_pos, back = lookup.find(v, u)
    closed = np.ones(n, dtype=bool)
    closed[u[~back]] = False
    closed[v[~back]] = False
    first = np.ones(len(keys), dtype=bool)
    first[1:] = keys[1:] != keys[:-1]
    val = np.bincount(faces.ravel(), minlength=n)
    # Class of each vertex: 0 (E, i + j even: valence 8, or 7 at a flipped code cell),
    # 1 (O: 4, or 5), -1 (open fan or another valence: not used by the local reading).
    cls = np.full(n, -1, dtype=np.int8)
    cls[closed & ((val == 7) | (val == 8))] = 0
    cls[closed & ((val == 4) | (val == 5))] = 1
    return _Fans(u, v, back_pos, back, first, val, closed, cls)


class _Mesh:
    """What the reader needs of a mesh: lookups both windings, vertex classes, components."""

    def __init__(self, vertices: NDArray[np.float64], faces: NDArray[np.int64]):
        n = len(vertices)
        self.n_vertices, self.faces, self.vertices = n, faces, vertices
        self.lookup = _Lookup(n, faces)
        self._reversed: _Lookup | None = None
        self._depth: NDArray[np.int64] | None = None
        # A vertex is interior (closed fan) when every directed edge at it has its reverse;
        # only there is the face count the valence of the 4-8 grid.
        fans = _fans(self.lookup, faces)
        self.valence, self.cls = fans.valence, fans.cls
        val = self.valence
        # Plain fans (see _sound): closed, no neighbour twice (a repeated directed edge out of
        # the vertex), and 8 faces (row 0, for samples with i + j even) or 4 (row 1); row 2:
        # vertices of one face (see _border_phase).
        out = np.bincount(fans.u[fans.first], minlength=n)
        simple = fans.closed & (out == val)
        self.plain = np.stack([simple & (val == 8), simple & (val == 4), val == 1])
        graph = sp.csr_matrix(
            (np.ones(2 * len(faces)), (faces[:, :2].ravel(), faces[:, 1:].ravel())),
            shape=(n, n),
        )
        self.graph = graph
        self.n_components, self.label = connected_components(graph, connection="weak")

    def depth(self) -> NDArray[np.int64]:
        """Per vertex, edge hops to the nearest unclassed vertex, capped at _DEPTH + 1."""
        # Cached on the instance: a functools.cache on the method would keep every mesh alive.
        if self._depth is None:
            self._depth = _clean_depth(self, _DEPTH + 1)
        return self._depth

    def lookup_for(self, reverse: bool) -> _Lookup:
        """The lookup of the faces as given, or with their winding reversed."""
        if not reverse:
            return self.lookup
        if self._reversed is None:
            self._reversed = self.lookup.reversed()
        return self._reversed


def _clean_depth(mesh: _Mesh, cap: int) -> NDArray[np.int64]:
    """Edge hops from each vertex to the nearest unclassed one (open fan, odd valence), <= cap."""
    graph = mesh.graph + mesh.graph.T
    reached = mesh.cls < 0
    depth = np.full(mesh.n_vertices, cap, dtype=np.int64)
    depth[reached] = 0
    for d in range(1, cap):
        grown = (graph @ reached.astype(np.float64)) > 0
        new = grown & ~reached
        depth[new] = d
        reached |= grown
    return depth
