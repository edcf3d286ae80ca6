"""Benchmark the fuzzy perceptual mask: scikit-fuzzy one point at a time vs ``infer_strength``.

What it measures
----------------
reference
    ``skfuzzy.control.ControlSystemSimulation`` on ``meshwm.signal.fuzzy.build_control_system()``
    with its default options, used the way a per-coefficient loop would use it: set the three
    inputs, ``compute()``, read ``output["weight"]``, for ``--reference-points`` random points
    (default 300, uniform in [0, 1]^3, after 10 warm-up points).  Per-point time = total / points.
vectorised
    ``meshwm.signal.fuzzy.infer_strength`` on ``--points`` random points (default 65,536: one
    channel of a 256 x 256 geometry image), median wall time of ``--repeats`` runs (default 5)
    after one warm-up run.  Per-point time = median / points.
agreement
    max |infer_strength - skfuzzy| over the reference points (the tests require <= 1e-9).

The speed-up per point (reference per point / vectorised per point) is printed next to its
target (>= 1000).  Nothing is asserted: the script only prints figures.

How to run
----------
From the repository root (no install needed)::

    python scripts/bench_fuzzy.py
    python scripts/bench_fuzzy.py --points 262144 --reference-points 1000 --json fuzzy.json

It takes about five seconds.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import warnings
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
TARGET_SPEEDUP = 1000.0
WARM_UP_POINTS = 10
#: scikit-fuzzy 0.5 calls np.maximum(a, b, out) positionally, deprecated in NumPy 2.4.
SKFUZZY_NUMPY_WARNING = r"Passing more than 2 positional arguments to np\.maximum"

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

import numpy as np  # noqa: E402
from _machine import machine_info  # noqa: E402
from skfuzzy import control  # noqa: E402

from meshwm.signal.fuzzy import (  # noqa: E402
    DEFAULT_CHUNK_SIZE,
    INPUT_NAMES,
    build_control_system,
    infer_strength,
)


def reference_weights(points: np.ndarray) -> tuple[np.ndarray, float]:
    """skfuzzy, one point at a time; returns the weights and the seconds taken."""
    simulation = control.ControlSystemSimulation(build_control_system())
    out = np.empty(len(points))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", SKFUZZY_NUMPY_WARNING, DeprecationWarning)
        start = time.perf_counter()
        for i, point in enumerate(points):
            for name, value in zip(INPUT_NAMES, point, strict=True):
                simulation.input[name] = float(value)
            simulation.compute()
            out[i] = simulation.output["weight"]
        seconds = time.perf_counter() - start
    return out, seconds


def bench(points: int, reference_points: int, repeats: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    reference_weights(rng.random((WARM_UP_POINTS, 3)))
    sample = rng.random((reference_points, 3))
    expected, reference_seconds = reference_weights(sample)
    got = infer_strength(sample[:, 0], sample[:, 1], sample[:, 2])
    max_difference = float(np.max(np.abs(got - expected)))

    inputs = rng.random((3, points))
    infer_strength(*inputs)  # warm-up (and the table cache)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        infer_strength(*inputs)
        times.append(time.perf_counter() - start)
    vector_median = statistics.median(times)

    reference_per_point = reference_seconds / reference_points
    vector_per_point = vector_median / points
    return {
        "reference_points": reference_points,
        "reference_seconds": reference_seconds,
        "reference_per_point_seconds": reference_per_point,
        "points": points,
        "chunk_size": DEFAULT_CHUNK_SIZE,
        "repeats": repeats,
        "vector_seconds": times,
        "vector_median_seconds": vector_median,
        "vector_per_point_seconds": vector_per_point,
        "speedup_per_point": reference_per_point / vector_per_point,
        "target_speedup": TARGET_SPEEDUP,
        "max_abs_difference": max_difference,
        "seed": seed,
    }


def print_results(machine: dict, row: dict) -> None:
    print("## Machine\n")
    print(f"- CPU: {machine['processor']}, os.cpu_count() = {machine['cpu_count']}")
    print(f"- OS: {machine['uname']}, Python {machine['python']}")
    print(f"- numpy {machine['numpy']}, scikit-fuzzy {machine['scikit-fuzzy']}")
    print()
    print("## Fuzzy perceptual mask\n")
    print("| implementation | points | wall time | per point |")
    print("|---|---:|---:|---:|")
    print(
        f"| skfuzzy ControlSystemSimulation, one at a time | {row['reference_points']:,} "
        f"| {row['reference_seconds']:.3f} s | {1e3 * row['reference_per_point_seconds']:.3f} ms |"
    )
    print(
        f"| infer_strength (median of {row['repeats']}, chunk {row['chunk_size']}) "
        f"| {row['points']:,} | {row['vector_median_seconds']:.3f} s "
        f"| {1e6 * row['vector_per_point_seconds']:.3f} µs |"
    )
    print()
    met = "met" if row["speedup_per_point"] >= row["target_speedup"] else "not met"
    print(
        f"Speed-up per point: {row['speedup_per_point']:,.0f}× "
        f"(target ≥ {row['target_speedup']:,.0f}×, {met})"
    )
    print(
        f"Max |infer_strength - skfuzzy| on the {row['reference_points']} reference points: "
        f"{row['max_abs_difference']:.2e} (tests require ≤ 1e-9)"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Time skfuzzy one point at a time against the vectorised infer_strength."
    )
    parser.add_argument(
        "--points", type=int, default=65536, help="points for infer_strength (default 65536)"
    )
    parser.add_argument(
        "--reference-points",
        type=int,
        default=300,
        help="points evaluated one at a time with skfuzzy (default 300)",
    )
    parser.add_argument(
        "--repeats", type=int, default=5, help="timed infer_strength runs (default 5)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the random points")
    parser.add_argument("--json", type=Path, help="also write the results as JSON to this file")
    args = parser.parse_args(argv)
    for name in ("points", "reference_points", "repeats"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1")

    machine = machine_info("scikit-fuzzy")
    row = bench(args.points, args.reference_points, args.repeats, args.seed)
    print_results(machine, row)
    if args.json is not None:
        args.json.write_text(json.dumps({"machine": machine, "result": row}, indent=2) + "\n")
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
