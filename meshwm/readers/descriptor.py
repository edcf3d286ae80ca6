"""A shape signature per asset, to pick which registered assets a received mesh may be.

:func:`shape_descriptor` gives one fixed-length vector per mesh, invariant to similarities
(rotation, uniform scale, translation), stable under re-tessellation, noise and smoothing, and
as far as it goes under a crop; :func:`descriptor_distance` compares one with a table of them,
so that only a short list of candidates is registered
(:func:`meshwm.readers.registration.register`).  Both use deterministic surface samples
(:func:`surface_samples`: area quantiles and a low-discrepancy sequence in each triangle, no
random stream), so the same mesh gives the same bytes on every machine.
"""

from __future__ import annotations

import struct

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist

from meshwm._validate import check_mesh
from meshwm.errors import MeshError

__all__ = [
    "AXIS_FLIPS",
    "CROPS",
    "CROP_FRACTION",
    "CROP_REFERENCE",
    "DESCRIPTOR_LENGTH",
    "checked_surface",
    "crop_descriptors",
    "descriptor_distance",
    "make_crops",
    "partial_distance",
    "principal_frame",
    "read_crops",
    "shape_descriptor",
    "surface_samples",
]

#: The plastic number; its powers make the R2 low-discrepancy sequence (Roberts 2018).
_PLASTIC = 1.324717957244746
_R2 = np.array([1.0 / _PLASTIC, 1.0 / _PLASTIC**2])

#: The descriptor's blocks: name -> (bins, upper end of the histogram, weight).  Each block is
#: the square roots of a histogram's frequencies times its weight (see the notes of
#: :func:`shape_descriptor`).
_BLOCKS: dict[str, tuple[int, float, float]] = {
    "d2": (32, 3.0, 0.5),
    "radial": (24, 2.5, 0.5),
    "normals": (16, 1.0, 0.5),
    "incidence": (16, 1.0, 1.0),
    "near_incidence": (16, 1.0, 1.0),
    "flatness": (16, 0.1, 0.5),
}
#: Length of :func:`shape_descriptor`'s vector.
DESCRIPTOR_LENGTH = sum(bins for bins, _, _ in _BLOCKS.values())

#: Surface samples of the descriptor; pairs are all pairs of every other sample.
_POINTS = 4096
_PAIR_STRIDE = 2
#: "Near" pairs: closer than this fraction of the mean pair distance.
_NEAR = 0.2
#: Samples in the neighbourhood whose flatness is measured.
_FLAT_NEIGHBOURS = 16

#: Surface area a stored crop (:func:`crop_descriptors`) cuts off.
CROP_FRACTION = 0.3
#: Directions of the stored crops' planes, in the asset's principal frame: the six axes and
#: the eight diagonals (every direction on the sphere is within 55 degrees of one).
_CROP_DIRECTIONS = np.array(
    [[s * (i == k) for k in range(3)] for i in range(3) for s in (1.0, -1.0)]
    + [[x, y, z] for x in (1.0, -1.0) for y in (1.0, -1.0) for z in (1.0, -1.0)]
)
_CROP_DIRECTIONS /= np.linalg.norm(_CROP_DIRECTIONS, axis=1, keepdims=True)
#: Number of :func:`crop_descriptors` rows.
CROPS = len(_CROP_DIRECTIONS)
#: The grid size :func:`make_crops`'s bytes are recorded under among an asset's references
#: (they hold for every size; the probe is 0).
CROP_REFERENCE = 1
_CROPS_MAGIC = b"CRD1"
_CROPS_HEADER = struct.Struct("<4sHH")
#: Points whose pairs a stored crop's pair blocks count (before the crop): a sample of the
#: kept points half as dense as :func:`shape_descriptor`'s pairs (the histograms are
#: frequencies, so only their noise grows).
_CROP_PAIR_POINTS = 1463


def checked_surface(
    vertices: NDArray, faces: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """:func:`meshwm._validate.check_mesh`, and a surface of positive area.

    Raises
    ------
    MeshError
        Unusable arrays, or every face degenerate.
    """
    v, f = check_mesh(vertices, faces)
    tri = v[f]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    if not float(area.sum()) > 0:
        raise MeshError("the mesh has zero surface area: every face is degenerate")
    return v, f


def surface_samples(
    vertices: NDArray, faces: NDArray, count: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Deterministic, area-uniform points on a triangle mesh and their face normals.

    Point ``i`` lies in the face where the cumulative area (in face order) reaches
    ``(i + 1/2) / count`` of the total, at the barycentric point of the R2 low-discrepancy
    sequence's ``i``-th term (folded into the triangle).  No random stream: the same arrays
    give the same bytes everywhere.  A strided subset (``points[::k]``) is spread over the
    whole surface too.

    Parameters
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
    count : int
        Number of points.

    Returns
    -------
    points : (count, 3) float64 ndarray
    normals : (count, 3) float64 ndarray
        Unit normals of the faces the points lie in (zero for a degenerate face).

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> p, n = surface_samples(v, np.array([[0, 1, 2]]), 8)
    >>> bool(np.all(p[:, :2] >= 0) and np.all(p.sum(axis=1) <= 1)), n[0].tolist()
    (True, [0.0, 0.0, 1.0])
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = v[np.asarray(faces, dtype=np.int64)]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    cumulative = np.cumsum(double_area)
    target = (np.arange(count) + 0.5) / count * cumulative[-1]
    face = np.minimum(np.searchsorted(cumulative, target), len(tri) - 1)
    uv = np.mod(0.5 + np.outer(np.arange(count), _R2), 1.0)
    fold = uv.sum(axis=1) > 1
    uv[fold] = 1.0 - uv[fold]
    chosen = tri[face]
    points = (
        chosen[:, 0]
        + uv[:, :1] * (chosen[:, 1] - chosen[:, 0])
        + uv[:, 1:] * (chosen[:, 2] - chosen[:, 0])
    )
    normals = cross[face] / np.maximum(double_area[face], np.finfo(float).tiny)[:, None]
    return points, normals


#: The four proper sign choices of a principal frame's axes (each a diagonal rotation): the
#: poses a frame alone cannot tell apart.
AXIS_FLIPS = np.array([np.diag(d) for d in ((1, 1, 1), (-1, -1, 1), (-1, 1, -1), (1, -1, -1))])


def principal_frame(
    points: NDArray[np.float64], weights: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Weighted centroid, principal axes (columns, largest first, right-handed) and RMS radius
    of points (weights: any positive scale, normalised here; default equal)."""
    w = np.full(len(points), 1.0 / len(points)) if weights is None else weights / weights.sum()
    centre = w @ points
    rel = points - centre
    values, axes = np.linalg.eigh((rel * w[:, None]).T @ rel)
    axes = axes[:, ::-1]
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return centre, axes, float(np.sqrt(max(values.sum(), np.finfo(float).tiny)))


def _block(name: str, values: NDArray[np.float64]) -> NDArray[np.float64]:
    """The weighted square roots of a normalised histogram on [0, high] (the last bin takes the
    tail), so that the Euclidean distance between two blocks is a weighted Hellinger distance."""
    return _counted(name, _bins(name, values), None)  # values are >= 0


def _bins(name: str, values: NDArray[np.float64]) -> NDArray[np.intp]:
    """:func:`_block`'s bin of each value."""
    bins, high, _ = _BLOCKS[name]
    index: NDArray[np.intp] = np.minimum(values * (bins / high), bins - 1).astype(np.intp)
    return index


def _counted(
    name: str,
    index: NDArray[np.intp] | tuple[NDArray[np.intp], ...],
    weights: NDArray[np.float64] | None,
) -> NDArray[np.float64]:
    """:func:`_block` of the values whose bins are ``index`` (or each of a tuple of bin
    arrays), counting value ``i`` ``weights[i]`` times (once each without weights)."""
    bins, _, weight = _BLOCKS[name]
    counts = sum(
        np.bincount(i, weights, minlength=bins)
        for i in (index if isinstance(index, tuple) else (index,))
    )
    total = float(np.sum(counts))
    return weight * np.sqrt(np.asarray(counts, dtype=np.float64) / max(total, 1.0))


def _flatness(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least over summed eigenvalue of the covariance of each point's neighbourhood."""
    _, neighbour = cKDTree(points).query(points, k=_FLAT_NEIGHBOURS)
    local = points[neighbour]
    local = local - local.mean(axis=1, keepdims=True)
    values = np.linalg.eigvalsh(np.einsum("pki,pkj->pij", local, local))
    result: NDArray[np.float64] = values[:, 0] / np.maximum(
        values.sum(axis=1), np.finfo(float).tiny
    )
    return result


def _pairs(
    p: NDArray[np.float64], n: NDArray[np.float64]
) -> tuple[tuple[NDArray[np.intp], NDArray[np.intp]], NDArray[np.float64], NDArray[np.float64]]:
    """The pairs ``a < b`` of points ``p`` (row by row, as :func:`pdist` orders them), their
    distances, and the |cosine| between each end's normal ``n`` and the pair's direction
    (2, pairs)."""
    first, second = np.triu_indices(len(p), k=1)
    distance = pdist(p)
    safe = np.maximum(distance, np.finfo(float).tiny)
    reach = n @ p.T  # reach[a, b] = n_a · p_b, so n_a · (p_b - p_a) = reach[a, b] - reach[a, a]
    own = np.diag(reach)
    incidence = np.abs(
        np.stack([reach[first, second] - own[first], own[second] - reach[second, first]]) / safe
    )
    return (first, second), distance, incidence


def shape_descriptor(vertices: NDArray, faces: NDArray) -> NDArray[np.float64]:
    """A similarity-invariant shape signature of a triangle mesh's surface.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int

    Returns
    -------
    (DESCRIPTOR_LENGTH,) float64 ndarray
        Compare two with :func:`descriptor_distance`.

    Raises
    ------
    MeshError
        Unusable arrays or a surface of zero area.

    Notes
    -----
    From 4096 deterministic area-uniform samples (:func:`surface_samples`) with their face
    normals, six histograms, each stored as the square roots of its frequencies times a weight
    (so the Euclidean distance is a weighted Hellinger distance per block):

    ``d2`` (weight 1/2)
        Distances of all pairs of every other sample over their mean, 32 bins on [0, 3]
        (Osada et al., "Shape distributions", doi:10.1145/571647.571648).
    ``radial`` (1/2)
        Sample distances to the samples' centroid over their RMS, 24 bins on [0, 2.5].
    ``normals`` (1/2)
        The |cosine| between the normals of a pair, 16 bins.
    ``incidence`` (1)
        The |cosine| between each normal of a pair and the pair's direction, 16 bins.
    ``near_incidence`` (1)
        The same for pairs closer than 0.2 of the mean pair distance: local curvature, which a
        crop changes less than the global blocks.
    ``flatness`` (1/2)
        For each sample, the least over the summed eigenvalue of its 16 nearest samples'
        covariance, 16 bins on [0, 0.1].

    Absolute cosines make it blind to the faces' orientation, ratios to the pose and scale.
    Re-tessellation, 0.1 % noise and smoothing move a dev mesh's descriptor by 0.01-0.1, the
    distance between two different dev meshes is 0.2 or more; a 30 % crop moves it by
    0.1-0.5 (the weights were chosen on the ten dev meshes for crops: right asset first in
    90 % of crops, in the top three in all; see ``scripts/check_registration.py``).

    Examples
    --------
    >>> from meshwm import data
    >>> from meshwm.attacks import apply_attack
    >>> from meshwm.mesh.io import read_mesh
    >>> v, f = read_mesh(data.path("spot"))
    >>> moved = apply_attack("similarity", v, f, seed=3)
    >>> d = descriptor_distance(shape_descriptor(v, f), shape_descriptor(*moved)[None])
    >>> bool(d[0] < 1e-6)
    True
    """
    v, f = checked_surface(vertices, faces)
    points, normals = surface_samples(v - v.mean(axis=0), f, _POINTS)
    radius = np.linalg.norm(points - points.mean(axis=0), axis=1)

    p, n = points[::_PAIR_STRIDE], normals[::_PAIR_STRIDE]
    (first, second), distance, incidence = _pairs(p, n)
    near = distance < _NEAR * distance.mean()
    return np.concatenate(
        [
            _block("d2", distance / distance.mean()),
            _block("radial", radius / np.sqrt(np.mean(radius**2))),
            _block("normals", np.abs((n @ n.T)[first, second])),
            _block("incidence", incidence.ravel()),
            _block("near_incidence", incidence[:, near].ravel()),
            _block("flatness", _flatness(points)),
        ]
    )


def crop_descriptors(points: NDArray, normals: NDArray) -> NDArray[np.float64]:
    """The descriptors of an asset's surface with :data:`CROP_FRACTION` of it cut off, from
    :data:`CROPS` directions.

    A received crop's :func:`shape_descriptor` is nearer its asset's crop from the nearest
    direction than to the asset's own descriptor: a crop moves the global blocks (``d2``,
    ``radial``) by more than near-duplicate assets differ, and a registry of near-duplicates
    then ranks the right asset hundreds deep.  :func:`partial_distance` takes the least
    distance over an asset's descriptor and its crops.

    Parameters
    ----------
    points : (a, 3) array_like of float
        Area-uniform samples of the asset's surface in surface order
        (:func:`surface_samples`; :attr:`meshwm.readers.informed.Reference.anchors`), at
        least ``4096 / (1 - CROP_FRACTION)`` of them.
    normals : (a, 3) array_like of float
        Their unit normals (the sign does not matter).

    Returns
    -------
    (CROPS, DESCRIPTOR_LENGTH) float64 ndarray

    Raises
    ------
    ValueError
        Too few points, shapes that do not match, or non-finite values.

    Notes
    -----
    Each crop keeps the points below the plane orthogonal to its direction (in the points'
    principal frame, :func:`principal_frame`) that leaves ``1 - CROP_FRACTION`` of them; an
    evenly spaced subset of the points is as dense on the kept part as
    :func:`shape_descriptor`'s samples on a received crop of that size, and each point's
    ``flatness`` is measured once among all of them (the cut moves only the neighbourhoods
    on its edge).  The pair blocks come from a sparser subset's pairs, computed once and
    masked per crop (0.4 s for 16k points).  Where a random plane cuts 30 % off a
    development mesh (three planes each) in a registry of 1,000 assets, about 99 deformed
    near-duplicates of each, the right asset ranks 1st-48th by the least distance, 1st-208th
    by the descriptor alone (``scripts/bench_trace.py``'s registry).
    """
    pts = np.asarray(points, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    dense = round(_POINTS / (1.0 - CROP_FRACTION))
    if pts.ndim != 2 or pts.shape[1] != 3 or nrm.shape != pts.shape or len(pts) < dense:
        raise ValueError(
            f"points and normals must both have shape (>= {dense}, 3), got "
            f"{pts.shape} and {nrm.shape}"
        )
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(nrm))):
        raise ValueError("points and normals must be finite")
    chosen = np.linspace(0, len(pts) - 1, dense).round().astype(np.intp)
    pts, nrm = pts[chosen], nrm[chosen]
    flat = _flatness(pts)
    centre, axes, _ = principal_frame(pts)
    heights = (pts - centre) @ axes @ _CROP_DIRECTIONS.T  # (dense, CROPS)
    paired = np.linspace(0, dense - 1, _CROP_PAIR_POINTS).round().astype(np.intp)
    p, n = pts[paired], nrm[paired]
    (first, second), distance, both = _pairs(p, n)
    # Every pair's bins once; a crop counts the pairs it keeps (weights 1) among them.
    incidence = (_bins("incidence", both[0]), _bins("incidence", both[1]))
    cosine = _bins("normals", np.abs(np.einsum("ij,ij->i", n[first], n[second])))
    rows = []
    for c in range(CROPS):
        kept = heights[:, c] <= np.quantile(heights[:, c], 1.0 - CROP_FRACTION)
        kept_paired = kept[paired]
        pair = (kept_paired[first] & kept_paired[second]).astype(np.float64)
        mean = float(distance @ pair) / max(float(pair.sum()), 1.0)
        near = pair * (distance < _NEAR * mean)
        kept_points = pts[kept]
        radius = np.linalg.norm(kept_points - kept_points.mean(axis=0), axis=1)
        rows.append(
            np.concatenate(
                [
                    _counted("d2", _bins("d2", distance / mean), pair),
                    _block("radial", radius / np.sqrt(np.mean(radius**2))),
                    _counted("normals", cosine, pair),
                    _counted("incidence", incidence, pair),
                    _counted("near_incidence", incidence, near),
                    _block("flatness", flat[kept]),
                ]
            )
        )
    return np.array(rows)


def make_crops(points: NDArray, normals: NDArray) -> bytes:
    """:func:`crop_descriptors` as recorded in a registry (float32 rows after a short header),
    read by :func:`read_crops`."""
    # From the points and normals as a reference stores them (float32, float16): crops made
    # later from a stored reference (``meshwm registry upgrade``) are the same bytes.
    rows = crop_descriptors(
        np.asarray(points, dtype=np.float32), np.asarray(normals, dtype=np.float16)
    )
    return _CROPS_HEADER.pack(_CROPS_MAGIC, *rows.shape) + rows.astype("<f4").tobytes()


def read_crops(data: bytes) -> NDArray[np.float64]:
    """The rows :func:`make_crops` recorded.

    Raises
    ------
    ValueError
        Anything else: another format, another descriptor length, a wrong size, non-finite
        or negative values.
    """
    try:
        magic, count, length = _CROPS_HEADER.unpack_from(data)
    except struct.error:
        raise ValueError("not crop descriptors: too short") from None
    if (
        magic != _CROPS_MAGIC
        or (count, length) != (CROPS, DESCRIPTOR_LENGTH)
        or len(data) != _CROPS_HEADER.size + 4 * count * length
    ):
        raise ValueError("not crop descriptors of this version")
    rows = np.frombuffer(data, dtype="<f4", offset=_CROPS_HEADER.size).reshape(count, length)
    if not (np.all(np.isfinite(rows)) and np.all(rows >= 0)):
        raise ValueError("crop descriptors with non-finite or negative values")
    return rows.astype(np.float64)


def partial_distance(query: NDArray, table: NDArray, crops: NDArray) -> NDArray[np.float64]:
    """The least :func:`descriptor_distance` from one descriptor to each asset's descriptor
    and its :func:`crop_descriptors`.

    Parameters
    ----------
    query : (DESCRIPTOR_LENGTH,) array_like of float
    table : (a, DESCRIPTOR_LENGTH) array_like of float
    crops : (a, CROPS, DESCRIPTOR_LENGTH) array_like of float
        NaN rows for an asset without crops (its descriptor alone counts).

    Returns
    -------
    (a,) float64 ndarray
    """
    q = np.asarray(query, dtype=np.float64)
    c = np.asarray(crops, dtype=np.float64)
    whole = descriptor_distance(q, table)
    if c.ndim != 3 or c.shape[0] != len(whole) or c.shape[2] != q.shape[0]:
        raise ValueError(f"crops must be ({len(whole)}, k, {q.shape[0]}), got {c.shape}")
    cropped = np.sqrt(np.sum((c - q) ** 2, axis=2))
    cropped[np.isnan(cropped)] = np.inf
    result: NDArray[np.float64] = np.minimum(whole, cropped.min(axis=1, initial=np.inf))
    return result


def descriptor_distance(query: NDArray, table: NDArray) -> NDArray[np.float64]:
    """Euclidean distances from one descriptor to each row of a table of descriptors.

    Parameters
    ----------
    query : (DESCRIPTOR_LENGTH,) array_like of float
    table : (a, DESCRIPTOR_LENGTH) array_like of float
        One row per asset.

    Returns
    -------
    (a,) float64 ndarray
        Smaller is more alike; ``np.argsort`` gives the candidates, best first.

    Raises
    ------
    ValueError
        Shapes that do not match.

    Examples
    --------
    >>> descriptor_distance([0.0, 1.0], [[0.0, 1.0], [3.0, 5.0]]).tolist()
    [0.0, 5.0]
    """
    q = np.asarray(query, dtype=np.float64)
    t = np.asarray(table, dtype=np.float64)
    if q.ndim != 1 or t.ndim != 2 or t.shape[1] != q.shape[0]:
        raise ValueError(
            f"query must be (k,) and table (a, k) with the same k, got {q.shape} and {t.shape}"
        )
    distances: NDArray[np.float64] = np.sqrt(np.sum((t - q) ** 2, axis=1))
    return distances
