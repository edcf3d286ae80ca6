"""Shared by the tests of :mod:`meshwm.apps.registry` and ``meshwm registry``: a real, throwaway
PostgreSQL server, and a registry target on each backend.

``postgres_url`` starts a server of its own for the session: ``initdb`` and ``pg_ctl`` from the
PATH or ``/usr/lib/postgresql/*/bin``, a temporary data folder and socket folder, a free TCP
port on 127.0.0.1, a database ``meshwm_test``; as root the server runs as the ``postgres``
user (initdb refuses root).  It is stopped and its folder deleted at the end.  When no server
can be started the PostgreSQL tests skip, saying what was missing (``.ci/run`` installs the
server on a clean Debian machine).
"""

from __future__ import annotations

import glob
import hashlib
import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

#: The database the fixture creates on its server.
DATABASE = "meshwm_test"
#: Length of the test descriptors.
DESCRIPTOR_LENGTH = 8


def _server_binaries() -> tuple[Path, Path] | str:
    """``initdb`` and ``pg_ctl``, or the reason they cannot be found."""
    initdb, pg_ctl = shutil.which("initdb"), shutil.which("pg_ctl")
    if initdb and pg_ctl:
        return Path(initdb), Path(pg_ctl)
    folders = sorted(
        glob.glob("/usr/lib/postgresql/*/bin"),
        key=lambda path: [int(p) if p.isdigit() else 0 for p in Path(path).parent.name.split(".")],
    )
    for folder in reversed(folders):
        initdb_path, pg_ctl_path = Path(folder, "initdb"), Path(folder, "pg_ctl")
        if initdb_path.exists() and pg_ctl_path.exists():
            return initdb_path, pg_ctl_path
    return "no PostgreSQL server binaries (initdb, pg_ctl) on PATH or in /usr/lib/postgresql/*/bin"


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _as_server_user() -> tuple[list[str], str | None] | str:
    """The command prefix that runs server programs, and the user to chown folders to."""
    if os.geteuid() != 0:
        return [], None
    try:
        import pwd

        pwd.getpwnam("postgres")
    except KeyError:
        return "running as root and there is no 'postgres' user to run the server as"
    runuser = shutil.which("runuser")
    if runuser:
        return [runuser, "-u", "postgres", "--"], "postgres"
    return "running as root and there is no runuser to run the server as 'postgres'"


def _run(command: list[str], what: str) -> str | None:
    """Run a server command; the reason it failed (last line of its output), or None."""
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:
        return f"{what} failed: {error}"
    if done.returncode != 0:
        lines = (done.stderr or done.stdout).strip().splitlines() or ["no output"]
        return f"{what} failed (exit {done.returncode}): {lines[-1]}"
    return None


@pytest.fixture(scope="session")
def postgres_url() -> Iterator[str]:
    """The URL of a database on a PostgreSQL server started for this session."""
    try:
        import psycopg
    except ImportError:
        pytest.skip("psycopg is not installed (pip install 'meshwm[test]')")
    binaries = _server_binaries()
    if isinstance(binaries, str):
        pytest.skip(binaries)
    initdb, pg_ctl = binaries
    runner = _as_server_user()
    if isinstance(runner, str):
        pytest.skip(runner)
    prefix, owner = runner
    root = Path(tempfile.mkdtemp(prefix="meshwm-postgres-"))
    data, sockets, log = root / "data", root / "sockets", root / "server.log"
    sockets.mkdir()
    if owner is not None:
        for path in (root, sockets):
            shutil.chown(path, user=owner)
    started = False
    try:
        reason = _run(
            [*prefix, str(initdb), "-D", str(data), "-A", "trust", "-U", "postgres",
             "-E", "UTF8", "--no-sync", "--no-instructions"],
            "initdb",
        )  # fmt: skip
        port = _free_port()
        options = (
            f"-p {port} -k {sockets} -c listen_addresses=127.0.0.1 -c fsync=off "
            "-c synchronous_commit=off -c full_page_writes=off"
        )
        if reason is None:
            reason = _run(
                [*prefix, str(pg_ctl), "-D", str(data), "-l", str(log), "-o", options,
                 "-w", "-t", "60", "start"],
                "pg_ctl start",
            )  # fmt: skip
            started = reason is None
        if reason is not None:
            pytest.skip(f"cannot start a PostgreSQL server: {reason}")
        admin = f"host=127.0.0.1 port={port} user=postgres dbname=postgres"
        with psycopg.connect(admin, autocommit=True) as connection:
            connection.execute(f"CREATE DATABASE {DATABASE}")
        yield f"postgresql://postgres@127.0.0.1:{port}/{DATABASE}"
    finally:
        if started:
            _run([*prefix, str(pg_ctl), "-D", str(data), "-m", "immediate", "-w", "stop"], "stop")
        shutil.rmtree(root, ignore_errors=True)


def reset_postgres(url: str) -> None:
    """Drop every table of the test database (each test starts from an empty one)."""
    import psycopg

    with psycopg.connect(url, autocommit=True) as connection:
        connection.execute("DROP SCHEMA public CASCADE")
        connection.execute("CREATE SCHEMA public")


@pytest.fixture(params=["sqlite", "postgresql"])
def target(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """Where a new registry goes: a file in ``tmp_path``, or the emptied test database."""
    if request.param == "sqlite":
        return str(tmp_path / "registry.db")
    url = request.getfixturevalue("postgres_url")
    reset_postgres(url)
    return str(url)


def execute_sql(target: str, *statements: str) -> list[tuple]:
    """Run SQL on a registry behind its back (to look inside it or damage it on purpose), in
    one transaction; the rows of the last statement, if it returns any."""
    from sqlalchemy import create_engine, text

    url = target.replace("postgresql://", "postgresql+psycopg://", 1)
    if "://" not in url:
        url = f"sqlite:///{target}"
    engine = create_engine(url)
    rows: list[tuple] = []
    try:
        with engine.begin() as connection:
            for statement in statements:
                result = connection.execute(text(statement))
                rows = [tuple(row) for row in result] if result.returns_rows else []
    finally:
        engine.dispose()
    return rows


def make_asset(index: int, *, sizes: tuple[int, ...] = (64, 128), reference_bytes: int = 1000):
    """The test asset ``index``: its hash, descriptor and reference bytes follow from ``index``."""
    from meshwm.apps.registry import AssetEntry

    rng = np.random.default_rng(index)
    references = {n: rng.bytes(reference_bytes) for n in sizes}
    return AssetEntry(
        name=f"asset{index}.ply",
        input_sha256=hashlib.sha256(f"asset {index}".encode()).hexdigest(),
        vertices=1000 + index,
        faces=2000 + index,
        descriptor=rng.normal(size=DESCRIPTOR_LENGTH),
        references=references,
    )


def make_copy(index: int, *, payload: str | None = None, recipient: str | None = "vendor"):
    """The test copy ``index``."""
    from meshwm.apps.registry import CopyEntry

    return CopyEntry(
        payload=payload or f"{index:016x}",
        recipient=recipient,
        output_name=f"copy{index}.ply",
        output_sha256=hashlib.sha256(f"copy {index}".encode()).hexdigest(),
        n=64,
        params={"profile": "robust", "strength": 1.0, "index": index},
    )


def record_many(target: str, worker: int, embeds: int, assets: int, start, results) -> None:
    """A process of the concurrency test: ``embeds`` copies of ``assets`` shared inputs.

    Waits for ``start`` (a barrier) so every process opens and writes at once; puts the
    (asset id, copy id) pairs, or the error's text, on ``results``.
    """
    from meshwm.apps.registry import Registry

    try:
        start.wait(timeout=60)
        pairs = []
        with Registry.open(target) as registry:
            for embed in range(embeds):
                index = embed % assets
                copy = make_copy(worker * 1000 + embed, recipient=f"worker {worker}")
                pairs.append(
                    registry.record_embed(make_asset(index, reference_bytes=100_000), copy)
                )
        results.put((worker, pairs))
    except BaseException as error:  # reported to the test, which fails with it
        results.put((worker, f"{type(error).__name__}: {error}"))
