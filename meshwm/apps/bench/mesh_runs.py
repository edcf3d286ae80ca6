"""The mesh-attack table of one mesh under one profile: distortion, then every attack."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.apps.bench.data import CORR2_TARGET, KEY, MRMS_TARGET, SIZE, Attack, apply_bench_attack
from meshwm.apps.bench.meshes import Model
from meshwm.apps.bench.scoring import _error_text, _sig, score_extraction
from meshwm.apps.bench.steps import (
    Tick,
    bench_params,
    extract_scored,
    faces_of,
    step_used,
    strength_of,
)
from meshwm.errors import MeshError
from meshwm.message.mark import default_mark
from meshwm.params import WatermarkParams
from meshwm.watermark import Embedded, embed


def _mesh_attack_row(
    model: Model,
    profile: str,
    attack: Attack,
    marked: Embedded,
    mark: NDArray[np.uint8],
    params: WatermarkParams,
) -> dict:
    """One attack on the marked mesh, then extraction; an attack that raises is a result."""
    t1 = time.perf_counter()
    try:
        av, af = apply_bench_attack(attack, marked.vertices, faces_of(marked))
    except Exception as exc:  # an attack that fails on a mesh is a result, not a crash
        scored = {**score_extraction(None, error="attack failed"), "error": _error_text(exc)}
    else:
        scored, _ = extract_scored(av, af, mark, params)
    return {
        "mesh": model.name,
        "profile": profile,
        "row": attack.key,
        "attack": attack.title,
        "name": attack.name,
        "params": attack.params,
        "seed": attack.seed,
        "required": attack.required,
        **scored,
        "pass": bool(scored["corr2"] >= CORR2_TARGET) if attack.required else None,
        "seconds": round(time.perf_counter() - t1, 3),
    }


def mesh_attack_runs(
    model: Model, profile: str, attacks: Sequence[Attack], tick: Tick
) -> tuple[dict, list[dict]]:
    """Embed at the profile's default strength, then every mesh attack: (distortion, rows)."""
    mark = default_mark(32)
    params = bench_params(profile)
    t0 = time.perf_counter()
    distortion: dict[str, Any] = {
        "mesh": model.name,
        "profile": profile,
        "n": SIZE,
        "step": strength_of(params),  # None: calibrated per mesh (the report's step, below)
        "vertices_in": len(model.vertices),
    }
    try:
        marked = embed(model.vertices, model.faces, mark, key=KEY, params=params, grid=True)
    except MeshError as exc:
        distortion.update(
            psnr=None,
            mrms_rel=None,
            hausdorff_rel=None,
            rms_rel=None,
            mark_hausdorff_rel=None,
            note=f"cannot embed: {_error_text(exc)}",
            seconds=round(time.perf_counter() - t0, 3),
        )
        tick(f"{model.name} {profile}: cannot embed", 1 + len(attacks))
        return distortion, []
    r = marked.report
    distortion.update(
        {
            k: _sig(r.get(k))
            for k in ("psnr", "mrms_rel", "hausdorff_rel", "rms_rel", "mark_hausdorff_rel")
        }
    )
    distortion.update(
        step=_sig(step_used(r, params)),
        mrms_ok=bool(r["mrms_rel"] <= MRMS_TARGET),
        carriers=r.get("carriers"),
        note="",
        seconds=round(time.perf_counter() - t0, 3),
    )
    tick(f"{model.name} {profile}: embedded")
    rows = []
    for attack in attacks:
        rows.append(_mesh_attack_row(model, profile, attack, marked, mark, params))
        tick(f"{model.name} {profile} {attack.key}")
    return distortion, rows
