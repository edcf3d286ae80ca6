"""What verifying a mesh that carries no mark costs: wall time and peak memory, by size.

A file that carries no mark (one from a store or a pipeline that is not ours, or one marked
under another key) is read to the end: every cut start of the mesh and of its mirror image is
mapped, every image decoded, the strongest again with every smoothing undone, and ``verify``
then reads the logo too.  This runs ``python -m meshwm verify FILE --key K --any-id`` as a
user does, one file at a time in a fresh process, on igea refined to each size
(``bench_scale.py``'s meshes, made in a cache folder, a temporary one by default) and on the
development meshes named, and prints each run's wall time, peak resident memory (the child's
own, from ``wait4``) and verdict.  Run it with nothing else on the machine.

    python scripts/bench_unmarked.py [--sizes 0.1 0.5 2] [--meshes spot fandisk]
        [--cache DIR]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from bench_scale import MESHES, make_meshes  # noqa: E402

#: A key no development mesh was marked with.
KEY = "bench-unmarked"


def verify_once(path: Path) -> tuple[float, float, int, str]:
    """Wall seconds, peak resident GB (10^9 bytes, as ``/usr/bin/time``'s kB / 10^6), exit
    code and the first line of ``verify`` on ``path``, in a fresh process."""
    command = [sys.executable, "-m", "meshwm", "verify", str(path), "--key", KEY, "--any-id"]
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        child = subprocess.Popen(command, stdout=out, stderr=err)
        # The child's own peak, from wait4 (RUSAGE_CHILDREN's is the largest of every child).
        _, status, usage = os.wait4(child.pid, 0)
        seconds = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        lines = out.read().strip().splitlines() or err.read().strip().splitlines() or [""]
    return seconds, usage.ru_maxrss / 1e6, child.returncode, lines[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="*", default=[0.1, 0.5, 2])
    parser.add_argument("--meshes", nargs="*", default=[])
    parser.add_argument("--cache", type=Path, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp)
        cache.mkdir(parents=True, exist_ok=True)
        files = [MESHES / f"{name}.ply" for name in args.meshes]
        files += list(make_meshes(cache, args.sizes).values()) if args.sizes else []
        print("| file | wall s | peak RSS GB | exit | verdict |")
        print("|---|---:|---:|---:|---|")
        for path in files:
            seconds, peak, code, line = verify_once(path)
            print(f"| {path.name} | {seconds:.1f} | {peak:.2f} | {code} | {line} |", flush=True)


if __name__ == "__main__":
    main()
