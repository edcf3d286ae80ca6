"""Pure row builders of the benchmark: scores, strength matching, the paper rows' verdicts.

Each function takes and returns plain numbers, dicts and lists (JSON-ready), so the tables can
be rebuilt and tested without running an embedding.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from meshwm.apps.bench.data import FPR, MRMS_TARGET, PSNR_TOLERANCE
from meshwm.detect import decide
from meshwm.metrics import psnr


def _sig(value: float | None, digits: int = 6) -> float | None:
    """A float to ``digits`` significant digits (JSON-friendly; None and inf kept)."""
    if value is None or not math.isfinite(value):
        return value
    return float(f"{value:.{digits}g}")


def _mark_hex(mark: NDArray) -> str:
    return np.packbits(np.asarray(mark, dtype=np.uint8).ravel()).tobytes().hex()


def mark_from_hex(text: str, side: int = 32) -> NDArray[np.uint8]:
    """The inverse of the ``mark`` field of a row: a (side, side) 0/1 array."""
    bits = np.unpackbits(np.frombuffer(bytes.fromhex(text), dtype=np.uint8))
    return bits[: side * side].reshape(side, side)


def score_extraction(report: dict | None, *, error: str | None = None, fpr: float = FPR) -> dict:
    """The table fields of one extraction: ``ber``, ``corr2``, ``p_value``, ``detected``, ``note``.

    Parameters
    ----------
    report : dict or None
        :func:`meshwm.watermark.extract`'s report (with ``expected`` given); ``None`` with
        ``error`` when extraction raised.
    error : str, optional
        Why no grid could be read: counted as not detected, corr2 0 and BER 0.5.

    Examples
    --------
    >>> score_extraction(None, error="no grid")["corr2"]
    0.0
    >>> r = score_extraction({"ber": 0.0, "correlation": 1.0, "p_value": 1e-300, "hypotheses": 1})
    >>> r["detected"], r["note"]
    (True, '')
    """
    if report is None:
        return {"ber": 0.5, "corr2": 0.0, "p_value": 1.0, "detected": False, "note": error or ""}
    corr = float(report["correlation"])
    note = ""
    if not math.isfinite(corr):
        corr, note = 0.0, "extracted mark is constant (corr2 undefined, counted as 0)"
    return {
        "ber": _sig(float(report["ber"])),
        "corr2": _sig(corr),
        "p_value": _sig(float(report["p_value"])),
        "detected": decide(report, fpr=fpr).detected,
        "note": note,
    }


def _error_text(exc: BaseException) -> str:
    """An exception as one line: its type and message."""
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def match_step(
    embed_at: Callable[[float | None], tuple[float, float]],
    target: float,
    step: float | None = None,
    *,
    tolerance: float = PSNR_TOLERANCE,
    max_iterations: int = 8,
    bounds: tuple[float, float] = (1e-6, 1.0),
) -> dict:
    """Find the step whose embedding PSNR is within ``tolerance`` dB of ``target``.

    PSNR falls by 20 dB per decade of step (distortion is linear in it), so each iteration
    scales the step by ``10 ** ((psnr - target) / 20)``.

    Parameters
    ----------
    embed_at : callable
        step -> (PSNR in dB, the step used): one embedding.  ``None`` asks for the profile's
        default, which may be calibrated per mesh; the step it reports is scaled from there.
    target : float
        The PSNR wanted, dB.
    step : float, optional
        The first step tried (default ``None``).

    Returns
    -------
    dict
        ``step``, ``psnr`` (of the last embedding, the one at ``step``), ``iterations`` and
        ``converged``.

    Examples
    --------
    >>> r = match_step(lambda s: (20 * math.log10(1 / (s or 0.01)) + 30, s or 0.01), 80.0)
    >>> r["converged"], round(r["psnr"], 3), r["iterations"]
    (True, 80.0, 2)
    """
    low, high = bounds
    value, step = embed_at(step)
    iterations = 1
    while abs(value - target) >= tolerance and iterations < max_iterations:
        new = min(high, max(low, step * 10 ** ((value - target) / 20)))
        if new == step:
            break
        value, step = embed_at(new)
        iterations += 1
    return {
        "step": float(step),
        "psnr": float(value),
        "iterations": iterations,
        "converged": bool(abs(value - target) < tolerance),
    }


def psnr_needed(points: Sequence[tuple[float, float]], target: float) -> dict:
    """Where a curve reaches a correlation: the highest PSNR with corr2 >= ``target``.

    Parameters
    ----------
    points : sequence of (psnr, corr2)
        One curve (one model, profile and attack), any order.
    target : float
        The correlation to reach (the paper's).

    Returns
    -------
    dict
        ``psnr_needed``: the PSNR (dB) at which the curve first reaches ``target`` coming from
        weak marks (linear interpolation between the bracketing points; the weakest point
        itself if it already reaches it), or ``None``; ``reason``: that in words.

    Examples
    --------
    >>> psnr_needed([(90, 0.2), (70, 0.6), (50, 1.0)], 0.8)["psnr_needed"]
    60.0
    >>> psnr_needed([(90, 0.2), (70, 0.3)], 0.8)["psnr_needed"] is None
    True
    """
    pts = sorted(((float(p), float(c)) for p, c in points), key=lambda pc: -pc[0])
    if not pts:
        return {"psnr_needed": None, "reason": "no curve measured"}
    for k, (p, c) in enumerate(pts):
        if c >= target:
            if k == 0:
                needed = p
            else:
                p0, c0 = pts[k - 1]
                needed = p0 + (target - c0) * (p - p0) / (c - c0)
            return {
                "psnr_needed": _sig(needed, 5),
                "reason": f"the curve reaches corr2 {target:.3f} at {needed:.1f} dB",
            }
    best_p, best_c = max(pts, key=lambda pc: pc[1])
    return {
        "psnr_needed": None,
        "reason": (
            f"not reached at any measured strength ({pts[0][0]:.1f} to {pts[-1][0]:.1f} dB); "
            f"best corr2 {best_c:.3f} at {best_p:.1f} dB"
        ),
    }


def attacked_psnr(reference: NDArray, index: NDArray, attacked: NDArray) -> float:
    """PSNR (dB) of an attacked mesh against the unmarked one, over the geometry-image samples.

    ``index`` is the (N, N) vertex index of the samples; both meshes have the vertex order of
    :func:`meshwm.watermark.embed`'s output (the gim attacks keep it).
    """
    return psnr(np.asarray(reference)[index], np.asarray(attacked)[index])


def judge_paper_rows(rows: list[dict], curves: list[dict]) -> None:
    """Fill ``won``, ``psnr_needed`` and ``reason`` of paper-table rows, in place.

    A row with a paper figure is won when our corr2 >= the paper's; otherwise the curve of the
    same model, profile and attack says at what PSNR it would be.
    """
    by_curve: dict[tuple, list[tuple[float, float]]] = {}
    for pt in curves:
        by_curve.setdefault((pt["model"], pt["profile"], pt["row"]), []).append(
            (pt["psnr"], pt["corr2"])
        )
    for row in rows:
        row["won"], row["psnr_needed"], row["reason"] = None, None, ""
        if row["paper_corr"] is None:
            continue
        row["won"] = bool(row["corr2"] >= row["paper_corr"])
        if not row["won"]:
            found = psnr_needed(
                by_curve.get((row["model"], row["profile"], row["row"]), []), row["paper_corr"]
            )
            row["psnr_needed"], row["reason"] = found["psnr_needed"], found["reason"]


def summarise_paper(rows: list[dict], runs: list[dict]) -> dict:
    """Per profile and paper table: rows won out of rows with a figure, and the rows lost."""
    out: dict[str, dict] = {}
    for run in runs:
        prof = out.setdefault(run["profile"], {})
        table = prof.setdefault(
            run["paper_model"],
            {
                "table": run["paper_table"],
                "target_psnr": run["target_psnr"],
                "psnr_matched": True,
                "rows": 0,
                "won": 0,
                "lost": [],
            },
        )
        table["psnr_matched"] &= bool(run["converged"])
    for row in rows:
        if row["won"] is None:
            continue
        table = out[row["profile"]][row["paper_model"]]
        table["rows"] += 1
        table["won"] += int(row["won"])
        if not row["won"]:
            table["lost"].append(
                {
                    k: row[k]
                    for k in ("model", "row", "corr2", "paper_corr", "psnr_needed", "reason")
                }
            )
    return out


def summarise_mesh_attacks(rows: list[dict], distortion: list[dict]) -> dict:
    """Per profile: required rows passing (corr2 >= 0.9), the failures, MRMS within target."""
    out: dict[str, dict] = {}
    for d in distortion:
        prof = out.setdefault(
            d["profile"],
            {
                "required": 0,
                "passed": 0,
                "failed": [],
                "mrms_ok": True,
                "embed_failed": [],
            },
        )
        if d.get("note"):
            prof["embed_failed"].append(d["mesh"])
        elif d["mrms_rel"] is not None:
            prof["mrms_ok"] &= bool(d["mrms_rel"] <= MRMS_TARGET)
    for row in rows:
        if not row["required"]:
            continue
        prof = out[row["profile"]]
        prof["required"] += 1
        if row["pass"]:
            prof["passed"] += 1
        else:
            prof["failed"].append(f"{row['mesh']}: {row['attack']} (corr2 {row['corr2']})")
    return out
