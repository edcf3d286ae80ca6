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

A frame fitted to the whole surface is what a crop moves, so a cropped copy fits no probe well:
:class:`meshwm.watermark.trace.Tracer` promotes only the candidates whose probe fits and keeps
the descriptor's order for the rest.  Nothing here is secret or keyed: the probe is made from
the unmarked input, like the reference it is a part of.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from meshwm.readers.descriptor import (
    AXIS_FLIPS,
    checked_surface,
    principal_frame,
    surface_samples,
)

__all__ = ["PROBE", "PROBE_FIT", "PROBE_POINTS", "ProbeError", "make_probe", "probe_residuals"]

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
    read = []
    for i, p in enumerate(probes):
        try:
            read.append(None if p is None else _read(bytes(p)))
        except ValueError as exc:
            raise ProbeError(i, str(exc)) from None
    out = np.full(len(read), np.inf)
    if all(r is None for r in read):
        return out
    v, f = checked_surface(vertices, faces)
    x, normals = surface_samples(v, f, _RECEIVED_POINTS)
    centre, axes, radius = principal_frame(x)
    tree = cKDTree(x)
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
