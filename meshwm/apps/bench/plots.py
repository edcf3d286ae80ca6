"""The benchmark's pictures: the extracted marks of the paper table, and the strength curves.

Both are PNG bytes drawn from a :func:`~meshwm.apps.bench.runner.run_bench` result (or a
``bench.json`` read back); matplotlib is imported inside the functions, only when drawing.
"""

from __future__ import annotations

import io
import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from meshwm.apps.bench.data import (
    PAPER_ATTACKS,
    PAPER_MODELS,
    PAPER_TABLES,
    Attack,
    paper_attacks_of,
    paper_psnr,
)
from meshwm.apps.bench.scoring import mark_from_hex
from meshwm.message.mark import default_mark

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: Colours of the curves, one per model; line styles, one per profile.
_COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:olive"]
_STYLES = {"paper": "-", "robust": "--"}


def _figure(width_px: float, height_px: float, dpi: float = 100.0) -> Figure:
    """A matplotlib figure of that size in pixels, on the Agg canvas (no pyplot, no display)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_px / dpi, height_px / dpi), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def _png(fig: Figure) -> bytes:
    """The figure as PNG bytes (no ``Software`` metadata: the same bytes on every run)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", metadata={"Software": None})
    return buffer.getvalue()


def paper_marks_png(result: dict) -> bytes:
    """The extracted marks of the paper table: one row per attack, one column per run."""
    pt = result["paper_table"]
    runs = [(r["model"], r["paper_model"], r["paper_table"], r["profile"]) for r in pt["runs"]]
    runs.sort(key=lambda r: (r[3] != "paper", r[3], [m for m, *_ in PAPER_MODELS].index(r[1])))
    cells = {(r["model"], r["paper_model"], r["profile"], r["row"]): r for r in pt["rows"]}
    zoom, gap, left, top = 2, 14, 210, 64
    side = 32 * zoom
    attacks = paper_attacks_of(pt)
    n_cols, n_rows = len(runs) + 1, len(attacks)
    width = left + n_cols * (side + gap) + gap
    height = top + n_rows * (side + gap) + gap
    mosaic = np.ones((height - top, width - left, 3))
    fig = _figure(width, height)
    ax = fig.add_axes((left / width, 0, 1 - left / width, 1 - top / height))
    ax.set_axis_off()

    def put(row: int, col: int, tile: NDArray) -> None:
        y, x = gap + row * (side + gap), gap + col * (side + gap)
        mosaic[y : y + side, x : x + side] = tile

    def tile_of(mark: NDArray) -> NDArray:
        big = np.kron(mark, np.ones((zoom, zoom)))
        return np.repeat((1.0 - big)[..., None], 3, axis=2)

    original = default_mark(32)
    for i in range(n_rows):
        put(i, 0, tile_of(original))
    for j, (model, paper_model, _, profile) in enumerate(runs, start=1):
        for i, attack in enumerate(attacks):
            r = cells.get((model, paper_model, profile, attack.key))
            if r is None or not r["mark"]:
                put(i, j, np.full((side, side, 3), (0.85, 0.55, 0.55)))
            else:
                put(i, j, tile_of(mark_from_hex(r["mark"])))
    ax.imshow(mosaic, interpolation="nearest", aspect="equal")
    ax.set_xlim(-0.5, mosaic.shape[1] - 0.5)
    ax.set_ylim(mosaic.shape[0] - 0.5, -0.5)
    for i, attack in enumerate(attacks):
        y = 1 - (top + gap + i * (side + gap) + side / 2) / height
        fig.text(6 / width, y, attack.title, fontsize=7.5, va="center", ha="left")
    heads = [("original", "", "")] + [
        (m, f"{t.replace('Table ', 'T')}: {paper_psnr(pm):.2f}", p) for m, pm, t, p in runs
    ]
    for j, (a, b, c) in enumerate(heads):
        x = (left + gap + j * (side + gap) + side / 2) / width
        fig.text(
            x,
            1 - 8 / height,
            f"{a}\n{b}\n{c}".rstrip(),
            fontsize=6.5,
            va="top",
            ha="center",
            linespacing=1.2,
        )
    return _png(fig)


def _curve_panel(
    ax: Axes,
    attack: Attack,
    points: list[dict[str, Any]],
    series: list[tuple[str, str]],
    models: list[str],
) -> None:
    """One attack's panel: corr2 against PSNR per (model, profile), the paper's points."""
    for model, profile in series:
        pts = sorted(
            (p["psnr"], p["corr2"])
            for p in points
            if p["row"] == attack.key and p["model"] == model and p["profile"] == profile
        )
        if pts:
            x, y = zip(*pts, strict=True)
            ax.plot(
                x,
                y,
                _STYLES.get(profile, ":"),
                marker="o",
                markersize=3,
                color=_COLOURS[models.index(model) % len(_COLOURS)],
                label=f"{model}, {profile}",
            )
    for paper_model, table, _ in PAPER_MODELS:
        c = PAPER_TABLES[paper_model][attack.key]["corr"]
        ax.plot([paper_psnr(paper_model)], [c], "k*", markersize=9)
        ax.annotate(
            table.replace("Table ", "T"),
            (paper_psnr(paper_model), c),
            textcoords="offset points",
            xytext=(4, 4),
            fontsize=7,
        )
    ax.axhline(0, color="0.8", linewidth=0.8)
    ax.set_title(attack.title, fontsize=10)
    ax.set_xlabel("embedding PSNR (dB)", fontsize=8)
    ax.set_ylabel("corr2 after the attack", fontsize=8)
    ax.set_ylim(-0.65, 1.05)
    ax.tick_params(labelsize=7)
    ax.grid(True, color="0.9")


def curves_png(result: dict) -> bytes:
    """corr2 after each paper attack against the embedding PSNR; the paper's points as stars."""
    points = result["curves"]["points"]
    attacks = [a for a in PAPER_ATTACKS if a.key in result["curves"]["attacks"]]
    n_cols = 3
    n_rows = max(1, math.ceil(len(attacks) / n_cols))
    fig = _figure(1500, 380 * n_rows + 90)
    axes = fig.subplots(n_rows, n_cols, squeeze=False)
    series = list(dict.fromkeys((p["model"], p["profile"]) for p in points))
    models = list(dict.fromkeys(m for m, _ in series))
    for k, ax in enumerate(axes.ravel()):
        if k >= len(attacks):
            ax.set_axis_off()
            continue
        _curve_panel(ax, attacks[k], points, series, models)
    handles, labels = axes.ravel()[0].get_legend_handles_labels()
    star = axes.ravel()[0].plot([], [], "k*", markersize=9)[0]
    fig.legend(
        [*handles, star],
        [*labels, "paper (Tables 2-4)"],
        loc="upper center",
        ncol=min(6, len(labels) + 1),
        fontsize=8,
        frameon=False,
    )
    fig.subplots_adjust(
        left=0.05, right=0.99, bottom=0.07, top=1 - 60 / fig.bbox.height, hspace=0.45, wspace=0.22
    )
    return _png(fig)
