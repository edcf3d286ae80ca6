"""The crisp inputs of the fuzzy perceptual mask, computed from the level-1 approximation CA.

Section 3, steps 6-7 of the paper [1]_: "Compute Inputs (like Curvature, Area and Bumpiness) of
3d model" and "Apply inputs to Fuzzy Inference system (FIS) and decide weight".  The paper names
the three inputs and nothing else.  This module defines them on CA, the level-1 Haar
approximation of the geometry image (the x, y and z matrices stacked into an ``(M, M, 3)``
array).  CA is a coarse grid of 3-D points, read as the open grid mesh of
:func:`meshwm.gim.code.grid_faces` (seams not welded).  One level-3 coefficient covers a
square *block* of ``block × block`` CA samples (``block = 4``: 8×8 image samples), and every
input is one number per block.  The inputs therefore have the shape of a level-3 coefficient
matrix, ``(M // block, M // block)``.

Why CA
    The embedding changes level-3 coefficients of the CH and CV subtrees only, never CA.
    Extraction therefore sees the same CA, up to rounding, and recomputes the same mask without
    side information: the mask is blind.  The paper computes its inputs "of the 3d model" at
    both ends and does not say which model.  If they come from the marked mesh, the mask read
    back can differ from the one used to embed.  That may be why its model 3 reads back at a
    correlation of only 0.934571 with no attack at all (Table 4 of [1]_).
    After an attack CA changes too, and the inputs, being continuous, change with it only as
    much as the attack moves the surface.

The three inputs
    All three are computed on a copy of CA that is centred and scaled to unit size.  The size is
    ``L``, the RMS distance of the points to their centroid.  Curvature is then measured in
    units of ``1/L`` and area in units of ``L**2``.  Let ``N_v`` be the *unnormalised* vertex
    normal of CA vertex ``v``: the sum of the cross products ``(b - a) × (c - a)`` of its faces.
    Its direction is the area-weighted normal, and its length is twice the vector area around
    ``v``.

    ``curvature``
        The RMS of the principal curvatures (Koenderink's *curvedness* [2]_), measured at the
        scale of the block.  ``N_B``, the sum of ``N_v`` over a block, is the vector area of the
        block.  The unit normal turns between neighbouring blocks ``B`` and ``B'`` by the
        angle chord ``|n_B - n_B'|``.  Dividing by the distance ``d`` between the block
        centroids gives the normal curvature along that grid direction.  Over two orthonormal
        directions, ``|S t1|**2 + |S t2|**2 = k1**2 + k2**2`` for the shape operator ``S``.
        The input is therefore the square root of the mean of ``(|n_B - n_B'| / d)**2`` over
        the 2 to 4 neighbours of the block, each neighbour weighted by ``(|N_B| |N_B'|)**2``.
    ``area``
        The surface area of the block: the sum of its vertex areas, a third of the area of
        every incident face (:func:`igl.doublearea`).
    ``bumpiness``
        The normal variation at the finest scale: ``1 - n_u · n_v`` over the edges ``(u, v)``
        of the grid mesh in the block, weighted by ``|N_u| |N_v|``.  Each edge counts half in
        the block of each end.  This is 0 on a plane, about ``theta**2 / 2`` for normals
        ``theta`` radians apart, and at most 2.

    Curvature sees the shape at the scale of a coefficient; bumpiness sees the texture below it.
    The weights ``|N|`` make both continuous where the vertex normal is undefined.  At a fold
    or a collapsed patch ``N_v`` tends to 0 and its direction turns at random, but its weight
    tends to 0 with it.  The formulas only use products and norms of the ``N_v``, never
    ``N_v / |N_v|``.

    Why not per-vertex principal curvatures?  :func:`igl.principal_curvature` alone takes
    130 ms on a 128×128 CA.  A per-vertex quadric fit in the tangent plane breaks down where
    the geometry image folds: on the CA of ``assets/plane_holes.ply`` a mere rotation moved its
    weights by up to 1e-2.  Second differences at the finest scale also amplify rounding
    roughly ``block**2`` times more than the turning between blocks does.

Normalisation to [0, 1]
    Each raw input ``x`` (one value per block) becomes ``x / (x + max(median(x), floor))``.
    The median block maps to 0.5, the FIS's MEDIUM; a quarter and four times the median map to
    0.2 and 0.8, where LOW and HIGH reach full membership.  The floors
    (:data:`CURVATURE_FLOOR`, :data:`AREA_FLOOR`, :data:`BUMPINESS_FLOOR`, dimensionless)
    keep a flat model from turning rounding noise into MEDIUM.  On a plane, curvature and
    bumpiness are 0, and so are their inputs.

    The map is invariant to rotation, reflection, translation and uniform scale of ``ca``.  The
    raw inputs are (they are computed in units of ``L``), and a ratio to the median would be
    anyway.  The map is also *continuous*.  The median is a continuous function of the data,
    and ``x / (x + m)`` changes by at most a quarter of the relative change of ``x``.  A rank
    transform would be invariant too, but two blocks with nearly equal values swap ranks under
    any perturbation, and their inputs jump by ``1 / m**2``.  Extraction recomputes the mask
    from a CA rounded differently (float32 storage, the inverse transform), so continuity is
    what keeps the marked coefficients the same.

Stability (measured)
    Rotating, reflecting, translating and scaling CA changes the weights of
    :func:`perceptual_weight` by about 1e-11.  Multiplying CA by ``1 + 1e-7 * noise``, with
    standard normal noise, changes them by at most 4e-6 (median over draws 2e-6) on the
    64×64 CA of ``assets/spot.ply`` (geometry image of size 128).  On its 128×128 CA the
    change is at most 4e-5.  Rounding CA to float32 changes them by 6e-6 there and flips no
    class.  The finer the grid, the more the same perturbation moves the normals of
    neighbouring samples relative to their difference, roughly as ``M**2``.  Folded geometry
    images are the worst case: 3e-4 for ``assets/plane_holes.ply`` at 128×128 (1.5e-5 for
    float32 rounding).  A 128×128 CA with ``block=4`` takes about 20 ms, the first call about
    50 ms.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic", section 3 steps 6-7 and Table 4.
.. [2] J. J. Koenderink, A. J. van Doorn, "Surface shape and curvature scales", Image and
   Vision Computing 10(8), 1992.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import igl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from meshwm._validate import check_integer
from meshwm.gim.code import grid_faces
from meshwm.signal.fuzzy import infer_strength

__all__ = [
    "AREA_FLOOR",
    "BUMPINESS_FLOOR",
    "CURVATURE_FLOOR",
    "PerceptualInputs",
    "perceptual_inputs",
    "perceptual_weight",
]

#: Smallest median of the raw curvature (in units of ``1/L``) used to normalise it: a radius
#: of a thousand model sizes.  Flatter models get a curvature input near 0.
CURVATURE_FLOOR = 1e-3
#: Smallest median of the raw block area (in units of ``L**2``) used to normalise it.  This
#: matters only for a collapsed CA.
AREA_FLOOR = 1e-12
#: Smallest median of the raw bumpiness (``1 - cos``, normals about 0.08 degrees apart) used
#: to normalise it.
BUMPINESS_FLOOR = 1e-6

_TINY = 1e-12  # relative floor of denominators: blocks that are (nearly) collapsed get 0


class PerceptualInputs(NamedTuple):
    """The three crisp inputs of the FIS, each ``(m, m)`` float64 in [0, 1]."""

    curvature: NDArray[np.float64]
    area: NDArray[np.float64]
    bumpiness: NDArray[np.float64]


def perceptual_inputs(ca: ArrayLike, *, block: int) -> PerceptualInputs:
    """Curvature, area and bumpiness of each block of CA, normalised to [0, 1].

    Parameters
    ----------
    ca : (M, M, 3) array_like of real numbers
        The level-1 Haar approximation of the x, y and z matrices of a geometry image, stacked
        on the last axis.  ``M`` is a power of two >= 8.  Any units.  It is not modified.
    block : int
        Side of the square of CA samples that one coefficient covers, a power of two from 1 to
        ``M // 2`` (4 for level-3 coefficients: ``N/2`` CA samples against ``N/8``).

    Returns
    -------
    PerceptualInputs
        ``(curvature, area, bumpiness)``, each ``(M // block, M // block)`` float64 in [0, 1],
        in the argument order of :func:`meshwm.signal.fuzzy.infer_strength`.

    Raises
    ------
    TypeError
        ``ca`` does not hold real numbers, or ``block`` is not an int.
    ValueError
        ``ca`` is not ``(M, M, 3)`` with ``M`` a power of two >= 8, contains NaN or infinite
        values, or ``block`` is not a power of two from 1 to ``M // 2``.

    See Also
    --------
    perceptual_weight : the FIS weight of these inputs.

    Notes
    -----
    The definitions and the normalisation are in the module docstring.  All three inputs are
    invariant to rotations, reflections, translations and uniform scaling of ``ca``, and
    continuous in ``ca``.  A CA whose points all coincide gives zeros.

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
       representation and fuzzy logic", section 3, step 6.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.mask import perceptual_inputs
    >>> u, v = np.meshgrid(np.linspace(-1, 1, 16), np.linspace(-1, 1, 16), indexing="ij")
    >>> plane = np.stack([u, v, np.zeros_like(u)], axis=-1)
    >>> curvature, area, bumpiness = perceptual_inputs(plane, block=4)
    >>> curvature.shape, float(curvature.max()), float(bumpiness.max())
    ((4, 4), 0.0, 0.0)
    >>> bumpy = np.stack([u, v, 0.2 * np.sin(4 * u) * np.cos(4 * v)], axis=-1)
    >>> float(perceptual_inputs(bumpy, block=4).bumpiness.mean()) > 0.3
    True
    """
    points = _check_ca(ca)
    side = points.shape[0]
    block = _check_block(block, side)
    m = side // block
    unit = _unit_size(points)
    if unit is None:  # all points coincide: nothing to measure
        zeros = np.zeros((m, m))
        return PerceptualInputs(zeros, zeros.copy(), zeros.copy())

    vertices = unit.reshape(-1, 3)
    faces = grid_faces(side)
    corners = vertices[faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    flat = faces.ravel()
    normals = np.stack(
        [np.bincount(flat, np.repeat(cross[:, k], 3), minlength=side * side) for k in range(3)],
        axis=-1,
    )
    vertex_area = np.bincount(
        flat, np.repeat(igl.doublearea(vertices, faces) / 6.0, 3), minlength=side * side
    )

    curvature = _block_curvature(
        _block_sum(normals.reshape(side, side, 3), block),
        _block_sum(unit, block) / block**2,
    )
    area = _block_sum(vertex_area.reshape(side, side), block)
    bumpiness = _block_bumpiness(normals, side, block)
    return PerceptualInputs(
        _normalise(curvature, CURVATURE_FLOOR),
        _normalise(area, AREA_FLOOR),
        _normalise(bumpiness, BUMPINESS_FLOOR),
    )


def perceptual_weight(ca: ArrayLike, *, block: int) -> NDArray[np.float64]:
    """The FIS weighting factor of each block of CA (steps 6-7 of [1]_).

    Parameters
    ----------
    ca : (M, M, 3) array_like of real numbers
        The level-1 Haar approximation of the geometry image; see :func:`perceptual_inputs`.
    block : int
        Side of the square of CA samples one coefficient covers (4 for level 3).

    Returns
    -------
    weight : (M // block, M // block) float64 ndarray
        ``infer_strength(*perceptual_inputs(ca, block=block))``, in [0, 1].  Coefficients whose
        :func:`meshwm.signal.fuzzy.strength_class` is in
        :data:`meshwm.signal.fuzzy.EMBEDDING_CLASSES` (HIGH or HIGHER) carry watermark bits.

    Raises
    ------
    TypeError, ValueError
        As :func:`perceptual_inputs`.

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
       representation and fuzzy logic", section 3, steps 6-7.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.mask import perceptual_weight
    >>> u, v = np.meshgrid(np.linspace(-1, 1, 16), np.linspace(-1, 1, 16), indexing="ij")
    >>> ca = np.stack([u, v, 0.2 * np.sin(4 * u) * np.cos(4 * v)], axis=-1)
    >>> weight = perceptual_weight(ca, block=4)
    >>> weight.shape, bool(((weight >= 0) & (weight <= 1)).all())
    ((4, 4), True)
    """
    return infer_strength(*perceptual_inputs(ca, block=block))


def _check_ca(ca: ArrayLike) -> NDArray[np.float64]:
    array = np.asarray(ca)
    if array.dtype == np.bool_ or array.dtype.kind not in "iuf":
        raise TypeError(f"ca must hold real numbers (int or float), got dtype {array.dtype}")
    side = array.shape[0] if array.ndim == 3 else 0
    if array.shape != (side, side, 3) or side < 8 or side & (side - 1):
        raise ValueError(
            "ca must be an (M, M, 3) array (the x, y, z approximation matrices stacked) with M "
            f"a power of two >= 8, got shape {array.shape}"
        )
    array = np.asarray(array, dtype=np.float64)
    bad = int(np.count_nonzero(~np.isfinite(array)))
    if bad:
        raise ValueError(f"ca contains {bad} NaN or infinite values; all must be finite")
    return array


def _check_block(block: int, side: int) -> int:
    block = check_integer(block, name="block")
    if block < 1 or block > side // 2 or block & (block - 1):
        raise ValueError(
            f"block must be a power of two from 1 to M // 2 = {side // 2} so that it divides "
            f"M = {side} into at least 2×2 blocks, got {block}"
        )
    return block


def _unit_size(points: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """``points`` centred on their centroid and divided by their RMS distance to it.

    ``None`` if all points coincide.  Scaling by the largest magnitude first avoids overflow.
    """
    largest = float(np.abs(points).max())
    if largest == 0.0:
        return None
    scaled = points / largest
    centred = scaled - scaled.reshape(-1, 3).mean(axis=0)
    rms = float(np.sqrt(np.mean(np.einsum("...k,...k->...", centred, centred))))
    if rms == 0.0:
        return None
    return centred / rms


def _block_sum(values: NDArray, block: int) -> NDArray[np.float64]:
    """Sum ``(M, M, ...)`` values over ``block × block`` tiles: ``(M // b, M // b, ...)``."""
    m = values.shape[0] // block
    return values.reshape(m, block, m, block, *values.shape[2:]).sum(axis=(1, 3))


def _ratio(numerator: NDArray, denominator: NDArray) -> NDArray:
    """``numerator / (denominator + tiny)``, with a floor continuous in the data; 0 where 0/0."""
    padded = denominator + _TINY * float(denominator.mean())
    safe = np.where(padded > 0.0, padded, 1.0)
    return np.where(padded > 0.0, numerator / safe, 0.0)


def _block_curvature(
    normals: NDArray[np.float64], centroids: NDArray[np.float64]
) -> NDArray[np.float64]:
    """RMS normal curvature between each block and its grid neighbours (see module docstring).

    ``normals`` are the blocks' vector areas ``N_B`` (unnormalised), ``centroids`` the mean
    points, both ``(m, m, 3)``.
    """
    length = np.linalg.norm(normals, axis=-1)
    pairs = (
        ((slice(None), slice(None, -1)), (slice(None), slice(1, None))),  # along j
        ((slice(None, -1), slice(None)), (slice(1, None), slice(None))),  # along i
    )
    gaps = [
        np.einsum("...k,...k->...", centroids[a] - centroids[b], centroids[a] - centroids[b])
        for a, b in pairs
    ]
    gap_floor = _TINY * float(np.mean(np.concatenate([g.ravel() for g in gaps])))
    turning = np.zeros(length.shape)
    weight = np.zeros(length.shape)
    for (a, b), gap in zip(pairs, gaps, strict=True):
        # |N_B'| N_B - |N_B| N_B' = |N_B| |N_B'| (n_B - n_B'): no division by |N|.
        chord = length[b][..., None] * normals[a] - length[a][..., None] * normals[b]
        squared = np.einsum("...k,...k->...", chord, chord) / np.maximum(gap, gap_floor)
        pair_weight = (length[a] * length[b]) ** 2
        for index in (a, b):
            turning[index] += squared
            weight[index] += pair_weight
    return np.sqrt(_ratio(turning, weight))


@functools.lru_cache(maxsize=16)
def _grid_edges(side: int, block: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The unique edges of ``grid_faces(side)`` and the block index of every vertex."""
    faces = grid_faces(side)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges = np.unique(edges[:, 0] * (side * side) + edges[:, 1])
    edges = np.stack(np.divmod(edges, side * side), axis=1)
    i, j = np.divmod(np.arange(side * side), side)
    owner = (i // block) * (side // block) + j // block
    edges.flags.writeable = False
    owner.flags.writeable = False
    return edges, owner


def _block_bumpiness(normals: NDArray, side: int, block: int) -> NDArray:
    """Weighted mean of ``1 - n_u · n_v`` over the edges of each block (see module docstring)."""
    edges, owner = _grid_edges(side, block)
    nu, nv = normals[edges[:, 0]], normals[edges[:, 1]]
    weight = np.linalg.norm(nu, axis=1) * np.linalg.norm(nv, axis=1)
    # |N_u| |N_v| (1 - n_u · n_v) without dividing by |N|; >= 0 up to rounding.
    spread = np.maximum(weight - np.einsum("ik,ik->i", nu, nv), 0.0)
    ends = owner[edges].ravel()
    blocks = (side // block) ** 2
    total = np.bincount(ends, np.repeat(spread, 2), minlength=blocks)
    norm = np.bincount(ends, np.repeat(weight, 2), minlength=blocks)
    m = side // block
    return _ratio(total, norm).reshape(m, m)


def _normalise(raw: NDArray[np.float64], floor: float) -> NDArray[np.float64]:
    """``raw / (raw + max(median(raw), floor))``: continuous, scale-free, median -> 0.5."""
    return raw / (raw + max(float(np.median(raw)), floor))
