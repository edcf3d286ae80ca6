"""Check that a refactor changes no output: the same files and JSON before and after.

For every mesh in a folder (default ``../shared/meshes``) this runs, in a checkout of a baseline
revision and in the working tree, as whole processes::

    meshwm embed MESH -o logo.ply --key K --json            (the bundled logo)
    meshwm embed MESH -o id.ply --key K --id 0xC0FFEE42 --json
    meshwm extract logo.ply --key K -o logo.png --json
    meshwm extract id.ply --key K --json
    meshwm verify id.ply --key K --id 0xC0FFEE42 --json
    meshwm remesh MESH -o grid.ply --json

and prints one row per mesh and output: the SHA-256 (first 12 hex digits) of each file and of each
JSON report with its timings and paths removed, before and after, and whether they match.  Exit code
0 when every row matches, 1 otherwise.

Usage::

    python scripts/check_behaviour.py --baseline f013407 [--meshes DIR] [--jobs 2]

The baseline is checked out with ``git worktree`` into a temporary folder and removed afterwards;
both trees run with ``PYTHONPATH`` set to their root, so neither needs installing.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

KEY = "behaviour-check-key"
IDENT = "0xC0FFEE42"
#: JSON fields that differ between runs or between folders, not between behaviours.
VOLATILE = {"seconds", "seconds_geometry_image", "input", "output", "path", "timings"}


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:12]


def _json_digest(text: str) -> str:
    report = json.loads(text)
    return _digest(json.dumps(_strip(report), sort_keys=True).encode())


def _strip(value: object) -> object:
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def _run(tree: Path, args: list[str]) -> tuple[int, str]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    proc = subprocess.run(
        [sys.executable, "-m", "meshwm", *args],
        env=env,
        capture_output=True,
        text=True,
        cwd=tree,
        check=False,
    )
    return proc.returncode, proc.stdout if proc.returncode in (0, 1) else proc.stderr


def _mesh_rows(tree: Path, mesh: Path, work: Path) -> dict[str, str]:
    """Run every command on one mesh; map ``output name -> digest`` (or an error text)."""
    work.mkdir(parents=True, exist_ok=True)
    logo, ident, png, grid = (work / n for n in ("logo.ply", "id.ply", "logo.png", "grid.ply"))
    steps = {
        "embed logo": ["embed", str(mesh), "-o", str(logo), "--key", KEY, "--json"],
        "embed id": ["embed", str(mesh), "-o", str(ident), "--key", KEY, "--id", IDENT, "--json"],
        "extract logo": ["extract", str(logo), "--key", KEY, "-o", str(png), "--json"],
        "extract id": ["extract", str(ident), "--key", KEY, "--json"],
        "verify id": ["verify", str(ident), "--key", KEY, "--id", IDENT, "--json"],
        "remesh": ["remesh", str(mesh), "-o", str(grid), "--json"],
    }
    files = {"embed logo": logo, "embed id": ident, "extract logo": png, "remesh": grid}
    rows: dict[str, str] = {}
    for name, args in steps.items():
        code, out = _run(tree, args)
        if code not in (0, 1):
            rows[f"{name} json"] = f"exit {code}: {out.strip().splitlines()[-1][:40]}"
            continue
        rows[f"{name} json"] = f"{_json_digest(out)} (exit {code})"
        if name in files:
            rows[f"{name} file"] = _digest(files[name].read_bytes())
    return rows


def _run_tree(tree: Path, meshes: list[Path], work: Path, jobs: int) -> dict[str, dict[str, str]]:
    with ThreadPoolExecutor(jobs) as pool:
        results = pool.map(lambda m: _mesh_rows(tree, m.resolve(), work / m.stem), meshes)
        return {m.stem: r for m, r in zip(meshes, results, strict=True)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", required=True, help="git revision to compare against")
    parser.add_argument("--meshes", type=Path, default=Path("../shared/meshes"))
    parser.add_argument("--jobs", type=int, default=2, help="meshes run at once (2)")
    args = parser.parse_args(argv)
    root = Path(__file__).resolve().parent.parent
    meshes = sorted(args.meshes.glob("*.ply"))
    if not meshes:
        print(f"no .ply meshes in {args.meshes}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "baseline"
        subprocess.run(
            ["git", "-C", str(root), "worktree", "add", "--detach", str(base), args.baseline],
            check=True,
            capture_output=True,
        )
        try:
            before = _run_tree(base, meshes, Path(tmp) / "before", args.jobs)
            after = _run_tree(root, meshes, Path(tmp) / "after", args.jobs)
        finally:
            subprocess.run(
                ["git", "-C", str(root), "worktree", "remove", "--force", str(base)], check=False
            )
            shutil.rmtree(base, ignore_errors=True)
    head = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    print(f"baseline {args.baseline} against the working tree at {head} (+ uncommitted changes)")
    print("| mesh | output | before | after | same |\n|---|---|---|---|---|")
    same_all = True
    for mesh in before:
        for name, digest in before[mesh].items():
            other = after[mesh].get(name, "missing")
            same = digest == other
            same_all &= same
            print(f"| {mesh} | {name} | {digest} | {other} | {'yes' if same else 'NO'} |")
    rows = sum(len(r) for r in before.values())
    print(f"\n{rows} outputs compared: {'all identical' if same_all else 'DIFFERENCES'}")
    return 0 if same_all else 1


if __name__ == "__main__":
    raise SystemExit(main())
