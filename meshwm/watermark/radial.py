"""The radial carrier on a mesh: bits into the spherical image of its vertices, and back.

The second carrier of a mesh kept as it is (:mod:`meshwm.profiles.radial` has the method): the
vertices move along their directions from the point set's centre, each bit's projection is
brought onto its lattice by the least-distortion move (a minimum-norm solution through the
sampling matrix of :mod:`meshwm.gim.sphere`) among the moves that keep the point set's centroid
and second moments, and so its pose, to first order; a second pass re-derives the pose from the
moved points, as a reader will, and checks that every projection sits on its lattice point.

Without that constraint the move shifted the pose it was made in (igea: by 5e-6 of its radius),
which moved the projections by half their change again; three more passes chased it (changes
of 1.0e-3, 4.8e-4, 2.2e-5 and 2.3e-9 radius units at a step of 2e-3), and where the pose kept
moving they did not settle (fandisk, igea: a bit wrong read back on their own; human_neutral's
pose turned).  Kept, the pose moves by the square of the move (1e-9), one move settles every
development mesh, and each reads back at full confidence.
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
#: A pass that finds no projection more than this many steps off its lattice point moves
#: nothing and is the last (the moves keep the pose to first order: one move is enough on every
#: development mesh, see the module notes).
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


def _moments(sampling: SphereSampling) -> NDArray[np.float64]:
    """(9, p): the first-order changes of the point set's centroid (3) and second moments (6)
    under radial moves of ``delta`` radius units, each row of unit norm.

    A point at ``c + r u`` moved to ``c + (r + t) u`` moves the centroid by ``t u / p`` and the
    second moments by ``2 t r u uᵀ / p`` (to first order, the centroid kept), so the moves that
    keep these nine sums keep the pose (its centre, axes and scale) to first order.
    """
    u = sampling.directions
    r = sampling.radii
    rows = [u[:, a] for a in range(3)]
    rows += [r * u[:, a] * u[:, b] for a in range(3) for b in range(a, 3)]
    out = np.stack(rows)
    return out / np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-300)


def _solve(
    sampling: SphereSampling,
    layout: RadialLayout,
    cost: NDArray[np.float64],
    change: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The least-cost radial moves (radius units) that change the projections by ``change``
    and keep the pose (:func:`_moments`)."""
    matrix = sampling.matrix
    n = layout.n
    keep = _moments(sampling)
    k = len(change)

    # The products with ``keep`` are einsum's, not BLAS's (``keep @ delta``, ``y @ keep``):
    # BLAS splits a long product between its threads, which changes its sums' rounding, and
    # the marked mesh (igea's, 134k vertices) came out other on a machine with other cores.
    def forward(delta: NDArray[np.float64]) -> NDArray[np.float64]:
        proj = radial_projections(np.asarray(matrix @ delta).reshape(n, n), layout)
        return np.concatenate([proj, np.einsum("ij,j->i", keep, delta)])

    def adjoint(y: NDArray[np.float64]) -> NDArray[np.float64]:
        out: NDArray[np.float64] = np.asarray(matrix.T @ radial_spread(y[:k], layout).ravel()) + (
            np.einsum("i,ij->j", y[k:], keep)
        )
        return out

    m = k + len(keep)
    # A small ridge keeps the normal matrix definite where the constraints are dependent (a
    # point set barely larger than the payload).
    ones = np.ones(m) / np.sqrt(m)
    ridge = 1e-9 * float(np.linalg.norm(forward(adjoint(ones) / cost)))
    gram = LinearOperator(
        (m, m), matvec=lambda y: forward(adjoint(y) / cost) + ridge * y, dtype=np.float64
    )
    y, _ = cg(gram, np.concatenate([change, np.zeros(len(keep))]), rtol=1e-10, maxiter=400)
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
        Most passes after the first (a pass that finds every change within a hundredth of
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
        change = target - proj
        if done > 0 and float(np.abs(change).max()) <= _SETTLED * step:
            break  # what is left is a hundredth of a step: not worth a move
        cost = _costs(points, pf, sampling.directions)
        delta = _solve(sampling, layout, cost, change)
        points = points + (delta * pose.scale)[:, None] * sampling.directions
    v[used] = points[ps.of_vertex[used]]
    report: dict = {"radial_n": n, "radial_passes": done}
    if read_back:
        got, _, _ = radial_read(v, f, len(bits), key=key, n=n)
        report["radial_ber"] = float(np.mean(got != bits))
    return RadialMark(v, report)
