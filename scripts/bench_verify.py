"""Verify throughput on a folder of marked assets (issue #5).

What it measures
----------------
A folder of ``--count`` (default 200) marked assets at N = 256, generated from the dev meshes
in ``../shared/meshes``: each mesh is remeshed once (``mesh_to_geometry_image``) and marked
with ``count / 10`` different 8-byte ids under one key (``embed(..., ident=...)``), written as
binary PLY, with a ``manifest.json`` (file -> id).  The folder is reused when its manifest
matches (``--regenerate`` forces a new one).  Then, over the same file list:

load only
    ``meshwm.mesh.io.read_mesh`` of every file, in this process, one after the other.
verify --jobs 1
    ``meshwm.apps.batch.run_local(paths, Check(any_id=True), jobs=1)``: in this process.
verify --jobs 2
    The same with ``jobs=2`` (a process pool; its start-up is included, as a user sees it).
dask
    ``meshwm.apps.batch.run_dask`` on a ``LocalCluster(n_workers=2, threads_per_worker=1)``; the
    cluster's start-up (with each worker importing meshwm) is reported separately, not
    timed.  Twice: as Dask starts its workers by default, and without the
    ``MALLOC_TRIM_THRESHOLD_=65536`` Dask sets in their environment (which once made every
    verification markedly slower, page faults and system time; meshwm's tasks now raise the
    thresholds themselves, see ``meshwm/_malloc.py``, and the two rows measure alike).
CLI
    ``python -m meshwm verify DIR --key K --any-id --jobs 2 --jsonl`` end to end (a
    subprocess: interpreter start-up, imports and the pool included).

Each row: files, seconds, assets/s, assets/s per core, correct ids (the id decoded with
``--any-id`` equals the manifest's), the speed-up over ``--jobs 1`` and the ratio of the
verify time to the load-only time, and the CPU seconds used (this process, its reaped
children and the Dask workers), whose ratio to the files is a per-core rate less sensitive
than wall time to what else the machine is running.  Then the targets of issue #5: ≥ 20 assets/s
per core (``--jobs 1``) and ≥ 1.8× from 1 to 2 jobs.  Also a per-stage breakdown on ``--breakdown``
files (median seconds per file: read, check_mesh, ``meshwm.gim.recover.recover_grid``, decode).

With ``--reorder``, the same measurements on a copy of the folder with every file's vertex
and face order shuffled (``meshwm.attacks.transforms.reorder``): files re-exported by other
tools lose the writer's order.

Each row is run ``--repeat`` times (default 3) and the run of median time is reported (all
times are in the JSON); a Dask cluster only exists while its own row runs.  ``--jobs 1`` and
``--jobs 2`` run alternately, and their speed-up is the median ratio of back-to-back runs
(the speed of a shared host drifts over a minute).  Timings are wall
clock on a possibly shared machine; the 1-minute load average before each
measurement is recorded next to it.  Nothing is asserted: the exit code is 1 only if an id
is wrong or missing.

How to run
----------
::

    python scripts/bench_verify.py
    python scripts/bench_verify.py --count 400 --reorder --json /tmp/bench_verify.json
    python scripts/bench_verify.py --regenerate --assets /tmp/other-folder
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
import logging
import os
import resource
import shlex
import statistics
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MESHES = REPO_ROOT.parent / "shared" / "meshes"
DEFAULT_ASSETS = Path("/tmp/meshwm-bench-verify/assets")
KEY = "bench-verify-key"
SIZE = 256
MANIFEST = "manifest.json"
MANIFEST_VERSION = 1
TARGET_PER_CORE = 20.0
TARGET_SPEEDUP = 1.8
DASK_VARIANTS = (
    ("dask LocalCluster 2x1", True),
    ("dask LocalCluster 2x1, MALLOC_TRIM_THRESHOLD_ unset", False),
)

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

from _machine import machine_info  # noqa: E402

from meshwm._validate import check_mesh  # noqa: E402
from meshwm.apps.batch import Check, run_dask, run_local  # noqa: E402
from meshwm.attacks.transforms import reorder  # noqa: E402
from meshwm.errors import GridError  # noqa: E402
from meshwm.gim.recover import recover_grid  # noqa: E402
from meshwm.gim.remesh import mesh_to_geometry_image  # noqa: E402
from meshwm.mesh.io import read_mesh, write_mesh  # noqa: E402
from meshwm.params import WatermarkParams  # noqa: E402
from meshwm.watermark import Decoder, embed  # noqa: E402

# --------------------------------------------------------------------------------------------
# assets


def asset_id(mesh: str, k: int) -> bytes:
    """The 8-byte id of the k-th copy of ``mesh`` (deterministic)."""
    return hashlib.sha256(f"{mesh}/{k}".encode()).digest()[:8]


def plan(meshes: Sequence[Path], count: int) -> dict[str, list[tuple[str, str]]]:
    """Mesh path -> [(file name, id hex)]: ``count`` files spread evenly over the meshes."""
    out: dict[str, list[tuple[str, str]]] = {}
    per, extra = divmod(count, len(meshes))
    for m, mesh in enumerate(meshes):
        n = per + (1 if m < extra else 0)
        out[str(mesh)] = [
            (f"{mesh.stem}_{k:03d}.ply", asset_id(mesh.stem, k).hex()) for k in range(n)
        ]
    return out


def _mark_one_mesh(args: tuple[str, list[tuple[str, str]], str]) -> dict[str, Any]:
    """Worker: remesh one dev mesh once, then embed and write each of its ids."""
    mesh, items, folder = args
    t0 = time.perf_counter()
    v, f = read_mesh(mesh)
    gim = mesh_to_geometry_image(v, f, size=SIZE)
    t_gim = time.perf_counter() - t0
    t1 = time.perf_counter()
    params = WatermarkParams(size=SIZE)
    for name, hexid in items:
        res = embed(
            v,
            f,
            key=KEY,
            params=params,
            ident=bytes.fromhex(hexid),
            geometry_image=gim,
            distances=False,
            grid=True,
        )
        write_mesh(Path(folder) / name, res.vertices, res.faces)
    return {
        "mesh": Path(mesh).name,
        "files": len(items),
        "gim_seconds": t_gim,
        "embed_write_seconds": time.perf_counter() - t1,
        "vertices": len(res.vertices) if items else 0,
        "faces": len(res.faces) if items else 0,
    }


def _manifest_matches(folder: Path, wanted: dict[str, Any]) -> bool:
    try:
        have = json.loads((folder / MANIFEST).read_text())
    except (OSError, ValueError):
        return False
    if any(have.get(k) != wanted[k] for k in ("version", "key", "size", "count", "files")):
        return False
    return all((folder / name).is_file() for name in wanted["files"])


def generate(
    folder: Path, meshes: Sequence[Path], count: int, regenerate: bool, workers: int
) -> dict[str, Any]:
    """Make (or reuse) the asset folder; the manifest, plus how long generation took."""
    layout = plan(meshes, count)
    files = {name: hexid for items in layout.values() for name, hexid in items}
    wanted = {
        "version": MANIFEST_VERSION,
        "key": KEY,
        "size": SIZE,
        "count": count,
        "meshes": [Path(m).name for m in layout],
        "files": files,
    }
    if not regenerate and _manifest_matches(folder, wanted):
        return {**wanted, "reused": True, "seconds": 0.0, "per_mesh": []}
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.ply"):
        old.unlink()
    (folder / MANIFEST).unlink(missing_ok=True)
    t0 = time.perf_counter()
    # Largest meshes first, so the two workers finish at about the same time.
    jobs = sorted(
        ((m, items, str(folder)) for m, items in layout.items()),
        key=lambda job: -Path(job[0]).stat().st_size,
    )
    with ProcessPoolExecutor(max_workers=workers) as pool:
        per_mesh = list(pool.map(_mark_one_mesh, jobs))
    seconds = time.perf_counter() - t0
    (folder / MANIFEST).write_text(json.dumps(wanted, indent=1, sort_keys=True))
    return {**wanted, "reused": False, "seconds": seconds, "per_mesh": per_mesh}


def _reorder_one(args: tuple[str, str, int]) -> None:
    src, dst, seed = args
    v, f = read_mesh(src)
    rv, rf = reorder(v, f, seed=seed)
    write_mesh(dst, rv, rf)


def generate_reordered(
    source: Path, folder: Path, manifest: dict[str, Any], regenerate: bool, workers: int
) -> dict[str, Any]:
    """A copy of ``source`` with every file's vertex and face order shuffled."""
    wanted = {k: manifest[k] for k in ("key", "size", "count", "meshes", "files")}
    wanted["version"] = MANIFEST_VERSION
    wanted["reordered_from"] = str(source)
    if not regenerate and _manifest_matches(folder, wanted):
        have = json.loads((folder / MANIFEST).read_text())
        if have.get("reordered_from") == str(source):
            return {**wanted, "reused": True, "seconds": 0.0}
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.ply"):
        old.unlink()
    (folder / MANIFEST).unlink(missing_ok=True)
    t0 = time.perf_counter()
    jobs = [
        (str(source / name), str(folder / name), 5000 + k)
        for k, name in enumerate(sorted(wanted["files"]))
    ]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        list(pool.map(_reorder_one, jobs, chunksize=4))
    seconds = time.perf_counter() - t0
    (folder / MANIFEST).write_text(json.dumps(wanted, indent=1, sort_keys=True))
    return {**wanted, "reused": False, "seconds": seconds}


# --------------------------------------------------------------------------------------------
# measurements


def _loadavg() -> float | None:
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None


def _cpu_seconds() -> float:
    """CPU time of this process and of its reaped children (pool workers, the CLI's tree)."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def start_cluster(malloc_trim: bool) -> tuple[Any, Any]:
    """A 2-worker, 1-thread-each LocalCluster and its Client.

    Dask's nannies put ``distributed.nanny.pre-spawn-environ`` (by default
    ``MALLOC_TRIM_THRESHOLD_=65536`` and one OpenMP/MKL/OpenBLAS thread) into ``os.environ``
    of *this* process before spawning each worker, and leave it there: every process started
    later (the CLI row) would inherit it.  So the environment is put back once the workers
    are up.  With ``malloc_trim`` False the workers start without that variable (a ``None``
    value in the config unsets it): glibc then keeps its dynamic mmap threshold, instead of
    mapping and unmapping every array over 128 KiB (meshwm's tasks now raise the thresholds
    with ``mallopt`` either way).
    """
    import dask
    from distributed import Client, LocalCluster

    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", default={}))
    if not malloc_trim:
        env["MALLOC_TRIM_THRESHOLD_"] = None
    # Quiet: no INFO lines when a cluster closes, no warning when the scheduler's HTTP port
    # (8787, used even without a dashboard) is taken by another cluster.
    logging.getLogger("distributed").setLevel(logging.ERROR)
    warnings.filterwarnings("ignore", message="Port .* is already in use")
    saved = dict(os.environ)
    try:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": env}):
            cluster = LocalCluster(
                n_workers=2,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
        client = Client(cluster)
        client.wait_for_workers(2)
    finally:
        os.environ.clear()
        os.environ.update(saved)
    # Part of start-up, not of the timed run: each worker imports meshwm (about 1 s).
    client.run(importlib.import_module, "meshwm.apps.batch")
    return client, cluster


def worker_env(client: Any) -> dict[str, Any]:
    """The memory and threading variables each Dask worker actually runs with."""

    def get() -> dict[str, str | None]:
        names = ("MALLOC_TRIM_THRESHOLD_", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
        return {k: os.environ.get(k) for k in names}

    return client.run(get)


def _dask_worker_cpu(client: Any) -> Callable[[], float]:
    """CPU seconds used so far by the Dask workers (they live on, so are never reaped)."""

    def total() -> float:
        return float(sum(client.run(time.process_time).values()))

    return total


def score(rows: Sequence[dict[str, Any]], files: dict[str, str]) -> dict[str, int]:
    """Correct ids, wrong ids, missing ids and error rows, against the manifest."""
    correct = wrong = missing = errors = 0
    for row in rows:
        want = files.get(Path(row["path"]).name)
        if row.get("error"):
            errors += 1
        if row.get("id") is None:
            missing += 1
        elif row["id"] == want:
            correct += 1
        else:
            wrong += 1
    return {"correct": correct, "wrong": wrong, "missing": missing, "errors": errors}


def _timed(
    run: Callable[[], list[dict[str, Any]] | None], worker_cpu: Callable[[], float] | None
) -> tuple[float, float, list[dict[str, Any]] | None]:
    """(wall seconds, CPU seconds, rows) of one run."""
    c0 = _cpu_seconds() + (worker_cpu() if worker_cpu else 0.0)
    t0 = time.perf_counter()
    rows = run()
    seconds = time.perf_counter() - t0
    cpu = _cpu_seconds() + (worker_cpu() if worker_cpu else 0.0) - c0
    return seconds, cpu, rows


def _row(
    name: str,
    cores: int,
    runs: list[tuple[float, float, list[dict[str, Any]] | None]],
    n_files: int,
    files: dict[str, str] | None,
    load: float | None,
) -> dict[str, Any]:
    # The run of median time (the machine may be shared; one slow run is not the code).
    seconds, cpu, rows = sorted(runs, key=lambda r: r[0])[len(runs) // 2]
    out: dict[str, Any] = {
        "name": name,
        "files": n_files,
        "cores": cores,
        "seconds": seconds,
        "assets_per_s": n_files / seconds,
        "assets_per_s_per_core": n_files / seconds / cores,
        "cpu_seconds": cpu,
        "assets_per_cpu_s": n_files / cpu if cpu > 0 else None,
        "loadavg_1min_before": load,
        "seconds_all_runs": [r[0] for r in runs],
    }
    if rows is not None and files is not None:
        out.update(score(rows, files))
        out["file_seconds"] = {Path(r["path"]).name: r["seconds"] for r in rows}
    shown = ", ".join(f"{r[0]:.1f}" for r in runs)
    print(f"  {name}: {seconds:.1f} s (runs: {shown})", file=sys.stderr, flush=True)
    return out


def measure(
    name: str,
    cores: int,
    run: Callable[[], list[dict[str, Any]] | None],
    n_files: int,
    files: dict[str, str] | None,
    worker_cpu: Callable[[], float] | None = None,
    repeat: int = 1,
) -> dict[str, Any]:
    load = _loadavg()
    runs = [_timed(run, worker_cpu) for _ in range(max(1, repeat))]
    return _row(name, cores, runs, n_files, files, load)


def measure_pair(
    names: tuple[str, str],
    runs: tuple[Callable[[], list[dict[str, Any]]], Callable[[], list[dict[str, Any]]]],
    n_files: int,
    files: dict[str, str],
    repeat: int,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """``--jobs 1`` and ``--jobs 2``, run alternately: a speed of the machine that drifts
    over a minute (a shared host) then affects both alike.  The second row gets the ratio of
    each back-to-back pair (``paired_speedups``) and their median (``paired_speedup``)."""
    load = _loadavg()
    first: list[tuple[float, float, list[dict[str, Any]] | None]] = []
    second: list[tuple[float, float, list[dict[str, Any]] | None]] = []
    for _ in range(max(1, repeat)):
        first.append(_timed(runs[0], None))
        second.append(_timed(runs[1], None))
    one = _row(names[0], 1, first, n_files, files, load)
    two = _row(names[1], 2, second, n_files, files, load)
    pairs = [a[0] / b[0] for a, b in zip(first, second, strict=True)]
    two["paired_speedups"] = pairs
    two["paired_speedup"] = statistics.median(pairs)
    return one, two


def run_cli(folder: Path, jobs: int) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    cmd = [sys.executable, "-m", "meshwm", "verify", str(folder), "--key", KEY]
    cmd += ["--any-id", "--jobs", str(jobs), "--jsonl"]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    rows: list[dict[str, Any]] = []
    summary: dict[str, Any] = {}
    for line in proc.stdout.splitlines():
        try:
            obj = json.loads(line)
        except ValueError:
            continue
        if "summary" in obj:
            summary = obj["summary"]
        else:
            rows.append(obj)
    info = {
        "command": shlex.join(cmd),
        "exit_code": proc.returncode,
        "MALLOC_TRIM_THRESHOLD_": os.environ.get("MALLOC_TRIM_THRESHOLD_"),
        "summary": summary,
        "stderr_tail": proc.stderr[-2000:],
    }
    return rows, info


def measure_folder(
    folder: Path,
    files: dict[str, str],
    label: str,
    dask_variants: Sequence[tuple[str, bool]],
    startup: dict[str, float],
    dask_env: dict[str, Any],
    repeat: int,
) -> list[dict[str, Any]]:
    """The rows (load only, jobs 1, jobs 2, each Dask cluster, CLI) on one folder.

    Each Dask cluster runs only while its own row is measured, so its idle workers do not
    share the cores with the other rows.
    """
    paths = [folder / name for name in sorted(files)]
    n = len(paths)
    check = Check(key=KEY, params=WatermarkParams(), any_id=True)
    for p in paths:  # untimed: the same page-cache state for every row
        p.read_bytes()

    def load_only() -> None:
        for p in paths:
            read_mesh(p)

    def local(jobs: int) -> Callable[[], list[dict[str, Any]]]:
        return lambda: list(run_local(paths, check, jobs=jobs))

    rows = [measure(f"{label}load only", 1, load_only, n, None, repeat=repeat)]
    rows.extend(
        measure_pair(
            (f"{label}verify --jobs 1", f"{label}verify --jobs 2"),
            (local(1), local(2)),
            n,
            files,
            repeat,
        )
    )
    for name, trim in dask_variants:
        t0 = time.perf_counter()
        client, cluster = start_cluster(trim)
        startup[label + name] = time.perf_counter() - t0
        try:
            wenv = worker_env(client)
            dask_env[label + name] = wenv
            shown = sorted({json.dumps(e, sort_keys=True) for e in wenv.values()})
            print(
                f"{label}{name} start-up: {startup[label + name]:.2f} s (not timed); worker "
                "env: " + "; ".join(shown)
            )
            rows.append(
                measure(
                    f"{label}{name}",
                    2,
                    lambda client=client: list(run_dask(paths, check, scheduler=client)),
                    n,
                    files,
                    worker_cpu=_dask_worker_cpu(client),
                    repeat=repeat,
                )
            )
        finally:
            client.close()
            cluster.close()
    cli_info: dict[str, Any] = {}

    def cli() -> list[dict[str, Any]]:
        got, info = run_cli(folder, 2)
        cli_info.update(info)
        return got

    row = measure(f"{label}CLI verify --jobs 2 --jsonl", 2, cli, n, files, repeat=repeat)
    row["cli"] = cli_info
    if len(row["file_seconds"]) != n:
        row["note"] = f"CLI printed {len(row['file_seconds'])} rows for {n} files"
    rows.append(row)
    base = rows[1]["assets_per_s"]
    load_s = rows[0]["seconds"]
    for r in rows:
        r["speedup_vs_jobs1"] = r["assets_per_s"] / base
        r["ratio_to_load"] = r["seconds"] / load_s
    return rows


def breakdown(paths: Sequence[Path], params: WatermarkParams) -> dict[str, Any]:
    """Median seconds per file of each stage of ``extract_id``, called piece by piece."""
    stages: dict[str, list[float]] = {
        "read": [],
        "check_mesh": [],
        "recover_grid": [],
        "decode": [],
    }
    totals: list[float] = []
    fallbacks = 0
    ids: dict[str, str | None] = {}
    warm = read_mesh(paths[0])
    Decoder(*warm, params=params).extract_id(key=KEY)  # warm-up, untimed
    for p in paths:
        t0 = time.perf_counter()
        v, f = read_mesh(p)
        t1 = time.perf_counter()
        cv, cf = check_mesh(v, f)
        t2 = time.perf_counter()
        try:
            recover_grid(cv, cf)
        except GridError:  # extract_id then cleans or repairs and reads again
            fallbacks += 1
        t3 = time.perf_counter()
        reader = Decoder(cv, cf, params=params)  # the grid again, for the decode below
        t4 = time.perf_counter()
        ids[p.name] = reader.extract_id(key=KEY).id
        t5 = time.perf_counter()
        for name, dt in zip(stages, (t1 - t0, t2 - t1, t3 - t2, t5 - t4), strict=True):
            stages[name].append(dt)
        totals.append((t3 - t0) + (t5 - t4))
    return {
        "files": len(paths),
        "median_seconds": {k: statistics.median(v) for k, v in stages.items()},
        "median_total": statistics.median(totals),
        "grid_fallbacks_to_clean": fallbacks,
        "ids": ids,
    }


# --------------------------------------------------------------------------------------------
# output


def source_state() -> dict[str, Any]:
    """The commit, the modified files and a hash of meshwm's sources (they may be in flux)."""

    def git(*cmd: str) -> str:
        try:
            out = subprocess.run(
                ["git", *cmd], cwd=REPO_ROOT, capture_output=True, text=True, check=False
            )
        except OSError:
            return ""
        return out.stdout.strip()

    digest = hashlib.sha256()
    for p in sorted((REPO_ROOT / "meshwm").glob("*.py")):
        digest.update(p.name.encode() + b"\0" + p.read_bytes())
    return {
        "commit": git("rev-parse", "--short", "HEAD"),
        "modified": [ln.strip() for ln in git("status", "--short", "--", "meshwm").splitlines()],
        "meshwm_sources_sha256": digest.hexdigest()[:16],
    }


def print_table(rows: Sequence[dict[str, Any]]) -> None:
    head = [
        "run",
        "files",
        "s",
        "assets/s",
        "assets/s/core",
        "CPU s",
        "assets/CPU-s",
        "correct ids",
        "speed-up vs jobs 1",
        "time / load-only",
        "load avg",
    ]
    print("| " + " | ".join(head) + " |")
    print("|---|" + "---:|" * (len(head) - 1))
    for r in rows:
        ids = f"{r['correct']}/{r['files']}" if "correct" in r else "-"
        if r.get("wrong") or r.get("errors"):
            ids += f" ({r['wrong']} wrong, {r['errors']} errors)"
        cells = [
            r["name"],
            str(r["files"]),
            f"{r['seconds']:.2f}",
            f"{r['assets_per_s']:.2f}",
            f"{r['assets_per_s_per_core']:.2f}",
            f"{r['cpu_seconds']:.1f}",
            f"{r['assets_per_cpu_s']:.2f}" if r["assets_per_cpu_s"] else "-",
            ids,
            f"{r['speedup_vs_jobs1']:.2f}",
            f"{r['ratio_to_load']:.1f}",
            f"{r['loadavg_1min_before']:.2f}" if r["loadavg_1min_before"] is not None else "-",
        ]
        print("| " + " | ".join(cells) + " |")


def targets(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    by = {r["name"].split(": ")[-1]: r for r in rows}
    per_core = by["verify --jobs 1"]["assets_per_s_per_core"]
    # Back-to-back pairs when there are (see measure_pair), else the two medians.
    jobs2 = by["verify --jobs 2"]
    speedup = jobs2.get("paired_speedup", jobs2["speedup_vs_jobs1"])
    return {
        "per_core_jobs1": per_core,
        "per_core_met": per_core >= TARGET_PER_CORE,
        "per_cpu_second_jobs1": by["verify --jobs 1"]["assets_per_cpu_s"],
        "speedup_1_to_2": speedup,
        "speedup_met": speedup >= TARGET_SPEEDUP,
    }


def print_targets(t: dict[str, Any]) -> None:
    met = {True: "MET", False: "NOT MET"}
    print(
        f"≥ {TARGET_PER_CORE:g} assets/s per core (--jobs 1): {met[t['per_core_met']]} "
        f"({t['per_core_jobs1']:.1f}; per CPU-second {t['per_cpu_second_jobs1']:.1f})"
    )
    print(
        f"≥ {TARGET_SPEEDUP:g}× from 1 to 2 jobs: {met[t['speedup_met']]} "
        f"({t['speedup_1_to_2']:.2f}, the median ratio of back-to-back runs)"
    )


def per_mesh_medians(row: dict[str, Any], files: dict[str, str]) -> dict[str, float]:
    """Median verify seconds per file (as verify_file reports them), per source mesh."""
    groups: dict[str, list[float]] = {}
    for name, s in row.get("file_seconds", {}).items():
        if s is not None and name in files:
            groups.setdefault(name.rsplit("_", 1)[0], []).append(s)
    return {m: statistics.median(v) for m, v in sorted(groups.items())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--assets", type=Path, default=DEFAULT_ASSETS, help="asset folder")
    parser.add_argument("--meshes", type=Path, default=DEFAULT_MESHES, help="dev mesh folder")
    parser.add_argument("--count", type=int, default=200, help="marked assets (200)")
    parser.add_argument("--regenerate", action="store_true", help="make the assets anew")
    parser.add_argument("--workers", type=int, default=2, help="processes for generation (2)")
    parser.add_argument("--breakdown", type=int, default=20, help="files in the stage breakdown")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster rows")
    parser.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="runs per row; the one of median time is reported (default 3)",
    )
    parser.add_argument(
        "--reorder", action="store_true", help="also a copy with vertex and face order shuffled"
    )
    parser.add_argument("--json", type=Path, help="write everything to this JSON file")
    args = parser.parse_args(argv)
    if args.count < 1:
        parser.error("--count must be positive")

    meshes = sorted(p for p in args.meshes.iterdir() if p.suffix.lower() == ".ply")
    if not meshes:
        parser.error(f"no .ply meshes in {args.meshes}")
    info = machine_info("numpy", "scipy", "libigl", "trimesh", "dask", "distributed")
    print(f"machine: {info}")
    print(f"command: {shlex.join([sys.executable, *sys.argv])}")
    state = source_state()
    print(
        f"source: commit {state['commit']}, meshwm sources {state['meshwm_sources_sha256']}, "
        f"modified: {', '.join(state['modified']) or 'none'}"
    )

    gen = generate(args.assets, meshes, args.count, args.regenerate, args.workers)
    files: dict[str, str] = gen["files"]
    if gen["reused"]:
        print(f"assets: reused {len(files)} files in {args.assets} (manifest matches)")
    else:
        print(
            f"assets: generated {len(files)} files in {args.assets} in {gen['seconds']:.1f} s "
            f"({args.workers} processes, one geometry image per mesh)"
        )
        for m in gen["per_mesh"]:
            print(
                f"  {m['mesh']}: {m['files']} files, geometry image {m['gim_seconds']:.2f} s, "
                f"embed + write {m['embed_write_seconds']:.2f} s "
                f"({m['vertices']} V, {m['faces']} F)"
            )
    size_mb = sum((args.assets / n).stat().st_size for n in files) / 1e6
    print(f"folder: {size_mb:.0f} MB, N = {SIZE}, key {KEY!r}, {len(meshes)} dev meshes")

    folders: list[tuple[str, Path, dict[str, Any]]] = [("", args.assets, {})]
    if args.reorder:
        rfolder = args.assets.parent / (args.assets.name + "-reordered")
        rgen = generate_reordered(args.assets, rfolder, gen, args.regenerate, args.workers)
        note = "reused" if rgen["reused"] else f"made in {rgen['seconds']:.1f} s"
        print(f"reordered copy: {rfolder} ({note})")
        folders.append(("reordered: ", rfolder, rgen))

    startup: dict[str, float] = {}
    dask_env: dict[str, Any] = {}
    results: dict[str, Any] = {}
    variants = [] if args.no_dask else list(DASK_VARIANTS)
    for label, folder, _ in folders:
        rows = measure_folder(folder, files, label, variants, startup, dask_env, args.repeat)
        results[label or "plain"] = rows

    print()
    all_rows = [r for rows in results.values() for r in rows]
    print_table(all_rows)
    print()
    print("assets/s per core: files / seconds / processes (1 for load only and --jobs 1).")
    print(
        "CPU s: this process + reaped children (pool workers, the CLI and its workers) + the "
        "Dask workers' process_time; assets/CPU-s is a per-core rate less sensitive to other "
        "load than wall time (not immune: contention for the cores and caches inflates it)."
    )
    print("Shared 2-core machine, other work running: timings are noisy (load avg per row).")
    tgt = targets(results["plain"])
    print()
    print_targets(tgt)
    if "reordered" in results:
        rt = targets(results["reordered"])
        print("reordered copy:")
        print_targets(rt)
    else:
        rt = None

    cli_rows = [r for r in all_rows if "cli" in r]
    for r in cli_rows:
        c = r["cli"]
        print(f"{r['name']}: exit code {c['exit_code']}, summary {c['summary']}")

    jobs1 = results["plain"][1]
    medians = per_mesh_medians(jobs1, files)
    print()
    print("verify --jobs 1, median seconds per file (verify_file's own timing) by source mesh:")
    print("  " + ", ".join(f"{m} {s:.3f}" for m, s in medians.items()))

    names = sorted(files)
    step = max(1, len(names) // max(1, args.breakdown))
    chosen = names[::step][: args.breakdown]
    breakdowns: dict[str, Any] = {}
    bad = sum(r.get("wrong", 0) + r.get("missing", 0) for r in all_rows)
    bad += sum(1 for r in cli_rows if r["cli"]["exit_code"] != 0)
    for label, folder, _ in folders:
        bd = breakdown([folder / n for n in chosen], WatermarkParams())
        bd["correct"] = sum(bd["ids"][n] == files[n] for n in chosen)
        bad += bd["files"] - bd["correct"]
        breakdowns[label or "plain"] = bd
        print()
        print(
            f"{label}stage breakdown (in-process, {bd['files']} files spread over the meshes, "
            "medians):"
        )
        print("| stage | median s/file | share of median total |")
        print("|---|---:|---:|")
        total = bd["median_total"]
        for stage, s in bd["median_seconds"].items():
            print(f"| {stage} | {s:.4f} | {100 * s / total:.0f} % |")
        print(f"| total | {total:.4f} | |")
        print(
            f"ids correct {bd['correct']}/{bd['files']}, recover_grid needed the clean "
            f"fallback {bd['grid_fallbacks_to_clean']} times"
        )

    if args.json:
        out = {
            "command": [sys.executable, *sys.argv],
            "machine": info,
            "source": state,
            "size": SIZE,
            "key": KEY,
            "assets": str(args.assets),
            "generation": {k: v for k, v in gen.items() if k != "files"},
            "dask_startup_seconds": startup,
            "dask_worker_env": dask_env,
            "results": results,
            "targets": tgt,
            "targets_reordered": rt,
            "per_mesh_median_seconds_jobs1": medians,
            "breakdown": breakdowns,
            "problems": bad,
        }
        args.json.write_text(json.dumps(out, indent=1, default=str))
        print(f"\nwrote {args.json}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
