"""A canonical pose, so that the remesh of a moved mesh is the moved remesh.

The remesh (:func:`meshwm.gim.remesh.mesh_to_geometry_image`) is invariant to similarities in
exact arithmetic, but it makes discrete choices (cut paths, corners, reweighting) whose near-ties
a rotation's rounding can flip: a random similarity changed its output on 13 of 17 meshes.
Here the mesh is first brought into a pose computed from its own surface: area centroid at the
origin, principal axes of the surface's second moments as the coordinate axes (largest first,
each pointing to the side of positive third moment, right-handed), unit RMS radius; then its
coordinates are snapped to a grid.  Two copies of one mesh in different poses thus give
canonical coordinates that are bit-identical or one grid step apart (a pose far from the origin
costs digits: translation ±100 at scale 0.01 leaves ~1e-12 of the radius).

The remesh runs on those coordinates.  A shape whose distances to its centre tie in pairs (a
rotation or a mirror maps it onto itself: the genus-8 plate) has choices that are exact ties,
which those last digits would decide; it is remeshed as its :func:`canonical_mesh` instead: the
coordinates snapped to :data:`REMESH_SNAP` (2⁻²⁴ of the RMS radius, far above those digits, so
that two poses give the same numbers but where a coordinate lies within ~1e-12 of a grid
line), the vertices numbered by their snapped coordinates, the faces in an order of their own,
the frame's signs from its two strongest third moments.  Two poses then hand the remesh the
same arrays, and every choice it makes (a cut path, a corner, a chain's grid steps) is the same
choice, exact ties included; a shape that a rotation maps onto itself gets the same arrays in
both of the frames it can be given.  The remesh's samples are taken back to the input's pose.

A shape whose principal moments (nearly) coincide, or whose third moment along an axis is
(nearly) zero, has no well-defined frame; there the pose is still a similarity, and the remesh is
as stable as it was without it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._vector import _columns, face_area
from meshwm.mesh.edges import canonical_faces

__all__ = ["REMESH_SNAP", "SNAP", "CanonicalMesh", "Pose", "canonical_mesh", "canonical_pose"]

#: Grid the canonical coordinates are snapped to, in units of the RMS radius.
SNAP = 2.0**-40
#: Grid of the remesh's coordinates (:func:`canonical_mesh`), in units of the RMS radius: a
#: move of at most 3e-8 of the radius, far below the remesh's own error (0.2-0.9 % of the
#: diagonal), far above what a pose's rounding leaves.
REMESH_SNAP = 2.0**-24
#: Faces at a time in :func:`canonical_pose`'s sums.
_POSE_CHUNK = 1 << 16


class Pose(NamedTuple):
    """A similarity ``canonical = (x - centre) @ rotation / scale``.

    Attributes
    ----------
    centre : (3,) float64 ndarray
    rotation : (3, 3) float64 ndarray
        Orthonormal, determinant +1; its columns are the principal axes.
    scale : float
    """

    centre: NDArray[np.float64]
    rotation: NDArray[np.float64]
    scale: float

    def forward(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Input pose to canonical coordinates, snapped to :data:`SNAP`."""
        return self.snap(points, SNAP)

    def snap(self, points: NDArray[np.float64], grid: float) -> NDArray[np.float64]:
        """Input pose to canonical coordinates, snapped to ``grid`` (RMS-radius units)."""
        canonical = (np.asarray(points, dtype=np.float64) - self.centre) @ self.rotation
        return np.round(canonical / (self.scale * grid)) * grid

    def inverse(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Canonical coordinates back to the input's pose."""
        return (np.asarray(points, dtype=np.float64) * self.scale) @ self.rotation.T + self.centre


def canonical_pose(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], *, strongest: bool = False
) -> Pose:
    """The pose of a triangle mesh's surface (see the module notes).

    Parameters
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
    strongest : bool, optional
        Orient the two axes with the largest third moments (in magnitude) by their signs and
        the third by right-handedness, instead of the first two axes.  A shape that a mirror
        or a half turn maps onto itself has no third moment along the axes it reverses, whose
        signs rounding would otherwise pick: then the frames a pose can get are the shape's
        own symmetries (:func:`canonical_mesh`).

    Returns
    -------
    Pose

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [4, 0, 0], [0, 1, 0], [0, 0, 0.5]])
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> pose = canonical_pose(v, f)
    >>> bool(np.allclose(pose.inverse(pose.forward(v)), v, atol=1e-8))
    True
    """
    v = np.asarray(vertices, dtype=np.float64)
    rough = v.mean(axis=0)  # far from the origin, subtract first: the moments stay accurate
    f = np.asarray(faces, dtype=np.int64)
    moved = v - rough
    area = face_area(moved, f)
    total = float(area.sum())
    if not total > 0:
        return Pose(rough, np.eye(3), 1.0)
    weight = area / total
    # The moments a chunk of faces and a coordinate at a time (the (m, 3, 3) corner arrays
    # were 0.7 GB each at 10M faces, 8.7 s): sums over each chunk by numpy's pairwise sum,
    # chunk after chunk, the same bits whatever the machine.
    columns = _columns(moved)
    offset = np.zeros(3)
    for lo in range(0, len(f), _POSE_CHUNK):
        corner = _columns(f[lo : lo + _POSE_CHUNK])
        w = weight[lo : lo + _POSE_CHUNK]
        for d in range(3):
            c = columns[d]
            offset[d] += np.sum(w * (c[corner[0]] + c[corner[1]] + c[corner[2]]))
    offset /= 3.0
    centre = rough + offset
    # Exact second moment of each triangle (uniform density): (Σ xᵢxⱼ + (Σx)(Σx)ᵀ) / 12.
    second = np.zeros((3, 3))
    sums = np.empty((len(f), 3))  # each face's corners summed, relative to the centre
    for lo in range(0, len(f), _POSE_CHUNK):
        corner = _columns(f[lo : lo + _POSE_CHUNK])
        w = weight[lo : lo + _POSE_CHUNK]
        rel = [[columns[d][k] - offset[d] for k in corner] for d in range(3)]
        s = [rel[d][0] + rel[d][1] + rel[d][2] for d in range(3)]
        sums[lo : lo + len(w)] = np.stack(s, axis=1)
        for i in range(3):
            for j in range(i, 3):
                corners = rel[i][0] * rel[j][0] + rel[i][1] * rel[j][1] + rel[i][2] * rel[j][2]
                second[i, j] += np.sum(w * (corners + s[i] * s[j]))
    second = np.triu(second) + np.triu(second, 1).T
    second /= 12.0
    values, axes = np.linalg.eigh(second)
    axes = axes[:, ::-1]
    scale = float(np.sqrt(max(values.sum(), np.finfo(float).tiny)))
    # Signs: positive third moment along the first two axes (vertex centroids of the faces,
    # area-weighted, suffice to orient them), the third by right-handedness.
    mid = (sums / 3.0) @ axes
    third = np.sum(weight[:, None] * (mid * mid * mid), axis=0)  # not ``**3``: libm's pow
    oriented = np.argsort(-np.abs(third), kind="stable")[:2] if strongest else np.arange(2)
    for k in oriented:
        if third[k] < 0:
            axes[:, k] = -axes[:, k]
    if np.linalg.det(axes) < 0:
        last = int(np.setdiff1d(np.arange(3), oriented)[0])
        axes[:, last] = -axes[:, last]
    return Pose(centre, axes, scale)


class CanonicalMesh(NamedTuple):
    """A mesh in its canonical pose, numbered by its own coordinates (:func:`canonical_mesh`).

    Attributes
    ----------
    pose : Pose
    vertices : (n, 3) float64 ndarray
        Canonical coordinates, snapped, in lexicographic order.
    faces : (m, 3) int64 ndarray
        The faces over them (winding kept), each from its smallest vertex, in lexicographic
        order.
    order : (n,) int64 ndarray
        The input vertex of each canonical vertex.
    fine : (n, 3) float64 ndarray
        The same vertices snapped to :data:`SNAP` only: where the remesh takes its samples
        (``vertices`` within half a grid step of them).
    """

    pose: Pose
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    order: NDArray[np.int64]
    fine: NDArray[np.float64]


def canonical_mesh(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    grid: float = REMESH_SNAP,
    pose: Pose | None = None,
) -> CanonicalMesh:
    """A mesh in its canonical pose, snapped to ``grid`` and numbered by its coordinates.

    The arrays depend on the shape alone, not on its pose, scale or element order (but where a
    coordinate lies within a pose's rounding of a grid line; see the module notes).  Where the
    snap would make two vertices coincide or a face lose its area, the coordinates are snapped
    to :data:`SNAP` instead (a mesh with detail below ``grid``).

    Parameters
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
        A cleaned mesh (distinct vertices, faces of nonzero area).
    grid : float, optional
        The snap, in units of the RMS radius.
    pose : Pose, optional
        The pose to use (default ``canonical_pose(vertices, faces, strongest=True)``).

    Returns
    -------
    CanonicalMesh

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [4, 0, 0], [0, 1, 0], [0, 0, 0.5]])
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> a = canonical_mesh(v, f)
    >>> b = canonical_mesh(v[::-1] * 3 + 7, (3 - f)[::-1])
    >>> bool(np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces))
    True
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    pose = canonical_pose(v, f, strongest=True) if pose is None else pose
    snapped, order = _numbered(pose.snap(v, grid))
    if grid != SNAP and _collapses(snapped, order, f):
        snapped, order = _numbered(pose.snap(v, SNAP))
    label = np.empty_like(order)
    label[order] = np.arange(len(order))
    return CanonicalMesh(
        pose, snapped[order], canonical_faces(f, label), order, pose.forward(v)[order] + 0.0
    )


def _numbered(
    snapped: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The points (``-0.0`` made ``0.0``: a coordinate that rounds to zero from either side is
    one number) and their lexicographic order."""
    snapped = snapped + 0.0
    return snapped, np.lexsort(snapped.T[::-1]).astype(np.int64)


def _collapses(
    points: NDArray[np.float64], order: NDArray[np.int64], faces: NDArray[np.int64]
) -> bool:
    """Whether two of ``points`` coincide (neighbours in their lexicographic ``order``) or a
    face has no area."""
    ranked = points[order]
    if np.any(np.all(ranked[1:] == ranked[:-1], axis=1)):
        return True
    return bool(np.any(face_area(points, faces) == 0))
