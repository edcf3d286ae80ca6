"""The steps every bench run is made of: its parameters, the remesh cache, a scored extraction.

Also :class:`Tick`, which counts the units of work for the progress callback.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.apps.bench.data import KEY, SIZE
from meshwm.apps.bench.scoring import _error_text, score_extraction
from meshwm.errors import GridError, MeshError
from meshwm.gim.remesh import GeometryImage, mesh_to_geometry_image
from meshwm.params import WatermarkParams
from meshwm.profiles import PROFILES, options_type
from meshwm.watermark import Embedded, extract

Remesh = Callable[..., GeometryImage]
Progress = Callable[[int, int, str], None]


class Tick:
    """Counts work units and reports them to a ``progress(done, total, label)`` callable."""

    def __init__(self, total: int, progress: Progress | None):
        self.total, self.done, self.progress = total, 0, progress
        if progress:
            progress(0, total, "starting")

    def __call__(self, label: str, units: int = 1) -> None:
        self.done = min(self.total, self.done + units)
        if self.progress:
            self.progress(self.done, self.total, label)


def _digest(vertices: NDArray, faces: NDArray) -> str:
    h = hashlib.blake2b(digest_size=16)
    for a in (np.ascontiguousarray(vertices, np.float64), np.ascontiguousarray(faces, np.int64)):
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def remesh_cache() -> Remesh:
    """Remesh each mesh once: the benchmark embeds the same mesh many times (strength
    matching, curves) and passes the cached geometry image to :func:`meshwm.watermark.embed`."""
    last: dict[tuple, GeometryImage] = {}

    def cached(vertices: NDArray, faces: NDArray, **options: Any) -> GeometryImage:
        key = (_digest(vertices, faces), tuple(sorted(options.items())))
        if key not in last:
            last.clear()
            last[key] = mesh_to_geometry_image(vertices, faces, **options)
        return last[key]

    return cached


def bench_params(profile: str, step: float | None = None) -> WatermarkParams:
    """The parameters of every bench embedding: ``profile`` at N = :data:`SIZE` and ``step``,
    the value of the profile's strength option (``None``: the profile's default)."""
    if step is None:
        return WatermarkParams(profile=profile, size=SIZE)
    options = options_type(profile)(**{PROFILES[profile].strength: step})
    return WatermarkParams(profile=profile, size=SIZE, options=options)


def strength_of(params: WatermarkParams) -> float | None:
    value: float | None = getattr(params.options, PROFILES[params.profile].strength)
    return value


def step_used(report: dict[str, Any], params: WatermarkParams) -> float:
    """The step of an embedding: the report's (a default calibrated per mesh), else ``params``'."""
    step = report.get("step") or strength_of(params)
    if step is None:
        raise TypeError("the embedding reports no step and its params have none")
    return float(step)


def faces_of(marked: Embedded) -> NDArray[np.int64]:
    """The faces of a marked mesh (:func:`meshwm.watermark.embed` of a mesh always has them)."""
    if marked.faces is None:
        raise TypeError("a marked geometry image has no faces; embed a mesh")
    return marked.faces


def extract_scored(
    v: NDArray, f: NDArray, mark: NDArray[np.uint8], params: WatermarkParams
) -> tuple[dict, NDArray | None]:
    """Extract from a (possibly attacked) mesh and score it against ``mark``.

    Returns the fields of :func:`~meshwm.apps.bench.scoring.score_extraction` plus ``error``
    (``None``, or why no grid could be read), and the extracted mark (``None`` then).
    """
    try:
        found = extract(v, f, key=KEY, mark_size=mark.shape[0], expected=mark, params=params)
    except GridError as exc:
        return {**score_extraction(None, error="no grid found"), "error": _error_text(exc)}, None
    except MeshError as exc:
        return {**score_extraction(None, error="unreadable mesh"), "error": _error_text(exc)}, None
    return {**score_extraction(found.report), "error": None}, found.mark
