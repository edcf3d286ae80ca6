"""The informed reader: a received surface read at an asset's registered reference points.

A blind reader re-derives the geometry image from the received mesh; after decimation,
subdivision or remeshing no blind map comes within a fraction of a sample of the original
layout, and nothing reads.  A studio that keeps a record of which copy went to whom can keep a
little more: for each asset, a *reference* (the points of its unmarked surface image and the
surface normals there, :func:`make_reference`), and for each copy, the mark's *signature*: the
normal offset of the marked surface from the reference at every reference point, less what
light smoothing does to the unmarked asset (:func:`copy_signature`, :func:`host_changes`),
stored permuted under the key (:func:`seal_signature`), so the registry alone does not tell
where any copy's mark lies.

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

When the received mesh is the registered one itself (the same vertex count and the same faces,
as after smoothing, noise or quantisation of the copy), the reference's stored unmarked vertex
positions give a second, sharper reading (:func:`same_mesh_offsets`): the received vertices,
brought into the asset's frame by the similarity their correspondence fixes, minus the asset's,
minus the best fit of a smoothing model of the host (a similarity, six steps of the cotangent
Laplacian flow and six powers of the uniform Laplacian, run on the asset); what is left is the
mark, attenuated, and the attack's noise.  MeshLab's three cotangent steps on the coarse cow move
its vertices 20 times as far as the mark, which masks the mark in the posed offsets (z 0.1); the
fit leaves 8 % of the attenuated mark's size as error.  It counts as one more hypothesis per
copy.

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

import hashlib
import io
import zipfile
from typing import Any, NamedTuple

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
    "HOST_STEPS",
    "MIN_SHIFT",
    "REFERENCE_SIZE",
    "SNAPSHOT_VERTICES",
    "CopyScore",
    "Reference",
    "copy_signature",
    "correlate",
    "faces_digest",
    "highpass",
    "host_changes",
    "identify",
    "make_reference",
    "received_offsets",
    "same_mesh_offsets",
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
#: Assets with at most this many vertices keep their unmarked vertex positions in the reference
#: (float32, 12 bytes a vertex) for :func:`same_mesh_offsets`; above it a mesh carries enough
#: vertices per sample that the blind reader undoes smoothing by itself.
SNAPSHOT_VERTICES = 250_000
#: Steps of each smoothing flow in the host model of :func:`same_mesh_offsets` (Taubin's λ|μ
#: pairs on cow need 6; MeshLab's Laplacian ×3 needs 4).
HOST_STEPS = 6
_FORMAT = 3
_FORMATS = (2, 3)


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
    vertices : (v, 3) float64 ndarray or None
        The asset's unmarked vertex positions (assets up to :data:`SNAPSHOT_VERTICES` vertices
        marked in place), for :func:`same_mesh_offsets`.
    faces_digest : bytes or None
        :func:`faces_digest` of the asset's faces, with ``vertices``.
    """

    n: int
    cells: NDArray[np.int64]
    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    diagonal: float
    anchors: NDArray[np.float64]
    anchor_normals: NDArray[np.float64]
    vertices: NDArray[np.float64] | None = None
    faces_digest: bytes | None = None

    def to_bytes(self) -> bytes:
        """The reference as stored in a registry (a NumPy ``.npz``, no pickles)."""
        buf = io.BytesIO()
        snapshot: dict[str, Any] = {}
        if self.vertices is not None and self.faces_digest is not None:
            snapshot = {
                "vertices": self.vertices.astype(np.float32),
                "faces_digest": np.frombuffer(self.faces_digest, dtype=np.uint8),
            }
        np.savez_compressed(
            buf,
            **snapshot,
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
                if int(z["format"]) not in _FORMATS:
                    raise ValueError(f"reference format {int(z['format'])}, expected {_FORMAT}")
                snapshot = "vertices" in z.files and "faces_digest" in z.files
                ref = cls(
                    int(z["n"]),
                    z["cells"].astype(np.int64),
                    z["points"].astype(np.float64),
                    z["normals"].astype(np.float64),
                    float(z["diagonal"]),
                    z["anchors"].astype(np.float64),
                    z["anchor_normals"].astype(np.float64),
                    z["vertices"].astype(np.float64) if snapshot else None,
                    z["faces_digest"].astype(np.uint8).tobytes() if snapshot else None,
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
            or (
                ref.vertices is not None
                and (
                    ref.vertices.ndim != 2
                    or ref.vertices.shape[1:] != (3,)
                    or not np.all(np.isfinite(ref.vertices))
                    or len(ref.faces_digest or b"") != 32
                )
            )
        ):
            raise ValueError("not a reference: inconsistent arrays")
        return ref


def make_reference(
    vertices: NDArray,
    faces: NDArray,
    *,
    n: int = REFERENCE_SIZE,
    max_faces: int,
    snapshot: bool = True,
) -> Reference:
    """The reference of an (unmarked) asset: its surface image's samples and normals.

    The points are the n×n samples of the asset's stable surface map
    (:func:`meshwm.gim.surface.sample_surface`), the normals those of the faces they lie on;
    the anchors are :data:`ANCHORS` area-uniform samples of the whole surface.  With
    ``snapshot`` (for copies that keep the asset's mesh) an asset of at most
    :data:`SNAPSHOT_VERTICES` vertices also keeps its vertex positions and the digest of its
    faces (:func:`same_mesh_offsets`).

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
    keep = snapshot and len(v) <= SNAPSHOT_VERTICES
    return Reference(
        int(n),
        index.astype(np.int64),
        points,
        normals,
        diagonal,
        anchors,
        anchor_normals,
        v.copy() if keep else None,
        faces_digest(f) if keep else None,
    )


def faces_digest(faces: NDArray) -> bytes:
    """SHA-256 of a face array (int64, little-endian, row-major): the same faces, the same
    digest."""
    return hashlib.sha256(np.ascontiguousarray(faces, dtype="<i8").tobytes()).digest()


def _similarity_to(x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x`` moved by the similarity that best maps it onto ``u`` (corresponding rows; Umeyama,
    no reflection)."""
    cx, cu = x.mean(axis=0), u.mean(axis=0)
    a, b = x - cx, u - cu
    left, sigma, right = np.linalg.svd(b.T @ a)
    sign = np.ones(3)
    sign[2] = np.sign(np.linalg.det(left @ right)) or 1.0
    rotation = (left * sign) @ right
    var = float(np.sum(a**2))
    scale = float(np.sum(sigma * sign)) / var if var > 0 else 1.0
    return scale * a @ rotation.T + cu


def _host_basis(u: NDArray[np.float64], f: NDArray[np.int64]) -> NDArray[np.float64]:
    """Columns (3·v each) spanning what a similarity and a smoothing do to the host ``u``."""
    from meshwm.mesh.edges import uniform_smoothing_operator
    from meshwm.mesh.unsmooth import cotangent_smooth

    c = u - u.mean(axis=0)
    columns = [np.zeros_like(u) + np.eye(3)[i] for i in range(3)]  # translations
    columns.append(c)  # scale
    columns += [np.cross(np.eye(3)[i], c) for i in range(3)]  # small rotations
    x = u
    for _ in range(HOST_STEPS):  # the cotangent flow (its weights change as it goes)
        x = cotangent_smooth(x, f, iterations=1)
        columns.append(x - u)
    neighbours, _ = uniform_smoothing_operator(len(u), f)
    x = u
    for _ in range(HOST_STEPS):  # powers of the uniform Laplacian
        x = neighbours @ x - x
        columns.append(x)
    return np.stack([col.ravel() for col in columns], axis=1)


def same_mesh_offsets(
    reference: Reference, vertices: NDArray, faces: NDArray
) -> NDArray[np.float64] | None:
    """The received mesh's offsets through its vertices' correspondence with the asset's.

    Applies only when ``reference`` keeps the asset's vertices and the received mesh has as
    many vertices and the same faces (else None): its vertices are moved onto the asset's by
    the similarity their correspondence fixes, the asset's positions subtracted, and the least
    squares fit of :func:`_host_basis` (a similarity, :data:`HOST_STEPS` cotangent-flow steps
    and powers of the uniform Laplacian, on the asset) removed; the rest, added to the asset's
    positions, is read as :func:`received_offsets` reads any surface.

    Returns
    -------
    (k,) float64 ndarray or None
    """
    u = reference.vertices
    if u is None or reference.faces_digest is None:
        return None
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if v.shape != u.shape or faces_digest(f) != reference.faces_digest:
        return None
    d = _similarity_to(v, u) - u
    basis = _host_basis(u, f)
    norms = np.linalg.norm(basis, axis=0)
    basis = basis[:, norms > 0] / norms[norms > 0]
    coef, *_ = np.linalg.lstsq(basis, d.ravel(), rcond=None)
    rest = d - (basis @ coef).reshape(d.shape)
    return received_offsets(reference, u + rest, f)


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


def host_changes(reference: Reference, vertices: NDArray, faces: NDArray) -> NDArray:
    """What light smoothing does to the unmarked asset, as offsets from its reference points.

    One and five uniform Laplacian steps (λ 0.5) and one cotangent step (MeshLab's), each
    applied to the asset (``vertices``, ``faces``) and read with :func:`received_offsets`:
    the directions in which decimation, subdivision and smoothing move *any* version of this
    surface (:func:`copy_signature` removes them from a copy's signature).

    Returns
    -------
    (k, 3) float64 ndarray
        One column per smoothing; 0 where a point is far.
    """
    from meshwm.mesh.edges import uniform_smoothing_operator
    from meshwm.mesh.unsmooth import cotangent_smooth

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    step, moved = uniform_smoothing_operator(len(v), f)
    columns = []
    x = v.copy()
    for k in range(5):
        x[moved] += 0.5 * ((step @ x)[moved] - x[moved])
        if k in (0, 4):
            columns.append(received_offsets(reference, x, f))
    columns.append(received_offsets(reference, cotangent_smooth(v, f, iterations=1), f))
    return np.nan_to_num(np.stack(columns, axis=1), nan=0.0)


def copy_signature(
    reference: Reference, vertices: NDArray, faces: NDArray, *, host: NDArray | None = None
) -> NDArray:
    """A marked copy's signature: its normal offsets from the (unmarked) reference.

    With ``host`` (:func:`host_changes` of the unmarked asset), the signature's high-passed
    component along the host's own smoothing directions is removed (least squares).  Embedding
    smooths a host's finest detail a little, so a raw signature shares a pattern with any
    smoothed or re-tessellated *unmarked* version of the asset: igea subdivided by Loop,
    unmarked, scored z 5.4 against its first copy's raw signature (the presence threshold over
    1,540 hypotheses is 6.1), and 0.4 against the signature with that pattern removed; the
    copy itself, decimated to 50 %, 36.6 and 34.9.

    Returns
    -------
    (k,) float32 ndarray
        NaN where the copy's surface is far from the reference (never, for a kept copy).
    """
    sig = received_offsets(reference, vertices, faces)
    if host is not None:
        fields = np.asarray(host, dtype=np.float64).reshape(len(sig), -1)
        h = np.stack([highpass(c, reference) for c in fields.T], axis=1)
        hs = highpass(sig, reference)
        ok = np.isfinite(hs) & np.all(np.isfinite(h), axis=1)
        if ok.sum() > h.shape[1]:
            coef, *_ = np.linalg.lstsq(h[ok], hs[ok], rcond=None)
            sig = sig - fields @ coef
    return sig.astype(np.float32)


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
