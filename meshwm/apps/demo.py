"""``meshwm demo``: the whole tool on one bundled mesh, in a minute.

Marks the bundled spot mesh (public domain, Keenan Crane) with a 64-bit id, keeping its mesh
(same vertices and faces, only positions move), applies the attacks a pipeline does to a file,
reads the id back blind from each, prints a table and writes the meshes and ``compare.png``
(where the mark moved the surface) into the output folder.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from meshwm._atomic import write_atomic
from meshwm.apps.render import render_comparison
from meshwm.attacks import apply_attack
from meshwm.detect import decide
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.watermark import embed, extract_id

__all__ = ["DEMO_ATTACKS", "DEMO_ID", "bundled_mesh_path", "run_demo"]

#: (label, attack name, options) run by the demo; the key is public, it is a demo.
DEMO_ATTACKS: tuple[tuple[str, str | None, dict], ...] = (
    ("none (PLY)", None, {}),
    ("OBJ round trip", "round_trip", {"suffix": ".obj"}),
    ("STL round trip (re-welded)", "weld_stl", {}),
    ("rotation+translation+scale", "similarity", {"seed": 1}),
    ("vertex+face reorder", "reorder", {"seed": 2}),
    ("10-bit quantisation", "quantize", {"bits": 10}),
    ("noise 0.1%", "noise", {"seed": 3, "amplitude": 0.001}),
    ("Laplacian smoothing x10", "laplacian", {"iterations": 10}),
    ("vertices split at seams, re-welded", "split_seams", {"seed": 4}),
    ("trimesh's default (merging) load", "merge_load", {}),
    ("mirrored (change of handedness)", "mirror", {"seed": 5}),
)
#: The id the demo embeds.
DEMO_ID = bytes.fromhex("5ca1ab1e0ddba11f")

_KEY = "meshwm-demo"


def bundled_mesh_path() -> Path:
    """Path of the bundled spot mesh (``meshwm/data/spot.ply``, :func:`meshwm.data.path`)."""
    from meshwm.data import path

    return path("spot")


def run_demo(out: str | os.PathLike, *, echo=print) -> list[dict]:
    """Run the demo, write its files into ``out`` and return the table rows."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    vertices, faces = read_mesh(bundled_mesh_path())
    echo(
        f"marking the bundled spot ({len(vertices)} vertices, {len(faces)} faces) with the "
        f"64-bit id {DEMO_ID.hex()}, keeping its mesh ..."
    )
    result = embed(vertices, faces, key=_KEY, ident=DEMO_ID)
    r = result.report
    marked_path = out / "spot_marked.ply"
    write_mesh(marked_path, result.vertices, result.faces)
    same = bool(np.array_equal(result.faces, faces) and len(result.vertices) == len(vertices))
    echo(
        f"  {'same' if same else 'CHANGED'} vertices and faces; against the input: MRMS "
        f"{100 * r['mrms_rel']:.4f}%, Hausdorff {100 * r['hausdorff_rel']:.3f}% of the bbox "
        f"diagonal; {r['seconds']:.1f} s -> {marked_path}"
    )
    png, _ = render_comparison(result.vertices, result.faces, vertices, faces, title="spot")
    write_atomic(out / "compare.png", png)
    v0, f0 = read_mesh(marked_path)
    rows = []
    for k, (label, name, options) in enumerate([*DEMO_ATTACKS, ("wrong key", None, {})]):
        v, f = (v0, f0) if name is None else apply_attack(name, v0, f0, **options)
        slug = "".join(ch if ch.isalnum() else "_" for ch in label.lower()).strip("_")
        if name is not None:
            write_mesh(out / f"attacked_{k}_{slug}.ply", v, f)
        key = "not-the-key" if label == "wrong key" else _KEY
        found = extract_id(v, f, key=key, expected=DEMO_ID)
        verdict = decide(found.report, found_id=found.id, expected_id=DEMO_ID.hex())
        rows.append(
            {
                "attack": label,
                "id": found.id,
                "ber": found.report["ber"],
                "p_value": verdict.p_value,
                "detected": verdict.detected,
            }
        )
    echo("")
    echo(f"{'attack':<36} {'id read back':<17} {'BER':>7} {'p-value':>9}  detected")
    for row in rows:
        echo(
            f"{row['attack']:<36} {row['id'] or 'none':<17} {row['ber']:7.4f} "
            f"{row['p_value']:9.2g}  {'yes' if row['detected'] else 'no'}"
        )
    echo(f"\nwhere the mark moved the surface (against the input): {out / 'compare.png'}")
    return rows
