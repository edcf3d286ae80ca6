"""Benchmark embed and extract against a one-solve floor (issue #3).

What it measures
----------------
For the largest dev mesh (default: the ``*.ply`` with the most faces in ``../shared/meshes``,
today ``igea.ply``, 268,686 faces) at N = 256 with the default 32×32 logo:

embed
    File to file, as ``meshwm embed --no-distance`` runs it: ``read_mesh``, ``meshwm.watermark``
    (remesh, read the cover back from its connectivity, mark) and ``write_mesh`` (PLY).
embed + distances
    The same with the MeshLab distance measurements of the report (``mrms_rel``,
    ``hausdorff_rel``, ``rms_rel``), as plain ``meshwm embed`` runs it.
extract
    File to mark, as ``meshwm extract`` runs it: ``read_mesh`` of the marked PLY and
    ``meshwm.extract`` (clean, recover the grid, read the bits).
floor
    ``read_mesh`` of the *input* mesh plus one ``igl.harmonic`` solve on it (the same floor as
    ``scripts/bench_remesh.py``, with the boundary every k-th vertex, 1 % of the vertices).

Median wall times over ``--repeats`` runs (after one warm-up), and the ratios to the floor
next to the target (≤ 3).  Nothing is asserted.

How to run
----------
::

    python scripts/bench_embed.py
    python scripts/bench_embed.py --repeats 3 --mesh path/to/mesh.ply
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MESHES = REPO_ROOT.parent / "shared" / "meshes"
TARGET_RATIO = 3.0

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

from _machine import machine_info  # noqa: E402
from bench_remesh import boundary_set, floor_once, largest_mesh  # noqa: E402

from meshwm.mesh.io import read_mesh, write_mesh  # noqa: E402
from meshwm.message.mark import default_mark  # noqa: E402
from meshwm.watermark import embed, extract  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mesh", type=Path, help="mesh to use (default: largest dev mesh)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--size", type=int, default=256)
    args = parser.parse_args(argv)
    path = args.mesh or largest_mesh(DEFAULT_MESHES)
    mark = default_mark(32)
    from meshwm.params import WatermarkParams

    params = WatermarkParams(size=args.size)
    times: dict[str, list[float]] = {"embed": [], "embed + distances": [], "extract": []}
    floors: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "marked.ply"
        report: dict = {}
        for k in range(args.repeats + 1):
            t0 = time.perf_counter()
            v, f = read_mesh(path)
            result = embed(v, f, mark, key="bench", params=params, distances=False, grid=True)
            write_mesh(out, result.vertices, result.faces)
            t1 = time.perf_counter()
            v2, f2 = read_mesh(out)
            found = extract(v2, f2, key="bench", expected=mark, params=params)
            t2 = time.perf_counter()
            if k == 0:
                report = {**result.report, "ber": found.report["ber"]}
                b, bc = boundary_set(len(v), max(3, int(0.01 * len(v))))
                floor_once(path, b, bc)
                continue
            times["embed"].append(t1 - t0)
            times["extract"].append(t2 - t1)
            floors.append(floor_once(path, b, bc))
        for _ in range(max(1, args.repeats // 2)):
            t0 = time.perf_counter()
            v, f = read_mesh(path)
            result = embed(v, f, mark, key="bench", params=params, distances=True, grid=True)
            write_mesh(out, result.vertices, result.faces)
            times["embed + distances"].append(time.perf_counter() - t0)
    floor = statistics.median(floors)
    info = machine_info("numpy", "scipy", "libigl", "pymeshlab", "trimesh")
    print(f"machine: {info}")
    print(
        f"mesh: {path.name}, {len(v)} vertices, {len(f)} faces; N={args.size}; "
        f"{args.repeats} repeats (medians)"
    )
    print(
        f"check: BER {report['ber']}, carriers {report['carriers']}, PSNR {report['psnr']:.2f} dB"
    )
    print()
    print("| step | median s | ratio to floor | target |")
    print("|---|---:|---:|---|")
    print(f"| floor: read + 1 harmonic solve | {floor:.3f} | 1.00 | |")
    for name, values in times.items():
        med = statistics.median(values)
        target = f"≤ {TARGET_RATIO:g}" if name in ("embed", "extract") else "(informative)"
        print(f"| {name} | {med:.3f} | {med / floor:.2f} | {target} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
