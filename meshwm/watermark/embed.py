"""Embedding on meshes: remesh, read the cover back, have the profile mark it, write it back."""

from __future__ import annotations

import time
from contextlib import nullcontext
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import CapacityError, GridError, MeshError
from meshwm.gim.recover import RecoveredGrid, recover_grid
from meshwm.gim.recover.expect import expected_reading
from meshwm.gim.remesh import GeometryImage, mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.edges import rows_all_distinct
from meshwm.message.payload import encode_id
from meshwm.message.scramble import arnold_scramble
from meshwm.metrics import bounding_box_diagonal, surface_distance
from meshwm.params import WatermarkParams
from meshwm.profiles import get_profile
from meshwm.profiles.base import Embedding, Profile
from meshwm.watermark.checks import check_gim, check_mark

__all__ = ["Embedded", "check_gim", "check_mark", "embed", "embed_gim"]


class Embedded(NamedTuple):
    """Result of :func:`embed`.

    Attributes
    ----------
    vertices : (n, 3) float64 ndarray
        The marked mesh's vertices.
    faces : (m, 3) int64 ndarray
        Its triangles.
    report : dict
        Figures of the embedding (see :func:`embed`).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    report: dict[str, Any]


def embed_gim(
    gim: NDArray, bits: NDArray, *, key: str | bytes, params: WatermarkParams | None = None
) -> Embedding:
    """Embed bits into a geometry image with the profile ``params.profile``.

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The cover geometry image, N = ``params.size``, finite.
    bits : (k,) array of 0/1
        The payload (already scrambled, for a mark).
    key : str or bytes
        The secret key.
    params : WatermarkParams, optional
        Defaults to ``WatermarkParams()``.

    Returns
    -------
    meshwm.profiles.base.Embedding
        The cover, the marked image (``changes`` is their difference) and the profile's report.

    Raises
    ------
    CapacityError
        More bits than the image has slots.

    Examples
    --------
    >>> n = 64
    >>> i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    >>> gim = np.stack([i, j, 0.1 * np.sin(6 * i) * np.cos(5 * j)], axis=-1)
    >>> bits = np.arange(16) % 2
    >>> p = WatermarkParams(size=n)
    >>> marked = embed_gim(gim, bits, key="k", params=p).marked
    >>> from meshwm.watermark import extract_gim
    >>> extract_gim(marked, 16, key="k", params=p).bits.tolist() == bits.tolist()
    True
    """
    params = params or WatermarkParams()
    gim = check_gim(gim, params)
    return get_profile(params.profile).embed(gim, bits, key=key, options=params.options)


def embed(
    vertices: NDArray,
    faces: NDArray,
    mark: NDArray | None = None,
    *,
    key: str | bytes,
    params: WatermarkParams | None = None,
    max_faces: int = DEFAULT_MAX_FACES,
    distances: bool = True,
    geometry_image: GeometryImage | None = None,
    ident: bytes | None = None,
    grid: bool = False,
) -> Embedded:
    """Watermark a triangle mesh: mark its own vertices (default), or remesh it to the grid.

    Parameters
    ----------
    vertices : (n, 3) float64 array_like
        The input mesh.
    faces : (m, 3) int array_like
        Its triangles.
    mark : (k, k) array of 0/1, optional
        The mark (1 = ink); default the bundled 32×32 logo.  It is Arnold-scrambled
        ``params.arnold_iterations`` times before embedding (step 5).
    key : str or bytes
        The secret key.
    params : WatermarkParams, optional
        Defaults to ``WatermarkParams()``.
    max_faces : int, optional
        Refuse larger inputs.
    distances : bool, optional
        Measure the surface distances (MeshLab, about a second at N = 256).
    ident : bytes, optional
        Embed this 8-byte identifier (:mod:`meshwm.message.payload`: CRC-32 and Reed-Solomon, 256
        code bits) instead of a mark; ``mark`` must then be None.  Read back with
        :func:`extract_id`.
    geometry_image : GeometryImage, optional
        With ``grid``: ``mesh_to_geometry_image(vertices, faces, size=params.size)`` computed
        earlier (the remesh is most of an embedding's time; a benchmark that marks one mesh at
        many strengths passes it in).  Not checked against ``vertices`` beyond its size.
    grid : bool, optional
        False (default): keep the input's mesh, move only its vertices
        (:mod:`meshwm.watermark.keep`; ``params.size`` is not used, the size follows the mesh).
        True: the paper's output, the N×N semi-regular grid mesh of the geometry image.

    Returns
    -------
    Embedded
        The marked mesh and a report: ``n``, ``capacity_bits``, ``used_bits``, ``carriers``,
        ``psnr``, and with ``distances``: ``mrms_rel`` (the larger one-sided RMS surface
        distance between the input and the output, over the input's bounding-box diagonal; with
        ``grid``, between the unmarked and marked grid meshes, the mark alone),
        ``hausdorff_rel`` and ``rms_rel`` (output against input).  Kept meshes: the input's
        vertices (moved) and faces; grid: the geometry-image grid, then any other components
        unchanged.

    Raises
    ------
    MeshError
        Input that cannot be remeshed.
    CapacityError
        A payload longer than the geometry image carries.
    """
    t0 = time.perf_counter()
    params = params or WatermarkParams()
    if ident is not None and mark is not None:
        raise ValueError("embed either a mark or an id, not both")
    mark = check_mark(mark)
    if ident is not None:
        bits = encode_id(ident)
    else:
        bits = arnold_scramble(mark, iterations=params.arnold_iterations).ravel()
    if not grid:
        if geometry_image is not None:
            raise ValueError("geometry_image is for grid=True only")
        out = _embed_kept(vertices, faces, bits, key=key, params=params, max_faces=max_faces)
        if distances:
            out.report.update(_distances_to_input(vertices, faces, out.vertices, out.faces))
    else:
        out = _embed_grid(
            vertices,
            faces,
            bits,
            key=key,
            params=params,
            max_faces=max_faces,
            distances=distances,
            geometry_image=geometry_image,
        )
    report = out.report
    if ident is not None:
        report["id"] = bytes(ident).hex()
    else:
        report["mark_size"] = int(mark.shape[0])
    report["seconds"] = time.perf_counter() - t0
    return out


def _distances_to_input(
    vertices: NDArray, faces: NDArray, out_v: NDArray, out_f: NDArray
) -> dict[str, float]:
    """MRMS, Hausdorff and RMS of the output against the input, over the input's diagonal."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    d = surface_distance(v, f, out_v, out_f)
    return {
        "mrms_rel": d.rms / d.diagonal,
        "hausdorff_rel": d.hausdorff / d.diagonal,
        "rms_rel": d.rms / d.diagonal,
    }


def _embed_kept(
    vertices: NDArray,
    faces: NDArray,
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    params: WatermarkParams,
    max_faces: int,
) -> Embedded:
    from meshwm.watermark.keep import embed_kept

    v, f = check_mesh(vertices, faces, max_faces=max_faces)
    kept = embed_kept(v, f, bits, key=key, params=params, max_faces=max_faces)
    report: dict[str, Any] = {"profile": params.profile, "mode": "kept", **kept.report}
    report["vertices"] = len(v)
    report["faces"] = len(f)
    return Embedded(kept.vertices, f, report)


def _embed_grid(
    vertices: NDArray,
    faces: NDArray,
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    params: WatermarkParams,
    max_faces: int,
    distances: bool,
    geometry_image: GeometryImage | None,
) -> Embedded:
    profile = get_profile(params.profile)
    if geometry_image is None:
        # What the profile keeps for this key and size (the robust one's keyed slot layout:
        # at N = 1024 0.06 s) made beside the remesh.
        warm = getattr(profile, "warm", None)
        with beside(warm, params.size, key=key, n_bits=len(bits)) if warm else nullcontext():
            g = mesh_to_geometry_image(vertices, faces, size=params.size, max_faces=max_faces)
    elif geometry_image.gim.shape != (params.size, params.size, 3):
        raise ValueError(
            f"geometry_image is {geometry_image.gim.shape[0]}-square, params.size is {params.size}"
        )
    else:
        g = geometry_image
    # The output mesh is made and read back exactly as extraction will (fold tips of cut
    # ends included) in a second thread, while the profile marks the image that reading is
    # expected to give; where the two differ, the profile marks what was read.  (igea, 134k
    # vertices, N = 1024: the embedding 3.09 -> 2.65 s, with the lazy row-sweep table 0.88 ->
    # 0.74 GB; the same bytes.)
    with beside(_written_and_read, g) as written:
        expected = expected_reading(g.gim, g.weld)
        marked = _mark(profile, expected, bits, key=key, params=params)
    out_v, out_f, n_grid_v, cover = written.result()
    if not np.array_equal(cover.gim, expected):
        marked = _mark(profile, cover.gim, bits, key=key, params=params)
    grid_v, grid_f = out_v[:n_grid_v], out_f[: len(out_f) - len(g.other_faces)]
    unmarked_v = grid_v.copy()
    out_v[cover.index.ravel()] = marked.marked.reshape(-1, 3)
    report: dict[str, Any] = {
        "n": params.size,
        "profile": params.profile,
        "mode": "grid",
        **marked.report,
    }
    # STL stores float32 and re-welds by position: distinct vertices must stay distinct.
    # (A sort of a hash of each row, exact in float64, not ``np.unique(axis=0)``'s sort of the
    # rows: 1.1 s at N = 1024.)
    as32 = out_v[:n_grid_v].astype(np.float32).astype(np.float64) + 0.0
    report["float32_distinct"] = rows_all_distinct(as32)
    if distances:
        diag = bounding_box_diagonal(unmarked_v)
        d_mark = surface_distance(unmarked_v, grid_f, out_v[:n_grid_v], grid_f)
        report["mrms_rel"] = d_mark.rms / diag
        report["mark_hausdorff_rel"] = d_mark.hausdorff / diag
        d_all = surface_distance(vertices, faces, out_v, out_f)
        report["hausdorff_rel"] = d_all.hausdorff / d_all.diagonal
        report["rms_rel"] = d_all.rms / d_all.diagonal
    report["vertices"] = len(out_v)
    report["faces"] = len(out_f)
    return Embedded(out_v, out_f, report)


def _written_and_read(
    g: GeometryImage,
) -> tuple[NDArray[np.float64], NDArray[np.int64], int, RecoveredGrid]:
    """The output mesh of ``g`` (the grid first, the other components after it), the grid's
    vertex count and the grid read back from it as extraction reads it."""
    out_v, out_f = geometry_image_to_mesh(
        g.gim, g.weld, other_vertices=g.other_vertices, other_faces=g.other_faces
    )
    n_grid_v = len(out_v) - len(g.other_vertices)
    try:
        cover = recover_grid(out_v[:n_grid_v], out_f[: len(out_f) - len(g.other_faces)])
    except GridError as exc:  # a remesher bug, not bad input
        raise MeshError(f"internal error: the geometry image does not read back ({exc})") from exc
    return out_v, out_f, n_grid_v, cover


def _mark(
    profile: Profile,
    gim: NDArray[np.float64],
    bits: NDArray[np.uint8],
    *,
    key: str | bytes,
    params: WatermarkParams,
) -> Embedding:
    """``profile.embed``, its ValueError a MeshError (CapacityError passes as it is)."""
    try:
        return profile.embed(gim, bits, key=key, options=params.options)
    except CapacityError:
        raise
    except ValueError as exc:
        raise MeshError(str(exc)) from exc
