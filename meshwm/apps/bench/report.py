"""The benchmark's files: Markdown tables and JSON, written atomically into one folder.

:func:`write_outputs` writes :data:`BENCH_FILES` from a
:func:`~meshwm.apps.bench.runner.run_bench` result; :func:`paper_table_markdown` and
:func:`mesh_attacks_markdown` lay out its tables, :mod:`meshwm.apps.bench.plots` its pictures.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from meshwm._atomic import write_atomic
from meshwm.apps.bench.data import (
    ATTACKED_PSNR_ROW,
    CORR2_TARGET,
    FPR,
    MESH_ATTACKS,
    MRMS_TARGET,
    PAPER_ATTACKS,
    PAPER_MODELS,
    Attack,
    paper_attacks_of,
    paper_psnr,
)
from meshwm.apps.bench.plots import curves_png, paper_marks_png

#: Files written by :func:`write_outputs`.
BENCH_FILES = (
    "paper_table.md",
    "paper_table.json",
    "paper_marks.png",
    "mesh_attacks.md",
    "mesh_attacks.json",
    "curves.png",
    "bench.json",
)

#: Paper row id -> its title in a table.
_TITLES = {a.key: a.title for a in PAPER_ATTACKS}

# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def check_out(out: str | os.PathLike, *, force: bool = False) -> None:
    """Refuse, before any work, an ``out`` that is a file or already holds our files."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out}: exists and is not a folder")
    if not out.exists() and not out.resolve().parent.is_dir():
        raise ValueError(f"{out}: folder {out.parent} does not exist")
    if not force:
        present = [name for name in BENCH_FILES if (out / name).exists()]
        if present:
            raise ValueError(f"{out}: would overwrite {', '.join(present)}; use --force")


def _json_bytes(data: Any) -> bytes:
    return (json.dumps(data, indent=1, sort_keys=False, allow_nan=False) + "\n").encode()


def write_outputs(result: dict, out: str | os.PathLike, *, force: bool = False) -> list[Path]:
    """Write :data:`BENCH_FILES` into ``out`` (created if missing), each atomically."""
    check_out(out, force=force)
    out = Path(out)
    out.mkdir(exist_ok=True)
    head = {k: result[k] for k in ("meshwm_bench", "command", "settings")}
    payloads = {
        "paper_table.md": paper_table_markdown(result).encode(),
        "paper_table.json": _json_bytes({**head, **result["paper_table"]}),
        "paper_marks.png": paper_marks_png(result),
        "mesh_attacks.md": mesh_attacks_markdown(result).encode(),
        "mesh_attacks.json": _json_bytes({**head, **result["mesh_attacks"]}),
        "curves.png": curves_png(result),
        "bench.json": _json_bytes(result),
    }
    written = []
    for name in BENCH_FILES:
        write_atomic(out / name, payloads[name])
        written.append(out / name)
    return written


# --------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------


def _f(value: float | None, digits: int = 4) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def _g(value: float | None) -> str:
    return "–" if value is None else f"{value:.6g}"


def _pct(value: float | None, digits: int = 4) -> str:
    return "–" if value is None else f"{100 * value:.{digits}f}"


def _header(result: dict, title: str) -> list[str]:
    s = result["settings"]
    lines = [f"# {title}", ""]
    if result.get("command"):
        lines += ["Made by:", "", "```", result["command"], "```", ""]
    lines.append(
        f"N = {s['n']}, key `{s['key']}`, mark: the bundled 32×32 logo; profiles run: "
        f"{', '.join(s['profiles_run']) or 'none'} (default profile: {s['default_profile']})."
    )
    for p, why in s["profiles_skipped"].items():
        lines.append(f"Profile **{p}** skipped: {why}.")
    m = result["machine"]
    lines += [
        f"meshwm {m['versions']['meshwm']} on {m['cpu_count']} × {m['processor']}, "
        f"Python {m['python']}; see bench.json. docs/bench.md explains every column.",
        "",
    ]
    return lines


# The paper table ----------------------------------------------------------------------------


def _paper_summary_lines(pt: dict) -> list[str]:
    """The summary table: rows won per profile and paper table, and the rows not won."""
    lines = [
        "## Summary",
        "",
        "| profile | table | target PSNR | rows won | rows not won (by every model unless named) |",
        "|---|---|---:|---:|---|",
    ]
    for profile, tables in pt["summary"].items():
        for t in tables.values():
            lost: dict[str, list[str]] = {}
            for x in t["lost"]:
                lost.setdefault(x["row"], []).append(x["model"])
            n_models = len({r["model"] for r in pt["runs"] if r["profile"] == profile})
            text = "; ".join(
                _TITLES[k] + ("" if len(m) == n_models else f" ({', '.join(m)})")
                for k, m in lost.items()
            )
            lines.append(
                f"| {profile} | {t['table']} | {t['target_psnr']:.2f} dB"
                f"{'' if t['psnr_matched'] else ' (not matched)'} | {t['won']}/{t['rows']} "
                f"| {text or '–'} |"
            )
    lines.append("")
    return lines


def _paper_row_cells(attack: Attack, mine: dict[str, dict], profiles: list[str]) -> list[str]:
    """One attack's cells: the paper's figures, then ours per profile run."""
    first = next(iter(mine.values()))
    paper_corr = first["paper_corr"]
    cells = [
        attack.title,
        "invariant (no figure)" if paper_corr is None and attack.name else _f(paper_corr, 6),
        _f(first["paper_psnr"], 2),
    ]
    for p in profiles:
        if p not in mine:
            continue
        r = mine[p]
        won = {True: "✓", False: "✗", None: ""}[r["won"]]
        seen = f"BER {r['ber']:.3f}" if r["mark"] else "no grid"
        cells += [
            _f(r["corr2"], 6),
            _f(r["psnr"], 2),
            won,
            f"{seen}, {'detected' if r['detected'] else 'not detected'}",
        ]
    return cells


def _paper_model_lines(
    pt: dict, paper_model: str, table: str, paper_name: str, model: str, profiles: list[str]
) -> list[str]:
    """One of the paper's tables for one of our models (nothing if it was not run)."""
    runs = {
        r["profile"]: r
        for r in pt["runs"]
        if r["model"] == model and r["paper_model"] == paper_model
    }
    if not runs:
        return []
    lines = [
        f"## {table} ({paper_name}, {paper_psnr(paper_model):.2f} dB): {model}",
        "",
        "Ours: "
        + "; ".join(
            f"{p} profile step {r['step']:.6g}, PSNR {r['psnr']:.2f} dB "
            f"({r['iterations']} embeddings)"
            for p, r in runs.items()
        )
        + ".",
        "",
    ]
    head = "| Attack | paper corr | paper PSNR |"
    rule = "|---|---:|---:|"
    for p in profiles:
        if p in runs:
            head += f" {p}: corr | {p}: PSNR | ≥ paper | {p}: extracted (BER) |"
            rule += "---:|---:|:-:|---|"
    lines += [head, rule]
    for attack in paper_attacks_of(pt):
        mine = {
            r["profile"]: r
            for r in pt["rows"]
            if r["model"] == model and r["paper_model"] == paper_model and r["row"] == attack.key
        }
        lines.append("| " + " | ".join(_paper_row_cells(attack, mine, profiles)) + " |")
    lines.append("")
    return lines


def _lost_lines(pt: dict) -> list[str]:
    """The rows not won, each with the PSNR its curve says it would take."""
    lost = [r for r in pt["rows"] if r["won"] is False]
    lines = ["## Rows not won, and what PSNR they would take", ""]
    if not lost:
        return [*lines, "None: every row with a paper figure is at least the paper's.", ""]
    lines += [
        "From the curves (curves.png, `curves` in bench.json): the highest embedding PSNR "
        "at which corr2 reaches the paper's figure, for the same model, profile and attack.",
        "",
        "| profile | table | model | attack | ours | paper | PSNR it takes |",
        "|---|---|---|---|---:|---:|---|",
    ]
    for r in lost:
        lines.append(
            f"| {r['profile']} | {r['paper_table']} | {r['model']} | {_TITLES[r['row']]} "
            f"| {r['corr2']:.4f} | {r['paper_corr']:.4f} | {r['reason']} |"
        )
    lines.append("")
    return lines


def _noise_lines(pt: dict) -> list[str]:
    """The attacked PSNR of the random-noise row, ours beside the paper's."""
    noise = [r for r in pt["rows"] if r["row"] == ATTACKED_PSNR_ROW]
    if not noise:
        return []
    lines = [
        "## Attacked PSNR of the random-noise row",
        "",
        "| profile | model | table | ours | paper |",
        "|---|---|---|---:|---:|",
    ]
    lines += [
        f"| {r['profile']} | {r['model']} | {r['paper_table']} | {_f(r['psnr_attacked'], 2)} "
        f"| {r['paper_psnr']:.2f} |"
        for r in noise
    ]
    lines.append("")
    return lines


def paper_table_markdown(result: dict) -> str:
    """The paper's Tables 2-4 layout with the paper's figures beside ours, as Markdown."""
    lines = _header(result, "meshwm against the paper's Tables 2-4")
    pt = result["paper_table"]
    profiles = result["settings"]["profiles_run"]
    lines += [
        "Each of our models is marked at three strengths, matched to the PSNR of the paper's "
        "three models. **Correlation** is MATLAB's corr2 of the original and extracted marks; "
        "**PSNR** that of the watermarked model (for random noise: of the attacked model, as "
        "in the paper). ✓: ours ≥ the paper's. The extracted marks are in "
        "[paper_marks.png](paper_marks.png), one column per table below, one row per attack.",
        "",
    ]
    lines += _paper_summary_lines(pt)
    models = list(dict.fromkeys(r["model"] for r in pt["runs"]))
    for paper_model, table, paper_name in PAPER_MODELS:
        for model in models:
            lines += _paper_model_lines(pt, paper_model, table, paper_name, model, profiles)
    lines += _lost_lines(pt)
    lines += _noise_lines(pt)
    return "\n".join(lines)


# The mesh attacks ---------------------------------------------------------------------------


def _mesh_summary_lines(ma: dict) -> list[str]:
    """Per profile: required rows passing, MRMS within the target, meshes that cannot embed."""
    lines = ["## Summary", ""]
    for profile, s in ma["summary"].items():
        lines.append(
            f"- **{profile}**: {s['passed']}/{s['required']} required rows reach corr2 ≥ "
            f"{CORR2_TARGET}; mark distortion MRMS ≤ {100 * MRMS_TARGET:g} % on every mesh: "
            f"{'yes' if s['mrms_ok'] else 'no'}"
            + (f"; cannot embed: {', '.join(s['embed_failed'])}" if s["embed_failed"] else "")
        )
    return lines


def _distortion_lines(ma: dict) -> list[str]:
    """The embedding's distortion, one row per mesh and profile."""
    lines = [
        "",
        "## Distortion of the embedding",
        "",
        "PSNR of the geometry image; MRMS: the mark alone (unmarked vs marked geometry-image "
        "meshes); Hausdorff and RMS: output against input (remeshing included); all relative "
        "to the bounding-box diagonal, in %.",
        "",
        "| mesh | profile | step | PSNR dB | MRMS % | Hausdorff % | RMS % | MRMS ok | note |",
        "|---|---|---:|---:|---:|---:|---:|:-:|---|",
    ]
    for d in ma["distortion"]:
        ok = "" if d["mrms_rel"] is None else ("✓" if d["mrms_ok"] else "✗")
        lines.append(
            f"| {d['mesh']} | {d['profile']} | {_g(d['step'])} | {_f(d['psnr'], 2)} "
            f"| {_pct(d['mrms_rel'])} | {_pct(d['hausdorff_rel'], 3)} | {_pct(d['rms_rel'])} "
            f"| {ok} | {d['note']} |"
        )
    lines.append("")
    return lines


def _corr2_lines(ma: dict, profile: str, meshes: list[str]) -> list[str]:
    """corr2 of one profile: one row per attack, one column per mesh."""
    titles = {a.key: a.title for a in MESH_ATTACKS}
    required = {a.key for a in MESH_ATTACKS if a.required}
    rows = {(r["mesh"], r["row"]): r for r in ma["rows"] if r["profile"] == profile}
    lines = [
        f"## corr2, profile {profile}",
        "",
        "**Bold ✗**: a required row under the target; no grid: extraction found no grid.",
        "",
        "| attack | required | " + " | ".join(meshes) + " |",
        "|---|:-:|" + "---:|" * len(meshes),
    ]
    for key in ma["attacks"]:
        cells = [titles[key], "✓" if key in required else ""]
        for mesh in meshes:
            r = rows.get((mesh, key))
            if r is None:
                cells.append("–")
                continue
            text = "no grid" if r["note"] == "no grid found" else f"{r['corr2']:.3f}"
            cells.append(f"**{text} ✗**" if r["pass"] is False else text)
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def _every_row_lines(ma: dict, profiles: list[str], meshes: list[str]) -> list[str]:
    """Every row: BER, corr2, the decision and the note, per profile and mesh."""
    titles = {a.key: a.title for a in MESH_ATTACKS}
    lines = ["## Every row", ""]
    for profile in profiles:
        for mesh in meshes:
            rows = [r for r in ma["rows"] if r["profile"] == profile and r["mesh"] == mesh]
            if not rows:
                continue
            lines += [
                f"### {mesh}, profile {profile}",
                "",
                "| attack | required | BER | corr2 | detected | note |",
                "|---|:-:|---:|---:|:-:|---|",
            ]
            for r in rows:
                lines.append(
                    f"| {titles[r['row']]} | {'✓' if r['required'] else ''} | {r['ber']:.4f} "
                    f"| {r['corr2']:.4f} | {'yes' if r['detected'] else 'no'} | {r['note']} |"
                )
            lines.append("")
    return lines


def mesh_attacks_markdown(result: dict) -> str:
    """The mesh-attack table: distortion per mesh, then corr2/BER/detected per attack."""
    lines = _header(result, "meshwm under mesh attacks")
    ma = result["mesh_attacks"]
    lines += [
        f"Each mesh is marked at its profile's default strength; a **required** attack must "
        f"leave corr2 ≥ {CORR2_TARGET} (issue #4), the others show how far the mark goes "
        "beyond. **detected**: verify's decision (binomial p-value below "
        f"{FPR:g} / hypotheses). A mesh whose grid cannot be read counts as not detected, "
        "corr2 0 and BER 0.5 (note *no grid*).",
        "",
    ]
    lines += _mesh_summary_lines(ma)
    lines += _distortion_lines(ma)
    meshes = list(dict.fromkeys(d["mesh"] for d in ma["distortion"]))
    profiles = result["settings"]["profiles_run"]
    for profile in profiles:
        lines += _corr2_lines(ma, profile, meshes)
    lines += _every_row_lines(ma, profiles, meshes)
    return "\n".join(lines)
