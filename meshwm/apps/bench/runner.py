"""Running the benchmark: :func:`run_bench` plans a run, runs both tables and gathers the result.

The paper table (:func:`~meshwm.apps.bench.paper_runs.paper_model_runs`) marks each model at the
three PSNRs of the paper's Tables 2-4 and attacks it with the paper's rows, then adds the curve
points; the mesh-attack table (:func:`~meshwm.apps.bench.mesh_runs.mesh_attack_runs`) marks each
mesh at its profile's default strength and attacks it with
:data:`~meshwm.apps.bench.data.MESH_ATTACKS`.  :func:`run_bench` runs both and returns one
JSON-ready dict, which :func:`~meshwm.apps.bench.report.write_outputs` turns into files.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

from meshwm.apps.bench.data import (
    CORR2_TARGET,
    CURVE_ATTACKS,
    CURVE_PSNRS,
    FPR,
    KEY,
    MESH_ATTACKS,
    MRMS_TARGET,
    PAPER_ATTACKS,
    PAPER_MODELS,
    PAPER_TABLES,
    PSNR_TOLERANCE,
    QUICK_MESH_ATTACKS,
    QUICK_PAPER_ATTACKS,
    SIZE,
    Attack,
)
from meshwm.apps.bench.mesh_runs import mesh_attack_runs
from meshwm.apps.bench.meshes import bundled_models, load_model, meshes_in, packaged_spot, show_path
from meshwm.apps.bench.paper_runs import paper_model_runs
from meshwm.apps.bench.report import check_out, write_outputs
from meshwm.apps.bench.scoring import judge_paper_rows, summarise_mesh_attacks, summarise_paper
from meshwm.apps.bench.steps import (
    Progress,
    Remesh,
    Tick,
    bench_params,
    remesh_cache,
    strength_of,
)
from meshwm.apps.machine import versions_info
from meshwm.params import WatermarkParams
from meshwm.profiles import PROFILES

MACHINE_PACKAGES = (
    "numpy",
    "scipy",
    "trimesh",
    "libigl",
    "pymeshlab",
    "PyWavelets",
    "scikit-fuzzy",
    "matplotlib",
)


class _Plan(NamedTuple):
    """What a run measures: the meshes and rows of both tables, and the curve strengths."""

    paper_models: list[tuple[str, Path]]
    attack_meshes: list[tuple[str, Path]]
    paper_attacks: list[Attack]
    attacks: list[Attack]
    curve_psnrs: tuple[float, ...]

    @property
    def curve_attacks(self) -> list[str]:
        """The paper rows with a curve, of those measured."""
        return [a.key for a in self.paper_attacks if a.key in CURVE_ATTACKS]

    def units(self, n_profiles: int) -> int:
        """Units of work (ticks) of a run over ``n_profiles`` profiles."""
        per_paper_model = len(PAPER_MODELS) * (1 + len(self.paper_attacks)) + len(
            self.curve_psnrs
        ) * (1 + len(self.curve_attacks))
        return n_profiles * (
            len(self.paper_models) * per_paper_model
            + len(self.attack_meshes) * (1 + len(self.attacks))
        )


def _plan(*, quick: bool, meshes: str | os.PathLike | None) -> _Plan:
    if quick:
        spot = [("spot", packaged_spot())]
        return _Plan(
            spot,
            spot,
            [a for a in PAPER_ATTACKS if a.key in QUICK_PAPER_ATTACKS],
            [a for a in MESH_ATTACKS if a.key in QUICK_MESH_ATTACKS],
            CURVE_PSNRS[quick],
        )
    paper_models = bundled_models()
    attack_meshes = meshes_in(meshes) if meshes is not None else bundled_models()
    return _Plan(
        paper_models, attack_meshes, list(PAPER_ATTACKS), list(MESH_ATTACKS), CURVE_PSNRS[quick]
    )


def _settings(*, quick: bool, profiles: Sequence[str], active: list[str], plan: _Plan) -> dict:
    """The ``settings`` of ``bench.json``: what was run, with which targets."""
    return {
        "quick": quick,
        "key": KEY,
        "n": SIZE,
        "mark": "default_mark(32)",
        "profiles": list(profiles),
        "profiles_run": active,
        "profiles_skipped": {},  # every profile runs; the field stays for bench.json's readers
        "default_profile": WatermarkParams().profile,
        "default_steps": {p: strength_of(bench_params(p)) for p in active},
        "fpr": FPR,
        "corr2_target": CORR2_TARGET,
        "mrms_target": MRMS_TARGET,
        "psnr_tolerance": PSNR_TOLERANCE,
        "paper_models": [{"name": n, "path": show_path(p)} for n, p in plan.paper_models],
        "attack_meshes": [{"name": n, "path": show_path(p)} for n, p in plan.attack_meshes],
        "curve_psnrs": list(plan.curve_psnrs),
    }


def _run_paper_table(plan: _Plan, active: list[str], remesh: Remesh, tick: Tick) -> dict:
    """Every paper model under every profile: ``runs``, ``rows`` and curve ``points``."""
    out: dict[str, list[dict]] = {"runs": [], "rows": [], "points": []}
    for name, path in plan.paper_models:
        model = load_model(name, path)
        for profile in active:
            runs, rows, points = paper_model_runs(
                model, profile, plan.paper_attacks, plan.curve_psnrs, remesh, tick
            )
            out["runs"] += runs
            out["rows"] += rows
            out["points"] += points
    return out


def _run_mesh_attacks(plan: _Plan, active: list[str], tick: Tick) -> dict:
    """Every attack mesh under every profile: ``distortion`` and ``rows``."""
    out: dict[str, list[dict]] = {"distortion": [], "rows": []}
    for name, path in plan.attack_meshes:
        model = load_model(name, path)
        for profile in active:
            distortion, rows = mesh_attack_runs(model, profile, plan.attacks, tick)
            out["distortion"].append(distortion)
            out["rows"] += rows
    return out


def run_bench(
    *,
    quick: bool = False,
    out: str | os.PathLike | None = None,
    meshes: str | os.PathLike | None = None,
    profiles: Sequence[str] | None = None,
    progress: Progress | None = None,
    force: bool = False,
    command: str | None = None,
) -> dict:
    """Run the benchmark; return everything as one JSON-ready dict (and write it to ``out``).

    Parameters
    ----------
    quick : bool
        Only the packaged spot mesh, 4 curve strengths and a few mesh attacks (CI).
    out : path, optional
        Write the files of :data:`~meshwm.apps.bench.report.BENCH_FILES` there
        (:func:`~meshwm.apps.bench.report.write_outputs`).
    meshes : path, optional
        Folder of meshes for the mesh-attack table (default: the bundled ones; with
        ``quick``: ignored, the packaged spot).
    profiles : sequence of str, optional
        Default: every profile of :data:`meshwm.profiles.PROFILES`, by name (``("paper",
        "robust")``); each is run (``settings.profiles_skipped`` is empty).
    progress : callable, optional
        Called as ``progress(done, total, label)`` after each unit of work.
    force : bool
        Allow overwriting existing files in ``out``.
    command : str, optional
        The command line, recorded in the output.
    """
    started = time.perf_counter()
    if out is not None:
        check_out(out, force=force)
    profiles = tuple(profiles or sorted(PROFILES))
    for p in profiles:
        WatermarkParams(profile=p)  # ValueError for an unknown profile, before any work
    active = list(profiles)
    plan = _plan(quick=quick, meshes=meshes)
    tick = Tick(plan.units(len(active)), progress)
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    paper = _run_paper_table(plan, active, remesh_cache(), tick)
    seconds["paper_table_and_curves"] = round(time.perf_counter() - t0, 3)
    t0 = time.perf_counter()
    mesh = _run_mesh_attacks(plan, active, tick)
    seconds["mesh_attacks"] = round(time.perf_counter() - t0, 3)
    judge_paper_rows(paper["rows"], paper["points"])
    settings = _settings(quick=quick, profiles=profiles, active=active, plan=plan)
    seconds["total"] = round(time.perf_counter() - started, 3)
    result: dict[str, Any] = {
        "meshwm_bench": 1,
        "command": command,
        "settings": settings,
        "machine": versions_info(*MACHINE_PACKAGES),
        "paper_table": {
            "paper": PAPER_TABLES,
            "attacks": [a.key for a in plan.paper_attacks],
            "runs": paper["runs"],
            "rows": paper["rows"],
            "summary": summarise_paper(paper["rows"], paper["runs"]),
        },
        "curves": {"attacks": plan.curve_attacks, "points": paper["points"]},
        "mesh_attacks": {
            "attacks": [a.key for a in plan.attacks],
            "distortion": mesh["distortion"],
            "rows": mesh["rows"],
            "summary": summarise_mesh_attacks(mesh["rows"], mesh["distortion"]),
        },
        "seconds": seconds,
    }
    if out is not None:
        write_outputs(result, out, force=force)
        result["seconds"]["total"] = round(time.perf_counter() - started, 3)
    return result
