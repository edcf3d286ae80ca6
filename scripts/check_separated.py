"""A marked mesh separated into several objects in one file: read as one.

Blender's Separate (by material or by loose parts), or an exporter that writes an object per
material, saves one mesh as several: each part has vertex records of its own (those on a
border between parts written once per part) and no part alone carries the mark.  For every
mesh: embed a 64-bit id (``meshwm.embed``, the input's mesh kept, ``check_keep.py``'s key and
id), separate it into ``k`` patches grown from random faces
(``meshwm.attacks.seams.material_patches``), one object each, export the scene with trimesh
as OBJ (8 decimals) and GLB (float32), and verify it as a user does
(``meshwm verify --json`` at FPR 1e-6, each file in a fresh process: each part big enough
read alone, then the parts not read together).  A cell is ``ok`` (the id
detected in every part's row, read together) or ``no``, then the verification's seconds;
``wrong key`` is the 3-part OBJ verified with another key (``no`` is right).

    python scripts/check_separated.py [--meshes spot fandisk ...] [--synthetic] [--jobs 2]
        [--out F]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_keep import FPR, IDENT, KEY, add_run_options, load, run_names

from meshwm.attacks.seams import material_patches
from meshwm.watermark import embed

#: (parts, seed) of each separation.
SEPARATIONS = ((3, 0), (8, 1))


def separated(v: np.ndarray, f: np.ndarray, patch: np.ndarray, path: Path) -> None:
    """One object per patch, exported by trimesh in ``path``'s format."""
    scene = trimesh.Scene()
    for p in range(int(patch.max()) + 1):
        piece = trimesh.Trimesh(v, f[patch == p], process=False)
        piece.remove_unreferenced_vertices()
        scene.add_geometry(piece, node_name=f"part_{p}", geom_name=f"part_{p}")
    data = scene.export(file_type=path.suffix[1:])
    path.write_bytes(data.encode() if isinstance(data, str) else data)


def _verify(path: Path, key: str) -> tuple[str, float, int]:
    """``meshwm verify --json`` in a fresh process (no map memoised from another file), timed."""
    argv = [sys.executable, "-m", "meshwm", "verify", str(path), "--key", key]
    argv += ["--id", "0x" + IDENT.hex(), "--fpr", str(FPR), "--json"]
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - t0
    if done.returncode not in (0, 1):
        return f"error: {done.stderr.strip()}", seconds, 0
    rows = json.loads(done.stdout)["meshes"]
    every = all(r["detected"] and "together" in r for r in rows)
    verdict = "ok" if every else "some" if any(r["detected"] for r in rows) else "no"
    return verdict, seconds, len(rows)


def run_mesh(name: str) -> dict[str, Any]:
    v, f = load(name)
    marked = embed(v, f, key=KEY, ident=IDENT).vertices
    row: dict[str, Any] = {"mesh": name, "V": len(v), "cells": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for count, seed in SEPARATIONS:
            patch = material_patches(f, count=count, seed=seed)
            for suffix in (".obj", ".glb"):
                path = Path(tmp) / f"{count}{suffix}"
                separated(marked, f, patch, path)
                verdict, seconds, meshes = _verify(path, KEY)
                label = f"{count} parts {suffix[1:].upper()}"
                row["cells"][label] = f"{verdict} {seconds:.1f} s ({meshes} meshes)"
        verdict, seconds, _ = _verify(Path(tmp) / f"{SEPARATIONS[0][0]}.obj", "another key")
        row["cells"]["wrong key"] = f"{verdict} {seconds:.1f} s"
    return row


def table(rows: list[dict[str, Any]]) -> str:
    labels = list(rows[0]["cells"])
    lines = ["| mesh | V | " + " | ".join(labels) + " |", "|---|---:|" + "---|" * len(labels)]
    for row in rows:
        cells = " | ".join(row["cells"][label] for label in labels)
        lines.append(f"| {row['mesh']} | {row['V']} | {cells} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_options(parser)
    args = parser.parse_args()
    names = run_names(parser, args)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(run_mesh, names))
    text = table(rows) + f"\n\n({time.perf_counter() - t0:.0f} s, key and id fixed, FPR {FPR:g})\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
