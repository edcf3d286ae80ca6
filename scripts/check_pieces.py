"""A marked mesh joined to another object in one mesh: read whole, and piece by piece.

A scene exported as one object, or a kit of props joined (Blender's Join), puts the marked mesh
in one mesh with other objects.  For every mesh: embed a 64-bit id (``meshwm.embed``, the
input's mesh kept, ``check_keep.py``'s key and id), join the marked mesh to another dev mesh
set beside it (its copy scaled to 1.5 times the marked mesh's bounding-box diagonal, two
diagonals along x; ``stanford_bunny``, which has more vertices than every mesh but igea; for
``stanford_bunny`` and ``igea``, ``kitten``, which has fewer), write the joined mesh as one PLY,
attack it, and verify it as a user does (``meshwm.mesh.asset.read_asset`` then
``meshwm.watermark.assets.verify_asset`` at FPR 1e-6: the whole mesh read first, then each
piece big enough for the id alone, every reading's hypotheses counted).  A cell is ``ok`` and
the piece that read (``whole`` or ``k/n``) when the id is detected, else ``no``; the seconds of
the verification follow.  ``whole only`` is what the whole mesh's readers give alone
(``meshwm.watermark.Decoder`` of the joined mesh, as before pieces were read).

    python scripts/check_pieces.py [--meshes spot fandisk ...] [--jobs 2] [--out F]
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_keep import DEV, FPR, IDENT, KEY, add_run_options, load, run_names, through_file

from meshwm.attacks import apply_attack
from meshwm.detect import decide
from meshwm.mesh.asset import read_asset
from meshwm.metrics import bounding_box_diagonal
from meshwm.watermark import Decoder, embed
from meshwm.watermark.assets import embed_asset, verify_asset

ATTACKS: dict[str, list[tuple[str, dict[str, Any]]]] = {
    "none": [],
    "similarity, reorder": [("similarity", {}), ("reorder", {})],
    "noise 0.1 %": [("noise", {"amplitude": 0.001})],
    "10 flips": [("flip_edges", {"count": 10})],
    "quantize 16 bits": [("quantize", {"bits": 16})],
}


def partner_of(name: str) -> str:
    return "kitten" if name in ("stanford_bunny", "igea") else "stanford_bunny"


def joined(
    v: np.ndarray, f: np.ndarray, other: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """``(v, f)`` and ``other`` beside it (scaled to 1.5 diagonals, two diagonals along x)."""
    ov, of = other
    diag = bounding_box_diagonal(v)
    ov = (ov - ov.mean(axis=0)) * (1.5 * diag / bounding_box_diagonal(ov))
    ov = ov + v.mean(axis=0) + np.array([2.0 * diag, 0.0, 0.0])
    return np.concatenate([v, ov]), np.concatenate([f, of + len(v)])


def _asset(v: np.ndarray, f: np.ndarray) -> Any:
    """``(v, f)`` written as one PLY and read back as a user's file."""
    return through_file(v, f, ".ply", read_asset)


def _verify(v: np.ndarray, f: np.ndarray, key: str) -> tuple[str, float]:
    asset = _asset(v, f)
    t0 = time.perf_counter()
    row = verify_asset(asset, key=key, ident=IDENT, fpr=FPR)[0]
    seconds = time.perf_counter() - t0
    if not row["detected"]:
        return "no", seconds
    piece = row.get("piece")
    return ("ok " + (f"{piece['index']}/{piece['of']}" if piece else "whole")), seconds


def _whole_only(v: np.ndarray, f: np.ndarray) -> str:
    got = Decoder(v, f).extract_id(key=KEY, expected=IDENT)
    verdict = decide(got.report, fpr=FPR, found_id=got.id, expected_id=IDENT.hex())
    return "ok" if verdict.detected else "no"


def _split(v: np.ndarray, f: np.ndarray, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
    """The piece of ``(v, f)`` on vertices ``start .. stop - 1``, on its own."""
    own = f[(f >= start).all(axis=1) & (f < stop).all(axis=1)]
    return v[start:stop], own - start


def run_mesh(name: str, joined_input: bool = False) -> dict[str, Any]:
    v, f = load(name)
    partner = partner_of(name)
    row: dict[str, Any] = {"mesh": name, "V": len(v), "partner": partner, "cells": {}}
    other = load(partner)
    if joined_input:
        jv, jf = joined(v, f, other)
        marks = embed_asset(_asset(jv, jf), key=KEY, ident=IDENT)
        found = marks.meshes[0]
        row["pieces"] = found.get("pieces")
        row["mrms"], row["hausdorff"] = found["mrms_rel"], found["hausdorff_rel"]
        jv = marks.asset.positions  # the file's rows, in the order written
        assert jv.shape == (len(v) + len(other[0]), 3)
        row["cells"]["mesh alone"] = _verify(*_split(jv, jf, 0, len(v)), KEY)
        row["cells"]["partner alone"] = _verify(*_split(jv, jf, len(v), len(jv)), KEY)
    else:
        marked = embed(v, f, key=KEY, ident=IDENT, distances=False)
        jv, jf = joined(marked.vertices, f, other)
        row["whole only"] = _whole_only(jv, jf)
    row["partner_V"] = len(jv) - len(v)
    for label, steps in ATTACKS.items():
        av, af = jv, jf
        for attack, options in steps:
            av, af = apply_attack(attack, av, af, seed=7, **options)
        row["cells"][label] = _verify(av, af, KEY)
    row["wrong key"] = _verify(jv, jf, "another key")
    return row


def table(rows: list[dict[str, Any]], joined_input: bool = False) -> str:
    labels = list(rows[0]["cells"])
    first = "pieces marked | MRMS | Hausdorff" if joined_input else "whole only"
    head = f"| mesh | vertices | joined to (vertices) | {first} | "
    head += " | ".join(labels) + " | wrong key |"
    lines = [head, "|" + "---|" * (len(labels) + (7 if joined_input else 5))]
    for r in rows:
        cells = [f"{c} ({s:.0f} s)" for c, s in (*r["cells"].values(), r["wrong key"])]
        if joined_input:
            p = r["pieces"]
            marked = f"{p['marked']} of {p['of']}" if p else "whole"
            front = f"{marked} | {r['mrms']:.4%} | {r['hausdorff']:.3%}"
        else:
            front = r["whole only"]
        lines.append(
            f"| {r['mesh']} | {r['V']} | {r['partner']} ({r['partner_V']}) | {front} | "
            + " | ".join(cells)
            + " |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_options(parser)
    parser.set_defaults(meshes=DEV)
    parser.add_argument(
        "--joined-input", action="store_true", help="join before marking (one mesh of two pieces)"
    )
    args = parser.parse_args()
    names = run_names(parser, args)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(run_mesh, names, [args.joined_input] * len(names)))
    text = (
        table(rows, args.joined_input)
        + f"\n\n{time.perf_counter() - t0:.0f} s in all, {args.jobs} jobs\n"
    )
    print(text)
    if args.out is not None:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
