"""The geometry image of a mesh as it is: its own vertices sampled through a stable map.

The paper's pipeline (Tamane & Deshmukh, *Blind 3D model watermarking based on
multi-resolution representation and fuzzy logic*) remeshes the input into its geometry image and
hands back the grid.  Here the geometry image is only a *view* of the user's mesh: the mesh is
cut and mapped to the unit square (:func:`meshwm.gim.tutte.stable_parameterize`), and the N×N
samples are barycentric combinations of its vertices (:func:`meshwm.gim.sampling.sampling_matrix`),
one sparse matrix ``S`` with ``samples = S @ positions``.  The embedder moves the vertices so
that ``S`` reproduces the marked image (:mod:`meshwm.gim.transfer`); a blind reader re-derives
the same ``S`` from the received mesh alone and samples it.

What is sampled
---------------
The mesh is cleaned first (:func:`meshwm.mesh.clean.clean_mesh`: vertices at exactly the same
position merged, degenerate faces dropped, pinched edges and vertices split, orientation made
consistent, the largest component by area kept), so an STL soup, a file with vertices split at
UV seams and the same file welded give one surface.  Every vertex of the cleaned component has
the position of some input vertex, and the matrix is expressed over the input's *distinct
positions*: all input vertices at one position move together, so a seam never opens.
"""

from __future__ import annotations

from contextlib import nullcontext
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

from meshwm._digest import LastResult, arrays_key, freeze
from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import MeshError
from meshwm.gim.holes import boundary_loops, fill_holes
from meshwm.gim.sampling import bilinear_matrix, sampling_matrix
from meshwm.gim.stable import cut_start, nudge_start, smoothed_near, smoothing_ahead
from meshwm.gim.tutte import StableMap, restart_map, stable_parameterize
from meshwm.mesh.clean import clean_mesh
from meshwm.mesh.edges import distinct_rows

__all__ = [
    "SURFACE_RANKS",
    "SURFACE_SIZES",
    "Surface",
    "SurfaceImage",
    "keep_start",
    "remap_surface",
    "same_cleaning",
    "sample_surface",
    "surface_basis",
    "surface_of",
]

#: The geometry-image sizes a mesh is sampled at (the embedder picks one, the reader tries all).
SURFACE_SIZES = (128, 256)
#: The cut's candidate starts a reader tries (the embedder uses the first).
SURFACE_RANKS = (0, 1, 2, 3)


class Surface(NamedTuple):
    """A mesh's largest clean component, mapped, over the input's distinct positions.

    Attributes
    ----------
    positions : (p, 3) float64 ndarray
        The input's distinct vertex positions.
    inverse : (n,) int64 ndarray
        The position of each input vertex: ``positions[inverse]`` is the input's vertices.
    faces : (m, 3) int64 ndarray
        The cleaned component's triangles over ``positions`` (pinched vertices joined again).
    used : (p,) bool ndarray
        The positions the cleaned component uses (the others belong to other components).
    map : StableMap
        The cut and map of the cleaned component with its holes filled virtually (on its own
        vertex numbering, the fans' centres after the cleaned vertices).
    clean_to_position : (k,) int64 ndarray
        The position of each vertex of the cleaned component (not of the centres).
    report : dict
        ``components``, ``vertices_merged`` and the other counts of the cleaning.
    """

    positions: NDArray[np.float64]
    inverse: NDArray[np.int64]
    faces: NDArray[np.int64]
    used: NDArray[np.bool_]
    map: StableMap
    clean_to_position: NDArray[np.int64]
    report: dict


class SurfaceImage(NamedTuple):
    """The N×N sampling of a :class:`Surface`.

    Attributes
    ----------
    samples : (N, N, 3) float64 ndarray
        ``matrix @ positions``, NaN where no triangle covers the grid point.
    matrix : (N², p) scipy.sparse.csr_matrix
        Barycentric weights over the distinct positions.
    covered : (N, N) bool ndarray
    """

    samples: NDArray[np.float64]
    matrix: sp.csr_matrix
    covered: NDArray[np.bool_]

    @property
    def n(self) -> int:
        """The grid size N."""
        return int(self.covered.shape[0])


def _distinct(vertices: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Distinct rows (bit-exact) and the index of each input row among them."""
    first, inverse = distinct_rows(vertices)  # numbered by first appearance
    if len(first) == len(vertices):  # every row its own (first is 0, 1, ...): not copied
        return vertices, inverse
    return vertices[first], inverse


#: Up to this many vertices the cut's smoothing starts beside the cleaning (above, the two
#: at once add to the peak memory: at 5M vertices the kept embedding's peak 7.37-7.45 GiB
#: against 7.36-7.41 without).
AHEAD_VERTICES = 3_000_000


def surface_of(
    vertices: NDArray,
    faces: NDArray,
    *,
    max_faces: int = DEFAULT_MAX_FACES,
    rank: int = 0,
    merge: bool = True,
    like: Surface | None = None,
    min_used: int = 0,
) -> Surface:
    """Clean, weld and map a mesh (see the module notes).

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    max_faces : int, optional
        Refuse larger inputs.
    rank : int, optional
        The cut's candidate start (:func:`meshwm.gim.stable.stable_cut`; 0 for embedding).
    merge : bool, optional
        Clean as described (default).  False: the connectivity as given, largest component,
        nothing merged: coarse quantisation makes distinct vertices coincide, and merging them
        can leave a surface that is no longer a manifold (the reader's second try).
    min_used : int, optional
        With ``merge=False``: refuse (``MeshError``) a largest component of fewer vertices (an
        STL soup as given is one triangle per component).
    like : Surface, optional
        A surface of a mesh with the same faces (the input of an embedding, for its read-back):
        where the cleaning, the filled holes and the cut's start come out the same, its cut
        and map are reused, and the result is bit for bit what it would be without ``like``
        (the cut and the map depend on nothing else: :mod:`meshwm.gim.stable`).

    Returns
    -------
    Surface

    Raises
    ------
    MeshError
        Unusable arrays, a non-manifold or non-orientable surface, or one the map cannot open
        to a disk.
    """
    v, f = check_mesh(vertices, faces, max_faces=max_faces, frozen=True)
    if not merge:
        return _as_given(v, f, rank=rank, min_used=min_used)
    with smoothing_ahead(v, f) if like is None and len(v) <= AHEAD_VERTICES else nullcontext():
        positions, inverse = _distinct(v)
        clean = clean_mesh(v, f, max_faces=max_faces)
        freeze(clean.vertices, clean.faces)  # ours alone (or shared, read-only already)
        # Each cleaned vertex is a copy of an input vertex (``clean.source``), so it is at that
        # vertex's distinct position (found before by grouping both sets of rows again: 5M
        # vertices, 2.9 s).
        to_position = inverse[clean.source]
        same = same_cleaning(like, inverse, to_position, to_position[clean.faces])
        reuse = like.map if like is not None and same else None
        smap = _map_filled(clean.vertices, clean.faces, rank=rank, like=reuse)
    used = np.zeros(len(positions), dtype=bool)
    used[to_position] = True
    # Each cleaned vertex its own distinct position, in order (most meshes): the faces as
    # they are, one array whose digest is kept.
    same_order = len(to_position) == len(positions) and np.array_equal(
        to_position, np.arange(len(positions))
    )
    out = Surface(
        positions,
        inverse,
        clean.faces if same_order else to_position[clean.faces],
        used,
        smap,
        to_position,
        clean.report,
    )
    freeze(out.positions, out.inverse, out.faces, out.used, out.clean_to_position)
    return out


def same_cleaning(
    like: Surface | None,
    inverse: NDArray[np.int64],
    to_position: NDArray[np.int64],
    faces: NDArray[np.int64],
) -> bool:
    """Whether a mesh whose vertices go to distinct positions by ``inverse``, cleaned to
    ``faces`` over those positions (its cleaned vertices at ``to_position``), is ``like``'s
    cleaned surface with its positions moved: then ``like``'s map can be restarted on it
    (:func:`~meshwm.gim.tutte.restart_map`)."""
    return (
        like is not None
        and bool(like.report.get("merged", True))
        and np.array_equal(like.inverse, inverse)
        and np.array_equal(like.clean_to_position, to_position)
        and np.array_equal(like.faces, faces)
    )


def _as_given(
    v: NDArray[np.float64], f: NDArray[np.int64], *, rank: int, min_used: int = 0
) -> Surface:
    """:func:`surface_of` on the largest component as given: every vertex its own position."""
    n = len(v)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]]])
    graph = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    face_label = labels[f[:, 0]]
    main = int(np.argmax(np.bincount(face_label)))
    cf_in = f[face_label == main]
    index = np.unique(cf_in)  # the component's vertices, in the input's order
    if len(index) < min_used:
        raise MeshError(f"the largest component as given has {len(index)} vertices")
    cf = np.searchsorted(index, cf_in).astype(np.int64)
    used = np.zeros(n, dtype=bool)
    used[index] = True
    smap = _map_filled(v[index], cf, rank=rank)
    report = {"components": int(labels[np.unique(f)].max() + 1), "merged": False}
    return Surface(v.copy(), np.arange(n, dtype=np.int64), cf_in, used, smap, index, report)


def remap_surface(
    surface: Surface, positions: NDArray, *, rank: int = 0, like: StableMap | None = None
) -> Surface:
    """The same cleaned surface with its distinct positions moved, and mapped again.

    Cleaning depends on which positions coincide and on the faces, which moving every copy of
    a position together does not change; only the map is computed anew (it may depend on the
    geometry through its start).

    Parameters
    ----------
    surface : Surface
    positions : (p, 3) array_like
        New distinct positions, one per ``surface.positions``.
    rank : int, optional
        The cut's candidate start.
    like : StableMap, optional
        A map of the same cleaned surface with other positions (the input's, when the
        embedder reads its output back): reused where this rank's start is its start, bit for
        bit what the map would be without it (:func:`~meshwm.gim.tutte.restart_map`).
    """
    p = np.asarray(positions, dtype=np.float64)
    _, clean_faces = _map_faces(surface)
    smap = _map_filled(p[surface.clean_to_position], clean_faces, rank=rank, like=like)
    return surface._replace(positions=p, map=smap)


def keep_start(
    surface: Surface,
    displacement: NDArray[np.float64],
    *,
    margin: float = 1e-5,
    rounds: int = 4,
) -> NDArray[np.float64] | None:
    """The bump to add to ``displacement`` (a move of ``surface``'s distinct positions) after
    which the map's cut keeps ``surface``'s start, or None where that fails.

    The cut and the map depend on the geometry only through the start, the farthest vertex of a
    smoothed copy (:func:`meshwm.gim.stable.cut_start`); where the input's farthest vertex is a
    near-tie, the mark can tip it, and the marked mesh's map is then another one.  Each round
    adds the least-norm smooth bump that puts the input's source back ahead by ``margin``
    (:func:`meshwm.gim.stable.nudge_start`), then checks the start as a reader computes it.

    The check is made on ``surface.positions + (displacement + bump)``, the very bits the
    marked mesh will have, so a reader's start of that mesh is the one found here (and
    :func:`meshwm.gim.stable.cut_start` has it memoised).  After a bump, the smoothed copy of
    the rows it reaches is computed from the last round's (:func:`meshwm.gim.stable.smoothed_near`,
    bit for bit the whole smoothing).

    Returns
    -------
    (p, 3) float64 ndarray or None
        The bump to add (zeros where the start is already kept), or None: the start is not
        kept within ``rounds`` (its first edge moved, or the bumps do not converge).
    """
    k = len(surface.clean_to_position)
    cut = surface.map.cut
    filled_faces, clean_faces = _map_faces(surface)
    want = (int(cut.order[0]), int(cut.order[1]))
    d = np.asarray(displacement, dtype=np.float64)
    bump = np.zeros_like(d)
    total = d
    previous = None
    for round_ in range(rounds + 1):
        moved = (surface.positions + total)[surface.clean_to_position]
        points, faces = _filled(moved, clean_faces)
        if not np.array_equal(faces, filled_faces):
            return None
        if previous is not None:  # the bump moved a few rows: their smoothing alone, exact
            smoothed_near(previous, points, faces)
        previous = points
        if cut_start(points, faces)[0] == want:
            return bump
        push = None if round_ == rounds else nudge_start(points, faces, want[0], margin=margin)
        if push is None:
            return None
        bump[surface.clean_to_position] += push[:k]
        total = d + bump
    return None


def _map_faces(surface: Surface) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The faces the map was made of (holes filled, over the cleaned vertices and the fans'
    centres) and, of those, the cleaned component's own (no centre)."""
    filled = surface.map.cut.mesh.origin[surface.map.cut.mesh.faces]
    own = filled[np.all(filled < len(surface.clean_to_position), axis=1)]
    freeze(filled, own)
    return filled, own


def _filled(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """A cleaned component's points and faces with its holes filled (:func:`_map_filled`;
    the loops of the same faces are kept by :func:`~meshwm.gim.holes.boundary_loops`)."""
    filled = fill_holes(vertices, faces, boundary_loops(faces))
    points = np.concatenate([vertices, filled.centres]) if len(filled.centres) else vertices
    return points, filled.faces


def _map_filled(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    rank: int,
    like: StableMap | None = None,
) -> StableMap:
    """The stable map of a cleaned component with its holes filled (:mod:`meshwm.gim.holes`).

    A surface with small holes is a sphere, not a disk: mapped onto its longest hole as the
    square's border, the far side shrinks to nothing.  Every hole but a long border is filled
    with a fan to a centre vertex, so it becomes an island inside the map (its grid points are
    not covered).  Which loops are filled depends only on the border's geometry.
    """
    points, filled_faces = _filled(vertices, faces)
    if like is not None:
        same = like.cut.mesh.origin[like.cut.mesh.faces]
        if np.array_equal(same, filled_faces):
            reused = restart_map(like, points, filled_faces, rank=rank)
            if reused is not None:
                return reused
    return stable_parameterize(points, filled_faces, rank=rank)


def sample_surface(surface: Surface, *, size: int) -> SurfaceImage:
    """The ``size``-square sampling of a mapped surface, over its distinct positions.

    Parameters
    ----------
    surface : Surface
    size : int
        N.

    Returns
    -------
    SurfaceImage
    """
    key = (
        *arrays_key(
            surface.map.uv,
            surface.map.cut.mesh.faces,
            surface.map.cut.mesh.origin,
            surface.clean_to_position,
        ),
        len(surface.positions),
        int(size),
    )
    found = _SAMPLING.get(key)
    if found is None:
        found = _sampling_of(surface, size)
        _SAMPLING.put(key, found)
    # Copies: the memoised pair is shared (a few entries a row at most: cheap).
    matrix, covered = found[0].copy(), found[1].copy()
    samples = np.asarray(matrix @ surface.positions).reshape(size, size, 3)
    samples[~covered] = np.nan
    return SurfaceImage(samples, matrix, covered)


#: The last map's sampling: the embedder's blind read-back samples the map it reuses again
#: (the same UVs, faces and positions' numbering: the same matrix, bit for bit).
_SAMPLING = LastResult()


def _sampling_of(surface: Surface, size: int) -> tuple[sp.csr_matrix, NDArray[np.bool_]]:
    """:func:`sample_surface`'s matrix (distinct positions to covered samples) and mask."""
    cut = surface.map.cut.mesh
    sampling = sampling_matrix(surface.map.uv, cut.faces, size)
    real = cut.origin < len(surface.clean_to_position)  # not a filled hole's centre
    covered = sampling.covered.copy()
    # The grid's border lies on the map's boundary, where triangles with three corners on one
    # side of the square have no area and rounding picks among them: not samples (the robust
    # profile never moves border samples anyway).
    covered[[0, -1], :] = False
    covered[:, [0, -1]] = False
    if not real.all():  # grid points in a filled hole touch its centre: not the surface
        in_hole = np.asarray(sampling.matrix @ (~real).astype(np.float64)).ravel() > 0
        covered &= ~in_hole.reshape(size, size)
    keep, position = _cut_positions(surface)
    fold = sp.csr_matrix(
        (np.ones(len(keep)), (keep, position)),
        shape=(len(cut.origin), len(surface.positions)),
    )
    rows = sp.diags(covered.ravel().astype(np.float64))
    matrix = sp.csr_matrix(rows @ sampling.matrix @ fold)
    matrix.eliminate_zeros()
    return matrix, covered


def _cut_positions(surface: Surface) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The cut mesh's vertices that are the surface's own (not a filled hole's centre), and
    the distinct position of each."""
    cut = surface.map.cut.mesh
    real = np.flatnonzero(cut.origin < len(surface.clean_to_position))
    return real, surface.clean_to_position[cut.origin[real]]


def surface_basis(surface: Surface, *, size: int) -> sp.csr_matrix:
    """Each distinct position's bilinear weights on the ``size``-square grid (N), at its UV.

    The reverse of :func:`sample_surface`'s matrix: ``basis @ c`` spreads values ``c`` on the
    grid points (an (N², k) array) onto the positions, bilinearly at each position's place in
    the map.  A position the cut splits has a UV on each side; it takes the mean of their
    weights.  Positions outside the mapped component (other components) get an empty row.

    Returns
    -------
    (p, N²) scipy.sparse.csr_matrix of float64
        Rows summing to 1 (0 for an unmapped position).
    """
    real, position = _cut_positions(surface)
    copies = np.bincount(position, minlength=len(surface.positions)).astype(np.float64)
    fold = sp.csr_matrix(
        (1.0 / copies[position], (position, np.arange(len(real)))),
        shape=(len(surface.positions), len(real)),
    )
    return sp.csr_matrix(fold @ bilinear_matrix(surface.map.uv[real], size))
