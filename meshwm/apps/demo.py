"""``meshwm demo``: the whole tool on one bundled mesh, in a minute.

Embeds the default 32×32 logo into the bundled spot mesh (public domain, Keenan Crane) at
N = 256, applies a few attacks that keep the connectivity, extracts blind from each, prints a
table and writes the meshes, the extracted marks and ``marks.png`` (original next to every
extracted mark) into the output folder.
"""

from __future__ import annotations

import io
import os
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from meshwm._atomic import write_atomic
from meshwm.attacks import apply_attack
from meshwm.detect import decide
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.message.mark import default_mark, save_mark
from meshwm.watermark import embed, extract

__all__ = ["DEMO_ATTACKS", "bundled_mesh_path", "run_demo"]

#: (label, attack name, options) run by the demo; the key is public, it is a demo.
DEMO_ATTACKS: tuple[tuple[str, str | None, dict], ...] = (
    ("none (PLY)", None, {}),
    ("OBJ round trip", "round_trip", {"suffix": ".obj"}),
    ("STL round trip", "round_trip", {"suffix": ".stl"}),
    ("rotation+translation+scale", "similarity", {"seed": 1}),
    ("vertex+face reorder", "reorder", {"seed": 2}),
    ("noise 0.05%", "noise", {"seed": 3, "amplitude": 0.0005}),
    ("noise 0.3%", "noise", {"seed": 4, "amplitude": 0.003}),
    ("Laplacian smoothing x30", "laplacian", {"iterations": 30}),
    ("8-bit quantisation", "quantize", {"bits": 8}),
    ("crop 30% by a plane", "crop", {"seed": 5, "fraction": 0.3}),
)

_KEY = "meshwm-demo"


def bundled_mesh_path() -> Path:
    """Path of the bundled spot mesh (``meshwm/data/spot.ply``)."""
    return Path(str(resources.files("meshwm") / "data" / "spot.ply"))


def _marks_figure(panels: list[tuple[str, NDArray[np.uint8]]], path: Path) -> None:
    """Original and extracted marks side by side, 4× enlarged, labelled."""
    zoom, pad, label_h = 4, 10, 28
    side = panels[0][1].shape[0] * zoom
    width = len(panels) * (side + pad) + pad
    image = Image.new("L", (width, side + label_h + 2 * pad), 255)
    draw = ImageDraw.Draw(image)
    for k, (label, mark) in enumerate(panels):
        x = pad + k * (side + pad)
        tile = Image.fromarray(np.where(mark == 1, 0, 255).astype(np.uint8))
        # Image.NEAREST is set at run time (mypy cannot see it); Image.Resampling needs Pillow
        # 9.1 and the floor is 9.0.
        nearest = Image.NEAREST  # type: ignore[attr-defined]
        image.paste(tile.resize((side, side), nearest), (x, pad))
        for line, text in enumerate(_wrap(label, side)):
            draw.text((x, pad + side + 4 + 11 * line), text, fill=0)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    write_atomic(path, buffer.getvalue())


def _wrap(text: str, width: int) -> list[str]:
    per_line = max(8, width // 6)
    words, lines, line = text.split(), [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > per_line:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return [*lines, line][:2]


def run_demo(out: str | os.PathLike, *, echo=print) -> list[dict]:
    """Run the demo, write its files into ``out`` and return the table rows."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    mark = default_mark(32)
    vertices, faces = read_mesh(bundled_mesh_path())
    echo(f"embedding a 32×32 logo into spot ({len(vertices)} vertices) at N=256 ...")
    result = embed(vertices, faces, mark, key=_KEY, grid=True)
    r = result.report
    marked_path = out / "spot_marked.ply"
    assert result.faces is not None  # embed of a mesh returns its faces (for mypy)
    write_mesh(marked_path, result.vertices, result.faces)
    save_mark(out / "mark_original.png", mark)
    echo(
        f"  PSNR {r['psnr']:.2f} dB, mark distortion MRMS {100 * r['mrms_rel']:.4f}% of the "
        f"bbox diagonal, output vs input Hausdorff {100 * r['hausdorff_rel']:.3f}%, "
        f"{r['seconds']:.1f} s -> {marked_path}"
    )
    rows = []
    panels: list[tuple[str, NDArray[np.uint8]]] = [("original", mark)]
    v0, f0 = read_mesh(marked_path)
    cases = [*DEMO_ATTACKS, ("wrong key", None, {})]
    for k, (label, name, options) in enumerate(cases):
        v, f = (v0, f0) if name is None else apply_attack(name, v0, f0, **options)
        slug = "".join(ch if ch.isalnum() else "_" for ch in label.lower()).strip("_")
        if name is not None:
            write_mesh(out / f"attacked_{k}_{slug}.ply", v, f)
        key = "not-the-key" if label == "wrong key" else _KEY
        found = extract(v, f, key=key, expected=mark)
        save_mark(out / f"extracted_{k}_{slug}.png", found.mark)
        fr = found.report
        rows.append(
            {
                "attack": label,
                "ber": fr["ber"],
                "correlation": fr["correlation"],
                "p_value": fr["p_value"],
                "detected": decide(fr).detected,
            }
        )
        panels.append((label, found.mark))
    echo("")
    echo(f"{'attack':<28} {'BER':>7} {'corr2':>7} {'p-value':>9}  detected")
    for row in rows:
        echo(
            f"{row['attack']:<28} {row['ber']:7.4f} {row['correlation']:7.4f} "
            f"{row['p_value']:9.2g}  {'yes' if row['detected'] else 'no'}"
        )
    _marks_figure(panels, out / "marks.png")
    echo(f"\nmarks (original, then extracted per attack): {out / 'marks.png'}")
    return rows
