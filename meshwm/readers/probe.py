"""An asset's probe: its principal frame and a few hundred surface points, to rank candidates.

The shape descriptor (:func:`meshwm.readers.descriptor.shape_descriptor`) is a histogram: it
ranks a received mesh among thousands of assets at once, but not among near-duplicates (one
character's variants, a prop re-scaled along one axis), and a decimated copy may rank tenth
among them, each wrong candidate costing a registration and a read before the right one.  The
probe settles that cheaply.  It keeps the asset's principal frame (centroid, axes and RMS
radius of its :data:`~meshwm.readers.informed.ANCHORS` area-uniform surface points) and
:data:`PROBE_POINTS` of those points (a strided subset, itself spread over the surface), about
6 KB.  :func:`probe_residuals` puts each probe into the received mesh's principal frame (the
four sign choices of the axes, no iteration) and measures how far its points lie from the
received surface's tangent planes: the right asset fits to ~1e-3 of the radius after a
decimation to 50 %, a 10 % anisotropic variant does not.

A frame fitted to the whole surface is what a crop moves, so a cropped copy fits no probe in
its frame.  :func:`partial_residuals` fits the probes to such a surface with a similarity
(trimmed ICP from the frames, then from the pose of the first probe that fits, which its
near-duplicates share): it ranks a 30 % crop among near-duplicates, for a few tenths of a
second per hundred probes.  Nothing here is secret or keyed: the probe is made from the unmarked
input, like the reference it is a part of.
"""

from __future__ import annotations

import itertools
import struct
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from meshwm.readers.descriptor import (
    AXIS_FLIPS,
    checked_surface,
    principal_frame,
    surface_samples,
)

__all__ = [
    "PROBE",
    "PROBE_FIT",
    "PROBE_POINTS",
    "ProbeError",
    "make_probe",
    "partial_residuals",
    "probe_residuals",
]

#: The grid size a probe is recorded under among an asset's references (it holds for every
#: size).
PROBE = 0
#: Surface points a probe keeps.
PROBE_POINTS = 512
#: A probe whose residual (over the received mesh's RMS radius) is at most this fits the shape.
PROBE_FIT = 0.015
#: Received surface samples the probes are measured against.
_RECEIVED_POINTS = 8192
#: Fraction of a probe's points whose distances are kept (the rest: holes, cut-offs).
_KEEP = 0.9
#: Distances are measured up to this many received RMS radii.
_REACH = 0.1
_MAGIC = b"PRB1"
_HEADER = struct.Struct("<4s13dI")


class ProbeError(ValueError):
    """A damaged probe: ``index`` is its place in the sequence given."""

    def __init__(self, index: int, message: str) -> None:
        super().__init__(f"probe {index}: {message}")
        self.index = index


def make_probe(anchors: NDArray) -> bytes:
    """The probe of an asset from its anchors (area-uniform points on its surface).

    Parameters
    ----------
    anchors : (a, 3) array_like
        :attr:`meshwm.readers.informed.Reference.anchors`: :func:`surface_samples` of the
        unmarked input, at least :data:`PROBE_POINTS` of them.

    Returns
    -------
    bytes
        The frame and :data:`PROBE_POINTS` of the points (float32), read by
        :func:`probe_residuals`.

    Raises
    ------
    ValueError
        Too few or non-finite anchors.
    """
    # As the reference stores them (float32): a probe made later from a stored reference
    # (``meshwm registry upgrade``) is the same bytes.
    a = np.asarray(anchors, dtype=np.float64).astype(np.float32).astype(np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or len(a) < PROBE_POINTS:
        raise ValueError(f"anchors must have shape (>= {PROBE_POINTS}, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("anchors must be finite")
    centre, axes, radius = principal_frame(a)
    kept = a[:: len(a) // PROBE_POINTS][:PROBE_POINTS].astype("<f4")
    head = _HEADER.pack(_MAGIC, *centre, *axes.ravel(), radius, len(kept))
    return head + kept.tobytes()


def _read(data: bytes) -> tuple[NDArray[np.float64], NDArray[np.float64], float, NDArray]:
    """:func:`make_probe`'s frame and points; :class:`ValueError` for anything else."""
    try:
        magic, *numbers, count = _HEADER.unpack_from(data)
    except struct.error:
        raise ValueError("not a probe: too short") from None
    if magic != _MAGIC or count != PROBE_POINTS or len(data) != _HEADER.size + 12 * count:
        raise ValueError("not a probe")
    frame = np.array(numbers)
    points = np.frombuffer(data, dtype="<f4", offset=_HEADER.size).reshape(count, 3)
    radius = float(frame[12])
    if not (np.all(np.isfinite(frame)) and np.all(np.isfinite(points)) and radius > 0):
        raise ValueError("not a probe: non-finite or empty frame")
    return frame[:3], frame[3:12].reshape(3, 3), radius, points.astype(np.float64)


def _residual(
    points: NDArray[np.float64],
    samples: NDArray[np.float64],
    normals: NDArray[np.float64],
    tree: cKDTree,
    *,
    reach: float,
) -> NDArray[np.float64]:
    """RMS over the last point axis of the nearest :data:`_KEEP` point-to-plane distances to
    the nearest sample; a point farther than ``reach`` from every sample counts as ``reach``
    (searching the tree for far points is what a misfit costs; a fit is ~1e-3 radii)."""
    _, near = tree.query(points.reshape(-1, 3), distance_upper_bound=reach)
    near = near.reshape(points.shape[:-1])
    far = near == len(samples)
    near[far] = 0
    gap = np.abs(np.einsum("...i,...i->...", points - samples[near], normals[near]))
    gap[far] = reach
    gap = np.sort(gap, axis=-1)[..., : max(1, int(_KEEP * gap.shape[-1]))]
    result: NDArray[np.float64] = np.sqrt(np.mean(gap**2, axis=-1))
    return result


_Probe = tuple[NDArray[np.float64], NDArray[np.float64], float, NDArray[np.float64]]


def _read_all(probes: Sequence[bytes | None]) -> list[_Probe | None]:
    """:func:`_read` of each probe (None stays None); :class:`ProbeError` names a bad one."""
    read: list[_Probe | None] = []
    for i, p in enumerate(probes):
        try:
            read.append(None if p is None else _read(bytes(p)))
        except ValueError as exc:
            raise ProbeError(i, str(exc)) from None
    return read


class _Surface(NamedTuple):
    """The received surface for partial fits: samples, their normals, frame, tree."""

    x: NDArray[np.float64]
    normals: NDArray[np.float64]
    centre: NDArray[np.float64]
    axes: NDArray[np.float64]
    radius: float
    tree: cKDTree


def _received(vertices: NDArray, faces: NDArray) -> _Surface:
    """The received mesh's :data:`_RECEIVED_POINTS` samples, their normals, frame and tree."""
    v, f = checked_surface(vertices, faces)
    x, normals = surface_samples(v, f, _RECEIVED_POINTS)
    return _Surface(x, normals, *principal_frame(x), cKDTree(x))


def probe_residuals(
    vertices: NDArray, faces: NDArray, probes: Sequence[bytes | None]
) -> NDArray[np.float64]:
    """How well each asset's probe fits the received surface, in its principal frame.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh, any pose (a similarity of the asset is undone by the frames).
    probes : sequence of bytes or None
        :func:`make_probe` outputs; None for an asset without one.

    Returns
    -------
    (len(probes),) float64 ndarray
        Per probe, the RMS point-to-plane distance from its points (the nearest :data:`_KEEP`
        of them, each counted up to :data:`_REACH`) to the received surface's samples, over the
        received RMS radius, under the sign choice of the principal axes that fits every 8th
        point best; ``inf`` for None.

    Raises
    ------
    MeshError
        An unusable received mesh.
    ProbeError
        A probe that :func:`make_probe` did not make (a ValueError naming its index).
    """
    read = _read_all(probes)
    out = np.full(len(read), np.inf)
    if all(r is None for r in read):
        return out
    x, normals, centre, axes, radius, tree = _received(vertices, faces)
    given = [(i, r) for i, r in enumerate(read) if r is not None]
    # Every probe under the four sign choices of its axes (probe axis k onto received axis k):
    # (probes, flips, points, 3).  The flip is chosen on every 8th point, then measured on all.
    moved = np.stack(
        [
            np.einsum("pj,fij->fpi", (p - c) * (radius / r), axes @ AXIS_FLIPS @ a.T)
            for _, (c, a, r, p) in given
        ]
    )
    moved += centre
    flip = np.argmin(_residual(moved[:, :, ::8], x, normals, tree, reach=_REACH * radius), axis=1)
    best = moved[np.arange(len(given)), flip]
    residual = _residual(best, x, normals, tree, reach=_REACH * radius)
    out[[i for i, _ in given]] = residual / radius
    return out


# --- Partial fits: a received surface that covers part of the asset (a crop) ---------------

#: Received samples matched to the probes' points while a pose is searched and while a pose
#: found for one probe is refined for every other (256 ranked the 30 test crops the same and
#: cost a fifth more).
_SEARCH_SAMPLES = 128
#: Point-to-point iterations, then point-to-plane steps, of the search from the frames.
_POINT_STEPS = 5
_PLANE_STEPS = 16
#: Fraction of the received samples kept by the trimmed search (their nearest probe points).
_SEARCH_KEEP = 0.8
#: Fraction of a probe's points whose point-to-plane distances count in a partial fit: a 30 %
#: crop leaves 70 % of them on the received surface.
_PARTIAL_KEEP = 0.6
#: The scale a search may reach, as a factor of the frames' RMS-radius ratio.
_SCALE_SPAN = 1.8
#: Probes searched from their frames together, the most such groups before giving up, and
#: the groups searched before the first is searched again from the cube's other turns (on 30
#: test crops against 1,000 assets a pose came from the first 4 groups or the turns; a search
#: that finds none costs about 0.06 s a group and 0.35 s the turns).
_BATCH = 4
_BATCHES = 8
_BEFORE_TURNS = 4
#: Probes refined again, to convergence, after the shared pose (the best fits).
_REFINED = 8
#: A probe whose partial residual is at most this gives a pose the others start from (the
#: search ends once a probe fits within :data:`PROBE_FIT`).
_POSE_FIT = 0.03
#: The proper rotations of the cube that are not one of the four sign choices of the axes.
_CUBE_TURNS = np.array(
    [
        m
        for m in (
            np.eye(3)[list(p)] * np.array(signs)[:, None]
            for p in itertools.permutations(range(3))
            for signs in itertools.product((1.0, -1.0), repeat=3)
        )
        if np.linalg.det(m) > 0 and not any(np.array_equal(m, flip) for flip in AXIS_FLIPS)
    ]
)
#: Neighbours (among a probe's own points) of a probe point's normal.
_PROBE_NEIGHBOURS = 8


def _rotations(omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) from rotation vectors (..., 3) (Rodrigues)."""
    angle = np.linalg.norm(omega, axis=-1)
    k = omega / np.maximum(angle, np.finfo(float).tiny)[..., None]
    cross = np.zeros((*omega.shape[:-1], 3, 3))
    cross[..., 0, 1], cross[..., 0, 2], cross[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    cross -= np.swapaxes(cross, -1, -2)
    sin, cos = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    result: NDArray[np.float64] = np.eye(3) + sin * cross + (1 - cos) * cross @ cross
    return result


def _trimmed(distance: NDArray[np.float64], keep: float) -> NDArray[np.float64]:
    """Weights (b, k): 1 for the closest ``keep`` of each row's distances, else 0."""
    k = max(1, int(keep * distance.shape[1])) - 1
    cut = np.partition(distance, k, axis=1)[:, k]
    return (distance <= cut[:, None]).astype(np.float64)


def _umeyama_batch(
    source: NDArray[np.float64], target: NDArray[np.float64], weight: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Weighted least-squares similarities ``target ≈ s * (source - μs) @ R.T + μt`` per row
    of a batch (b, k, 3) (Umeyama 1991, doi:10.1109/34.88573): ``s`` (b,), ``R`` (b, 3, 3) and
    the weighted centroids ``μs``, ``μt`` (b, 3)."""
    w = weight / np.maximum(weight.sum(axis=1, keepdims=True), np.finfo(float).tiny)
    mu_s, mu_t = np.einsum("bk,bkd->bd", w, source), np.einsum("bk,bkd->bd", w, target)
    a, b = source - mu_s[:, None], target - mu_t[:, None]
    u, d, vt = np.linalg.svd(np.einsum("bk,bki,bkj->bij", w, b, a))
    sign = np.ones((len(d), 3))
    sign[:, 2] = np.where(np.linalg.det(u) * np.linalg.det(vt) < 0, -1.0, 1.0)
    rotation = (u * sign[:, None, :]) @ vt
    spread = np.maximum(np.einsum("bk,bkd->b", w, a**2), np.finfo(float).tiny)
    scale = (d * sign).sum(axis=1) / spread
    return scale, rotation, mu_s, mu_t


def _plane_steps(
    y: NDArray[np.float64],
    target: NDArray[np.float64],
    normal: NDArray[np.float64],
    weight: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One linearised, weighted point-to-plane step per row of a batch (b, k, 3), as
    :func:`meshwm.readers.registration` takes it: ``y -> (1 + σ) R(ω) (y - c) + c + τ`` about
    the weighted centroid ``c``; returns ``c``, ``R``, ``σ``, ``τ``."""
    c = np.einsum("bk,bkd->bd", weight, y) / np.maximum(weight.sum(axis=1), 1.0)[:, None]
    rel = y - c[:, None]
    jacobian = np.concatenate(
        [np.cross(rel, normal), np.sum(rel * normal, axis=-1)[..., None], normal], axis=-1
    )
    residual = np.sum((target - y) * normal, axis=-1)
    weighted = np.swapaxes(jacobian * weight[..., None], 1, 2)
    matrix = weighted @ jacobian
    ridge = 1e-9 * np.trace(matrix, axis1=1, axis2=2) / 7 + np.finfo(float).tiny
    matrix += ridge[:, None, None] * np.eye(7)
    solution = np.linalg.solve(matrix, weighted @ residual[..., None])[..., 0]
    return c, _rotations(solution[:, :3]), solution[:, 3], solution[:, 4:]


def _sizes(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """RMS distance of each row's points (b, k, 3) to their centroid."""
    rel = points - points.mean(axis=1, keepdims=True)
    result: NDArray[np.float64] = np.sqrt(np.mean(np.sum(rel**2, axis=-1), axis=1))
    return result


_Apart = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray
]


def _apart(points: NDArray[np.float64]) -> _Apart:
    """Rows of points (b, k, 3) each in its own unit frame (centred, over its RMS size), and
    those laid out far apart so that one KD-tree serves every row: the centres (b, 3), sizes
    (b,), the rows in their frames (b, k, 3), the shifts (b, 3) and the points laid out
    (b * k, 3)."""
    centre = points.mean(axis=1)
    size = _sizes(points)
    own = (points - centre[:, None]) / np.maximum(size, np.finfo(float).tiny)[:, None, None]
    shift = np.zeros((len(points), 3))
    shift[:, 0] = 20.0 * np.arange(len(points))
    return centre, size, own, shift, (own + shift[:, None]).reshape(-1, 3)


def _point_normals(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit normals (b, k, 3) of point sets (b, k, 3), each row on its own: the least principal
    axis of each point's 8 nearest points in its row."""
    flat = _apart(points)[4]
    local = flat[cKDTree(flat).query(flat, k=_PROBE_NEIGHBOURS)[1]]
    local -= local.mean(axis=1, keepdims=True)
    normal: NDArray[np.float64] = np.linalg.eigh(np.swapaxes(local, 1, 2) @ local)[1][:, :, 0]
    return normal.reshape(points.shape)


def _received_to_probes(
    surface: _Surface,
    y: NDArray[np.float64],
    normals: NDArray[np.float64] | None,
    *,
    samples: int,
    point_steps: int,
    plane_steps: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Trimmed ICP of received samples onto placed probes ``y`` (b, k, 3), received
    coordinates: every received sample of a crop has a counterpart on the asset, not every
    probe point one on the crop.  ``point_steps`` point-to-point iterations (Umeyama's
    similarity), then ``plane_steps`` point-to-plane steps on the probe points' ``normals``
    (None where there are none).  Returns ``y`` moved by the inverse of the fitted
    similarity (the probes posed on the received surface), and per row the RMS distance of the
    closest 80 % of the samples to its points, in units of the row's RMS size."""
    count = len(y)
    centre, size, own, shift, flat = _apart(y)
    tree = cKDTree(flat)
    x = surface.x[:: max(1, len(surface.x) // samples)]
    # z = s R x + t: received coordinates into each row's unit frame; starts at the placement.
    rotation = np.broadcast_to(np.eye(3), (count, 3, 3)).copy()
    scale, translation = 1.0 / size, -centre / size[:, None]
    low, high = scale / _SCALE_SPAN, scale * _SCALE_SPAN

    def match() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
        z = scale[:, None, None] * (x @ np.swapaxes(rotation, 1, 2)) + translation[:, None]
        distance, index = tree.query((z + shift[:, None]).reshape(-1, 3))
        return z, distance.reshape(count, -1), index.reshape(count, -1)

    for _ in range(point_steps):
        z, distance, index = match()
        scale, rotation, mu_x, mu_p = _umeyama_batch(
            np.broadcast_to(x, z.shape),
            flat[index] - shift[:, None],
            _trimmed(distance, _SEARCH_KEEP),
        )
        scale = np.clip(scale, low, high)
        translation = mu_p - scale[:, None] * (rotation @ mu_x[..., None])[..., 0]
    if normals is not None:
        normal = normals.reshape(-1, 3)
        for _ in range(plane_steps):
            z, distance, index = match()
            c, r, sigma, tau = _plane_steps(
                z, flat[index] - shift[:, None], normal[index], _trimmed(distance, _SEARCH_KEEP)
            )
            scale = np.clip((1 + sigma) * scale, low, high)
            turned = (r @ (translation - c)[..., None])[..., 0]
            translation = (1 + sigma)[:, None] * turned + c + tau
            rotation = r @ rotation
    _, distance, _ = match()
    kept = np.sort(distance, axis=1)[:, : int(_SEARCH_KEEP * distance.shape[1])]
    posed = ((own - translation[:, None]) @ rotation) / scale[:, None, None]
    return posed, np.sqrt(np.mean(kept**2, axis=1))


def _probes_to_received(
    surface: _Surface, y: NDArray[np.float64], *, steps: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Trimmed point-to-plane ICP of posed probes ``y`` (b, k, 3) on the received samples'
    tangent planes (every 4th point, the closest :data:`_PARTIAL_KEEP`); returns the probes
    moved and their residuals: RMS of the closest :data:`_PARTIAL_KEEP` of all points'
    distances (each at most :data:`_REACH`), over the received RMS radius."""
    reach = _REACH * surface.radius

    def gaps(
        points: NDArray[np.float64],
    ) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.bool_]]:
        _, index = surface.tree.query(points.reshape(-1, 3), distance_upper_bound=reach)
        index = index.reshape(points.shape[:2])
        far = index == len(surface.x)
        index[far] = 0
        gap = np.abs(np.sum((points - surface.x[index]) * surface.normals[index], axis=-1))
        gap[far] = reach
        return gap, index, far

    for _ in range(steps):
        some = y[:, ::4]
        gap, index, far = gaps(some)
        c, r, sigma, tau = _plane_steps(
            some,
            surface.x[index],
            surface.normals[index],
            _trimmed(gap, _PARTIAL_KEEP) * ~far,
        )
        sigma = np.clip(sigma, -0.1, 0.1)  # a step never shrinks a probe onto a patch
        y = (1 + sigma)[:, None, None] * ((y - c[:, None]) @ np.swapaxes(r, 1, 2))
        y += (c + tau)[:, None]
    gap, _, _ = gaps(y)
    kept = np.sort(gap, axis=1)[:, : max(1, int(_PARTIAL_KEEP * gap.shape[1]))]
    return y, np.sqrt(np.mean(kept**2, axis=1)) / surface.radius


def _shared_fits(
    surface: _Surface,
    points: NDArray[np.float64],
    source: NDArray[np.float64],
    fitted: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Every probe's ``points`` (p, k, 3) placed by the similarity that took ``source`` (k, 3)
    onto ``fitted``, then fitted from there (:func:`partial_residuals`): their residuals and
    the points fitted."""
    scale, rotation, mu_p, mu_y = _umeyama_batch(
        source[None], fitted[None], np.ones((1, len(source)))
    )
    placed = scale[0] * (points - mu_p[0]) @ rotation[0].T + mu_y[0]
    posed, _ = _received_to_probes(
        surface, placed, None, samples=_SEARCH_SAMPLES, point_steps=4, plane_steps=0
    )
    moved, residual = _probes_to_received(surface, posed, steps=3)
    # The best few again, to convergence, and the likeliest few (the first given: the
    # descriptor's nearest): a pose shared from a re-proportioned variant leaves the asset
    # itself a few steps short of its own fit, sometimes behind variants that fit it better.
    top = np.union1d(np.argsort(residual, kind="stable")[:_REFINED], np.arange(_REFINED))
    top = top[top < len(residual)]
    posed, _ = _received_to_probes(
        surface,
        moved[top],
        _point_normals(moved[top]),
        samples=_SEARCH_SAMPLES,
        point_steps=0,
        plane_steps=_PLANE_STEPS,
    )
    again, refined = _probes_to_received(surface, posed, steps=6)
    better = refined < residual[top]
    residual[top[better]] = refined[better]
    moved[top[better]] = again[better]
    return residual, moved


def partial_residuals(
    vertices: NDArray, faces: NDArray, probes: Sequence[bytes | None]
) -> NDArray[np.float64]:
    """How well each probe fits a received surface that may cover only part of its asset.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh, any pose; a crop of an asset, or all of it.
    probes : sequence of bytes or None
        :func:`make_probe` outputs, the likeliest first (the order the search for a pose takes:
        the shape descriptor's); None for an asset without one.

    Returns
    -------
    (len(probes),) float64 ndarray
        Per probe, the RMS point-to-plane distance of the closest 60 % of its points to the
        received surface's samples after a similarity fit, over the received RMS radius
        (~5e-4 for the asset of a 30 % crop, several 1e-3 for a near-duplicate); ``inf`` for
        None and for probes no pose was found for.

    Raises
    ------
    MeshError
        An unusable received mesh.
    ProbeError
        A probe that :func:`make_probe` did not make.

    Notes
    -----
    A crop moves the principal frame :func:`probe_residuals` relies on, so each probe is
    fitted.  The probes are taken 4 at a time, in the order given: each is placed in the
    received frame under the four sign choices of the axes, then trimmed ICP takes 128
    received samples onto its points (5 point-to-point iterations with Umeyama's similarity,
    16 point-to-plane steps on the probe points' normals, each point's from its 8 nearest in
    the probe; the closest 80 %: a crop's samples all lie on the asset, not the probe's points
    on the crop; the scale within a factor 1.8 of the frames'); the best sign choice is refined
    the other way, probe points onto the received samples' tangent planes (6 steps, the
    closest 60 %).  A probe of the group fitting within 0.03 of the radius gives a pose, in
    registry coordinates, that places every probe: near-duplicates of one asset (its
    variants, LODs, a re-proportioned copy) share its frame.  From there each is fitted by 4
    point-to-point iterations on 128 samples and 3 point-to-plane steps the other way, and the
    8 that fit best and the first 8 given by the full 16 and 6 steps again (a pose shared
    from a re-proportioned variant leaves the asset itself short of its own fit, at times
    behind variants that fit better than it; among 1,000 assets a plane_holes crop's own
    probe came 13th of those fits and its variants filled the candidates).  The search ends
    when a probe fits within :data:`PROBE_FIT` (at most 8 groups: 32 probes).  A fit whose
    scale left 1.8 times the frames' ratio (RMS radii) is no fit: ICP can shrink a probe onto a
    patch.  A probe's residual is the smallest of its fits.  Deterministic: no random start, fixed
    samples (:func:`surface_samples`).

    A crop can turn the frame beyond what ICP from the four sign choices reaches (as it can
    the registration's, which then searches rotations spread over SO(3)): where no probe fits
    after the first 4 groups, the first group is searched again from the other 20 rotations
    that map the axes onto each other, before the other groups.  On 30 random 30 % crops of
    spot, kitten and plane_holes the asset's own probe fitted 29 times (28 from the sign
    choices alone; the 30th, a plane_holes crop, needs the registration's spread too).
    """
    read = _read_all(probes)
    out = np.full(len(read), np.inf)
    known = [(i, r) for i, r in enumerate(read) if r is not None]
    if not known:
        return out
    given = [i for i, _ in known]
    surface = _received(vertices, faces)
    points = np.stack([r[3] for _, r in known])
    # Each probe's points in its own frame's units: where its search starts.
    unit = np.stack([(p - c) / r for _, (c, _, r, p) in known])
    unit_size = _sizes(unit)

    def scaled(index: NDArray[np.intp], fits: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Fits whose scale is within 1.8 times the frames' (the RMS radii's) ratio: a fit
        that shrank a probe onto a patch of the surface is no fit."""
        ratio = _sizes(fits) / (surface.radius * unit_size[index])
        result: NDArray[np.bool_] = (ratio >= 1 / _SCALE_SPAN) & (ratio <= _SCALE_SPAN)
        return result

    def search(start: int, turns: NDArray[np.float64]) -> bool:
        """The probes from ``start`` (a group), each from the received frame under ``turns``
        (t, 3, 3) of its own, fitted; the pose of the best, where it fits roughly, shared
        with every probe (:func:`_shared_fits`).  True once a probe fits."""
        group = given[start : start + _BATCH]
        count = len(turns)
        # (probes, turns, 3, 3): the probe's frame onto the received one, under each turn.
        turn = np.einsum(
            "ij,fjk,pkl->pfil",
            surface.axes,
            turns,
            np.stack([np.swapaxes(r[1], 0, 1) for _, r in known[start : start + _BATCH]]),
        ).reshape(-1, 3, 3)
        rows = np.repeat(np.arange(start, start + len(group)), count)
        placed = surface.radius * unit[rows] @ np.swapaxes(turn, 1, 2) + surface.centre
        posed, coarse = _received_to_probes(
            surface,
            placed,
            _point_normals(unit[start : start + len(group)])[rows - start]
            @ np.swapaxes(turn, 1, 2),
            samples=_SEARCH_SAMPLES,
            point_steps=_POINT_STEPS,
            plane_steps=_PLANE_STEPS,
        )
        best = np.arange(len(group)) * count + coarse.reshape(len(group), count).argmin(axis=1)
        fitted, residual = _probes_to_received(surface, posed[best], steps=6)
        residual[~scaled(np.arange(start, start + len(group)), fitted)] = np.inf
        out[group] = np.minimum(out[group], residual)
        k = int(np.argmin(residual))
        if residual[k] <= _POSE_FIT:
            shared, moved = _shared_fits(surface, points, points[start + k], fitted[k])
            shared[~scaled(np.arange(len(known)), moved)] = np.inf
            out[given] = np.minimum(out[given], shared)
        return bool(np.min(out) <= PROBE_FIT)

    # A crop that turned the frame too far for the sign choices: the first group again from
    # the other 20 rotations that map the axes onto each other, after the first few groups.
    starts = list(range(0, min(len(given), _BATCH * _BATCHES), _BATCH))
    searches = [(start, AXIS_FLIPS) for start in starts]
    searches.insert(min(_BEFORE_TURNS, len(searches)), (0, _CUBE_TURNS))
    for start, turns in searches:
        if search(start, turns):
            break
    return out
