"""Figures for meshwm.readers.registration: informed registration and asset look-up.

For each dev mesh (``/work/shared/meshes``) the reference is its geometry image at N = 128
(:func:`meshwm.gim.remesh.mesh_to_geometry_image`; random surface points where the remesh
fails), and the descriptor table holds the ten meshes as they are.  Each attack is applied, then
a random similarity (rotation uniform on SO(3), scale log-uniform in [0.01, 100], translation up
to ±100 diagonals; seeded by the mesh and attack), and the result is registered back.  Printed
per mesh × attack: the received faces, the pose error (RMS distance between the registered
received vertices and their true place, over the diagonal), :class:`Registration`'s ``rms``,
``overlap`` and ``hypotheses``, the seconds :func:`register` took, and the rank of the right
asset by :func:`descriptor_distance` among the ten, with the margin (nearest other asset's
distance over the right one's; > 1 when it ranks first).

    python scripts/check_registration.py [--meshes spot fandisk] [--attacks none crop30]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from meshwm.attacks import apply_attack
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.mesh.io import read_mesh
from meshwm.readers.registration import descriptor_distance, register, shape_descriptor

MESHES = Path("/work/shared/meshes")
ATTACKS: dict[str, tuple[str, dict[str, float]]] = {
    "none": ("", {}),
    "simplify50": ("simplify", {"keep_fraction": 0.5}),
    "simplify30": ("simplify", {"keep_fraction": 0.3}),
    "subdivide_midpoint": ("subdivide_midpoint", {}),
    "subdivide_loop": ("subdivide_loop", {}),
    "crop30": ("crop", {"fraction": 0.3}),
    "noise": ("noise", {"amplitude": 0.001}),
    "laplacian": ("laplacian", {}),
    "quantize": ("quantize", {"bits": 10}),
}


def similarity(diag: float, seed: int) -> tuple[float, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    s = float(np.exp(rng.uniform(np.log(0.01), np.log(100.0))))
    return s, q, rng.uniform(-100, 100, size=3) * s * diag


def reference_of(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, str]:
    try:
        return mesh_to_geometry_image(v, f, size=128).gim, "gim128"
    except ValueError:
        rng = np.random.default_rng(0)
        tri = v[f]
        area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        face = rng.choice(len(f), size=16384, p=area / area.sum())
        uv = rng.random((16384, 2))
        uv[uv.sum(axis=1) > 1] = 1 - uv[uv.sum(axis=1) > 1]
        t = tri[face]
        return t[:, 0] + uv[:, :1] * (t[:, 1] - t[:, 0]) + uv[:, 1:] * (t[:, 2] - t[:, 0]), "pts16k"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--meshes", nargs="*", default=None)
    parser.add_argument("--attacks", nargs="*", default=list(ATTACKS), choices=list(ATTACKS))
    args = parser.parse_args(argv)
    everything = {p.stem: read_mesh(p) for p in sorted(MESHES.glob("*.ply"))}
    names = sorted(everything)
    table = np.array([shape_descriptor(*everything[n]) for n in names])
    print(
        f"| mesh | attack | faces | reference | pose error | rms | overlap | hyp | s "
        f"| rank | margin |\n|{'---|' * 11}"
    )
    for name in args.meshes or names:
        v, f = everything[name]
        diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
        reference, kind = reference_of(v, f)
        for index, label in enumerate(args.attacks):
            attack, options = ATTACKS[label]
            va, fa = apply_attack(attack, v, f, seed=1, **options) if attack else (v, f)
            s, r, t = similarity(diag, 1000 * names.index(name) + index)
            moved = s * va @ r.T + t
            start = time.perf_counter()
            fit = register(moved, fa, reference)
            seconds = time.perf_counter() - start
            error = np.sqrt(np.mean(np.sum((fit.apply(moved) - va) ** 2, axis=1))) / diag
            distance = descriptor_distance(shape_descriptor(moved, fa), table)
            own = distance[names.index(name)]
            rank = 1 + int(np.sum(distance < own))
            margin = np.min(np.delete(distance, names.index(name))) / max(own, 1e-300)
            print(
                f"| {name} | {label} | {len(fa)} | {kind} | {error:.1e} | {fit.rms:.1e} "
                f"| {fit.overlap:.3f} | {fit.hypotheses} | {seconds:.2f} | {rank} "
                f"| {min(margin, 999):.2f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
