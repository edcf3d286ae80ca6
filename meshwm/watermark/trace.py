"""Trace a received mesh to a registered copy: which asset, which copy, how sure.

Composition only: the registry's shape descriptors pick the candidate assets
(:func:`meshwm.readers.registration.shape_descriptor`) and their probes order them
(:func:`meshwm.readers.probe.probe_residuals`: among near-duplicates, the one the received
surface fits first; :func:`~meshwm.readers.probe.partial_residuals` where a crop moved the
received frame), each candidate's reference gives the
pose (:func:`meshwm.readers.registration.register`, in two steps:
:class:`~meshwm.readers.registration.PoseSearch`) and the received offsets
(:func:`meshwm.readers.informed.received_offsets`) — and, when the received mesh has the asset's
own vertices and faces, the offsets through that correspondence
(:func:`meshwm.readers.informed.same_mesh_offsets`) —, and each copy's signature, unsealed with
the key, is tested against them (:func:`meshwm.readers.informed.identify`).  Candidates are tried
in that order (:func:`ranked_assets`), each first through its principal frames (cheap), then
those whose frames did not fit through the rotations spread over SO(3) (one whose probe fitted
a crop at once, after its own frames); the first that identifies a copy stops the search.
The decision counts every hypothesis that could have been tried (every candidate × pose ×
copy, each pose tried among them), so stopping early never raises the false-positive rate.

The registry is anything with the methods of :class:`RegistryView` (the storage lives in
:mod:`meshwm.apps.registry`; this module does not import it).
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.detect import DEFAULT_FPR, is_detected
from meshwm.readers.descriptor import (
    CROP_REFERENCE,
    CROPS,
    partial_distance,
    read_crops,
)
from meshwm.readers.informed import (
    REFERENCE_SIZE,
    Reference,
    identify,
    received_offsets,
    same_mesh_offsets,
    unseal_signature,
)
from meshwm.readers.probe import (
    PROBE,
    PROBE_FIT,
    ProbeError,
    partial_residuals,
    probe_residuals,
)
from meshwm.readers.registration import (
    PoseSearch,
    ReceivedSurface,
    descriptor_distance,
    shape_descriptor,
)

__all__ = [
    "CANDIDATES",
    "MAX_REGISTRATION_RMS",
    "PARTIAL_FITTED",
    "PRESELECTED",
    "VERTEX_HYPOTHESES",
    "RegistryView",
    "Traced",
    "Tracer",
    "nearest_assets",
    "ranked_assets",
    "trace",
]

#: Candidate assets tried, nearest descriptors first.
CANDIDATES = 10
#: Nearest descriptors whose probes are measured, to pick the candidates among them.
PRESELECTED = 100
#: Nearest descriptors whose probes are fitted to a received crop (its own asset ranked
#: 1st-48th of 1,000 on 30 test crops; each probe fitted costs ~2 ms).
PARTIAL_FITTED = 64
#: A pose whose residual (over the reference's diagonal) is larger than this is not the asset.
MAX_REGISTRATION_RMS = 0.01
#: Readings through the received mesh's own vertices (the same mesh as the asset), per copy:
#: counted for every candidate, whether or not it applies.
VERTEX_HYPOTHESES = 1


class RegistryView(Protocol):
    """What tracing reads from a registry."""

    def descriptors(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]: ...

    def references(self, asset_id: int) -> Mapping[int, bytes]: ...

    def references_of(self, asset_ids: Sequence[int], *, n: int) -> Mapping[int, bytes]: ...

    def copies(self, asset_id: int | None = None) -> Sequence[Any]: ...

    def asset(self, asset_id: int) -> Any: ...


def nearest_assets(
    registry: RegistryView,
    vertices: NDArray,
    faces: NDArray,
    *,
    among: Sequence[int] | None = None,
    count: int | None = None,
) -> list[int]:
    """Registered asset ids, the nearest shape descriptor to the mesh's first.

    An asset recorded with crop descriptors
    (:func:`meshwm.readers.descriptor.crop_descriptors`, under
    :data:`~meshwm.readers.descriptor.CROP_REFERENCE`) is as near as the nearest of its
    descriptor and its crops' (:func:`~meshwm.readers.descriptor.partial_distance`): a
    received crop of it ranks near it.

    Parameters
    ----------
    registry : RegistryView
    vertices, faces : array_like
        The received mesh.
    among : sequence of int, optional
        Only these assets (default: every registered one).
    count : int, optional
        At most this many (default: all).

    Returns
    -------
    list of int
        Ties keep the registry's order (by asset id).

    Raises
    ------
    ValueError
        Damaged crop descriptors in the registry (the message names their asset).
    """
    ids, table = registry.descriptors()
    if among is not None:
        keep = np.isin(ids, np.asarray(list(among), dtype=np.int64))
        ids, table = ids[keep], table[keep]
    if not len(ids):
        return []
    query = shape_descriptor(vertices, faces)
    stored = registry.references_of([int(a) for a in ids], n=CROP_REFERENCE)
    if stored:
        crops = np.full((len(ids), CROPS, table.shape[1]), np.nan)
        for i, asset_id in enumerate(ids.tolist()):
            if asset_id in stored:
                try:
                    crops[i] = read_crops(stored[asset_id])
                except ValueError:
                    raise ValueError(
                        f"registered asset {asset_id}: damaged crop descriptors"
                    ) from None
        distance = partial_distance(query, table, crops)
    else:
        distance = descriptor_distance(query, table)
    return [int(ids[i]) for i in np.argsort(distance, kind="stable")[:count]]


def ranked_assets(
    registry: RegistryView,
    vertices: NDArray,
    faces: NDArray,
    *,
    count: int = CANDIDATES,
    preselected: int = PRESELECTED,
) -> list[int]:
    """The candidate assets of a received mesh, the likeliest first.

    The ``preselected`` nearest shape descriptors (:func:`nearest_assets`), then among them
    those whose probe fits the received surface (:func:`meshwm.readers.probe.probe_residuals`
    at most :data:`~meshwm.readers.probe.PROBE_FIT`) by their residual, then the others in
    descriptor order; the first ``count``.  Where no probe fits in the received frame (a crop
    moves it) and there are more preselected assets than ``count``, the probes are fitted to
    the surface instead (those of the nearest :data:`PARTIAL_FITTED`, with
    :func:`meshwm.readers.probe.partial_residuals`, searched from the nearest descriptor on:
    with the assets' crop descriptors, a crop's own asset is near the front) and those that
    fit that way come first.  Which assets are tried depends on the
    received mesh and the registry only, never on a key.

    Parameters
    ----------
    registry : RegistryView
    vertices, faces : array_like
        The received mesh.
    count, preselected : int, optional

    Returns
    -------
    list of int

    Raises
    ------
    ValueError
        A damaged probe in the registry (the message names its asset).
    """
    return _ranked(registry, vertices, faces, count=count, preselected=preselected)[0]


def _ranked(
    registry: RegistryView,
    vertices: NDArray,
    faces: NDArray,
    *,
    count: int,
    preselected: int,
) -> tuple[list[int], set[int]]:
    """:func:`ranked_assets`, and those of them whose probe fitted a crop (no probe fitted in
    the received frame, and theirs fitted the surface)."""
    near = nearest_assets(registry, vertices, faces, count=max(count, preselected))
    stored = registry.references_of(near, n=PROBE)
    probes = [stored.get(a) for a in near]
    try:
        residual = probe_residuals(vertices, faces, probes)
    except ProbeError as exc:
        raise ValueError(f"registered asset {near[exc.index]}: damaged probe") from None
    cropped = False
    if not np.any(residual <= PROBE_FIT) and len(near) > count:
        # Searched in descriptor order (every probe read and checked by now): with the
        # assets' crops, the nearest descriptors put a crop's asset near the front (among
        # 1,000 assets: first on 4 of 30 test crops, 48th at worst), where the frame
        # residuals put it 23rd-81st.
        residual = np.full(len(near), np.inf)
        fitted = min(len(near), PARTIAL_FITTED)
        residual[:fitted] = partial_residuals(vertices, faces, probes[:fitted])
        cropped = True
    fits = [i for i in np.argsort(residual, kind="stable") if residual[i] <= PROBE_FIT]
    rest = [i for i in range(len(near)) if not residual[i] <= PROBE_FIT]
    order = [near[i] for i in fits + rest][:count]
    fitted_crop = {near[i] for i in fits} & set(order) if cropped else set()
    return order, fitted_crop


class Traced(NamedTuple):
    """Result of :func:`trace`.

    Attributes
    ----------
    detected : bool
        A registered copy was identified at the false-positive rate asked for.
    report : dict
        ``reader`` ("informed"), ``asset_id``, ``asset``, ``copy_id``, ``id`` (the copy's
        payload), ``recipient``, ``p_value`` (a copy of the asset is present) over
        ``hypotheses``, ``z``, ``versus_z`` and ``versus_p_value`` (the best copy against the
        runner-up) over ``alternatives`` (the asset's other copies), ``asset_detected``,
        ``present`` (fraction of reference points the received surface covers),
        ``correspondence`` ("pose": the received surface registered to the reference;
        "vertices": the received mesh is the asset's own mesh, read vertex by vertex),
        ``registration_rms``, ``candidates`` (what was tried, nearest first) and ``seconds``.

    Notes
    -----
    Two decisions, each at ``fpr``.  *Presence*: the best copy's correlation p-value times
    every hypothesis the tracer could test (candidates × (poses + :data:`VERTEX_HYPOTHESES`) ×
    copies).  *Identity*, made only
    once presence holds: the best copy against the runner-up, on the difference of their
    signatures, times the asset's other copies (the alternatives it could be mistaken for).
    Against a registered alternative the difference test's true null mean is negative (the
    alternative's own pattern), so its zero-mean p-value is conservative.
    """

    detected: bool
    report: dict[str, Any]


class _Candidate(NamedTuple):
    asset_id: int
    reference: Reference | None
    offsets: NDArray[np.float64] | None
    same: NDArray[np.float64] | None
    copies: list[Any]
    pose_hypotheses: int
    rms: float | None
    settled: bool  # the principal frames fitted: the spread would give the same pose
    note: str | None


class Tracer:
    """A received mesh, posed against its candidate assets once, traced with any key.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any pose, any tessellation).
    registry : RegistryView
    candidates : int, optional
        How many assets (nearest shape descriptors first) may be tried.
    max_faces : int, optional
    """

    def __init__(
        self,
        vertices: NDArray,
        faces: NDArray,
        registry: RegistryView,
        *,
        candidates: int = CANDIDATES,
        max_faces: int = DEFAULT_MAX_FACES,
    ) -> None:
        if isinstance(candidates, bool) or not isinstance(candidates, int) or candidates < 1:
            raise ValueError(f"candidates must be a positive integer, got {candidates!r}")
        self._v, self._f = check_mesh(vertices, faces, max_faces=max_faces)
        self._registry = registry
        self._order, self._partial = _ranked(
            registry, self._v, self._f, count=candidates, preselected=PRESELECTED
        )
        self._copies = {a: list(registry.copies(a)) for a in self._order}
        self._posed: dict[tuple[int, bool], _Candidate] = {}
        self._searches: dict[int, tuple[Reference, NDArray[np.float64] | None, PoseSearch]] = {}
        self._surface: ReceivedSurface | None = None

    @property
    def hypotheses(self) -> int:
        """Every hypothesis the tracer can test: candidates × (poses + vertex reading) × copies."""
        from meshwm.readers.registration import POSE_HYPOTHESES

        per_copy = POSE_HYPOTHESES + VERTEX_HYPOTHESES
        return max(1, sum(per_copy * max(1, len(c)) for c in self._copies.values()))

    def _candidate(self, asset_id: int, *, spread: bool) -> _Candidate:
        """The asset posed: through its principal frames only (``spread`` False, the cheap first
        look), or on to the rotations spread over SO(3) where those do not fit."""
        if (asset_id, spread) in self._posed:
            return self._posed[asset_id, spread]
        copies = [c for c in self._copies[asset_id] if getattr(c, "signature", None)]
        blob = self._registry.references(asset_id).get(REFERENCE_SIZE)
        cand: _Candidate
        if blob is None or not copies:
            cand = _Candidate(
                asset_id, None, None, None, copies, 0, None, True, "no reference or no copy"
            )
        else:
            if asset_id not in self._searches:  # the reference read and posed once
                reference = Reference.from_bytes(blob)
                self._searches[asset_id] = (
                    reference,
                    same_mesh_offsets(reference, self._v, self._f),
                    PoseSearch(
                        self._received(),
                        reference.anchors,
                        reference_normals=reference.anchor_normals,
                    ),
                )
            reference, same, search = self._searches[asset_id]
            pose = search.spread() if spread else search.frames()
            moved = pose.scale * self._v @ pose.rotation.T + pose.translation
            offsets = None
            note = None
            if pose.rms > MAX_REGISTRATION_RMS:
                note = f"no pose fits (residual {pose.rms:.2g} of the diagonal)"
            else:
                offsets = received_offsets(reference, moved, self._f)
            cand = _Candidate(
                asset_id,
                reference,
                offsets,
                same,
                copies,
                pose.hypotheses,
                pose.rms,
                pose.settled,
                note,
            )
        self._posed[asset_id, spread] = cand
        return cand

    def _received(self) -> ReceivedSurface:
        """The received mesh prepared for posing, once for every candidate."""
        if self._surface is None:
            self._surface = ReceivedSurface(self._v, self._f)
        return self._surface

    def _looks(self) -> Iterator[tuple[int, bool]]:
        """The candidates in their order through their principal frames, then, for those whose
        frames did not fit, again with the spread (a wrong candidate ranked first must not pay
        the spread before the right one has had its cheap look).  A candidate whose probe
        fitted a crop (:func:`meshwm.readers.probe.partial_residuals`; it is then ranked before
        those that did not) has its spread right after its own frames look: it is the likely
        asset, and the frames of the candidates after it seldom fit a crop that moved the
        frame (each such look costs a search and a polish: about 1 s per candidate on
        human_neutral's crops, ten of them before the first one's spread found its pose)."""

        def unsettled(asset_id: int) -> bool:
            return not self._candidate(asset_id, spread=False).settled

        for asset_id in self._order:
            yield asset_id, False
            if asset_id in self._partial and unsettled(asset_id):
                yield asset_id, True
        for asset_id in self._order:
            if asset_id not in self._partial and unsettled(asset_id):
                yield asset_id, True

    def trace(self, *, key: str | bytes, fpr: float = DEFAULT_FPR) -> Traced:
        """Identify the registered copy the mesh carries, with ``key``."""
        t0 = time.perf_counter()
        hypotheses = self.hypotheses
        tried: list[dict[str, Any]] = []
        best: dict[str, Any] | None = None
        detected = False
        for asset_id, spread in self._looks():
            cand = self._candidate(asset_id, spread=spread)
            entry: dict[str, Any] = {
                "asset_id": asset_id,
                "poses": cand.pose_hypotheses,
                "registration_rms": cand.rms,
            }
            tried.append(entry)
            # The vertex-by-vertex reading does not depend on the pose: made at the first look.
            readings = [
                (label, offsets)
                for label, offsets in (
                    ("pose", cand.offsets),
                    ("vertices", None if spread else cand.same),
                )
                if offsets is not None
            ]
            if not readings or cand.reference is None:
                entry["note"] = cand.note
                continue
            signatures = [
                unseal_signature(c.signature, cand.reference, key=key) for c in cand.copies
            ]
            read = [(label, o, *identify(o, signatures, cand.reference)) for label, o in readings]
            correspondence, offsets, k, score, versus = min(read, key=lambda r: r[3].p_value)
            entry.update(z=score.z, p_value=score.p_value)
            # Two decisions: a copy of this asset is present (every hypothesis counted), then
            # which one (the best against each other copy it could be: the runner-up first).
            alternatives = len(signatures) - 1
            told = versus is None or is_detected(versus.p_value, fpr=fpr, hypotheses=alternatives)
            found = {
                "asset_id": asset_id,
                "copy_id": int(cand.copies[k].id),
                "id": cand.copies[k].payload,
                "recipient": cand.copies[k].recipient,
                "p_value": score.p_value,
                "z": score.z,
                "rho": score.rho,
                "versus_z": None if versus is None else versus.z,
                "versus_p_value": None if versus is None else versus.p_value,
                "alternatives": alternatives,
                "present": float(np.mean(np.isfinite(offsets))),
                "correspondence": correspondence,
                "registration_rms": cand.rms,
            }
            if best is None or score.p_value < best["p_value"]:
                best = found
            if is_detected(score.p_value, fpr=fpr, hypotheses=hypotheses):
                best = found
                best["asset_detected"] = True
                detected = told
                if not told:
                    best["note"] = (
                        "a registered copy of this asset is present, but which one is not told "
                        "apart at this false-positive rate"
                    )
                break
        report: dict[str, Any] = {"reader": "informed", "registry": True}
        if best is not None:
            report.update(best)
            report["asset"] = self._registry.asset(best["asset_id"]).name
        else:
            report.update(p_value=1.0, id=None)
        if not detected:  # the nearest copy is named, never claimed
            report["nearest_id"] = report.pop("id", None)
            report["id"] = None
        report["hypotheses"] = hypotheses
        report["candidates"] = tried
        report["seconds"] = time.perf_counter() - t0
        return Traced(detected, report)


def trace(
    vertices: NDArray,
    faces: NDArray,
    *,
    key: str | bytes,
    registry: RegistryView,
    fpr: float = DEFAULT_FPR,
    candidates: int = CANDIDATES,
    max_faces: int = DEFAULT_MAX_FACES,
) -> Traced:
    """Which registered asset and copy a received mesh is (the informed reader).

    ``Tracer(vertices, faces, registry, ...).trace(key=key, fpr=fpr)``.

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    """
    t0 = time.perf_counter()
    out = Tracer(vertices, faces, registry, candidates=candidates, max_faces=max_faces).trace(
        key=key, fpr=fpr
    )
    out.report["seconds"] = time.perf_counter() - t0
    return out
