"""The informed reader: a received surface read at an asset's registered reference points.

A blind reader re-derives the geometry image from the received mesh; after decimation,
subdivision or remeshing no blind map comes within a fraction of a sample of the original
layout, and nothing reads.  A studio that keeps a record of which copy went to whom can keep a
little more: for each asset, a *reference* (the points of its unmarked surface image and the
surface normals there, :func:`make_reference`), and for each copy, the mark's *signature*: the
normal offset of the marked surface from the reference at every reference point
(:func:`copy_signature`), stored permuted under the key (:func:`seal_signature`), so the
registry alone does not tell where any copy's mark lies.

To read, the received mesh is brought into the reference's pose
(:mod:`meshwm.readers.registration`) and its normal offsets from the reference points are
measured (:func:`received_offsets`): the closest point of the received surface to each
reference point, along the reference normal.  Re-tessellation, noise and smoothing change these
offsets, but the mark's low-frequency normal pattern survives in them.  Each registered copy is
then tested by the normalised correlation of the offsets with its signature
(:func:`correlate`); its null distribution is measured on the same data, as the correlations at
every cyclic shift of the signature on the image grid that is farther than
:data:`MIN_SHIFT` samples (thousands of decoys, one FFT), so the p-value accounts for the
spatial correlation of the offsets and of the mark.  Copies of one asset carry different ids
and partly the same pattern (the same key and host): the best copy is also tested against the
runner-up on their *difference* (:func:`identify`).

This reader decides between registered copies; it does not decode bits, and a copy that was
never registered is not read by it.  Every candidate asset, pose and copy counts as a
hypothesis of the decision.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic" (the geometry image the reference points come from).
.. [2] I. J. Cox, J. Kilian, F. T. Leighton, T. Shamoon, "Secure spread spectrum watermarking
   for multimedia", IEEE Trans. Image Processing 6(12), 1997 (informed, correlation detection).
"""

from __future__ import annotations

import io
import zipfile
from typing import NamedTuple

import igl
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.special import ndtr

from meshwm.errors import MeshError
from meshwm.message.keying import keyed_permutation

__all__ = [
    "ANCHORS",
    "FAR",
    "MIN_SHIFT",
    "REFERENCE_SIZE",
    "CopyScore",
    "Reference",
    "copy_signature",
    "correlate",
    "highpass",
    "identify",
    "make_reference",
    "received_offsets",
    "seal_signature",
    "unseal_signature",
]

#: The size of the reference image (REFERENCE_SIZE² points on the asset's surface).
REFERENCE_SIZE = 128
#: A reference point whose closest received point is farther than this (over the diagonal) is
#: missing (cropped away, or a part the received mesh does not have).
FAR = 0.01
#: Decoy shifts closer than this (in samples, along either grid axis) are not counted: the
#: signature is smooth over a few samples, so nearby shifts still correlate with it.
MIN_SHIFT = 8
#: The offsets and the signature are high-passed before they are correlated: minus their
#: Gaussian blur of this radius (in samples) on the grid.  The mark lives in the level-3 detail
#: band; smoothing and re-tessellation leave most of their error in broader swells (uniform
#: Laplacian ×10 on spot: z 9.5 unfiltered, 17.3 at 2 samples, 13.2 at 4).
HIGHPASS_SIGMA = 2.0
#: Fewer reference points present than this fraction: nothing is read.
MIN_PRESENT = 0.2
#: Area-uniform points on the asset's surface kept for the pose: the surface image's samples
#: crowd where its map stretches and thin out elsewhere (genus-4 fertility: half its vertices
#: more than 1 % of the diagonal from any of them), which is fine for the test but not for
#: registering a whole received mesh.
ANCHORS = 16384
_FORMAT = 2


class Reference(NamedTuple):
    """An asset's reference: points on its unmarked surface, on an n×n grid.

    Attributes
    ----------
    n : int
        Grid size.
    cells : (k,) int64 ndarray
        Flat grid index of each point (the grid's other samples are not on the surface).
    points : (k, 3) float64 ndarray
        The points, in the asset's coordinates.
    normals : (k, 3) float64 ndarray
        Unit surface normals there.
    diagonal : float
        The asset's bounding-box diagonal.
    anchors : (a, 3) float64 ndarray
        :data:`ANCHORS` area-uniform points on the asset's surface, for the pose
        (:func:`meshwm.readers.registration.surface_samples`).
    anchor_normals : (a, 3) float64 ndarray
    """

    n: int
    cells: NDArray[np.int64]
    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    diagonal: float
    anchors: NDArray[np.float64]
    anchor_normals: NDArray[np.float64]

    def to_bytes(self) -> bytes:
        """The reference as stored in a registry (a NumPy ``.npz``, no pickles)."""
        buf = io.BytesIO()
        np.savez_compressed(
            buf,
            format=np.int64(_FORMAT),
            n=np.int64(self.n),
            cells=self.cells.astype(np.int32),
            points=self.points.astype(np.float32),
            normals=self.normals.astype(np.float32),
            diagonal=np.float64(self.diagonal),
            anchors=self.anchors.astype(np.float32),
            anchor_normals=self.anchor_normals.astype(np.float16),
        )
        return buf.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> Reference:
        """Read :meth:`to_bytes`; :class:`ValueError` for anything else."""
        try:
            with np.load(io.BytesIO(data), allow_pickle=False) as z:
                if int(z["format"]) != _FORMAT:
                    raise ValueError(f"reference format {int(z['format'])}, expected {_FORMAT}")
                ref = cls(
                    int(z["n"]),
                    z["cells"].astype(np.int64),
                    z["points"].astype(np.float64),
                    z["normals"].astype(np.float64),
                    float(z["diagonal"]),
                    z["anchors"].astype(np.float64),
                    z["anchor_normals"].astype(np.float64),
                )
        except (OSError, KeyError, EOFError, ValueError, zipfile.BadZipFile) as exc:
            raise ValueError(f"not a reference: {exc}") from None
        k = len(ref.cells)
        if (
            ref.points.shape != (k, 3)
            or ref.normals.shape != (k, 3)
            or k == 0
            or ref.cells.min() < 0
            or ref.cells.max() >= ref.n * ref.n
            or not np.all(np.isfinite(ref.points))
            or ref.anchors.ndim != 2
            or ref.anchors.shape[1:] != (3,)
            or ref.anchor_normals.shape != ref.anchors.shape
        ):
            raise ValueError("not a reference: inconsistent arrays")
        return ref


def make_reference(
    vertices: NDArray, faces: NDArray, *, n: int = REFERENCE_SIZE, max_faces: int
) -> Reference:
    """The reference of an (unmarked) asset: its surface image's samples and normals.

    The points are the n×n samples of the asset's stable surface map
    (:func:`meshwm.gim.surface.sample_surface`), the normals those of the faces they lie on;
    the anchors are :data:`ANCHORS` area-uniform samples of the whole surface.

    Raises
    ------
    MeshError
        A mesh the map cannot open.
    """
    from meshwm.gim.surface import sample_surface, surface_of
    from meshwm.readers.registration import surface_samples

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    surface = surface_of(v, f, max_faces=max_faces)
    image = sample_surface(surface, size=n)
    flat = image.samples.reshape(-1, 3)
    index = np.flatnonzero(image.covered.ravel() & np.all(np.isfinite(flat), axis=1))
    points = flat[index]
    _, face, _ = igl.point_mesh_squared_distance(points, v, f)
    normals = _face_normals(v, f)[face]
    diagonal = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    anchors, anchor_normals = surface_samples(v, f, ANCHORS)
    return Reference(
        int(n), index.astype(np.int64), points, normals, diagonal, anchors, anchor_normals
    )


def _face_normals(v: NDArray[np.float64], f: NDArray[np.int64]) -> NDArray[np.float64]:
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    return cross / np.where(length > 0, length, 1.0)


def received_offsets(reference: Reference, vertices: NDArray, faces: NDArray) -> NDArray:
    """Normal offset of a surface from each reference point (NaN where it is far or absent).

    ``vertices`` must be in the reference's pose.  The offset is the closest surface point's
    displacement along the reference normal.

    Returns
    -------
    (k,) float64 ndarray
        Offsets in the reference's units.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(v) == 0 or len(f) == 0:
        raise MeshError("the received mesh has no faces")
    d2, _, closest = igl.point_mesh_squared_distance(reference.points, v, f)
    out = np.einsum("ij,ij->i", closest - reference.points, reference.normals)
    out[np.sqrt(d2) > FAR * reference.diagonal] = np.nan
    return out


def copy_signature(reference: Reference, vertices: NDArray, faces: NDArray) -> NDArray:
    """A marked copy's signature: its normal offsets from the (unmarked) reference.

    Returns
    -------
    (k,) float32 ndarray
        NaN where the copy's surface is far from the reference (never, for a kept copy).
    """
    return received_offsets(reference, vertices, faces).astype(np.float32)


def _purpose(n: int, count: int) -> str:
    return f"meshwm/informed/v1/n{n}/k{count}"


def seal_signature(signature: NDArray, reference: Reference, *, key: str | bytes) -> bytes:
    """The signature as stored: float16, permuted under the key (never the key itself)."""
    sig = np.asarray(signature, dtype=np.float32)
    scale = float(np.nanmax(np.abs(sig))) if np.isfinite(sig).any() else 0.0
    perm = keyed_permutation(key, _purpose(reference.n, len(sig)), len(sig))
    body = (sig / (scale or 1.0)).astype(np.float16)[perm]
    return np.float64(scale).tobytes() + body.tobytes()


def unseal_signature(data: bytes, reference: Reference, *, key: str | bytes) -> NDArray:
    """:func:`seal_signature` undone with ``key`` (a wrong key gives a scrambled signature)."""
    k = len(reference.cells)
    if len(data) != 8 + 2 * k:
        raise ValueError(f"a signature of {len(data)} bytes does not fit a {k}-point reference")
    scale = float(np.frombuffer(data[:8], dtype=np.float64)[0])
    body = np.frombuffer(data[8:], dtype=np.float16).astype(np.float64)
    out = np.empty(k)
    out[keyed_permutation(key, _purpose(reference.n, k), k)] = body
    return out * scale


class CopyScore(NamedTuple):
    """The correlation of received offsets with one signature, against its decoys.

    Attributes
    ----------
    rho : float
        Normalised correlation over the points present in both.
    z : float
        ``(rho - mean) / std`` of the decoys' correlations.
    p_value : float
        One-sided Gaussian tail of ``z``.
    decoys : int
        How many shifted signatures the null was measured on.
    """

    rho: float
    z: float
    p_value: float
    decoys: int


def _grid(values: NDArray, reference: Reference) -> NDArray[np.float64]:
    g = np.zeros(reference.n * reference.n)
    g[reference.cells] = np.where(np.isfinite(values), values, 0.0)
    return g.reshape(reference.n, reference.n)


def highpass(values: NDArray, reference: Reference) -> NDArray[np.float64]:
    """``values`` (on the reference's points, NaN = absent) minus their local mean: a Gaussian
    of :data:`HIGHPASS_SIGMA` samples on the grid, normalised over the points present."""
    x = np.asarray(values, dtype=np.float64)
    present = np.isfinite(x)
    num = ndimage.gaussian_filter(_grid(x, reference), HIGHPASS_SIGMA, mode="wrap")
    den = ndimage.gaussian_filter(
        _grid(present.astype(np.float64), reference), HIGHPASS_SIGMA, mode="wrap"
    )
    low = (num / np.maximum(den, 1e-12)).ravel()[reference.cells]
    return np.where(present, x - low, np.nan)


def correlate(offsets: NDArray, signature: NDArray, reference: Reference) -> CopyScore:
    """Test received ``offsets`` for a ``signature`` (both on the reference's points).

    Both are high-passed (:func:`highpass`) over the points present in both; the correlation
    at every cyclic shift of the signature on the n×n grid is computed at once (FFT); the
    shifts at least :data:`MIN_SHIFT` samples away along an axis are the decoys, whose mean and
    standard deviation give ``z``.
    """
    h = np.where(np.isfinite(signature), np.asarray(offsets, np.float64), np.nan)
    present = np.isfinite(h)
    if present.mean() < MIN_PRESENT:
        return CopyScore(0.0, 0.0, 1.0, 0)
    h = highpass(h, reference)
    s = highpass(np.where(present, np.asarray(signature, np.float64), np.nan), reference)
    hg, sg = _grid(h, reference), _grid(s, reference)
    norm = float(np.sqrt(np.sum(hg**2) * np.sum(sg**2)))
    if norm == 0:
        return CopyScore(0.0, 0.0, 1.0, 0)
    cross = np.fft.irfft2(np.fft.rfft2(hg) * np.conj(np.fft.rfft2(sg)), s=hg.shape) / norm
    n = reference.n
    shift = np.minimum(np.arange(n), n - np.arange(n))
    far = (shift[:, None] >= MIN_SHIFT) | (shift[None, :] >= MIN_SHIFT)
    decoys = cross[far]
    spread = float(np.std(decoys))
    rho = float(cross[0, 0])
    z = (rho - float(np.mean(decoys))) / spread if spread > 0 else 0.0
    return CopyScore(rho, z, float(ndtr(-z)), int(decoys.size))


def identify(
    offsets: NDArray, signatures: list[NDArray], reference: Reference
) -> tuple[int, CopyScore, CopyScore | None]:
    """The copy whose signature the offsets carry best, and the test against the runner-up.

    Returns
    -------
    best : int
        Index into ``signatures``.
    score : CopyScore
        Its test (:func:`correlate`).
    versus : CopyScore or None
        The offsets tested for the difference between the best signature and the runner-up's
        (None with one copy): a copy is told from the others only when this is significant.
    """
    if not signatures:
        raise ValueError("no signatures to test")
    scores = [correlate(offsets, s, reference) for s in signatures]
    order = sorted(range(len(scores)), key=lambda i: -scores[i].z)
    best = order[0]
    if len(order) == 1:
        return best, scores[best], None
    second = order[1]
    versus = correlate(offsets, signatures[best] - signatures[second], reference)
    return best, scores[best], versus
