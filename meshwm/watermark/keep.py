"""Marking the user's own mesh: the mark made in a geometry image, carried onto its vertices.

The output has the input's vertices in the input's order and its faces untouched; only the
positions move.  The mesh is sampled through a map that the mark does not move
(:mod:`meshwm.gim.surface`), the profile marks that image as it marks any geometry image, and
the change is carried back onto the vertices by regularised least squares through the sampling
matrix (:class:`meshwm.gim.transfer.Transfer`).  A mesh has fewer degrees of freedom than the
image where it is coarser than the grid, so one transfer leaves part of each coefficient's move
undone; the embedder therefore works in passes (re-sample the moved mesh, let the profile
quantise what is there now, carry the new change over) and calibrates the step so that the
distortion against the *input* hits the target.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic".
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple, TypeVar

import igl
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from trimesh.triangles import closest_point

from meshwm._concurrent import beside
from meshwm._digest import LastResult, arrays_key
from meshwm._validate import check_mesh
from meshwm._vector import face_cross, row_norm
from meshwm.errors import CapacityError, MeshError
from meshwm.gim.sampling import Sampling
from meshwm.gim.sphere import point_count
from meshwm.gim.surface import (
    SURFACE_SIZES,
    Surface,
    SurfaceImage,
    keep_start,
    sample_surface,
    surface_basis,
    surface_of,
)
from meshwm.gim.transfer import Transfer
from meshwm.mesh.edges import border_half_edges
from meshwm.message.payload import PAYLOAD_BITS
from meshwm.metrics import bounding_box_diagonal
from meshwm.params import WatermarkParams
from meshwm.profiles import get_profile
from meshwm.profiles.base import Decoded, Embedding
from meshwm.readers.base import SampledImage
from meshwm.readers.radial import MIN_POINTS
from meshwm.signal.fill import fill_missing
from meshwm.watermark.extract import Decoder
from meshwm.watermark.radial import RADIAL_PASSES, embed_radial, radial_read, radial_size

__all__ = [
    "KEEP_MAX_PEAK",
    "KEEP_PASSES",
    "KeptMark",
    "embed_kept",
    "normal_rms",
    "surface_peak",
]

_T = TypeVar("_T")

#: Up to this many positions the cut start's check runs beside the radial carrier's read-back
#: (:func:`_carry_radial`); above, after it: at 5M vertices the two together put the kept
#: embedding's peak memory at 7.72 GiB (7.43 GiB one after the other).
_BESIDE_POSITIONS = 3_000_000

#: Passes of (sample, quantise, transfer) after the first.
KEEP_PASSES = 3
#: Calibration rounds of the step against the distortion measured on the input's vertices
#: (dithered quantisation moves a coefficient by a uniform fraction of its step, so the
#: distortion grows with the step, though not in proportion: one correction lands within a
#: few percent, and a mark still over the target is then scaled down to it).
_CALIBRATION_ROUNDS = 1
#: Passes beyond :data:`KEEP_PASSES` while the mesh does not yet read back every bit.
_EXTRA_PASSES = 4
#: The largest vertex-to-surface distance allowed between the input and the output, over the
#: diagonal (:func:`surface_peak`, both ways): MeshLab's Hausdorff distance, which also samples
#: edges and faces, stays under 0.15 % with it.  (The largest move along the vertex normals,
#: used before, missed tangential moves across sharp edges: the genus-8 plate 0.31 %.)
KEEP_MAX_PEAK = 1.3e-3
#: Rounds of shrinking the moves of the vertices over :data:`KEEP_MAX_PEAK` (:func:`_clamp_peaks`:
#: a vertex's distance also depends on its neighbours' moves), each aiming a little under it.
_PEAK_ROUNDS = 3
_PEAK_AIM = 0.97
#: How many of the largest moves :func:`surface_peak` measures first.
_PEAK_FIRST = 1024
#: Vertices whose ring bound is computed at once (:func:`_ring_bound`).
_RING_CHUNK = 250_000
#: The transfer's smoothness energy (:data:`meshwm.gim.transfer.ENERGIES`).
KEEP_ENERGY = "dirichlet"
#: Vertices per covered grid point from which the transfer's unknowns are the grid points'
#: values, spread bilinearly onto the vertices (:func:`meshwm.gim.surface.surface_basis`),
#: rather than the vertices' own moves.  igea (134k vertices, 8.5 a sample at N = 128): the
#: embedding 6.7 → 5.6 s (medians of 3, alternating with the vertices' moves), every attack
#: of issue 13's table read as before (16 until 2026-12-05; the other dev meshes have at
#: most 2.2 vertices a sample and keep their own moves).
_BASIS_DENSITY = 8
#: Rounds of reinforcing the weak bits of a mark whose blind read-back failed (each re-embeds
#: the slots of the bits whose vote is under :data:`_WEAK_VOTE`, moves them
#: :data:`_REINFORCE_GAIN` times as far and transfers that alone).  The transfer onto the
#: vertices cannot carry every slot's move (kitten has 0.14 vertices a sample at N = 256):
#: the uniform passes leave the same 2-3 % of a logo's bits wrong while the distortion grows
#: (kitten, 16 passes: 2.0 % -> 1.4 %, the distortion 15 % over its target).  Reinforced,
#: kitten's logo reads back with 0-0.2 % wrong for 0.8 % more distortion.
_REINFORCE_ROUNDS = 8
_WEAK_VOTE = 0.1
_REINFORCE_GAIN = 1.5
#: A read-back with more wrong bits than this is not reinforced: the mark is far from fitting
#: (or the map not the mark's), and rounds on a tenth of the bits do not bring it back.
_REINFORCE_UP_TO = 0.1
#: Least-squares refinement passes of each transfer (the outer passes refine too).
_TRANSFER_PASSES = 1
#: Radial moves after a peak clamp moved a projection to the wrong side of its bit.
_RADIAL_REPAIRS = 2
#: A read-back with more wrong bits than this at every size reads as another map would: a
#: symmetric shape, whose cut start the mark itself decides, or a payload too large for the
#: mesh (a 32×32 logo on cow: 37 % at N = 256, through its own map as blind).  Every size is
#: tried either way: until 2026-12-06 the first such read-back was refused at once as a
#: symmetric shape, and cow, fertility and camelhead were never tried at N = 128.
_AT_CHANCE = 0.3


class KeptMark(NamedTuple):
    """Result of :func:`embed_kept`.

    Attributes
    ----------
    vertices : (n, 3) float64 ndarray
        The input's vertices, moved; same count and order.
    report : dict
        ``n`` (the geometry-image size chosen), ``capacity_bits``, ``step``, ``distortion``
        (the RMS normal displacement over the diagonal, on the input's vertices), ``confidence``
        (mean |vote| of a re-read through the input's map), ``ber`` of that re-read,
        ``read_ber`` (the blind read-back's, through the map re-derived from the output: 0, or
        up to 2 % for a mark or an id's code, :meth:`~meshwm.watermark.Decoder.reads`),
        ``transfer`` (``"vertices"``: the vertices' own moves solved for; ``"grid"``: a mesh
        much finer than the grid, moved by the grid points' values spread bilinearly),
        ``reinforced`` (present when the weak bits were reinforced after a first mark did not
        read back) and the sizes tried.
    """

    vertices: NDArray[np.float64]
    report: dict[str, Any]


def normal_rms(
    positions: NDArray[np.float64], faces: NDArray[np.int64], displacement: NDArray[np.float64]
) -> float:
    """Area-weighted RMS of a vertex displacement along the vertex normals, over the diagonal.

    A first-order stand-in for the one-sided RMS surface distance between the mesh and the
    moved mesh (MRMS): a move along the surface leaves the surface where it was.

    Parameters
    ----------
    positions : (p, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
    displacement : (p, 3) float64 ndarray

    Returns
    -------
    float
    """
    frame = _frame(positions, faces)
    return _rms_along(frame, _host(positions, np.asarray(faces, dtype=np.int64)).diag, displacement)


def _rms_along(frame: _Frame, diag: float, displacement: NDArray[np.float64]) -> float:
    """:func:`normal_rms` with the input's frame and diagonal at hand."""
    along = np.einsum("ij,ij->i", frame.normals, displacement)
    area = frame.area
    if diag <= 0 or area.sum() <= 0:
        return 0.0
    return float(np.sqrt(np.sum(area * along**2) / area.sum())) / diag


class _Frame(NamedTuple):
    """The input's vertex normals and vertex areas (a third of each face's area)."""

    normals: NDArray[np.float64]
    area: NDArray[np.float64]


#: The last input's :class:`_Frame`: the embedder measures the distortion of one input twice
#: or more, and its normals alone took 3.5 s at 5M vertices.
_FRAME = LastResult()


def _frame(positions: NDArray[np.float64], faces: NDArray[np.int64]) -> _Frame:
    key = arrays_key(positions, faces)
    found: _Frame | None = _FRAME.get(key)
    if found is None:
        normals = np.nan_to_num(igl.per_vertex_normals(positions, faces))
        tri = 0.5 * row_norm(face_cross(positions, faces))
        weights = np.repeat(tri / 3.0, 3)
        area = np.asarray(
            np.bincount(faces.ravel(), weights=weights, minlength=len(positions)), np.float64
        )
        normals.flags.writeable = False
        area.flags.writeable = False
        found = _Frame(normals, area)
        _FRAME.put(key, found)
    return found


def _input_measures(positions: NDArray[np.float64], faces: NDArray[np.int64]) -> None:
    """:func:`_frame` and :func:`_host` of the input, found ahead (both are memoised)."""
    _frame(positions, faces)
    _host(positions, faces)


def _used(faces: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """The positions some face uses, increasing (a count, not a sort)."""
    return np.flatnonzero(np.bincount(np.asarray(faces, dtype=np.int64).ravel(), minlength=n))


class _Host(NamedTuple):
    """What the distance bounds need of the input mesh: the used positions, their bounding-box
    diagonal, the longest edge and each face's longest edge."""

    used: NDArray[np.int64]
    diag: float
    edge: float
    longest: NDArray[np.float64]


#: The last input's :class:`_Host`: an embedding measures distances to one input four to six
#: times, and its longest edge alone took 0.2 s a call at 0.5M vertices.
_HOST = LastResult()


def _host(positions: NDArray[np.float64], faces: NDArray[np.int64]) -> _Host:
    key = arrays_key(positions, faces)
    found: _Host | None = _HOST.get(key)
    if found is not None:
        return found
    used = _used(faces, len(positions))
    pts = positions[used]
    diag = bounding_box_diagonal(pts) if len(used) else 0.0
    square = np.zeros(len(faces))
    for k in range(3):
        step = ((positions[faces[:, k]] - positions[faces[:, k - 1]]) ** 2).sum(axis=1)
        np.maximum(square, step, out=square)
    longest = np.sqrt(square)
    edge = float(longest.max(initial=0.0))
    used.flags.writeable = False
    longest.flags.writeable = False
    found = _Host(used, diag, edge, longest)
    _HOST.put(key, found)
    return found


def surface_peak(
    positions: NDArray[np.float64],
    faces: NDArray[np.int64],
    displacement: NDArray[np.float64],
    *,
    largest: float | None = None,
) -> float:
    """The largest vertex-to-surface distance between the mesh and the moved mesh, both ways,
    over the used vertices' bounding-box diagonal.

    The two-sided Hausdorff distance sampled at the vertices and along the border edges:
    what MeshLab's Hausdorff filter measures, without its face samples
    (:func:`_vertex_distances`, :func:`_border_distances`).  ``largest``: that
    distance, where the caller has measured it for this displacement (the peak clamp's last
    round, :func:`_clamp_peaks`).
    """
    host = _host(positions, np.asarray(faces, dtype=np.int64))
    used, diag = host.used, host.diag
    if diag <= 0:
        return 0.0
    if largest is not None:
        return largest / diag
    # No vertex is farther than its own move: the largest moves first, then, if none of them
    # is as far as the rest may move, every vertex whose bound passes the best found.
    move = np.linalg.norm(displacement[used], axis=1)
    k = len(move) - min(_PEAK_FIRST, len(move))
    first = float(np.partition(move, k)[k])  # the _PEAK_FIRST-th largest move
    dist, _ = _peak_distances(positions, faces, displacement, above=first / diag)
    best = float(dist.max(initial=0.0))
    if best < first:
        dist, _ = _peak_distances(positions, faces, displacement, above=best / diag)
        best = float(dist.max(initial=0.0))
    return best / diag


def _peak_distances(
    positions: NDArray[np.float64],
    faces: NDArray[np.int64],
    displacement: NDArray[np.float64],
    *,
    above: float = 0.0,
) -> tuple[NDArray[np.float64], float]:
    """:func:`_vertex_distances`, each border vertex's raised to its border edges' own
    (:func:`_border_distances`)."""
    dist, diag = _vertex_distances(positions, faces, displacement, above=above)
    return np.maximum(dist, _border_distances(positions, faces, displacement, above=above)), diag


#: Where a border edge is sampled (:func:`_border_distances`), as fractions of its length.
_BORDER_SAMPLES = np.arange(1, 16) / 16.0


def _border_distances(
    positions: NDArray[np.float64],
    faces: NDArray[np.int64],
    displacement: NDArray[np.float64],
    *,
    above: float = 0.0,
) -> NDArray[np.float64]:
    """Per position: the largest distance of the points along its border edges, the moved
    edge's to the input surface and the input edge's to the moved surface, where that
    exceeds ``above`` times the diagonal (0 elsewhere).

    Off the border, a face's points are about as near the other surface as its corners are;
    along a border they need not be: two border vertices that slide along a hole's rim stay
    on the input surface, but the edge between them, a chord of the rim, now spans the hole
    (kitten with 35 holes, its 32×32 logo: the corners 0.130 % of the diagonal away, the
    chords' midpoints 0.183 %, which MeshLab's face samples found in one run of three).  A
    point on an edge is at most the larger of its corners' moves from the other surface, so
    only the edges with a corner that moved more than ``above`` are sampled, each against the
    faces near it (as :func:`_vertex_distances` searches them).
    """
    f = np.asarray(faces, dtype=np.int64)
    host = _host(positions, f)
    diag = host.diag
    out = np.zeros(len(positions))
    border = border_half_edges(f)
    if diag <= 0 or len(border) == 0:
        return out
    move = np.linalg.norm(displacement, axis=1)
    reach = np.maximum(move[border[:, 0]], move[border[:, 1]])
    asked = reach > above * diag
    border, reach = border[asked], reach[asked]
    if len(border) == 0:
        return out
    moved = positions + displacement
    t = _BORDER_SAMPLES[:, None, None]
    radius = float(reach.max())
    corner_move = np.maximum(np.maximum(move[f[:, 0]], move[f[:, 1]]), move[f[:, 2]])
    worst = np.zeros(len(border))
    for points, surface, grown in ((moved, positions, 0.0), (positions, moved, 2.0)):
        query = ((1.0 - t) * points[border[:, 0]] + t * points[border[:, 1]]).reshape(-1, 3)
        own = (radius + host.longest + grown * corner_move) * (1.0 + 1e-9)
        limit = float(np.nextafter(own.max(initial=0.0), np.inf))
        gap = _gaps(surface, query, limit)
        nearest = np.minimum(np.minimum(gap[f[:, 0]], gap[f[:, 1]]), gap[f[:, 2]])
        square = igl.point_mesh_squared_distance(query, surface, f[nearest <= own])[0]
        worst = np.maximum(worst, np.sqrt(square).reshape(len(_BORDER_SAMPLES), -1).max(axis=0))
    np.maximum.at(out, border[:, 0], worst)
    np.maximum.at(out, border[:, 1], worst)
    out[out <= above * diag] = 0.0
    return out


def _vertex_distances(
    positions: NDArray[np.float64],
    faces: NDArray[np.int64],
    displacement: NDArray[np.float64],
    *,
    above: float = 0.0,
) -> tuple[NDArray[np.float64], float]:
    """Per position: the larger of its moved copy's distance to the input surface and its
    input copy's distance to the moved surface, where that exceeds ``above`` times the
    diagonal (0 elsewhere and where unused); and the used vertices' bounding-box diagonal.

    Both distances are at most the vertex's own move (its other copy lies on the other
    surface) and at most the distance to the faces around the vertex (:func:`_ring_bound`),
    so only the vertices whose bound exceeds ``above`` are queried exactly, each against the
    faces that can hold its nearest point: those with a corner within that bound plus the
    longest edge (``scipy.spatial.cKDTree``, then ``igl.point_mesh_squared_distance``).  The
    bound first: on a 0.5M-vertex mesh the exact queries of every vertex that moved more than
    ``above`` took 5 s a call, most of them for vertices that sit well inside the cap.
    """
    f = np.asarray(faces, dtype=np.int64)
    host = _host(positions, f)
    used, diag = host.used, host.diag
    out = np.zeros(len(positions))
    if diag <= 0:
        return out, 0.0
    move = np.linalg.norm(displacement, axis=1)
    ask = used[move[used] > above * diag]
    if len(ask) == 0:
        return out, diag
    moved = positions + displacement
    bound = np.maximum(
        _ring_bound(moved, positions, f, ask, move), _ring_bound(positions, moved, f, ask, move)
    )
    ask = ask[bound[ask] > above * diag]
    if len(ask) == 0:
        return out, diag
    # The faces that can hold a query point's nearest point: that point is within the query's
    # bound, so each corner of its face is within the bound plus the face's longest edge of
    # the query (on the moved surface the input's edge grown by twice its corners' largest
    # move).  Each corner's distance to the nearest query point by one nearest-neighbour query,
    # bounded by the largest such reach (a ball query around each query point makes a list
    # per point: 0.5M points, 90 s and 12 GB that way); a face is kept where its nearest
    # corner is within its own reach.  (The longest edge of all and the largest move, used
    # for every face before, kept 7.7M of a 5M-vertex mesh's 10M faces for 8,169 points.)
    radius = float(bound[ask].max())
    corner_move = np.maximum(np.maximum(move[f[:, 0]], move[f[:, 1]]), move[f[:, 2]])
    square = []
    for query, surface, grown in ((moved[ask], positions, 0.0), (positions[ask], moved, 2.0)):
        own = (radius + host.longest + grown * corner_move) * (1.0 + 1e-9)
        limit = float(np.nextafter(own.max(initial=0.0), np.inf))
        gap = _gaps(surface, query, limit)
        nearest = np.minimum(np.minimum(gap[f[:, 0]], gap[f[:, 1]]), gap[f[:, 2]])
        square.append(igl.point_mesh_squared_distance(query, surface, f[nearest <= own])[0])
    out[ask] = np.sqrt(np.maximum(square[0], square[1]))
    return out, diag


#: Cells per axis at most of the grid that keeps the points near a query (:func:`_gaps`).
_GAP_CELLS = 256


def _gaps(
    points: NDArray[np.float64], query: NDArray[np.float64], limit: float
) -> NDArray[np.float64]:
    """Each point's distance to the nearest query point where under ``limit``, else infinite:
    ``cKDTree(query).query(points, distance_upper_bound=limit)``'s distances, bit for bit.

    Only the points in or next to a query point's grid cell are asked (the grid spans the
    query points' box grown by a cell): the cells are at least twice ``limit`` wide, so a point
    nearer than ``limit`` to a query point (nearer on every axis) lies in its cell or a
    neighbouring one, whatever the rounding.  An embedding asks a few thousand query points
    here; the tree's query of all 5M vertices of a mesh, twice a call and five calls, took 20 s.
    """
    gap = np.full(len(points), np.inf)
    if len(query) == 0 or len(points) == 0:
        return gap
    size = 2.0 * limit
    lo = query.min(axis=0) - size
    extent = query.max(axis=0) + size - lo
    size = max(size, float(extent.max()) / _GAP_CELLS)
    if not (np.isfinite(size) and np.isfinite(lo).all()) or size <= 0:
        near = np.arange(len(points))
    else:
        dims = (extent // size).astype(np.int64) + 1
        cells = np.zeros(tuple(dims.tolist()), dtype=bool)
        at = np.floor((query - lo) / size).astype(np.int64)
        for offset in np.stack(np.meshgrid(*[[-1, 0, 1]] * 3, indexing="ij"), -1).reshape(-1, 3):
            index = np.clip(at + offset, 0, dims - 1)
            cells[index[:, 0], index[:, 1], index[:, 2]] = True
        at = np.floor((points - lo) / size)
        inside = np.flatnonzero(((at >= 0) & (at < dims)).all(axis=1))
        cell = at[inside].astype(np.int64)
        near = inside[cells[cell[:, 0], cell[:, 1], cell[:, 2]]]
    if len(near):
        gap[near] = cKDTree(query).query(points[near], k=1, distance_upper_bound=limit)[0]
    return gap


def _ring_bound(
    points: NDArray[np.float64],
    surface: NDArray[np.float64],
    faces: NDArray[np.int64],
    ask: NDArray[np.int64],
    move: NDArray[np.float64],
) -> NDArray[np.float64]:
    """An upper bound of each asked vertex's distance from ``points[i]`` to the surface
    ``(surface, faces)``: the distance to the faces around vertex i (exact point-triangle
    distances, ``trimesh.triangles.closest_point``), and at most its move (``surface[i]`` is
    on that surface).  Infinite elsewhere.
    """
    out = np.full(len(points), np.inf)
    out[ask] = move[ask]
    asked = np.zeros(len(points), dtype=bool)
    for lo in range(0, len(ask), _RING_CHUNK):  # bounded memory on a mesh of millions
        asked[:] = False
        asked[ask[lo : lo + _RING_CHUNK]] = True
        face, corner = np.nonzero(asked[faces])
        vertex = faces[face, corner]
        with np.errstate(all="ignore"):  # a degenerate face gives NaN: fmin skips it
            nearest = closest_point(surface[faces[face]], points[vertex])
            gap = np.linalg.norm(nearest - points[vertex], axis=1)
        np.fmin.at(out, vertex, gap)
    return out


class _Clamped(NamedTuple):
    displacement: NDArray[np.float64]
    #: The largest distance (:func:`surface_peak` times the diagonal) where the last round
    #: measured it: every vertex it did not ask is nearer than the ones it asked.
    largest: float | None


def _clamp_peaks(
    positions: NDArray[np.float64], faces: NDArray[np.int64], displacement: NDArray[np.float64]
) -> _Clamped:
    """Shrink the displacement where a vertex is farther than the cap from the other surface.

    Only the vertices over :data:`KEEP_MAX_PEAK` (and their neighbourhood, through the
    distance to the moved surface) lose part of their move, so the rest of the mark keeps its
    strength; the blind read-back then says whether the mark survived the clamp.
    """
    d = np.array(displacement, dtype=np.float64)
    largest = None
    for _ in range(_PEAK_ROUNDS):
        dist, diag, largest = _above_aim(positions, faces, d)
        cap = KEEP_MAX_PEAK * diag
        if diag <= 0 or dist.max() <= cap:
            break
        largest = None  # measured before this round's shrink
        d *= np.minimum(1.0, _PEAK_AIM * cap / np.maximum(dist, 1e-300))[:, None]
    return _Clamped(d, largest)


def _above_aim(
    positions: NDArray[np.float64], faces: NDArray[np.int64], displacement: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float, float | None]:
    """:func:`_peak_distances` of the vertices whose bound passes the peak clamp's aim, the
    diagonal, and the largest distance (:func:`surface_peak` times the diagonal) where it
    passes the aim, else None: the vertices not asked are at most the aim away."""
    above = _PEAK_AIM * KEEP_MAX_PEAK
    dist, diag = _peak_distances(positions, faces, displacement, above=above)
    best = float(dist.max(initial=0.0))
    return dist, diag, (best if diag > 0 and best > above * diag else None)


def _largest_above(
    positions: NDArray[np.float64], faces: NDArray[np.int64], displacement: NDArray[np.float64]
) -> float | None:
    """:func:`_above_aim`'s largest distance, or None (then only :func:`surface_peak` finds
    it)."""
    return _above_aim(positions, faces, displacement)[2]


class _Attempt(NamedTuple):
    displacement: NDArray[np.float64]
    report: dict[str, Any]


def _carry_radial(
    positions: NDArray[np.float64],
    faces: NDArray[np.int64],
    clamp_faces: NDArray[np.int64],
    displacement: NDArray[np.float64],
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    alongside: Callable[[NDArray[np.float64]], _T] | None = None,
) -> tuple[_Clamped, dict[str, Any], _T | None]:
    """The radial carrier on top of ``displacement``, then the peaks clamped (see module notes).

    ``faces`` are the input's faces over ``positions`` (every component: the radial carrier
    reads the whole point set); ``clamp_faces`` the surface whose peaks are capped.  A clamp
    that moves a projection to the wrong side of its bit is followed by one more radial move.

    ``alongside(d)`` of the clamped displacement is computed in a second thread while the
    carrier is read back (both are numpy and scipy work that releases the GIL), and returned
    with it: the embedder's check of the cut's start, which comes next.  None where the carrier
    was not made (too few points, no pose).
    """
    n = radial_size(len(bits))
    d = np.array(displacement, dtype=np.float64)
    report: dict[str, Any] = {"radial_n": n}
    if point_count(positions, faces) < MIN_POINTS:  # too few to carry it
        clamped = _clamp_peaks(positions, clamp_faces, d)
        return clamped, {"radial_n": None, "radial": "too small"}, None
    after: _T | None = None
    # First one move, no second pass checking it (one settles every projection within a
    # hundredth of a step on every development mesh): the read-back after the clamp below is
    # the check that counts, and the carrier's own check read the mesh before the clamp.  A
    # read-back with a wrong bit is followed by the carrier's passes (a pose that is a
    # near-tie, a ball's or a torus's, moves under the first move: its passes follow it),
    # then by one more move.
    for passes in (0, RADIAL_PASSES, *(1,) * (_RADIAL_REPAIRS - 1)):
        try:
            mark = embed_radial(
                positions + d, faces, bits, key=key, n=n, passes=passes, read_back=False
            )
        except MeshError as exc:  # no pose (a flat point set): the surface carrier alone
            clamped = _clamp_peaks(positions, clamp_faces, d)
            return clamped, {"radial_n": None, "radial": str(exc)}, None
        clamped = _clamp_peaks(positions, clamp_faces, mark.vertices - positions)
        d = clamped.displacement
        with beside(alongside or _nothing, d) as next_step:
            got, _, _ = radial_read(positions + d, faces, len(bits), key=key, n=n)
            report["radial_ber"] = float(np.mean(got != bits))
            if report["radial_ber"] == 0:
                after = next_step.result()
                break
    return clamped, report, after


def _nothing(_: NDArray[np.float64]) -> None:
    return None


def _mark_at(
    surface: Surface,
    image: SurfaceImage,
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    params: WatermarkParams,
    faces_in: NDArray[np.int64],
    reinforce_weak: bool = False,
) -> _Attempt:
    """Embed at one size: calibrate the step on the input's distortion, then passes (with
    ``reinforce_weak``, then rounds on the weak bits alone); then the radial carrier and the peak
    clamp (:func:`_carry_radial`)."""
    profile = get_profile(params.profile)
    # The profile's embedding of some bits alone (the robust profile's), when asked for.
    reinforce: Callable[..., Embedding] | None = (
        getattr(profile, "reinforce", None) if reinforce_weak else None
    )
    positions = surface.positions
    faces = surface.faces
    sampling = Sampling(image.matrix, image.covered)
    fine = int(surface.used.sum()) >= _BASIS_DENSITY * int(image.covered.sum())
    basis = surface_basis(surface, size=image.n) if fine else None
    transfer = Transfer(faces, sampling, n_vertices=len(positions), energy=KEEP_ENERGY, basis=basis)
    target = float(getattr(params.options, "distortion", 0.0)) or None
    options = params.options
    cover, _ = fill_missing(image.samples)
    first = profile.embed(cover, bits, key=key, options=options)
    report = dict(first.report)
    report["transfer"] = "grid" if fine else "vertices"
    step = report.get("step")

    frame, diag = _frame(positions, faces), _host(positions, faces).diag

    def distortion(d: NDArray[np.float64]) -> float:
        """:func:`normal_rms` of ``d`` (the input's frame and diagonal found once)."""
        return _rms_along(frame, diag, d)

    def votes(d: NDArray[np.float64]) -> Decoded:
        """The soft bits of the moved mesh through the same map."""
        marked = (image.matrix @ (positions + d)).reshape(image.samples.shape)
        marked[~image.covered] = np.nan
        prepared = profile.prepare(SampledImage(marked, 1, "surface"), options=params.options)
        return profile.decode(prepared, len(bits), key=key)

    def read(d: NDArray[np.float64]) -> tuple[float, float]:
        """BER and mean |confidence| of the moved mesh through the same map."""
        found = votes(d)
        return float(np.mean(found.bits != bits)), float(np.mean(np.abs(found.confidence)))

    def reinforced(
        d: NDArray[np.float64], opts: Any, transfer: Transfer, reinforce: Callable[..., Embedding]
    ) -> NDArray[np.float64]:
        """``d`` after rounds on the bits whose vote is weak (or wrong); the round that
        read back with the fewest wrong bits (the latest of equals) is kept."""
        # Border vertices keep their moves: pushed along the surface, a border vertex widens
        # or narrows its hole, which the Hausdorff cap then takes back along its border edges
        # (:func:`_border_distances`); the rounds reinforce the interior.
        inner = np.ones(len(positions))
        inner[border_half_edges(faces).ravel()] = 0.0
        best, fewest = d, np.inf
        for done in range(_REINFORCE_ROUNDS + 1):
            found = votes(d)
            wrong = int(np.sum(found.bits != bits))
            if wrong <= fewest:
                best, fewest = d, wrong
            weak = found.confidence * (2.0 * bits - 1.0) < _WEAK_VOTE
            if not weak.any() or done == _REINFORCE_ROUNDS:
                break
            now = (image.matrix @ (positions + d)).reshape(image.samples.shape)
            now[~image.covered] = cover[~image.covered]
            emb = reinforce(now, bits, key=key, options=opts, weak=weak)
            change = np.where(image.covered[..., None], emb.changes, 0.0)
            move = transfer.apply(_REINFORCE_GAIN * change, passes=_TRANSFER_PASSES)
            d = d + inner[:, None] * move
        return best

    def run(
        opts: Any, transfer: Transfer, *, until_read: bool = False
    ) -> tuple[NDArray[np.float64], dict]:
        d = np.zeros_like(positions)
        rep: dict[str, Any] = {}
        for k in range(1 + KEEP_PASSES + (_EXTRA_PASSES if until_read else 0)):
            if until_read and k >= 1 + KEEP_PASSES and read(d)[0] == 0:
                break
            now = (image.matrix @ (positions + d)).reshape(image.samples.shape)
            now[~image.covered] = cover[~image.covered]
            emb = profile.embed(now, bits, key=key, options=opts)
            rep = emb.report
            change = np.where(image.covered[..., None], emb.changes, 0.0)
            d = d + transfer.apply(change, passes=_TRANSFER_PASSES)
        return d, rep

    if step is not None and target is not None and hasattr(options, "tangential_step"):
        for _ in range(_CALIBRATION_ROUNDS):
            opts = dataclasses.replace(options, tangential_step=float(step))
            d, rep = run(opts, transfer)
            measured = distortion(d)
            if measured <= 0:
                break
            step = float(np.clip(step * target / measured, 1e-6, 1.0))
        opts = dataclasses.replace(options, tangential_step=float(step))
    else:
        opts = options
    d, rep = run(opts, transfer, until_read=True)
    if step is not None and target is not None and hasattr(options, "tangential_step"):
        # Over the target, the move is scaled down to it: each coefficient keeps all but a
        # few percent of its move.  The distortion is not proportional to the step, and
        # another step's quantisation lands elsewhere: igea through the grid basis came out
        # at 2.01e-4 against 1.85e-4 after the correction above (its MRMS 0.0202 %, over
        # issue 13's 0.02 %), and a second correction of the step gave 1.92e-4.
        measured = distortion(d)
        if measured > target:
            d = d * (target / measured)
        if reinforce is not None and read(d)[0] > 0:
            d = reinforced(d, opts, transfer, reinforce)
            report["reinforced"] = True
            measured = distortion(d)
            if measured > target:
                d = d * (target / measured)
    # The transfer's solver (at 5M vertices its multigrid hierarchy is over 1 GB) is not
    # needed by the radial carrier, the start check or the read-back after them.
    del transfer
    radial_faces = surface.inverse[faces_in]
    check = partial(_keep_start, surface) if len(positions) <= _BESIDE_POSITIONS else None
    clamped, radial, start = _carry_radial(
        positions, radial_faces, faces, d, bits, key=key, alongside=check
    )
    d = clamped.displacement
    # The start last: the radial carrier moves vertices along their distance from the centre,
    # which is what picks the start (it tipped spot's and camelhead's after it had been put
    # back, 2 of 36 dev marks, when this came first).  Where the bump that puts it back costs
    # the radial carrier bits, the carrier is made again and the start checked once more.
    for again in (True, False):
        d, report["start"] = _keep_start(surface, d) if start is None else start
        start = None
        if report["start"] != "nudged" or not radial.get("radial_n"):
            break
        got, _, _ = radial_read(
            positions + d, radial_faces, len(bits), key=key, n=radial["radial_n"]
        )
        radial["radial_ber"] = float(np.mean(got != bits))
        if radial["radial_ber"] == 0 or not again:
            break
        clamped, radial, _ = _carry_radial(positions, radial_faces, faces, d, bits, key=key)
        d = clamped.displacement
    report.update(radial)
    # The clamp's last round measured this displacement's largest distance, unless the start
    # was nudged since: then measured as the clamp's rounds measure it, only the vertices whose
    # bound passes its aim (a smooth move gives many vertices of about the largest move, and
    # every one of them was measured exactly: 40 s at 2.1M vertices).
    largest = clamped.largest if d is clamped.displacement else _largest_above(positions, faces, d)
    peak = surface_peak(positions, faces, d, largest=largest)
    report.update(rep)
    report["step"] = step
    report["distortion"] = distortion(d)
    report["peak"] = peak
    report["ber"], report["confidence"] = read(d)
    return _Attempt(d, report)


def _keep_start(surface: Surface, d: NDArray[np.float64]) -> tuple[NDArray[np.float64], str]:
    """``d`` with a smooth bump where the mark tipped the cut's start (see
    :func:`meshwm.gim.surface.keep_start`): the marked mesh then has the input's cut and map,
    which a blind reader re-derives first.  Where that fails ``d`` is kept (a reader then finds
    the mark through the runner-up starts it tries, and the embedder's read-back checks it)."""
    bump = keep_start(surface, d)
    if bump is None:
        return d, "moved"
    if not bump.any():
        return d, "kept"
    return d + bump, "nudged"


def embed_kept(
    vertices: NDArray,
    faces: NDArray,
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    params: WatermarkParams,
    sizes: tuple[int, ...] = SURFACE_SIZES,
    max_faces: int,
) -> KeptMark:
    """Mark a mesh in place: same vertices (moved), same faces.

    Parameters
    ----------
    vertices : (n, 3) array_like
    faces : (m, 3) array_like of int
    bits : (k,) uint8 ndarray
        The payload, as carried.
    key : str or bytes
    params : WatermarkParams
        The profile and its options (``size`` is not used: the size follows the mesh).
    sizes : tuple of int, optional
        The geometry-image sizes tried; the one whose re-read decodes best is kept.
    max_faces : int

    Returns
    -------
    KeptMark

    Raises
    ------
    MeshError
        A mesh the map cannot open.
    CapacityError
        A payload no size carries (the message names the largest that fits).
    """
    # Read-only from here: the surface, its cleaning and the read-back take these very arrays
    # (not copies), and the digests their memoised steps key on are kept with them.
    vertices, faces = check_mesh(vertices, faces, max_faces=max_faces, frozen=True)
    surface = surface_of(vertices, faces, max_faces=max_faces)
    if int(surface.used.sum()) < len(bits):  # fewer vertices than bits: refused at once
        used, whole = int(surface.used.sum()), len(np.unique(faces))
        # The surface is the largest connected piece: say so when the mesh has more.
        what = (
            f"a mesh of {used} vertices"
            if used == whole
            else f"the largest connected piece of this mesh ({used} of its {whole} vertices)"
        )
        raise CapacityError(
            f"{what} cannot carry a {len(bits)}-bit payload (a 64-bit id's needs about 2,000)"
        )
    tried: dict[str, Any] = {}
    best = 1.0
    order = _size_order(sizes, len(bits))
    # What the distortion and the distances measure of the input (memoised), beside the
    # first size's sampling.
    with beside(_input_measures, surface.positions, surface.faces):
        first = sample_surface(surface, size=order[0])
    # Read back as a blind reader will: the map re-derived from the marked mesh itself.
    # (The input's map is a speed hint: reused only where provably the same.)
    hints = {"surface": {"like": surface}}

    def read_back(attempt: _Attempt) -> tuple[NDArray[np.float64], bool, float]:
        """The marked vertices, whether they read back blind, and the wrong bits' share."""
        out = (surface.positions + attempt.displacement)[surface.inverse]
        decoder = Decoder(
            out,
            faces,
            params=params,
            max_faces=max_faces,
            hints=hints,
            readers=("surface",),
            mirror=False,
        )
        return (out, *decoder.reads(bits, key=key))

    can_reinforce = hasattr(get_profile(params.profile), "reinforce")
    for n in order:
        image = first if n == order[0] else sample_surface(surface, size=n)
        mark = partial(
            _mark_at,
            surface,
            image,
            bits,
            key=key,
            params=params,
            faces_in=np.asarray(faces, np.int64),
        )
        try:
            attempt = mark()
        except CapacityError as exc:
            tried[str(n)] = str(exc)
            continue
        out, ok, ber = read_back(attempt)
        tried[str(n)] = {"ber": ber}
        if not ok and ber <= _REINFORCE_UP_TO and can_reinforce:
            # The weak bits reinforced, at the same size (the mark made again: the outputs of
            # meshes that read without it are the same bytes as before).
            again = mark(reinforce_weak=True)
            if again.report.get("reinforced"):
                again_out, ok, again_ber = read_back(again)
                tried[str(n)]["reinforced_ber"] = again_ber
                if ok or again_ber < ber:
                    attempt, out, ber = again, again_out, again_ber
        if ok:
            radial_ber = attempt.report.get("radial_ber")
            if attempt.report.get("start") == "nudged" and (radial_ber or 0.0) > _AT_CHANCE:
                # No pose of its own (the radial carrier reads at chance), and a cut start
                # the mark tipped and a bump put back: what holds the surface map is that
                # bump, far smaller than 0.1 % noise or a clean-up's move (a torus read back
                # whole, then at chance after either).  Every size shares both.
                raise CapacityError(
                    "this mesh does not carry a blind mark that survives a move: a symmetric "
                    "shape (a torus, a cylinder, a sphere) has no pose of its own (the "
                    f"spherical image reads back {radial_ber:.0%} wrong bits) and its cut start "
                    "is held only by a nudge the mark made, which noise or a clean-up re-decides"
                )
            report = {
                **attempt.report,
                "n": n,
                "read_ber": ber,
                "sizes_tried": tried,
                **_clean_counts(surface),
            }
            return KeptMark(out, report)
        best = min(best, ber)
    smaller = f" (a 64-bit id is {PAYLOAD_BITS} bits: --id)" if len(bits) > PAYLOAD_BITS else ""
    if best > _AT_CHANCE:
        raise CapacityError(
            f"this mesh does not carry a blind mark of {len(bits)} bits: read back, its surface "
            f"map gives {best:.0%} wrong bits at best, as another map would: the payload may "
            f"be too large for the mesh{smaller}, or a symmetric shape (a torus, a cylinder, a "
            f"sphere) has no cut start of its own, and the mark decides it"
        )
    raise CapacityError(
        f"this mesh does not carry the {len(bits)}-bit payload: read back blind, the best "
        f"size has {best:.1%} wrong bits{smaller}"
    )


def _size_order(sizes: tuple[int, ...], n_bits: int) -> list[int]:
    """The sizes to try, first the one the payload is likeliest to fit.

    At level 3 an N×N image has 9 (N/8)² slots; a mesh carries the change of a coarse image
    best (fewer, larger atoms per vertex), so the smallest size with at least 8 slots per bit
    comes first, then the others from small to large.
    """
    ordered = sorted(sizes)
    first = next((n for n in ordered if 9 * (n // 8) ** 2 >= 8 * n_bits), ordered[-1])
    return [first, *(n for n in ordered if n != first)]


def _clean_counts(surface: Surface) -> dict[str, Any]:
    rep = surface.report
    return {
        "components": int(rep.get("components", 1)),
        "components_passed_through": int(rep.get("components_passed_through", 0)),
        "faces_detached": int(rep.get("faces_detached", 0)),
        "marked_positions": int(surface.used.sum()),
    }
