"""Is the re-derived geometry image the same under similarities?  Issue 13's stability table.

For every mesh: the image of the input, then of 20 random similarities of it (rotation, scale
0.01-100, translation ±100, vertex and face order shuffled), taken back to the input's pose and
compared sample by sample; printed: the largest difference over the bounding-box diagonal and
how many of the 20 agree to 1e-9.  Four images: the surface reader's (the user's mesh kept,
``meshwm.gim.surface``, N = 128), the radial reader's (``meshwm.gim.sphere``, N = 128: the
input's first pose against the nearest of the poses the moved mesh offers, as a reader tries
them all; radii in units of the RMS radius, compared over the diagonal in those units),
``meshwm remesh``'s and the ``--grid`` output's (both ``mesh_to_geometry_image``, N = 256).

A mesh that a rotation maps onto itself (``meshwm.apps.bench.symmetry``: the genus-8 plate's
half turn) bounds what any reader can do: a random similarity is as likely to be ``S`` as
``S ρ``, which give the same mesh, so at most ``1/k`` of them can give the input's image with
``k`` such rotations.  The last columns: how many rotations map the mesh onto itself, and how
many trials give the input's image up to one of them (to 1e-9).

    python scripts/check_stability.py [--meshes spot ...] [--trials 20] [--out FILE]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from meshwm.apps.bench.symmetry import proper_symmetries, random_similarity, up_to_symmetry
from meshwm.apps.bench.synthetic import SYNTHETIC, make
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.sphere import point_poses, point_set, sphere_sampling
from meshwm.gim.surface import sample_surface, surface_of
from meshwm.mesh.io import read_mesh
from meshwm.metrics import bounding_box_diagonal

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
DEV = [p.stem for p in sorted(MESHES.glob("*.ply"))] + list(SYNTHETIC)


def surface_image(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    return sample_surface(surface_of(v, f), size=128).samples


def grid_image(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    return mesh_to_geometry_image(v, f, size=256).gim


def radial_images(v: np.ndarray, f: np.ndarray) -> list[np.ndarray]:
    """The radius images (N = 128) of every pose the point set offers, the first first."""
    points = point_set(v, f).points
    return [sphere_sampling(points, pose, 128).image for pose in point_poses(points)]


def radial_trials(
    v: np.ndarray, f: np.ndarray, trials: int, rng: np.random.Generator
) -> tuple[float, int]:
    """Largest difference over the diagonal (in RMS-radius units) and how many agree."""
    base = radial_images(v, f)[0]
    diag = bounding_box_diagonal(v) / point_poses(point_set(v, f).points)[0].scale
    worst, same = 0.0, 0
    for _ in range(trials):
        mv, mf, _, _ = random_similarity(rng, v, f)
        diff = min(float(np.abs(im - base).max()) for im in radial_images(mv, mf)) / diag
        worst = max(worst, diff)
        same += diff <= 1e-9
    return worst, same


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=DEV)
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--kinds", nargs="+", default=["surface", "radial", "grid"])
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    kinds = {"surface": surface_image, "grid": grid_image}
    lines = [
        "| mesh | image | largest difference / diagonal | same to 1e-9 | rotations onto itself "
        "| same up to them |",
        "|---|---|---|---|---:|---|",
    ]
    t0 = time.perf_counter()
    for name in args.meshes:
        v, f = make(name) if name in SYNTHETIC else read_mesh(MESHES / f"{name}.ply")
        diag = bounding_box_diagonal(v)
        turns = proper_symmetries(v, f)
        centre = np.asarray(v, dtype=np.float64).mean(axis=0)
        for kind in args.kinds:
            if kind == "radial":
                worst, same = radial_trials(v, f, args.trials, np.random.default_rng(2026))
                lines.append(
                    f"| {name} | radial | {worst:.2e} | {same}/{args.trials} | {len(turns)} | – |"
                )
                print(lines[-1], flush=True)
                continue
            image = kinds[kind]
            try:
                base = image(v, f)
            except Exception as exc:  # a row of the table
                lines.append(f"| {name} | {kind} | {type(exc).__name__}: {exc} | - | - | - |")
                continue
            rng = np.random.default_rng(2026)
            worst, same, up_to = 0.0, 0, 0
            for _ in range(args.trials):
                mv, mf, _, back = random_similarity(rng, v, f)
                got = back(image(mv, mf).reshape(-1, 3)).reshape(base.shape)
                up_to += up_to_symmetry(got, base, turns, centre) / diag <= 1e-9
                diff = up_to_symmetry(got, base, turns[:1], centre) / diag  # as it is
                worst = max(worst, diff)
                same += diff <= 1e-9
            lines.append(
                f"| {name} | {kind} | {worst:.2e} | {same}/{args.trials} | {len(turns)} "
                f"| {up_to}/{args.trials} |"
            )
            print(lines[-1], flush=True)
    text = "\n".join(lines) + f"\n\n({time.perf_counter() - t0:.0f} s)\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
