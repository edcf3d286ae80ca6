"""Verify many files: path expansion, one self-contained check per file, parallel runners.

``meshwm verify PATH… --key-file K [--mark IMG | --id X | --any-id] [--jobs J] [--jsonl]``
answers "is this ours, and whose copy is it?" for a whole asset library.  Each file is checked
by :func:`verify_file`, a pure function of (path, :class:`Check`) that never raises: a file that
cannot be read is a row with an ``error``, never the end of the batch.  Every mesh of a file is
read (:func:`meshwm.watermark.assets.verify_asset`); the file is present when one of its meshes
is, and its row lists them all under ``meshes``.  The rows are the same
whether the files are checked in this process, by ``--jobs`` worker processes
(:mod:`concurrent.futures`) or on a Dask cluster (``--scheduler``, :func:`run_dask`); the
order of the output is the order of the paths.
"""

from __future__ import annotations

import glob
import os
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from meshwm._malloc import keep_freed_memory
from meshwm._validate import DEFAULT_MAX_FACES
from meshwm.errors import MeshError
from meshwm.mesh.asset import ASSET_SUFFIXES, read_asset
from meshwm.params import WatermarkParams
from meshwm.watermark.assets import verify_asset

__all__ = ["Check", "expand_paths", "run_dask", "run_local", "summarise", "verify_file"]


@dataclass(frozen=True)
class Check:
    """What to look for in each file.

    Exactly one of ``mark`` (a 0/1 image), ``ident`` (8 bytes) or ``any_id`` is set;
    ``ident_text`` is the id as typed (to point out a hex id typed without ``0x``).  The key is
    never part of a row or a message.
    """

    key: str | bytes = field(repr=False)
    params: WatermarkParams
    mark: np.ndarray | None = None
    ident: bytes | None = None
    any_id: bool = False
    fpr: float = 1e-6
    max_faces: int = DEFAULT_MAX_FACES
    ident_text: str | None = None
    #: A registry (path or URL): meshes the blind readers miss go to the informed reader.
    registry: str | None = None

    def __post_init__(self) -> None:
        chosen = (self.mark is not None) + (self.ident is not None) + bool(self.any_id)
        if chosen != 1:
            raise ValueError("check for exactly one of a mark, an id or any id")


def expand_paths(items: Iterable[str | os.PathLike]) -> list[Path]:
    """Files named, found under folders (recursively, by mesh suffix) or matched by globs.

    Named files are kept whatever their suffix (an unreadable one becomes an error row);
    duplicates are dropped; folders and globs are sorted.  A pattern that matches nothing is
    kept as given, so it is reported as missing rather than silently skipped.
    """
    out: list[Path] = []
    seen: set[str] = set()

    def add(p: Path) -> None:
        key = os.path.normpath(os.path.abspath(p))
        if key not in seen:
            seen.add(key)
            out.append(p)

    for item in items:
        text = os.fspath(item)
        path = Path(text)
        if path.is_dir():
            for f in sorted(path.rglob("*")):
                if f.is_file() and f.suffix.lower() in ASSET_SUFFIXES:
                    add(f)
        elif not path.exists() and glob.has_magic(text):
            matches = sorted(glob.glob(text, recursive=True))
            for m in matches:
                if Path(m).is_file():
                    add(Path(m))
            if not matches:
                add(path)
        else:
            add(path)
    return out


#: The figures of a file's row taken from its best mesh.
_TOP = (
    "p_value",
    "ber",
    "id",
    "id_text",
    "hypotheses",
    "threshold",
    "correlation",
    "bits",
    "reader",
    "informed",
)


def _best(meshes: list[dict[str, Any]]) -> dict[str, Any]:
    """The mesh whose figures stand for the file: the first present, else the least absent."""
    present = [m for m in meshes if m["detected"]]
    if present:
        return present[0]
    read = [m for m in meshes if m.get("p_value") is not None]
    return min(read, key=lambda m: m["p_value"]) if read else meshes[0]


def verify_file(
    path: str | os.PathLike, check: Check, *, progress: Callable[[str], None] | None = None
) -> dict[str, Any]:
    """One row: path, detected, p_value, ber, id, seconds, error, meshes (never raises).

    ``detected``: some mesh of the file carries what was sought; the figures (``p_value``,
    ``ber``, ``id``, ``note``, ``reason``, ``piece``, ``together``, ...) are that mesh's, or
    the closest one's.
    ``progress`` is told which mesh is being read.
    """
    t0 = time.perf_counter()
    row: dict[str, Any] = {
        "path": os.fspath(path),
        "detected": False,
        "p_value": None,
        "ber": None,
        "id": None,
        "seconds": None,
        "error": None,
    }
    try:
        asset = read_asset(path, max_faces=check.max_faces)
        meshes = verify_asset(
            asset,
            key=check.key,
            mark=check.mark,
            ident=check.ident,
            any_id=check.any_id,
            ident_text=check.ident_text,
            fpr=check.fpr,
            params=check.params,
            max_faces=check.max_faces,
            progress=progress,
        )
        if check.registry is not None and not any(m["detected"] for m in meshes):
            _informed(asset, meshes, check, check.registry, progress)
        best = _best(meshes)
        row.update({k: best[k] for k in _TOP if k in best})
        for name in ("note", "reason", "piece", "together"):
            if name in best:
                row[name] = best[name]
        row["detected"] = any(m["detected"] for m in meshes)
        row["meshes"] = meshes
    except (MeshError, OSError, ValueError) as exc:
        row["error"] = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row


def _informed(
    asset: Any, meshes: list[dict[str, Any]], check: Check, target: str, progress: Any
) -> None:
    """The informed reader on each mesh the blind readers missed (rows updated in place).

    A mesh is present when the copy it is traced to carries what was sought: the id, any id,
    or the mark (:func:`meshwm.apps.tracing.mark_payload`).
    """
    from meshwm.apps.registry import Registry
    from meshwm.apps.tracing import mark_payload, trace_mesh

    wanted = None
    if check.ident is not None:
        wanted = check.ident.hex()
    elif check.mark is not None:
        wanted = mark_payload(check.mark)
    with Registry.open(target, create=False) as registry:
        for k, row in enumerate(meshes):
            if asset.meshes[k].reason is not None:
                continue
            if progress is not None:
                progress(f"informed reading of {asset.meshes[k].name}")
            found = trace_mesh(
                asset.vertices(k),
                asset.meshes[k].faces,
                key=check.key,
                registry=registry,
                fpr=check.fpr,
                max_faces=check.max_faces,
            )
            payload = found.get("id")
            carries = found["detected"] and (
                payload == wanted if wanted is not None else not str(payload).startswith("mark:")
            )
            row["informed"] = {
                name: found.get(name)
                for name in ("detected", "asset_id", "asset", "copy_id", "id", "recipient")
            }
            if carries:
                row.update(
                    detected=True,
                    reader="informed (registry)",
                    p_value=found["p_value"],
                    hypotheses=found["hypotheses"],
                    id=None if str(payload).startswith("mark:") else payload,
                )


def _verify_indexed(args: tuple[int, str, Check]) -> tuple[int, dict[str, Any]]:
    k, path, check = args
    keep_freed_memory()
    return k, verify_file(path, check)


def run_local(
    paths: Sequence[str | os.PathLike], check: Check, *, jobs: int = 1
) -> Iterator[dict[str, Any]]:
    """Rows in path order, as they complete in order; ``jobs`` worker processes (1: in-process).

    The processes that check files keep freed memory for reuse (glibc's malloc thresholds are
    raised, see :mod:`meshwm._malloc`): this one too when ``jobs`` is 1.
    """
    items = [(k, os.fspath(p), check) for k, p in enumerate(paths)]
    if jobs <= 1 or len(items) <= 1:
        for item in items:
            yield _verify_indexed(item)[1]
        return
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        for _, row in pool.map(_verify_indexed, items, chunksize=1):
            yield row


def _verify_on_worker(paths: list[str], check: Check) -> list[dict[str, Any]]:
    keep_freed_memory()
    return [verify_file(p, check) for p in paths]


#: Files per Dask task at most: a task costs the cluster a few milliseconds of its own
#: (scheduling, messages), a tenth of a file's check at N = 256.
DASK_CHUNK = 16


#: Dask tasks per worker at least, while groups have more than one file: the last groups
#: finish at different times, and a file whose grid must be read without the writer's face
#: order takes ten times as long.  Measured on 2 workers and 200 files at N = 256, as
#: written and with shuffled faces: groups of 3 (32 tasks per worker) were the fastest of 1,
#: 3, 6 and 12 in one pass; a second pass did not separate 3 from 16 beyond the noise.
DASK_TASKS_PER_WORKER = 32


def _chunk_size(n_files: int, n_workers: int) -> int:
    """Files per Dask task: :data:`DASK_TASKS_PER_WORKER` tasks per worker, 1 to ``DASK_CHUNK``."""
    per = DASK_TASKS_PER_WORKER * max(n_workers, 1)
    return max(1, min(DASK_CHUNK, n_files // per))


def run_dask(
    paths: Sequence[str | os.PathLike], check: Check, *, scheduler: Any
) -> Iterator[dict[str, Any]]:
    """Rows in path order from a Dask cluster (``scheduler``: an address or a Client).

    Needs the optional ``dask`` extra (``pip install 'meshwm[dask]'``); every worker needs
    meshwm installed and read access to the paths (a shared file system or object store
    mounted at the same place).  Files go to the workers in small groups (at least
    :data:`DASK_TASKS_PER_WORKER` per worker, at most :data:`DASK_CHUNK` files each), since
    every task costs the cluster a few milliseconds.  Each worker's malloc thresholds are
    raised as in :func:`run_local` (which also undoes the 64 KiB trim threshold Dask's nanny
    sets).
    """
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise RuntimeError(
            "--scheduler needs dask.distributed: pip install 'meshwm[dask]'"
        ) from exc
    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        names = [os.fspath(p) for p in paths]
        workers = len(client.scheduler_info(n_workers=-1).get("workers", {}))
        size = _chunk_size(len(names), workers)
        chunks = [names[k : k + size] for k in range(0, len(names), size)]
        futures = client.map(_verify_on_worker, chunks, check=check, pure=False, retries=1)
        for fut in futures:
            yield from fut.result()
    finally:
        if client is not scheduler:
            client.close()


def summarise(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Counts and the exit code: 2 if any file could not be read, else 1 if any is not marked."""
    errors = sum(1 for r in rows if r["error"])
    present = sum(1 for r in rows if r["detected"])
    absent = len(rows) - errors - present
    code = 2 if errors else (1 if absent else 0)
    return {
        "files": len(rows),
        "present": present,
        "absent": absent,
        "errors": errors,
        "seconds": round(sum(r["seconds"] or 0.0 for r in rows), 3),
        "exit_code": code,
    }
