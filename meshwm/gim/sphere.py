"""A spherical geometry image of a mesh's vertices: their distance to the centre, by direction.

The surface map (:mod:`meshwm.gim.surface`) is made of the mesh's connectivity, so an edit of
the connectivity that moves no vertex (flipped edges, quads split the other way, what clean-up
tools and exporters do) moves that map.  This image is made of the *point set* alone: the
distinct positions of the vertices the faces use, brought into a pose of their own (centroid,
principal axes, third-moment signs, RMS radius) and seen from the centroid.  Each pixel of an
N×N octahedral map of the directions (Praun & Hoppe's spherical geometry images unfold the
sphere onto a square the same way) holds a weighted mean of the radii of the nearest vertex
directions, each weighed by a Gaussian of its distance less the Gaussian of the first direction
left out, so that a direction's weight falls to zero as it leaves the pixel's neighbours and the
image is continuous in the points (a tiny move that swaps the last neighbour and the next one
moves no sample; with a weight that stayed positive at the last, a shape that is not
star-shaped around its centre, the bunny's ears or fertility's handles, jumped by the
difference of two layers' radii, and 16-bit quantisation already left the radial carrier's
id unread there).  A connectivity edit, a vertex order, a seam split or weld and an STL soup
leave the point set, and so the image, exactly as they were; a similarity leaves it the same
to rounding.

Moving a vertex along its direction from the centre changes its radius and nothing else the
weights depend on, so ``image = matrix @ radii`` is exactly linear in such moves
(:class:`SphereSampling`): the embedder carries a change of the image onto the vertices by
least squares through ``matrix`` (:mod:`meshwm.watermark.radial`).

Near-ties
---------
A pose is a choice, and near-ties in it are hypotheses for a reader, not errors: where an axis's
third moment is (nearly) zero (a mirror-symmetric model: human_neutral, plane_holes), both of its
directions are offered; where two principal moments (nearly) coincide (camelhead's are 0.8 %
apart), the two axes are oriented in their plane by the strongest of the third and fourth
circular moments, and each of its 3 or 4 turns is offered.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic".
.. [2] E. Praun, H. Hoppe, "Spherical parametrization and remeshing", ACM SIGGRAPH 2003.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from meshwm.errors import MeshError
from meshwm.gim.pose import SNAP, Pose
from meshwm.mesh.edges import _hashed_groups, unique_rows

__all__ = [
    "GAP_MARGIN",
    "SIGN_MARGIN",
    "SPHERE_NEIGHBOURS",
    "PointSet",
    "SphereSampling",
    "octahedral_directions",
    "point_count",
    "point_poses",
    "point_set",
    "sphere_sampling",
]

#: Vertex directions each pixel averages.
SPHERE_NEIGHBOURS = 8
#: An axis whose normalised third moment ``|E x³| / E[x²]^1.5`` is under this has no sign of
#: its own: both are offered.
SIGN_MARGIN = 0.02
#: Two principal moments closer than this (relative to the largest) are a near-tie: their axes
#: are oriented by a circular moment instead.
GAP_MARGIN = 0.02
#: A circular moment weaker than this (relative to ``E |z|^k``) orients nothing.
_CIRCULAR_MARGIN = 0.02


class PointSet(NamedTuple):
    """The distinct positions of the vertices a mesh's faces use.

    Attributes
    ----------
    points : (p, 3) float64 ndarray
        Sorted rows (``numpy.unique``): the same for any vertex or face order, any duplicate
        vertices and any connectivity.
    of_vertex : (n,) int64 ndarray
        The point of each input vertex, -1 for a vertex no face uses.
    """

    points: NDArray[np.float64]
    of_vertex: NDArray[np.int64]


def point_set(vertices: NDArray, faces: NDArray) -> PointSet:
    """The point set of a mesh (see :class:`PointSet`).

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [5, 5, 5]])
    >>> ps = point_set(v, np.array([[0, 1, 2], [0, 3, 2]]))
    >>> len(ps.points), ps.of_vertex.tolist()
    (3, [0, 2, 1, 2, -1])
    """
    v = np.asarray(vertices, dtype=np.float64)
    used = np.zeros(len(v), dtype=bool)
    used[np.asarray(faces, dtype=np.int64).ravel()] = True
    # + 0.0 turns -0.0 into 0.0: one position, one point.
    x = v[used] + 0.0
    first, inverse = unique_rows(x)  # as np.unique(axis=0): the points in sorted order
    index = np.full(len(v), -1, dtype=np.int64)
    index[used] = inverse
    return PointSet(x[first], index)


def point_count(vertices: NDArray, faces: NDArray) -> int:
    """``len(point_set(vertices, faces).points)`` without sorting the points (one hash of each
    row: 2.1M vertices, 0.2 s against 1 s).

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [-0.0, 0, 0]])
    >>> point_count(v, np.array([[0, 1, 2], [4, 3, 2]]))
    3
    """
    v = np.asarray(vertices, dtype=np.float64)
    used = np.zeros(len(v), dtype=bool)
    used[np.asarray(faces, dtype=np.int64).ravel()] = True
    first, _ = _hashed_groups(v[used] + 0.0)
    return len(first)


def _moments(rel: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Principal moments (decreasing) and axes (columns) of centred points."""
    values, axes = np.linalg.eigh(rel.T @ rel / len(rel))
    return values[::-1], axes[:, ::-1]


def _orient_pair(
    rel: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64]
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Axes of a near-tied pair, oriented in their plane by a circular moment: one per turn."""
    z = rel @ a + 1j * (rel @ b)
    best, best_k = 0.0, 0
    for k in (3, 4):
        strength = abs(np.mean(z**k)) / max(float(np.mean(np.abs(z) ** k)), 1e-300)
        if strength > best:
            best, best_k = strength, k
    if best < _CIRCULAR_MARGIN:  # turned about freely: no orientation to find
        return [(a, b)]
    theta = np.angle(np.mean(z**best_k)) / best_k
    out = []
    for j in range(best_k):
        t = theta + 2 * np.pi * j / best_k
        out.append((np.cos(t) * a + np.sin(t) * b, -np.sin(t) * a + np.cos(t) * b))
    return out


def point_poses(points: NDArray[np.float64]) -> list[Pose]:
    """The canonical pose of a point set, and the others its near-ties allow.

    Parameters
    ----------
    points : (p, 3) float64 ndarray
        At least 4 points, not all in a plane.

    Returns
    -------
    list of Pose
        ``canonical = (x - centre) @ rotation / scale``: centroid at the origin, principal axes
        (largest moment first) as the coordinate axes, each pointing to the side of positive
        third moment, right-handed, unit RMS radius.  The first is the pose a mesh without
        near-ties has; the others (if any) differ where an axis's sign or a pair's orientation
        is a near-tie (see the module notes).

    Raises
    ------
    MeshError
        Fewer than 4 points, or all of them in a plane or on a line.

    Examples
    --------
    >>> p = np.array([[0.0, 0, 0], [4, 0, 0], [0, 1, 0], [0, 0, 0.5], [1, 1, 1]])
    >>> poses = point_poses(p)
    >>> len(poses), bool(np.allclose(poses[0].rotation.T @ poses[0].rotation, np.eye(3)))
    (1, True)
    """
    pts = np.asarray(points, dtype=np.float64)
    if len(pts) < 4:
        raise MeshError(f"a pose needs at least 4 distinct vertices, got {len(pts)}")
    rough = pts.mean(axis=0)
    offset = (pts - rough).mean(axis=0)
    centre = rough + offset
    rel = pts - centre
    values, axes = _moments(rel)
    if not values[2] > 1e-12 * values[0]:
        raise MeshError("the vertices lie in a plane or on a line: no pose")
    scale = float(np.sqrt(values.sum()))
    # Near-tied pairs are oriented by a circular moment (the larger pair first).
    frames: list[NDArray[np.float64]] = [axes]
    for i in (0, 1):
        if values[i] - values[i + 1] < GAP_MARGIN * values[0]:
            frames = [
                _replace_pair(f, i, pair)
                for f in frames
                for pair in _orient_pair(rel, f[:, i], f[:, i + 1])
            ]
            break  # a triple near-tie (a ball) has no second pair to orient
    poses: list[Pose] = []
    for frame in frames:
        for signed in _signings(rel, frame, values):
            if not any(np.allclose(signed, p.rotation, atol=1e-9) for p in poses):
                poses.append(Pose(centre, signed, scale))
    return poses


def _replace_pair(
    frame: NDArray[np.float64], i: int, pair: tuple[NDArray[np.float64], NDArray[np.float64]]
) -> NDArray[np.float64]:
    out = frame.copy()
    out[:, i], out[:, i + 1] = pair
    return out


def _signings(
    rel: NDArray[np.float64], frame: NDArray[np.float64], values: NDArray[np.float64]
) -> list[NDArray[np.float64]]:
    """The frame's sign choices: positive third moments, both signs where it is a near-tie."""
    along = rel @ frame
    # Cubed by two products, not ``**3`` (libm's pow: 0.17 s a pose at 0.5M points, against
    # 6 ms); the moments differ in their last bits, which only their signs and the margin use.
    third = np.mean(along * along * along, axis=0) / np.maximum(values, 1e-300) ** 1.5
    choices: list[tuple[float, ...]] = [()]
    for k in range(2):
        own = 1.0 if third[k] >= 0 else -1.0
        opts = (own,) if abs(third[k]) >= SIGN_MARGIN else (own, -own)
        choices = [(*c, s) for c in choices for s in opts]
    out = []
    for s0, s1 in choices:
        f = frame.copy()
        f[:, 0] *= s0
        f[:, 1] *= s1
        f[:, 2] = np.cross(f[:, 0], f[:, 1])
        out.append(f)
    return out


def octahedral_directions(n: int) -> NDArray[np.float64]:
    """Unit directions of the N×N pixel centres of the octahedral map, row-major.

    The square ``[-1, 1]²`` is the octahedron ``|x| + |y| + |z| = 1`` unfolded: its inner
    diamond is the upper half (z ≥ 0), its four corners fold onto the lower half.

    Examples
    --------
    >>> d = octahedral_directions(4)
    >>> d.shape, bool(np.allclose(np.linalg.norm(d, axis=1), 1))
    ((16, 3), True)
    """
    g = (np.arange(n, dtype=np.float64) + 0.5) / n * 2.0 - 1.0
    u, v = np.meshgrid(g, g)  # u along a row (j), v down the rows (i)
    z = 1.0 - np.abs(u) - np.abs(v)
    x, y = u.copy(), v.copy()
    low = z < 0
    x[low] = (1.0 - np.abs(v[low])) * np.sign(u[low])
    y[low] = (1.0 - np.abs(u[low])) * np.sign(v[low])
    d = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


class SphereSampling(NamedTuple):
    """A point set seen from its centre through a pose, on the N×N octahedral grid.

    Attributes
    ----------
    matrix : (N², p) scipy.sparse.csr_matrix
        Row ``i * N + j`` weighs the radii of the pixel's nearest vertex directions; rows sum
        to 1.  ``(matrix @ radii).reshape(N, N)`` is the image.
    radii : (p,) float64 ndarray
        Each point's distance to the centre, in units of the pose's RMS radius.
    directions : (p, 3) float64 ndarray
        Each point's unit direction in the input's frame (a radial move of ``t`` radius units
        is ``t * scale * directions``).
    pose : Pose
    """

    matrix: sp.csr_matrix
    radii: NDArray[np.float64]
    directions: NDArray[np.float64]
    pose: Pose

    @property
    def n(self) -> int:
        """The grid size N."""
        return round(np.sqrt(self.matrix.shape[0]))

    @property
    def image(self) -> NDArray[np.float64]:
        """(N, N) float64: the radius image."""
        return np.asarray(self.matrix @ self.radii).reshape(self.n, self.n)


def sphere_sampling(
    points: NDArray[np.float64], pose: Pose, n: int, *, neighbours: int = SPHERE_NEIGHBOURS
) -> SphereSampling:
    """The radius image of a point set through ``pose`` (see the module notes).

    Parameters
    ----------
    points : (p, 3) float64 ndarray
    pose : Pose
        From :func:`point_poses`.
    n : int
        Grid size N (>= 2).
    neighbours : int, optional
        Vertex directions averaged per pixel (the nearest ``k``, by chord), weighted by
        ``g(d) - g(d_next)``, ``g(d) = exp(-d² / 2h²)`` with ``h`` the larger of the pixel's
        angular size and the nearest direction's distance and ``d_next`` the distance of the
        nearest direction left out: a weight vanishes as its direction leaves the ``k``
        nearest, so the image is continuous in the points.  A pixel whose ``k + 1`` nearest
        are all at one distance (an exact tie, no continuity to keep) weighs them by ``g``;
        a point set of ``k`` directions or fewer, all of them by ``g``.

    Returns
    -------
    SphereSampling

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> p = rng.normal(size=(500, 3))
    >>> p = p / np.linalg.norm(p, axis=1, keepdims=True) * [1, 2, 3]
    >>> s = sphere_sampling(p, point_poses(p)[0], 16)
    >>> s.image.shape, bool(np.allclose(s.matrix.sum(axis=1), 1))
    ((16, 16), True)
    """
    pts = np.asarray(points, dtype=np.float64)
    canonical = pose.forward(pts)  # snapped: a similarity gives the same numbers
    radius = np.linalg.norm(canonical, axis=1)
    live = radius > 16 * SNAP
    unit = np.zeros_like(canonical)
    unit[live] = canonical[live] / radius[live, None]
    grid = octahedral_directions(n)
    count = int(live.sum())
    if count < 1:
        raise MeshError("every vertex is at the centre: no spherical image")
    k = int(min(neighbours, count))
    # One more than the neighbours kept: its Gaussian is each weight's floor.
    query = k + 1 if count > k else k
    rows = np.flatnonzero(live)
    # A sliding-midpoint tree: the same exact neighbours, built in 40 % of the time of a
    # balanced one (5M directions: 1.7 s against 4.4 s); it serves one query of N² pixels,
    # so leaves of 32 points (half the nodes to build; 537k directions: 0.105 → 0.069 s,
    # the query 0.03 s either way).
    # Each pixel's query is its own: split between two threads, the same neighbours (igea at
    # 134k vertices, N = 128: 28 -> 19 ms).
    tree = cKDTree(unit[rows], leafsize=32, balanced_tree=False, compact_nodes=False)
    dist, nearest = tree.query(grid, k=query, workers=2)
    dist = dist.reshape(len(grid), query)
    nearest = rows[nearest.reshape(len(grid), query)[:, :k]]
    pixel = np.sqrt(4.0 * np.pi) / n
    width = np.maximum(pixel, dist[:, :1])
    gauss = np.exp(-0.5 * (dist / width) ** 2)
    weight = gauss[:, :k]
    if query > k:
        tapered = weight - gauss[:, k:]
        total = tapered.sum(axis=1)
        # An exact tie of all k + 1 (a ring of directions around the pixel) leaves nothing:
        # the Gaussian alone, as the tie makes any choice of k as good as another.
        tied = total <= 1e-12 * weight.sum(axis=1)
        weight = np.where(tied[:, None], weight, tapered)
    weight = weight / weight.sum(axis=1, keepdims=True)
    matrix = sp.csr_matrix(
        (weight.ravel(), (np.repeat(np.arange(len(grid)), k), nearest.ravel())),
        shape=(len(grid), len(pts)),
    )
    world = unit @ pose.rotation.T  # unit directions back in the input's frame
    return SphereSampling(matrix, radius, world, pose)
