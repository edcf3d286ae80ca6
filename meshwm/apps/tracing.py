"""What an embed records in a registry, and what a read asks of it.

The glue between the registry's storage (:mod:`meshwm.apps.registry`) and the informed reader
(:mod:`meshwm.readers.informed`, :mod:`meshwm.watermark.trace`): for each marked mesh of a
file, its asset (a hash of the input mesh, its shape descriptor, its reference) and the copy
(the payload, the recipient, the signature sealed under the key; never the key).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES

__all__ = [
    "MarkedMesh",
    "mark_payload",
    "mesh_sha256",
    "record_copies",
    "trace_mesh",
    "upgrade_assets",
]


class MarkedMesh(NamedTuple):
    """One mesh of an embed, before and after: what :func:`record_copies` records.

    Attributes
    ----------
    name : str
        The asset's name (the input file's name, and the mesh's when the file has several).
    vertices : (n, 3) float64 ndarray
        The input mesh's vertices.
    faces : (m, 3) int64 ndarray
    marked : (n, 3) float64 ndarray
        The marked copy's vertices (kept mode: same count and order; grid mode: the grid).
    marked_faces : (k, 3) int64 ndarray
    payload : str
        16 hex digits of the id, or ``mark:`` and :func:`mark_payload`.
    n : int
        The geometry-image size the copy was marked at.
    """

    name: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    marked: NDArray[np.float64]
    marked_faces: NDArray[np.int64]
    payload: str
    n: int


def mesh_sha256(vertices: NDArray, faces: NDArray) -> str:
    """SHA-256 of a mesh's geometry (float64 vertices, int64 faces): the asset's identity,
    the same whichever format the file was in."""
    h = hashlib.sha256()
    v = np.ascontiguousarray(vertices, dtype="<f8")
    f = np.ascontiguousarray(faces, dtype="<i8")
    h.update(np.asarray(v.shape, dtype="<i8").tobytes())
    h.update(v.tobytes())
    h.update(np.asarray(f.shape, dtype="<i8").tobytes())
    h.update(f.tobytes())
    return h.hexdigest()


def mark_payload(mark: NDArray | None, ident: bytes | None = None) -> str:
    """A copy's payload as the registry keeps it: the id's 16 hex digits, else ``mark:`` and
    the SHA-256 of the 0/1 mark image's packed bits (its side first)."""
    if ident is not None:
        return bytes(ident).hex()
    if mark is None:
        raise ValueError("a payload is an id or a mark; neither was given")
    bits = np.asarray(mark, dtype=np.uint8)
    data = np.asarray(bits.shape, dtype="<i8").tobytes() + np.packbits(bits.ravel()).tobytes()
    return "mark:" + hashlib.sha256(data).hexdigest()


def record_copies(
    registry: Any,
    meshes: Sequence[MarkedMesh],
    *,
    key: str | bytes,
    recipient: str | None,
    output_name: str,
    output_sha256: str,
    params: Mapping[str, Any],
    max_faces: int = DEFAULT_MAX_FACES,
) -> list[tuple[int, int]]:
    """Record each marked mesh (its asset, then the copy) in ``registry``; (asset, copy) ids.

    The reference is made from the input mesh (:func:`meshwm.readers.informed.make_reference`;
    with the input's vertex positions when the copy keeps its mesh), the signature from the
    marked one, sealed under ``key``.
    """
    from meshwm.apps.registry import AssetEntry, CopyEntry
    from meshwm.readers.descriptor import CROP_REFERENCE, make_crops
    from meshwm.readers.informed import (
        REFERENCE_SIZE,
        copy_signature,
        host_changes,
        make_reference,
        seal_signature,
    )
    from meshwm.readers.probe import PROBE, make_probe
    from meshwm.readers.registration import shape_descriptor

    out = []
    for mesh in meshes:
        kept = mesh.marked.shape == mesh.vertices.shape and np.array_equal(
            mesh.faces, mesh.marked_faces
        )
        reference = make_reference(
            mesh.vertices, mesh.faces, max_faces=max_faces, snapshot=bool(kept)
        )
        host = host_changes(reference, mesh.vertices, mesh.faces)
        signature = copy_signature(reference, mesh.marked, mesh.marked_faces, host=host)
        asset = AssetEntry(
            name=mesh.name,
            input_sha256=mesh_sha256(mesh.vertices, mesh.faces),
            vertices=len(mesh.vertices),
            faces=len(mesh.faces),
            descriptor=shape_descriptor(mesh.vertices, mesh.faces),
            references={
                REFERENCE_SIZE: reference.to_bytes(),
                PROBE: make_probe(reference.anchors),
                CROP_REFERENCE: make_crops(reference.anchors, reference.anchor_normals),
            },
        )
        copy = CopyEntry(
            payload=mesh.payload,
            recipient=recipient,
            output_name=output_name,
            output_sha256=output_sha256,
            n=mesh.n,
            params=dict(params),
            signature=seal_signature(signature, reference, key=key),
        )
        out.append(registry.record_embed(asset, copy))
    return out


def upgrade_assets(registry: Any) -> tuple[list[int], list[int]]:
    """Give each asset recorded by an earlier meshwm what embed records now and it lacks: the
    probe (:func:`meshwm.readers.probe.make_probe`) and the crop descriptors
    (:func:`meshwm.readers.descriptor.make_crops`), both made from its reference's anchors.

    Parameters
    ----------
    registry : meshwm.apps.registry.Registry
        Open for writing.

    Returns
    -------
    added, skipped : list of int
        The assets given either; those without a reference to make them from.

    Raises
    ------
    RegistryError
        An asset's reference is damaged (nothing is added for it or after it).
    """
    from meshwm.errors import RegistryError
    from meshwm.readers.descriptor import CROP_REFERENCE, make_crops
    from meshwm.readers.informed import REFERENCE_SIZE, Reference
    from meshwm.readers.probe import PROBE, make_probe

    added, skipped = [], []
    for asset in registry.assets():
        sizes = registry.reference_sizes(asset.id)
        if PROBE in sizes and CROP_REFERENCE in sizes:
            continue
        if REFERENCE_SIZE not in sizes:
            skipped.append(asset.id)
            continue
        try:
            reference = Reference.from_bytes(registry.references(asset.id)[REFERENCE_SIZE])
            blobs = {}
            if PROBE not in sizes:
                blobs[PROBE] = make_probe(reference.anchors)
            if CROP_REFERENCE not in sizes:
                blobs[CROP_REFERENCE] = make_crops(reference.anchors, reference.anchor_normals)
        except ValueError as exc:
            raise RegistryError(
                f"{registry.name}: asset {asset.id} ({asset.name}): damaged reference ({exc})"
            ) from None
        if registry.add_references(asset.id, blobs):
            added.append(asset.id)
    return added, skipped


def trace_mesh(
    vertices: NDArray,
    faces: NDArray,
    *,
    key: str | bytes,
    registry: Any,
    fpr: float,
    candidates: int | None = None,
    max_faces: int = DEFAULT_MAX_FACES,
) -> dict[str, Any]:
    """The informed reader on one mesh: :func:`meshwm.watermark.trace.trace`'s report, with
    ``detected``."""
    from meshwm.watermark.trace import CANDIDATES, trace

    found = trace(
        vertices,
        faces,
        key=key,
        registry=registry,
        fpr=fpr,
        candidates=candidates or CANDIDATES,
        max_faces=max_faces,
    )
    return {"detected": found.detected, **found.report}
