"""A mesh's exact rotational symmetries: what no reader that ignores vertex order can undo.

A reader is *stable* when the image it re-derives from a moved copy, taken back by the move,
is the image of the input (issue 13: 20 random similarities give the same image to 1e-9 of
the diagonal).  A mesh that a rotation ``ρ`` about its centroid maps onto itself (every vertex
onto a vertex, every face onto a face) sets a bound on that for *any* reader that uses the
received mesh alone.  The similarities ``S`` and ``S ρ`` give the same mesh, up to the order
of its vertices and faces, so such a reader returns one image ``A`` for both; taken back, that
is ``S⁻¹ A`` for the one and ``ρ⁻¹ S⁻¹ A`` for the other, and both can be the input's image
only if that image is unchanged by ``ρ``, which no surface's image is (its samples would all
lie on the axis).  A uniformly random rotation is as likely to be ``S`` as ``S ρ``, so with a
group of ``k`` such rotations at most ``1/k`` of random similarities can give the input's
image: what is left to ask is that the image be the input's *up to the mesh's own symmetry*,
one of the ``k`` images a reader cannot tell apart, as the mesh cannot.

:func:`proper_symmetries` finds them among the rotations the mesh's principal axes allow.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from meshwm.mesh.edges import canonical_faces
from meshwm.metrics import bounding_box_diagonal

__all__ = ["proper_symmetries", "random_similarity", "up_to_symmetry"]

#: Two principal moments closer than this (relative to the largest) are tied: rotations about
#: the third axis by ``2π/k`` are tried.
_TIE = 1e-9
#: The turns ``k`` tried about an axis whose other two moments are tied.
_TURNS = (3, 4, 5, 6, 8, 12)


def _rotation(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    """Rodrigues' rotation matrix about a unit ``axis``."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def proper_symmetries(
    vertices: NDArray, faces: NDArray, *, tol: float = 1e-9
) -> list[NDArray[np.float64]]:
    """The rotations about the vertex centroid that map a mesh onto itself.

    Parameters
    ----------
    vertices : (n, 3) array_like
    faces : (m, 3) array_like of int
    tol : float, optional
        Largest distance, over the bounding-box diagonal, between a rotated vertex and the
        vertex it lands on.

    Returns
    -------
    list of (3, 3) float64 ndarray
        Rotation matrices ``R`` (``x ↦ c + R (x - c)``, ``c`` the vertex centroid), the
        identity first, under which every vertex lands on a distinct vertex and the faces (with
        their winding) are the faces.  Tried: the half turns about the principal axes of the
        vertices' second moments (an exact symmetry keeps the centroid and those moments), and
        where two moments are tied (within ``1e-9`` of the largest), the turns by ``2π/k``
        about the third axis for k in 3, 4, 5, 6, 8 and 12 (other symmetries of a mesh with
        tied moments, a cube's quarter turns about the other axes, are not looked for).

    Examples
    --------
    >>> from meshwm.apps.bench.synthetic import make
    >>> v, f = make("genus8")  # the plate's half turn about its normal
    >>> len(proper_symmetries(v, f)), len(proper_symmetries(*make("genus8_jittered")))
    (2, 1)
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    centre = v.mean(axis=0)
    rel = v - centre
    diag = bounding_box_diagonal(v)
    values, axes = np.linalg.eigh(rel.T @ rel / len(rel))
    values, axes = values[::-1], axes[:, ::-1]
    candidates = [_rotation(axes[:, i], np.pi) for i in range(3)]
    for i, j, other in ((0, 1, 2), (1, 2, 0)):
        if values[i] - values[j] <= _TIE * values[0]:
            candidates += [
                _rotation(axes[:, other], 2 * np.pi * m / k) for k in _TURNS for m in range(1, k)
            ]
    tree = cKDTree(rel)
    labels = np.arange(len(v))
    own = canonical_faces(f, labels)
    found = [np.eye(3)]
    for r in candidates:
        if any(np.allclose(r, g, atol=1e-9) for g in found):
            continue
        # Bounded: a rotated vertex with no vertex near it ends the search at once.
        dist, lands = tree.query(rel @ r.T, distance_upper_bound=tol * diag)
        if not np.isfinite(dist).all() or len(np.unique(lands)) != len(v):
            continue
        if np.array_equal(canonical_faces(lands[f], labels), own):
            found.append(r)
    return found


def up_to_symmetry(
    got: NDArray[np.float64],
    image: NDArray[np.float64],
    rotations: list[NDArray[np.float64]],
    centre: NDArray[np.float64],
) -> float:
    """The largest difference of ``got`` from the nearest of ``image``'s turns.

    Parameters
    ----------
    got, image : (..., 3) float64 ndarray
        Two images of positions (NaN where not covered: left out).
    rotations : list of (3, 3) ndarray
        From :func:`proper_symmetries`.
    centre : (3,) ndarray
        The rotations' centre (the vertex centroid).

    Returns
    -------
    float
        ``min over R of max |got - (centre + R (image - centre))|`` over the samples both
        cover (``inf`` where they cover different samples).

    Examples
    --------
    >>> half = np.diag([-1.0, -1.0, 1.0])
    >>> im = np.array([[1.0, 2.0, 3.0], [0.0, 1.0, 0.0]])
    >>> up_to_symmetry(im @ half.T, im, [np.eye(3), half], np.zeros(3))
    0.0
    """
    covered = np.isfinite(got).all(axis=-1)
    if not np.array_equal(covered, np.isfinite(image).all(axis=-1)) or not covered.any():
        return float("inf")
    a, b = got[covered], image[covered]
    # The identity compares the images as they are (no round trip through the centre).
    turned = [b if np.array_equal(r, np.eye(3)) else centre + (b - centre) @ r.T for r in rotations]
    return min(float(np.abs(a - t).max()) for t in turned)


def random_similarity(
    rng: np.random.Generator, vertices: NDArray, faces: NDArray
) -> tuple[
    NDArray[np.float64],
    NDArray[np.int64],
    NDArray[np.float64],
    Callable[[NDArray[np.float64]], NDArray[np.float64]],
]:
    """A random similarity of a mesh, its vertices and faces shuffled (issue 13's stability
    trials): a uniformly random rotation, scale 0.01-100, translation ±100.

    Returns
    -------
    moved : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
        The faces over ``moved``, in a random order.
    rotation : (3, 3) float64 ndarray
    back : callable
        Points of the moved pose taken back to the input's.

    Examples
    --------
    >>> v = np.eye(3)
    >>> mv, mf, q, back = random_similarity(np.random.default_rng(0), v, np.array([[0, 1, 2]]))
    >>> bool(np.allclose(np.sort(back(mv), axis=0), np.sort(v, axis=0)))
    True
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    scale = 10.0 ** rng.uniform(-2, 2)
    shift = rng.uniform(-100, 100, 3)
    perm = rng.permutation(len(v))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(v))
    moved = (scale * v @ q.T + shift)[perm]
    moved_faces = inverse[f][rng.permutation(len(f))]

    def back(x: NDArray[np.float64]) -> NDArray[np.float64]:
        out: NDArray[np.float64] = ((x - shift) / scale) @ q
        return out

    return moved, moved_faces, q, back
