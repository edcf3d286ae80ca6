"""Geometry images: a triangle mesh resampled onto a regular N×N grid.

Section 3 of the paper works on "three matrices (x1, x2, x3) of dimension N × N": a *geometry
image* (Gu, Gortler and Hoppe, "Geometry images", SIGGRAPH 2002, doi:10.1145/566654.566589).
The paper does not say how it gets one.  :func:`mesh_to_geometry_image` builds it the way Gu et
al. do, with choices each made so that the same surface always gives the same image, in four
steps, one module each:

Cut (:mod:`meshwm.gim.cut`)
    The mesh is cut open into a topological disk: a closed genus-0 mesh along one shortest edge
    path between the ends of an approximate geodesic diameter, other meshes by
    ``igl.cut_to_disk`` on a canonically ordered copy.
Boundary map (:mod:`meshwm.gim.boundary`)
    The disk's boundary loop is split into chains at the nodes of the cut graph and laid on the
    perimeter of the square by arc length, each chain on a whole number of grid steps, the same
    on both sides of a cut, so both sides fall on the same grid samples (welded when the mesh is
    rebuilt).
Interior map (:mod:`meshwm.gim.parameterize`)
    A harmonic map with positive-clamped cotangent weights (an embedding: no flipped triangle),
    then stretch-minimising reweighting.
Sampling (:mod:`meshwm.gim.sample`)
    Each grid point is interpolated barycentrically in the UV triangles; boundary samples come
    from the 3-D boundary chains directly.

Where the map still samples a region too sparsely, the region is cut open at its tip and the
map is made again (up to ``max_rounds`` rounds), and the most even round is kept.
:func:`meshwm.gim.to_mesh.geometry_image_to_mesh` turns the image back into a mesh.

References
----------
.. [1] X. Gu, S. J. Gortler, H. Hoppe, "Geometry images", ACM TOG 21(3), 2002.
.. [2] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic", section 3.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm._validate import check_mesh, check_square_pow2
from meshwm._vector import face_area
from meshwm.errors import MeshError
from meshwm.gim.boundary import (
    Chains,
    Disk,
    boundary_chains,
    chain_points_at,
    split_corners,
    unit_to_uv,
)
from meshwm.gim.cut import (
    CutMesh,
    area_centroid,
    count_loops,
    cut_open,
    edge_graph,
    extend_cut,
    initial_cut,
    path_edges,
)
from meshwm.gim.parameterize import GridStep, flat_faces, signed_uv_area, stretch_parameterize
from meshwm.gim.pose import CanonicalMesh, Pose, canonical_mesh, canonical_pose
from meshwm.gim.sample import sample_geometry_image
from meshwm.mesh.clean import clean_mesh, unique_edges

__all__ = ["GeometryImage", "mesh_to_geometry_image"]


class GeometryImage(NamedTuple):
    """A geometry image and what is needed to turn it back into a mesh.

    Attributes
    ----------
    gim : (N, N, 3) float64 ndarray
        ``gim[i, j]`` is the surface point at ``(u, v) = (j, i) / (N - 1)``; ``gim[..., 0]``,
        ``gim[..., 1]`` and ``gim[..., 2]`` are the paper's x1, x2, x3.
    weld : (N, N) int64 ndarray
        For each sample, the flat index ``i * N + j`` of the sample it is welded to (itself if
        none).  Welded samples are the two sides of a cut: always equal in ``gim``.
    other_vertices, other_faces : ndarray
        Components of the input other than the largest, passed through unchanged.
    report : dict
        Counts and timings (see :func:`mesh_to_geometry_image`).
    """

    gim: NDArray[np.float64]
    weld: NDArray[np.int64]
    other_vertices: NDArray[np.float64]
    other_faces: NDArray[np.int64]
    report: dict


class _Surface(NamedTuple):
    """The cleaned input and what every cut round measures it by."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    graph: sp.csr_matrix  # edge lengths
    radial: NDArray[np.float64]  # distance of each vertex to the area centroid
    diameter: float  # of the centroid-centred bounding sphere: the scale of the stretch
    uniform: float  # spacing of samples spread evenly over the surface (a unit square's worth)
    euler_characteristic: int
    boundary_loops: int
    closed_genus0: bool


class _Round(NamedTuple):
    """One cut round: the cut, its map, and how evenly the map samples the surface."""

    max_step: float  # largest local stretch off the cut (the round's score, lower is better)
    number: int  # 0 for the first cut, then one per extension of the cut
    paths: list[NDArray[np.int64]]  # the cut paths (input vertex ids)
    chains: Chains
    disk: Disk  # the cut mesh with its corners split
    uv: NDArray[np.float64]  # the map of each disk vertex
    stretch_history: list[float]  # global stretch of each map tried in this round
    step: NDArray[np.float64]  # local stretch per input vertex (0 on the cut)
    on_cut: NDArray[np.bool_]  # input vertices on the boundary loop
    cut: CutMesh  # the mesh cut open along ``paths`` (before its corners were split)


def _surface(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> _Surface:
    """Topology, edge graph and scales of the cleaned mesh."""
    edges, inverse = unique_edges(faces)
    face_count = np.bincount(inverse, minlength=len(edges))
    n_border = int(np.sum(face_count == 1))
    chi = len(vertices) - len(edges) + len(faces)
    n_loops = count_loops(len(vertices), edges, face_count == 1)
    graph = edge_graph(vertices, edges)
    centroid = area_centroid(vertices, faces)
    radial = np.linalg.norm(vertices - centroid, axis=1)
    # Scale for the stretch threshold: the diameter of the centroid-centred bounding sphere.
    # (The bounding-box diagonal would do, but it changes when the mesh is rotated.)
    diameter = 2.0 * float(radial.max())
    # Spacing of samples spread evenly over the surface (the unit square has area 1).
    uniform = float(np.sqrt(face_area(vertices, faces).sum()))
    return _Surface(
        vertices,
        faces,
        graph,
        radial,
        diameter,
        uniform,
        chi,
        n_loops,
        n_border == 0 and chi == 2,
    )


def _local_stretch(
    uv: NDArray[np.float64],
    *,
    surface: _Surface,
    grid_step: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    on_cut: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """Grid step per input vertex relative to the diameter, 0 on the cut."""
    s = grid_step(uv) / surface.diameter
    s[on_cut] = 0.0
    return s


#: A round whose largest local sample spacing is at most this many times the spacing of samples
#: spread evenly over the surface ends the rounds, and a map that does ends its round's
#: reweighting.  ``max_stretch`` is relative to the diameter, and a sphere-like surface mapped
#: evenly already spans about 1.8 diameters per UV unit, so it never stopped either there.
#: Igea subdivided to 537k vertices: the first round's harmonic map at 3.09 (just over
#: ``accept_uniformity``), the first reweighting at 1.26; before, 9 more reweighting solves and
#: two more rounds (23 solves in all) kept that round, now 2 solves.  The ten development
#: meshes' geometry images at N = 256 are the same as before, bit for bit (fandisk and kitten
#: stop reweighting at the map they kept after 5 more solves; camelhead's rounds stop after
#: the first, which they kept).
_EVEN_ENOUGH = 2.0


def _spacing(step: NDArray[np.float64], surface: _Surface) -> float:
    """The largest local sample spacing (``step``: per vertex, over the diameter) over the
    spacing of samples spread evenly over the surface."""
    return float(step.max()) * surface.diameter / surface.uniform


def _good_enough(
    uv: NDArray[np.float64],
    *,
    local_stretch: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    surface: _Surface,
    max_stretch: float,
) -> bool:
    step = local_stretch(uv)
    return float(step.max()) <= max_stretch or _spacing(step, surface) <= _EVEN_ENOUGH


def _samples_evenly(
    uv: NDArray[np.float64],
    *,
    local_stretch: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    surface: _Surface,
    accept_uniformity: float,
) -> bool:
    # The plain harmonic map of the first cut samples evenly enough: keep it.
    return _spacing(local_stretch(uv), surface) <= accept_uniformity


def _cut_round(
    surface: _Surface,
    paths: list[NDArray[np.int64]],
    n: int,
    *,
    number: int,
    stretch_iterations: int,
    max_stretch: float,
    accept_uniformity: float,
) -> _Round:
    """Cut along ``paths``, lay the boundary on the square, map the interior, measure it."""
    cut = cut_open(surface.vertices, surface.faces, paths)
    chains = boundary_chains(cut.vertices, cut.faces, cut.origin, n, surface.radial)
    disk = split_corners(cut.vertices, cut.faces, cut.origin, chains, n)
    on_cut = np.zeros(len(surface.vertices), dtype=bool)
    on_cut[disk.origin[disk.loop]] = True
    boundary_uv = unit_to_uv(disk.unit, n)
    flat = flat_faces(disk.faces, disk.loop, boundary_uv)
    # The disk's 3-D side of the grid step is first asked for after the first solve: made in
    # a second thread while the map's system is built and solved (5M vertices: 1.0 s).
    with beside(
        GridStep, disk.vertices, disk.faces, disk.origin, len(surface.vertices), surface.graph, flat
    ) as step_of:
        local_stretch = functools.partial(
            _local_stretch,
            surface=surface,
            grid_step=lambda uv: step_of.result()(uv),
            on_cut=on_cut,
        )
        first_round_accept = functools.partial(
            _samples_evenly,
            local_stretch=local_stretch,
            surface=surface,
            accept_uniformity=accept_uniformity,
        )
        uv, stretch_history = stretch_parameterize(
            disk.vertices,
            disk.faces,
            disk.loop,
            boundary_uv,
            iterations=stretch_iterations,
            good_enough=functools.partial(
                _good_enough, local_stretch=local_stretch, surface=surface, max_stretch=max_stretch
            ),
            accept=first_round_accept if number == 0 else None,
        )
        step = local_stretch(uv)
    return _Round(
        float(step.max()), number, paths, chains, disk, uv, stretch_history, step, on_cut, cut
    )


def _cut_rounds(
    surface: _Surface,
    n: int,
    *,
    stretch_iterations: int,
    max_stretch: float,
    max_rounds: int,
    accept_uniformity: float,
    paths: list[NDArray[np.int64]] | None = None,
) -> tuple[_Round, _Round]:
    """Cut, map, and extend the cut where the map undersamples; the best and the last round.

    Stops when the first round's harmonic map samples evenly enough, when a round's local
    stretch is at most ``max_stretch`` or its spacing at most :data:`_EVEN_ENOUGH` times the
    even one, when an extended cut does not fit the grid, after ``max_rounds`` extensions, or
    two rounds after the best one.
    """
    if paths is None:
        paths = initial_cut(
            surface.vertices,
            surface.faces,
            surface.graph,
            closed_genus0=surface.closed_genus0,
            radial=surface.radial,
        )
    number = 0
    best: _Round | None = None
    last: _Round | None = None
    while True:
        try:
            state = _cut_round(
                surface,
                paths,
                n,
                number=number,
                stretch_iterations=stretch_iterations,
                max_stretch=max_stretch,
                accept_uniformity=accept_uniformity,
            )
        except MeshError:
            if best is None or last is None:
                raise
            # An extended cut that the grid cannot lay out (more chains than boundary
            # samples): the rounds so far are what this size can do.
            return best, last
        last = state
        if best is None or state.max_step < best.max_step:
            best = state
        step = state.step
        accepted = (
            number == 0
            and len(state.stretch_history) == 1
            and _spacing(step, surface) <= accept_uniformity
        )
        if (
            accepted
            or step.max() <= max_stretch
            or _spacing(step, surface) <= _EVEN_ENOUGH
            or number >= max_rounds
            or number - best.number >= 2
        ):
            return best, state
        number += 1
        paths = extend_cut(
            paths,
            surface.graph,
            on_cut=state.on_cut,
            undersampled=step > max_stretch,
            radial=surface.radial,
        )


def _report(surface: _Surface, best: _Round, last: _Round, weld: NDArray[np.int64], n: int) -> dict:
    """The counts of the remesh (the keys of :func:`mesh_to_geometry_image`'s report)."""
    fs = best.disk.faces
    area_uv = signed_uv_area(best.uv, fs)
    flipped = int(np.sum(area_uv < -1e-12 / len(fs)))
    degenerate = int(np.sum(np.abs(area_uv) <= 1e-12 / len(fs)))
    chi, n_loops = surface.euler_characteristic, surface.boundary_loops
    genus = (2 - chi - n_loops) // 2
    history, diameter = best.stretch_history, surface.diameter
    return {
        "n": n,
        "euler_characteristic": int(chi),
        "boundary_loops": n_loops,
        "genus": int(genus),
        "cut_edges": int(np.unique(np.sort(path_edges(last.paths), axis=1), axis=0).shape[0]),
        "chains": len(best.chains.chain_steps),
        "cut_paths": len(best.paths),
        "cut_rounds": best.number,
        "cut_rounds_tried": last.number,
        "stretch_iterations": len(history) - 1,
        "stretch_rel": min(history) / diameter,
        "stretch_initial_rel": history[0] / diameter,
        "flipped_triangles": flipped,
        "degenerate_uv_triangles": degenerate,
        "welded_samples": int(np.sum(weld.ravel() != np.arange(n * n))),
    }


#: A mesh is remeshed as its canonical copy where more than this fraction of its vertices'
#: distances to the centroid equal another's to :data:`_TIE` (relative): a shape that a
#: rotation or a mirror maps onto itself ties them in pairs.  The genus-8 plate ties 100 %,
#: the development meshes and the jittered plate at most 0.07 %.  (Edge lengths would not
#: do: spot ties 98 % of them and cow 64 %, whose remesh is stable as it is.)
_TIED_FRACTION = 0.5
_TIE = 1e-9


def _tied(points: NDArray[np.float64]) -> bool:
    """Whether most of the distances of canonical ``points`` to the centre (the origin) tie
    exactly (see :data:`_TIED_FRACTION`)."""
    return _tie_fraction(np.linalg.norm(points, axis=1)) > _TIED_FRACTION


def _tie_fraction(values: NDArray[np.float64]) -> float:
    """The fraction of ``values`` within :data:`_TIE` (relative) of another."""
    if len(values) < 2:
        return 0.0
    s = np.sort(values)
    close = np.diff(s) <= _TIE * np.abs(s[1:])
    tied = np.zeros(len(s), dtype=bool)
    tied[1:] |= close
    tied[:-1] |= close
    return float(tied.mean())


#: Up to this many vertices the pose, surface and first cut are found beside the cleaning
#: (:func:`_posed`).  Not at 1M: the two at once put the peak of igea decimated and
#: subdivided to 1M vertices at N = 1024 at 1.85-1.90 GiB (1.99-2.04 GB, over issue 16's
#: 2 GB), one after the other 1.57 GiB, for 0.3-0.9 s of its 11-12 s.  (Nor at 5M: there
#: the peak depended on how the two threads' allocations interleaved, 7.21-7.77 GiB from
#: run to run; cc4e54b.)
AHEAD_VERTICES = 750_000


class _Posed(NamedTuple):
    pose: Pose
    canon: CanonicalMesh | None
    surface: _Surface
    paths: list[NDArray[np.int64]] | None


def _posed(vertices: NDArray[np.float64], faces: NDArray[np.int64], *, cut: bool) -> _Posed:
    """The canonical pose of a cleaned mesh, its canonical copy where tied, its surface and,
    where asked or where it is a closed genus-0 surface, its first cut (:func:`initial_cut`).

    Remeshed in a canonical pose, near-ties cannot flip under a similarity's rounding.  A mesh
    whose distances to its centre tie exactly (a rotation or a mirror maps it onto itself: its
    remesh's choices are exact ties) is remeshed as its canonical copy
    (:func:`meshwm.gim.pose.canonical_mesh`: snapped coarser, numbered by its coordinates),
    where those ties are the same numbers in every pose; its samples are taken at the finer
    coordinates.  Made ahead on a mesh as given (``cut=False``), the cut of a surface of
    another topology is left to the cleaned mesh: ``igl.cut_to_disk`` wants a manifold.
    """
    pose = canonical_pose(vertices, faces)
    fine = pose.forward(vertices)
    canon = canonical_mesh(vertices, faces) if _tied(fine) else None
    surface = _surface(fine, faces) if canon is None else _surface(canon.vertices, canon.faces)
    paths = None
    if cut or surface.closed_genus0:
        paths = initial_cut(
            surface.vertices,
            surface.faces,
            surface.graph,
            closed_genus0=surface.closed_genus0,
            radial=surface.radial,
        )
    return _Posed(pose, canon, surface, paths)


def _sample_fine(
    best: _Round, fine: NDArray[np.float64], n: int
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The round's image with its samples at the ``fine`` positions: every choice (the cut,
    the corners, each chain's grid steps, the map) is the round's, made on the snapped
    coordinates; only the points are taken from finer ones, so that a coordinate on the other
    side of a grid line in another pose moves the image by its rounding, not by a grid step."""
    cut = best.cut
    disk = split_corners(fine[cut.origin], cut.faces, cut.origin, best.chains, n)
    chains = best.chains._replace(chain_points=chain_points_at(best.chains, cut.origin, fine))
    return sample_geometry_image(disk.vertices, best.disk.faces, best.uv, chains, n)


def mesh_to_geometry_image(
    vertices: NDArray,
    faces: NDArray,
    *,
    size: int = 256,
    max_faces: int = 5_000_000,
    stretch_iterations: int = 10,
    max_stretch: float = 1.25,
    max_rounds: int = 5,
    accept_uniformity: float = 3.0,
) -> GeometryImage:
    """Resample a triangle mesh onto a regular ``size × size`` grid (a geometry image).

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Vertex positions, any units; the image keeps them.
    faces : (m, 3) array_like of int
        Triangles.
    size : int, optional
        N, a power of two from 64 to 2048 (default 256).
    max_faces : int, optional
        Refuse meshes with more faces (default 5 million).
    stretch_iterations : int, optional
        Most stretch-reweighting solves per cut round (default 10).
    max_stretch : float, optional
        A round is good enough when, around every vertex off the cut, one UV unit spans at most
        this fraction of the diameter of the centroid-centred bounding sphere (default 1.25);
        the vertices above it are where the next round extends the cut.
    max_rounds : int, optional
        Most extensions of the first cut (default 5).
    accept_uniformity : float, optional
        The first cut's plain harmonic map is kept when its largest local sample spacing is at
        most this many times the spacing of samples spread evenly over the surface (default 3).

    Returns
    -------
    GeometryImage
        The image, the weld map of its cut seams, the components passed through and a report
        with ``vertices_in``, ``faces_in``, ``genus``, ``boundary_loops``, ``cut_edges``,
        ``chains``, ``cut_rounds`` (the round kept), ``cut_rounds_tried``, ``flipped_triangles``,
        ``welded_samples`` and the cleaning counts.

    Raises
    ------
    MeshError
        A mesh that cannot be cleaned (see :func:`meshwm.mesh.clean.clean_mesh`) or cut open.
    ValueError
        ``size`` out of range.

    Notes
    -----
    The choices behind the cut, the boundary map, the interior map and the sampling are in the
    docstrings of this module and of its four step modules, and in ``docs/geometry_image.md``.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.gim.remesh import mesh_to_geometry_image
    >>> v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    >>> f = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    >>> g = mesh_to_geometry_image(v, f, size=64)
    >>> g.gim.shape
    (64, 64, 3)
    """
    n = check_square_pow2(size, name="size")
    t_start = time.perf_counter()
    posed = None
    if len(vertices) <= AHEAD_VERTICES:
        # Most meshes come out of the cleaning as they went in: their pose, surface and first
        # cut are found beside it, on the mesh as given, and used where the cleaning kept it.
        # (Not above: the checked copy of the input held through the cleaning, and the work
        # beside it, would add to the peak memory.)
        v, f = check_mesh(vertices, faces, max_faces=max_faces)
        with beside(_posed, v, f, cut=False) as ahead:
            clean = clean_mesh(v, f, max_faces=max_faces)
            if np.array_equal(clean.vertices, v) and np.array_equal(clean.faces, f):
                posed = ahead.result()
        del v, f
    else:
        clean = clean_mesh(vertices, faces, max_faces=max_faces)
    if posed is None:
        posed = _posed(clean.vertices, clean.faces, cut=True)
    pose, canon, surface, paths = posed
    best, last = _cut_rounds(
        surface,
        n,
        stretch_iterations=stretch_iterations,
        max_stretch=max_stretch,
        max_rounds=max_rounds,
        accept_uniformity=accept_uniformity,
        paths=paths,
    )
    if canon is None:
        gim, weld = sample_geometry_image(
            best.disk.vertices, best.disk.faces, best.uv, best.chains, n
        )
    else:
        gim, weld = _sample_fine(best, canon.fine, n)
    back = pose if canon is None else canon.pose
    gim = back.inverse(gim.reshape(-1, 3)).reshape(gim.shape)
    report = dict(clean.report)
    report.update(_report(surface, best, last, weld, n))
    report["seconds_geometry_image"] = time.perf_counter() - t_start
    return GeometryImage(gim, weld, clean.other_vertices, clean.other_faces, report)
