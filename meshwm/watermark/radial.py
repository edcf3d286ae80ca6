"""The radial carrier on a mesh: bits into the spherical image of its vertices, and back.

The second carrier of a mesh kept as it is (:mod:`meshwm.profiles.radial` has the method): the
vertices move along their directions from the point set's centre, each bit's projection is
brought onto its lattice by the least-distortion move (a minimum-norm solution through the
sampling matrix of :mod:`meshwm.gim.sphere`), and a few passes re-derive the pose from the moved
points, as a reader will, until every projection sits on its lattice point.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.sparse.linalg import LinearOperator, cg

from meshwm._vector import face_cross, row_norm
from meshwm.gim.pose import Pose
from meshwm.gim.sphere import SphereSampling, point_poses, point_set, sphere_sampling
from meshwm.profiles.radial.scheme import (
    RADIAL_LEVEL,
    RADIAL_STEP,
    RadialLayout,
    lattice_change,
    radial_layout,
    radial_projections,
    radial_spread,
    read_radial_bits,
)
from meshwm.readers.radial import RADIAL_SIZES

__all__ = [
    "RADIAL_PASSES",
    "RADIAL_SIZE",
    "RadialMark",
    "embed_radial",
    "radial_read",
    "radial_size",
]

#: The spherical image's size for a 64-bit id (``3 (N/8)²`` = 768 slots: 3 per code bit).
RADIAL_SIZE = 128
#: Slots each bit gets at least (the size follows the payload, :func:`radial_size`).
_SLOTS_PER_BIT = 3
#: Passes of (pose, sample, solve) after the first.
RADIAL_PASSES = 3
#: A pass that moves no projection by more than this many steps is the last: the pose it
#: shifts moves the projections by about a hundredth of that again (igea: changes of 9.9e-4,
#: 1.2e-5, 1.5e-9 and 2.2e-12 radius units over four passes at a step of 2e-3, so it stops
#: after two; spot after three; cow, whose pose keeps moving, takes all four).
_SETTLED = 1e-2
#: The weight of a move along the surface against one across it (a radial move at a grazing
#: vertex slides it along the surface: cheap for the distance, not free).
_SLIDE = 0.25


class RadialMark(NamedTuple):
    """Result of :func:`embed_radial`.

    Attributes
    ----------
    vertices : (n, 3) float64 ndarray
        The input's vertices, moved along their directions from the centre.
    report : dict
        ``radial_n``, ``radial_passes`` (taken after the first) and, with ``read_back``,
        ``radial_ber`` (read back through the pose of the moved points).
    """

    vertices: NDArray[np.float64]
    report: dict


def _costs(
    points: NDArray[np.float64], faces: NDArray[np.int64], directions: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Per point: its area times ``(n·d)² + _SLIDE``, the cost of a unit radial move."""
    cross = face_cross(points, faces)
    n = len(points)
    corners = faces.T.ravel()  # each face's corners, column by column
    third = np.tile(0.5 * row_norm(cross) / 3.0, 3)
    area = np.bincount(corners, weights=third, minlength=n)
    normal = np.stack(
        [np.bincount(corners, weights=np.tile(cross[c], 3), minlength=n) for c in range(3)],
        axis=1,
    )
    normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    across = np.einsum("ij,ij->i", normal, directions)
    floor = max(float(area.mean()), 1e-300) * 1e-3
    return np.maximum(area, floor) * (across**2 + _SLIDE)


def _solve(
    sampling: SphereSampling,
    layout: RadialLayout,
    cost: NDArray[np.float64],
    change: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The least-cost radial moves (radius units) that change the projections by ``change``."""
    matrix = sampling.matrix
    n = layout.n

    def forward(delta: NDArray[np.float64]) -> NDArray[np.float64]:
        out: NDArray[np.float64] = radial_projections(
            np.asarray(matrix @ delta).reshape(n, n), layout
        )
        return out

    def adjoint(y: NDArray[np.float64]) -> NDArray[np.float64]:
        out: NDArray[np.float64] = np.asarray(matrix.T @ radial_spread(y, layout).ravel())
        return out

    k = len(change)
    # A small ridge keeps the normal matrix definite where the constraints are dependent (a
    # point set barely larger than the payload).
    ones = np.ones(k) / np.sqrt(k)
    ridge = 1e-9 * float(np.linalg.norm(forward(adjoint(ones) / cost)))
    gram = LinearOperator(
        (k, k), matvec=lambda y: forward(adjoint(y) / cost) + ridge * y, dtype=np.float64
    )
    y, _ = cg(gram, change, rtol=1e-10, maxiter=400)
    return adjoint(y) / cost


def radial_size(n_bits: int) -> int:
    """The smallest size of :data:`meshwm.readers.radial.RADIAL_SIZES` with 3 slots per bit.

    Examples
    --------
    >>> radial_size(256), radial_size(1024)
    (128, 256)
    """
    for n in RADIAL_SIZES:
        if 3 * (n >> RADIAL_LEVEL) ** 2 >= _SLOTS_PER_BIT * n_bits:
            return n
    return RADIAL_SIZES[-1]


def radial_read(
    vertices: NDArray, faces: NDArray, n_bits: int, *, key: str | bytes, n: int = RADIAL_SIZE
) -> tuple[NDArray[np.uint8], NDArray[np.float64], Pose]:
    """Bits and confidences of the radial carrier through the mesh's first pose."""
    points = point_set(vertices, faces).points
    pose = point_poses(points)[0]
    sampling = sphere_sampling(points, pose, n)
    layout = radial_layout(n, key, n_bits)
    bits, confidence = read_radial_bits(radial_projections(sampling.image, layout), layout)
    return bits, confidence, pose


def embed_radial(
    vertices: NDArray,
    faces: NDArray,
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    n: int = RADIAL_SIZE,
    step: float = RADIAL_STEP,
    passes: int = RADIAL_PASSES,
    read_back: bool = True,
) -> RadialMark:
    """Carry ``bits`` in the spherical image of a mesh's vertices (see the module notes).

    Parameters
    ----------
    vertices : (n, 3) array_like
    faces : (m, 3) array_like of int
    bits : (k,) uint8 ndarray
    key : str or bytes
    n : int, optional
        The spherical image's size.
    step : float, optional
        The projections' quantisation step (radius units).
    passes : int, optional
        Most passes after the first (a pass whose changes are all within a hundredth of
        ``step`` is the last).
    read_back : bool, optional
        Read the moved mesh back for the report's ``radial_ber`` (a caller that moves it
        further and reads it itself does without).

    Returns
    -------
    RadialMark
        All input vertices at one position move together; a vertex no face uses stays.
    """
    v = np.array(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    bits = np.asarray(bits, dtype=np.uint8)
    ps = point_set(v, f)
    used = ps.of_vertex >= 0
    pf = ps.of_vertex[f]
    layout = radial_layout(n, key, len(bits))
    points = ps.points.copy()
    target = None
    done = 0
    for done in range(1 + int(passes)):
        pose = point_poses(points)[0]
        sampling = sphere_sampling(points, pose, n, neighbours=8)
        proj = radial_projections(sampling.image, layout)
        if target is None:
            target = proj + lattice_change(proj, bits, layout, step=step)
        cost = _costs(points, pf, sampling.directions)
        change = target - proj
        delta = _solve(sampling, layout, cost, change)
        points = points + (delta * pose.scale)[:, None] * sampling.directions
        if done > 0 and float(np.abs(change).max()) <= _SETTLED * step:
            break
    v[used] = points[ps.of_vertex[used]]
    report: dict = {"radial_n": n, "radial_passes": done}
    if read_back:
        got, _, _ = radial_read(v, f, len(bits), key=key, n=n)
        report["radial_ber"] = float(np.mean(got != bits))
    return RadialMark(v, report)
