"""Informed reading, step one: which asset a received mesh is, and its pose in the asset's frame.

The owner keeps a *reference* of every asset: points on the original surface (the geometry
image's samples, in the original's coordinates).  A received mesh may have been moved by a
similarity, re-tessellated, cropped, noised or smoothed.  Two steps serve the informed reader:

:func:`shape_descriptor` and :func:`descriptor_distance` (from
:mod:`meshwm.readers.descriptor`, re-exported here)
    One fixed-length vector per mesh, invariant to similarities and stable under
    re-tessellation: a received mesh is compared with thousands of assets at once and only a
    short list of candidates is registered.
:func:`register`
    The similarity taking the received mesh into the reference's frame
    (``x_ref = scale * x @ rotation.T + translation``), from several initial poses, trimmed
    ICP with a similarity, and a last fit of the reference points on the received surface.
    Its residual and overlap tell the right candidate from the others.

The received surface is sampled at deterministic points
(:func:`~meshwm.readers.descriptor.surface_samples`), never from a random stream, so the same
input gives the same bytes on every machine.
"""

from __future__ import annotations

from typing import NamedTuple

import igl
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from meshwm.errors import MeshError
from meshwm.mesh.edges import unique_edges
from meshwm.readers.descriptor import (
    AXIS_FLIPS,
    DESCRIPTOR_LENGTH,
    checked_surface,
    descriptor_distance,
    principal_frame,
    shape_descriptor,
    surface_samples,
)

__all__ = [
    "DESCRIPTOR_LENGTH",
    "POSE_HYPOTHESES",
    "PoseSearch",
    "ReceivedSurface",
    "Registration",
    "descriptor_distance",
    "register",
    "shape_descriptor",
    "surface_samples",
]

#: Received samples for the coarse search, the refinement and the overlap.
_COARSE_POINTS = 400
_REFINE_POINTS = 3000
_FINE_POINTS = 20000
#: Point-to-plane steps of the refinement; the most steps and reference points of the polish.
_PLANE_STEPS = 8
_POLISH_STEPS = 20
_POLISH_POINTS = 20000
#: Reference points in the coarse search's tree.
_COARSE_REFERENCE = 6000
#: Neighbours for the reference's normals and its area per point.
_NEIGHBOURS = 10
#: Reference points the spacing and the frame are measured on.
_SUBSET = 20000
#: The scale may move this far (factor) from the RMS-radius estimate: a crop moves it less.
_SCALE_RANGE = 1.8


class Registration(NamedTuple):
    """A similarity from the received mesh's coordinates into the reference's frame.

    ``x_ref = scale * x @ rotation.T + translation`` for received points ``x`` (n, 3).

    Attributes
    ----------
    scale : float
    rotation : (3, 3) float64 ndarray
        Orthonormal, determinant +1.
    translation : (3,) float64 ndarray
    rms : float
        RMS distance from the reference points matched in the last step to the registered
        received surface, as a fraction of the reference's bounding-box diagonal: ~1e-14 for
        the original surface (re-tessellated without moving it, or cropped), the surface's
        own deviation otherwise (a few 1e-4 for a decimation to 30 %).
    overlap : float
        Fraction of the received samples whose nearest reference point is within 3 local
        spacings after registration (that point's distance to its own nearest neighbour, at
        least the reference's median one).
    hypotheses : int
        Initial poses tried.
    settled : bool
        The search ended on a good fit (overlap 95 %, polished residual within 2e-3 of the
        diagonal) before the spread over SO(3): ``register`` with and without ``spread`` give
        the same pose.
    """

    scale: float
    rotation: NDArray[np.float64]
    translation: NDArray[np.float64]
    rms: float
    overlap: float
    hypotheses: int
    settled: bool

    def apply(self, points: NDArray) -> NDArray[np.float64]:
        """Received coordinates (..., 3) into the reference's frame."""
        x = np.asarray(points, dtype=np.float64)
        return self.scale * x @ self.rotation.T + self.translation


class _Reference(NamedTuple):
    """The reference points prepared once: finite points, unit normals (NaN: not made yet),
    trees, spacing, frame."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    tree: cKDTree
    coarse_points: NDArray[np.float64]
    coarse_normals: NDArray[np.float64]
    coarse: cKDTree
    spacing: float
    diagonal: float
    centre: NDArray[np.float64]
    axes: NDArray[np.float64]
    radius: float


def _prepare(reference_points: NDArray, reference_normals: NDArray | None) -> _Reference:
    p = np.asarray(reference_points, dtype=np.float64)
    if p.ndim < 2 or p.shape[-1] != 3:
        raise MeshError(f"reference_points must have shape (..., 3), got {p.shape}")
    p = p.reshape(-1, 3)
    finite = np.isfinite(p).all(axis=1)
    if finite.sum() < 2 * _NEIGHBOURS:
        raise MeshError(
            f"reference_points has {int(finite.sum())} finite points, fewer than {2 * _NEIGHBOURS}"
        )
    points = p[finite]
    tree = cKDTree(points)
    # Spacing and frame from at most _SUBSET points (a 512² geometry image has 262 144).
    subset = points[:: max(1, len(points) // _SUBSET)]
    spacing = float(np.median(tree.query(subset, k=2)[0][:, 1]))
    if not spacing > 0:
        raise MeshError("reference_points are (nearly all) coincident")
    normals = np.full_like(points, np.nan)  # NaN: made from the neighbours when first needed
    if reference_normals is not None:
        given = np.asarray(reference_normals, dtype=np.float64)
        if given.size != p.size:
            raise MeshError(
                f"reference_normals must have the shape of reference_points {p.shape}, "
                f"got {given.shape}"
            )
        given = given.reshape(-1, 3)[finite]
        length = np.linalg.norm(given, axis=1)
        good = np.isfinite(length) & (length > 0)
        normals[good] = given[good] / length[good, None]
    # Area per point ~ squared distance to the k-th neighbour: a density-compensated frame.
    reach = cKDTree(subset).query(subset, k=_NEIGHBOURS)[0][:, -1]
    centre, axes, radius = principal_frame(subset, reach**2 + float(np.median(reach)) ** 2)
    step = max(1, len(points) // _COARSE_REFERENCE)
    ref = _Reference(
        points=points,
        normals=normals,
        tree=tree,
        coarse_points=points[::step],
        coarse_normals=normals[::step],
        coarse=cKDTree(points[::step]),
        spacing=spacing,
        diagonal=float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))),
        centre=centre,
        axes=axes,
        radius=radius,
    )
    return ref._replace(coarse_normals=_normals_at(ref, np.arange(0, len(points), step)))


def _normals_at(ref: _Reference, index: NDArray[np.intp]) -> NDArray[np.float64]:
    """The reference normals at ``index``; those not given are the least principal axis of
    the point's neighbourhood, computed once and kept in ``ref.normals``."""
    todo = np.unique(index[~np.isfinite(ref.normals[index, 0])])
    if len(todo):
        local = ref.points[ref.tree.query(ref.points[todo], k=_NEIGHBOURS)[1]]
        local = local - local.mean(axis=1, keepdims=True)
        ref.normals[todo] = np.linalg.eigh(np.einsum("pki,pkj->pij", local, local))[1][:, :, 0]
    result: NDArray[np.float64] = ref.normals[index]
    return result


def _umeyama(
    source: NDArray[np.float64], target: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares similarity ``target ≈ s * source @ R.T + t`` (Umeyama 1991,
    doi:10.1109/34.88573)."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    u, d, vt = np.linalg.svd(b.T @ a / len(a))
    sign = np.ones(3)
    sign[2] = np.sign(np.linalg.det(u) * np.linalg.det(vt)) or 1.0
    rotation = (u * sign) @ vt
    scale = float((d * sign).sum() / max(np.mean(np.sum(a**2, axis=1)), np.finfo(float).tiny))
    return scale, rotation, mu_t - scale * mu_s @ rotation.T


def _rodrigues(omega: NDArray[np.float64]) -> NDArray[np.float64]:
    angle = float(np.linalg.norm(omega))
    if angle < 1e-300:
        return np.eye(3)
    k = omega / angle
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross


class _Pose(NamedTuple):
    scale: float
    rotation: NDArray[np.float64]
    translation: NDArray[np.float64]


def _clamp(pose: _Pose, scale_guess: float) -> _Pose:
    low, high = scale_guess / _SCALE_RANGE, scale_guess * _SCALE_RANGE
    return pose._replace(scale=float(np.clip(pose.scale, low, high)))


def _icp_points(
    x: NDArray[np.float64],
    tree: cKDTree,
    targets: NDArray[np.float64],
    pose: _Pose,
    scale_guess: float,
    *,
    iterations: int,
    keep: float,
) -> _Pose:
    """Trimmed (closest ``keep``) point-to-point ICP with Umeyama's similarity."""
    count = max(3, int(keep * len(x)))
    for _ in range(iterations):
        y = pose.scale * x @ pose.rotation.T + pose.translation
        distance, index = tree.query(y)
        best = np.argpartition(distance, count - 1)[:count]
        s, r, t = _umeyama(x[best], targets[index[best]])
        pose = _clamp(_Pose(s, r, t), scale_guess)
        if pose.scale != s:  # clamped: keep the rotation, refit the translation
            fitted = pose.scale * x[best] @ r.T
            pose = pose._replace(translation=targets[index[best]].mean(axis=0) - fitted.mean(0))
    return pose


def _search(
    x: NDArray[np.float64], ref: _Reference, pose: _Pose, scale_guess: float
) -> tuple[float, _Pose]:
    """The coarse search from one initial pose: 3 point-to-point iterations, then 12
    point-to-plane steps on the closest 80 % of the samples (which converge from ~30° where
    point-to-point stalls a few degrees short).  Returns the trimmed RMS distance and the pose.
    """
    pose = _icp_points(x, ref.coarse, ref.coarse_points, pose, scale_guess, iterations=3, keep=0.8)
    count = int(0.8 * len(x))
    for _ in range(12):
        y = pose.scale * x @ pose.rotation.T + pose.translation
        index = ref.coarse.query(y)[1]
        best = np.argpartition(np.sum((y - ref.coarse_points[index]) ** 2, axis=1), count)[:count]
        index = index[best]
        s, r, t = _point_to_plane_step(y[best], ref.coarse_points[index], ref.coarse_normals[index])
        pose = _compose(pose, s, r, t, scale_guess)
    y = pose.scale * x @ pose.rotation.T + pose.translation
    distance = np.sort(ref.coarse.query(y)[0])[:count]
    return float(np.sqrt(np.mean(distance**2))), pose


def _compose(
    pose: _Pose, s: float, r: NDArray[np.float64], t: NDArray[np.float64], scale_guess: float
) -> _Pose:
    """``pose`` followed by the step ``y -> (1 + s) y @ r.T + t``, the scale clamped."""
    return _clamp(
        _Pose((1 + s) * pose.scale, r @ pose.rotation, (1 + s) * pose.translation @ r.T + t),
        scale_guess,
    )


def _point_to_plane_step(
    y: NDArray[np.float64], target: NDArray[np.float64], normal: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """One linearised point-to-plane step with a similarity about the samples' centroid:
    ``y -> (1 + σ) R(ω) (y - c) + c + τ``; returns σ, R(ω), τ."""
    c = y.mean(axis=0)
    rel = y - c
    jacobian = np.column_stack([np.cross(rel, normal), np.einsum("kd,kd->k", rel, normal), normal])
    residual = np.einsum("kd,kd->k", target - y, normal)
    normal_matrix = jacobian.T @ jacobian
    normal_matrix += 1e-9 * np.trace(normal_matrix) / 7 * np.eye(7)
    solution = np.linalg.solve(normal_matrix, jacobian.T @ residual)
    rotation = _rodrigues(solution[:3])
    return float(solution[3]), rotation, c - (1 + solution[3]) * c @ rotation.T + solution[4:]


def _gate(distance: NDArray[np.float64], spacing: float) -> NDArray[np.bool_]:
    """Matches kept by the ICP: within ``max(3 × median, 1.5 × spacing)``."""
    result: NDArray[np.bool_] = distance <= max(3.0 * float(np.median(distance)), 1.5 * spacing)
    return result


def _refine(
    x: NDArray[np.float64], ref: _Reference, pose: _Pose, scale_guess: float
) -> tuple[_Pose, float]:
    """Trimmed ICP of received samples on the full reference: point-to-point, then
    point-to-plane on the reference's normals.  Returns the pose and the RMS distance of the
    closest 90 % of the samples to their nearest reference points (the score poses are compared
    by)."""
    pose = _icp_points(x, ref.tree, ref.points, pose, scale_guess, iterations=8, keep=0.9)
    for _ in range(_PLANE_STEPS):
        y = pose.scale * x @ pose.rotation.T + pose.translation
        distance, index = ref.tree.query(y)
        inlier = _gate(distance, ref.spacing)
        index = index[inlier]
        s, r, t = _point_to_plane_step(y[inlier], ref.points[index], _normals_at(ref, index))
        pose = _compose(pose, s, r, t, scale_guess)
    y = pose.scale * x @ pose.rotation.T + pose.translation
    distance = np.sort(ref.tree.query(y)[0])[: int(0.9 * len(y))]
    return pose, float(np.sqrt(np.mean(distance**2)))


class _PolishSurface(NamedTuple):
    """What :func:`_polish` needs of the received mesh, made once per mesh: the faces that
    may hold a reference point's closest point, their unit normals, libigl's AABB tree."""

    usable: NDArray[np.bool_]
    normal: NDArray[np.float64]
    tree: igl.AABB


def _polish_surface(v: NDArray[np.float64], f: NDArray[np.int64]) -> _PolishSurface:
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(cross, axis=1)
    usable = length > 0
    # A crop's reference points snap to the cut: skip the faces that touch the boundary
    # (an edge of one face; by one sort, libigl's on_boundary took 0.4 s on 188k faces).
    edges, inverse = unique_edges(f)
    boundary = (np.bincount(inverse, minlength=len(edges)) == 1)[inverse]
    rim = np.zeros(len(v), dtype=bool)
    rim[edges[inverse[boundary]].ravel()] = True
    if (usable & ~rim[f].any(axis=1)).any():  # else a mesh that is all rim: use it all
        usable &= ~rim[f].any(axis=1)
    normal = cross / np.maximum(length, np.finfo(float).tiny)[:, None]
    tree = igl.AABB()
    tree.init(v, f)
    return _PolishSurface(usable, normal, tree)


def _polish(
    v: NDArray[np.float64],
    f: NDArray[np.int64],
    ref: _Reference,
    pose: _Pose,
    surface: _PolishSurface | None = None,
) -> tuple[_Pose, float]:
    """Reference points projected onto the received surface (exact closest points, libigl's
    AABB tree), point-to-plane on the received faces' normals, until the step is below 1e-10:
    no sampling bias, so an unattacked or midpoint-subdivided mesh registers to rounding.
    Returns the pose and the RMS distance of the kept reference points to the received
    surface, as a fraction of the reference's diagonal.  ``surface``: :func:`_polish_surface`
    of ``v, f``, where made already."""
    usable, normal, tree = _polish_surface(v, f) if surface is None else surface
    p = ref.points[:: max(1, len(ref.points) // _POLISH_POINTS)]
    rms = np.inf
    for _ in range(_POLISH_STEPS):
        query = ((p - pose.translation) @ pose.rotation) / pose.scale
        squared, face, closest = tree.squared_distance(v, f, query)
        distance = pose.scale * np.sqrt(squared)
        # Gated on the residuals alone (no spacing floor): a point the crop removed can lie
        # within a spacing of another part of the surface (a thin feature, a fold).
        keep = usable[face]
        keep &= distance <= 3.0 * float(np.median(distance[keep])) if keep.any() else keep
        if keep.sum() < 7:
            break
        y = pose.scale * closest[keep] @ pose.rotation.T + pose.translation
        rms = float(np.sqrt(np.mean(distance[keep] ** 2))) / ref.diagonal
        s, r, t = _point_to_plane_step(y, p[keep], normal[face[keep]] @ pose.rotation.T)
        pose = _Pose((1 + s) * pose.scale, r @ pose.rotation, (1 + s) * pose.translation @ r.T + t)
        move = abs(s) + float(np.linalg.norm(r - np.eye(3))) + float(np.linalg.norm(t)) / ref.radius
        if move < 1e-10:
            break
    return pose, rms


def _overlap(x: NDArray[np.float64], ref: _Reference, pose: _Pose) -> float:
    """Fraction of received samples within 3 local spacings of their nearest reference point
    (the distance from that point to its own nearest neighbour, at least the median spacing:
    a geometry image samples some regions far more sparsely than others)."""
    y = pose.scale * x @ pose.rotation.T + pose.translation
    distance, index = ref.tree.query(y)
    near = np.unique(index)
    local = np.maximum(ref.tree.query(ref.points[near], k=2)[0][:, 1], ref.spacing)
    allowed = np.empty(len(ref.points))
    allowed[near] = 3.0 * local
    return float(np.mean(distance <= allowed[index]))


def _first(item: tuple[float, _Pose]) -> float:
    return item[0]


def _spread_rotations(count: int) -> NDArray[np.float64]:
    """``count`` rotations spread evenly over SO(3): the Super-Fibonacci spiral (Alexa 2022,
    doi:10.1109/CVPR52688.2022.00811), deterministic."""
    s = np.arange(count) + 0.5
    r, rr = np.sqrt(s / count), np.sqrt(1 - s / count)
    alpha, beta = 2 * np.pi * s / np.sqrt(2), 2 * np.pi * s / 1.533751168755204288118041
    w, x, y, z = r * np.sin(alpha), r * np.cos(alpha), rr * np.sin(beta), rr * np.cos(beta)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


#: The four proper sign flips of a principal frame.
#: Extra rotations tried when the principal frames do not give a full overlap (crops).
_SPREAD = 72
#: A polished pose whose residual (over the diagonal) is above this, though its overlap is
#: full, is not trusted: the SO(3) spread is searched too and the lower residual wins (a
#: decimated fertility, genus 4, fitted its principal frames upside down at 2 % of the diagonal
#: with 95 % overlap).
_GOOD_RMS = 2e-3
#: The most initial poses :func:`register` tries (its ``hypotheses`` never exceeds it): the
#: principal frames' four proper sign flips, then the spread over SO(3).  A caller that
#: decides on the pose counts them all.
POSE_HYPOTHESES = len(AXIS_FLIPS) + _SPREAD
#: Poses from the coarse search refined on the full reference.
_REFINED = 3
#: ... those whose coarse residual is within this factor of the best one.
_CLOSE = 1.5
#: A refined pose with at least this overlap ends the search early.
_GOOD_OVERLAP = 0.95


def register(
    vertices: NDArray,
    faces: NDArray,
    reference_points: NDArray,
    *,
    reference_normals: NDArray | None = None,
    spread: bool = True,
) -> Registration:
    """The similarity taking a received mesh into the frame of an asset's reference points.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        The received mesh, in any pose; it may be re-tessellated, cropped, noised or smoothed.
    faces : (m, 3) array_like of int
    reference_points : (..., 3) array_like of float
        Points on the original surface in the reference's frame, e.g. an N×N×3 geometry
        image; rows with a NaN (not covered) are ignored.
    reference_normals : (..., 3) array_like of float, optional
        Normals at those points (any length, any sign), for the refinement's point-to-plane
        steps; the final polish uses the received faces' normals.  Default (or where NaN or
        zero): the least principal axis of each point's 10 nearest reference points.
    spread : bool, default True
        Go on to the 72 rotations spread over SO(3) where the principal frames do not fit
        (stage 2 below).  False: the four principal frames only, the cheap first look
        (``Registration.settled`` says whether the spread would have been tried).

    Returns
    -------
    Registration
        ``x_ref = scale * x @ rotation.T + translation``, with the residual, overlap and the
        number of initial poses tried.

    Raises
    ------
    MeshError
        An unusable received mesh (empty, zero area), or fewer than 20 finite reference
        points, or normals of the wrong size.

    Notes
    -----
    Three stages, all on similarities ``(scale, rotation, translation)``:

    1. *Search.*  The received surface is sampled at 20 000 deterministic area-uniform points
       (:func:`surface_samples`).  Initial poses map the samples' centroid, principal axes and
       RMS radius onto the reference's (reference points weighted by the squared distance to
       their 10th neighbour, an area per point, so that an uneven sampling such as a geometry
       image's does not bias the frame) under the four proper sign flips of the axes.  Each
       runs 3 iterations of trimmed (closest 80 %) point-to-point ICP with Umeyama's
       similarity (doi:10.1109/34.88573), then 12 point-to-plane steps, on 400 samples
       against ~6000 reference points (point-to-point alone stalls a few degrees short).
    2. *Refinement* of the best three (those within 1.5 times the best coarse residual) on
       3000 samples and all reference points: 8 trimmed point-to-point iterations, then 8
       linearised point-to-plane steps (rotation, scale and translation: 7 unknowns) on the
       reference's normals, keeping the samples whose nearest reference point is within
       ``max(3 × median, 1.5 × spacing)``.  Received samples are matched to reference
       points, not the other way round, so a received mesh covering part of the surface (a
       crop) fits as well as a whole one.  If no refined pose has an overlap of 95 % (see
       :class:`Registration`) or the polished pose's residual is over 2e-3 of the diagonal,
       72 more initial rotations (Super-Fibonacci, spread
       over SO(3), taken relative to the two principal frames so that the search does not
       depend on the received pose) go through stages 1-2: a crop turns the principal axes.
       The pose with the smallest RMS distance of its closest 90 % of samples wins.
    3. *Polish.*  Up to 20 000 reference points are projected onto the received surface
       itself (exact closest points, libigl AABB tree); those within 3 × their median
       distance, and not on a face touching the boundary (where the points a crop removed
       snap to the cut), drive point-to-plane steps on the received faces' normals until
       the step is below 1e-10.  No sampling bias is left: an unattacked, cropped or
       midpoint-subdivided mesh registers to rounding (~1e-14 of the diagonal).  A decimated
       or Loop-subdivided surface is a different surface; its best-fit similarity is off by
       a few 1e-4 of the diagonal at most.

    The scale stays within a factor 1.8 of the RMS-radius ratio during stages 1-2 (a crop moves
    the ratio less; this prevents ICP from shrinking the mesh onto a small patch).

    Examples
    --------
    >>> from meshwm import data
    >>> from meshwm.attacks import apply_attack
    >>> from meshwm.mesh.io import read_mesh
    >>> v, f = read_mesh(data.path("spot"))
    >>> moved, _ = apply_attack("similarity", v, f, seed=5)
    >>> fit = register(moved, f, v)
    >>> bool(np.abs(fit.apply(moved) - v).max() < 1e-6), fit.overlap
    (True, 1.0)
    """
    search = PoseSearch(
        ReceivedSurface(vertices, faces), reference_points, reference_normals=reference_normals
    )
    return search.spread() if spread else search.frames()


class ReceivedSurface:
    """A received mesh prepared once for posing it against any number of references: its
    centred copy, 20,000 surface samples and their frame, and (made when first needed) the
    faces, normals and AABB tree of the final polish.

    Parameters
    ----------
    vertices, faces : array_like
        As :func:`register`.

    Raises
    ------
    MeshError
        An unusable mesh (empty, zero area).
    """

    def __init__(self, vertices: NDArray, faces: NDArray) -> None:
        v, f = checked_surface(vertices, faces)
        # Far from the origin: fit centred coordinates, compose at the end.
        self.offset = v.mean(axis=0)
        self.vertices, self.faces = v - self.offset, f
        self.samples, _ = surface_samples(self.vertices, f, _FINE_POINTS)
        self.centre, self.axes, self.radius = principal_frame(self.samples)
        self.coarse = self.samples[:: max(1, len(self.samples) // _COARSE_POINTS)]
        self.refine = self.samples[:: max(1, len(self.samples) // _REFINE_POINTS)]
        self._polish: _PolishSurface | None = None

    def polish_surface(self) -> _PolishSurface:
        """:func:`_polish_surface` of the centred mesh, made once."""
        if self._polish is None:
            self._polish = _polish_surface(self.vertices, self.faces)
        return self._polish


class PoseSearch:
    """:func:`register` in two steps that share their work: :meth:`frames` (the principal
    frames only, ``spread=False``), then :meth:`spread` (the full search) without making the
    frames' part again.

    Parameters
    ----------
    received : ReceivedSurface
        The received mesh, prepared once for every reference it is posed against.
    reference_points, reference_normals
        As :func:`register`.

    Notes
    -----
    ``PoseSearch(ReceivedSurface(v, f), ...).frames()`` is ``register(v, f, ...,
    spread=False)`` and ``.spread()``, before or after it, is ``register(v, f, ...)``, bit for
    bit.  A tracer looks at every candidate through its frames first and spreads only those
    that did not fit; keeping the search saves the spread its repeat of the frames (the
    reference's trees, four coarse searches and their refinements), and one
    :class:`ReceivedSurface` saves every candidate the received mesh's samples and AABB tree.
    """

    def __init__(
        self,
        received: ReceivedSurface,
        reference_points: NDArray,
        *,
        reference_normals: NDArray | None = None,
    ) -> None:
        self._ref = ref = _prepare(reference_points, reference_normals)
        self._received = received
        self._offset = received.offset
        self._v, self._f = received.vertices, received.faces
        self._x = received.samples
        self._centre, self._axes = received.centre, received.axes
        self._scale_guess = ref.radius / received.radius
        self._coarse_x = received.coarse
        self._refine_x = received.refine
        self._candidates: list[tuple[float, _Pose]] = []
        self._chosen: tuple[_Pose, float] | None = None
        self._best: _Pose | None = None
        self._hypotheses = 0
        self._stages = 0  # stages made: 1 the frames, 2 the spread too
        self._stopped = False  # a stage ended on a good fit: no further stage

    def _stage(self, rotations: NDArray[np.float64]) -> None:
        """One stage of the search from the initial ``rotations`` (see :func:`register`)."""
        ref, scale_guess, centre = self._ref, self._scale_guess, self._centre
        self._stages += 1
        self._hypotheses += len(rotations)
        starts = [
            _Pose(scale_guess, rotation, ref.centre - scale_guess * centre @ rotation.T)
            for rotation in rotations
        ]
        found = sorted(
            (_search(self._coarse_x, ref, start, scale_guess) for start in starts), key=_first
        )
        for score, start in found[:_REFINED]:
            if score > _CLOSE * found[0][0]:
                break
            pose, trimmed = _refine(self._refine_x, ref, start, scale_guess)
            self._candidates.append((trimmed, pose))
        self._best = min(self._candidates, key=_first)[1]
        if _overlap(self._refine_x, ref, self._best) < _GOOD_OVERLAP:
            return
        polished = _polish(self._v, self._f, ref, self._best, self._received.polish_surface())
        if self._chosen is None or polished[1] < self._chosen[1]:
            self._chosen = polished
        if polished[1] <= _GOOD_RMS:
            self._stopped = True

    def _result(self) -> Registration:
        """The search so far, finished (without changing its state)."""
        assert self._best is not None
        chosen = self._chosen
        frames_only = self._hypotheses == len(AXIS_FLIPS)
        settled = chosen is not None and chosen[1] <= _GOOD_RMS and frames_only
        if chosen is None or chosen[1] > _GOOD_RMS:
            surface = self._received.polish_surface()
            polished = _polish(self._v, self._f, self._ref, self._best, surface)
            if chosen is None or polished[1] < chosen[1]:
                chosen = polished
        pose, rms = chosen
        translation = pose.translation - pose.scale * self._offset @ pose.rotation.T
        overlap = _overlap(self._x, self._ref, pose)
        return Registration(
            pose.scale, pose.rotation, translation, rms, overlap, self._hypotheses, settled
        )

    def frames(self) -> Registration:
        """The pose from the four principal frames only (``register(..., spread=False)``)."""
        if self._stages == 0:
            self._stage(self._ref.axes @ AXIS_FLIPS @ self._axes.T)
        if self._stages > 1:
            raise RuntimeError("frames() after spread(): the search has gone past the frames")
        return self._result()

    def spread(self) -> Registration:
        """The full search (``register(...)``), the frames' stage made once."""
        if self._stages == 0:
            self._stage(self._ref.axes @ AXIS_FLIPS @ self._axes.T)
        if self._stages == 1 and not self._stopped:
            self._stage(self._ref.axes @ _spread_rotations(_SPREAD) @ self._axes.T)
        return self._result()
