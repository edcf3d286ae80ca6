"""Where a registry lives: an SQLite file or a PostgreSQL database, behind one SQLAlchemy engine.

:func:`connect` turns a target (a path, or a ``postgresql://`` URL) into a :class:`Backend`:
the engine, the name messages use (a URL never shows its password) and how a write
transaction begins.  SQLite runs in WAL mode with a busy timeout and foreign keys on, and a
write transaction starts with ``BEGIN IMMEDIATE`` (it waits for the write lock up front, so
two writers never deadlock on a read lock they both hold); reads start with a plain
``BEGIN``.  :func:`errors_as_registry_errors` turns a driver's failure into a one-line
:class:`~meshwm.errors.RegistryError`, and :func:`retryable` says which failures a write may
simply run again (PostgreSQL serialization failures and deadlocks, SQLite's busy lock).
"""

from __future__ import annotations

import contextlib
import itertools
import os
import random
import sqlite3
import struct
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, exc, pool
from sqlalchemy.engine import make_url

from meshwm.errors import RegistryError

__all__ = [
    "BUSY_TIMEOUT",
    "WRITE_OPTION",
    "Backend",
    "connect",
    "errors_as_registry_errors",
    "is_url",
    "retryable",
    "set_wal",
]

#: Seconds an SQLite connection waits for another process's lock before it gives up.
BUSY_TIMEOUT = 30.0
#: The first 16 bytes of every SQLite database file.
SQLITE_MAGIC = b"SQLite format 3\x00"
#: PostgreSQL error codes a write is run again for: serialization failure, deadlock.
RETRY_SQLSTATES = frozenset({"40001", "40P01"})
#: Execution option that makes an SQLite transaction begin with ``BEGIN IMMEDIATE``.
WRITE_OPTION = "meshwm_write"
_URL_SCHEMES = ("postgresql://", "postgresql+psycopg://", "postgres://")


@dataclass(frozen=True)
class Backend:
    """An open engine and what the registry needs to know about it."""

    engine: Engine
    #: ``"sqlite"`` or ``"postgresql"``.
    dialect: str
    #: The registry as messages name it: the path, or the URL without its password.
    name: str
    #: The SQLite file (None for PostgreSQL).
    path: Path | None


def is_url(target: str | os.PathLike[str]) -> bool:
    """Whether ``target`` names a PostgreSQL database rather than a file."""
    return isinstance(target, str) and target.lower().startswith(_URL_SCHEMES)


def connect(target: str | os.PathLike[str], *, create: bool) -> Backend:
    """The backend of ``target``: a path is an SQLite file, a URL a PostgreSQL database.

    Raises
    ------
    RegistryError
        When the file is missing (``create=False``), is a folder, is not an SQLite database
        or is cut short, or the URL is malformed or names another kind of database.
    """
    if is_url(target):
        return _postgresql(str(target))
    if isinstance(target, str) and "://" in target:
        scheme = target.split("://", 1)[0]
        raise RegistryError(
            f"{scheme}://...: unknown registry URL scheme {scheme!r}; give a file path or a "
            "postgresql:// URL"
        )
    return _sqlite(Path(target), create=create)


def _postgresql(target: str) -> Backend:
    try:
        url = make_url(target)
    except (exc.ArgumentError, ValueError):
        raise RegistryError("the registry URL is malformed (expected postgresql://...)") from None
    if url.drivername in ("postgresql", "postgres", "postgresql+psycopg"):
        url = url.set(drivername="postgresql+psycopg")
    name = url.render_as_string(hide_password=True)
    try:
        engine = create_engine(url, pool_pre_ping=True)
    except (exc.ArgumentError, ImportError) as error:
        hint = " (pip install 'meshwm[postgres]')" if isinstance(error, ImportError) else ""
        raise RegistryError(f"{name}: cannot use this database: {_one_line(error)}{hint}") from None
    return Backend(engine=engine, dialect="postgresql", name=name, path=None)


def _sqlite(path: Path, *, create: bool) -> Backend:
    name = str(path)
    if path.is_dir():
        raise RegistryError(f"{name}: is a folder, not a registry file")
    if not path.exists():
        if not create:
            raise RegistryError(f"{name}: no such registry")
        if not path.absolute().parent.is_dir():
            raise RegistryError(f"{name}: folder {path.parent} does not exist")
    else:
        _check_sqlite_file(path)
    database = os.fspath(path)

    def creator() -> sqlite3.Connection:
        # isolation_level=None: the sqlite3 module starts no transaction itself; _begin does.
        return sqlite3.connect(
            database, timeout=BUSY_TIMEOUT, isolation_level=None, check_same_thread=False
        )

    engine = create_engine("sqlite+pysqlite://", creator=creator, poolclass=pool.QueuePool)
    event.listen(engine, "connect", _sqlite_on_connect)
    event.listen(engine, "begin", _sqlite_begin)
    return Backend(engine=engine, dialect="sqlite", name=name, path=path)


def _sqlite_on_connect(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    try:
        cursor.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT * 1000)}")
        cursor.execute("PRAGMA foreign_keys = ON")
    finally:
        cursor.close()


def _sqlite_begin(connection: Any) -> None:
    write = connection.get_execution_options().get(WRITE_OPTION, False)
    connection.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")


def set_wal(backend: Backend) -> None:
    """SQLite: switch the file to write-ahead logging (kept in the file; a no-op after).

    Done on the DBAPI connection, outside any transaction (the pragma refuses to run in one).
    """
    row = None
    # The switch needs the file to itself for a moment, and SQLite may answer "locked" at
    # once rather than wait out the busy timeout (a reader that would have to upgrade its lock
    # backs off to avoid a deadlock): seen with four processes opening a new registry on a
    # loaded machine.  Try again, with a growing random pause, for up to the busy timeout.
    deadline = time.monotonic() + BUSY_TIMEOUT
    for attempt in itertools.count():
        raw = backend.engine.raw_connection()
        try:
            cursor = raw.cursor()
            cursor.execute("PRAGMA journal_mode = WAL")
            row = cursor.fetchone()
            cursor.close()
            break
        except sqlite3.OperationalError as error:
            if "locked" not in str(error) and "busy" not in str(error):
                raise RegistryError(f"{backend.name}: {_one_line(error)}") from None
            if time.monotonic() > deadline:
                raise RegistryError(f"{backend.name}: {_one_line(error)}") from None
        finally:
            raw.close()
        time.sleep(random.uniform(0.0, min(0.02 * 2**attempt, 1.0)))
    mode = row[0] if row else None
    if str(mode).lower() != "wal":
        raise RegistryError(f"{backend.name}: cannot switch the registry to WAL mode ({mode})")


def _check_sqlite_file(path: Path) -> None:
    """Refuse a file that is not an SQLite database, or one cut short, before SQLite opens it.

    An empty file is what SQLite itself makes of a new database (another process may be
    creating the registry right now), so it passes; the schema check decides.
    """
    name = str(path)
    try:
        size = path.stat().st_size
        with path.open("rb") as stream:
            header = stream.read(100)
    except OSError as error:
        raise RegistryError(f"{name}: cannot read the registry: {_one_line(error)}") from None
    if size == 0:
        return
    if not header.startswith(SQLITE_MAGIC[: len(header)]) or len(header) < len(SQLITE_MAGIC):
        raise RegistryError(f"{name}: not a meshwm registry (not an SQLite database)")
    if len(header) < 100:
        raise RegistryError(f"{name}: registry file is truncated ({size} bytes)")
    (page_size,) = struct.unpack(">H", header[16:18])
    page_size = 65536 if page_size == 1 else page_size
    counter, pages = struct.unpack(">II", header[24:32])
    (valid_for,) = struct.unpack(">I", header[92:96])
    wal = path.with_name(path.name + "-wal")
    wal_in_use = wal.exists() and wal.stat().st_size > 0
    # The header's page count is trusted when it is current; while a WAL holds pages another
    # process may be checkpointing, so the file may be growing: SQLite itself decides then.
    if pages and counter == valid_for and not wal_in_use and size < pages * page_size:
        raise RegistryError(
            f"{name}: registry file is truncated ({size} bytes of {pages * page_size})"
        )


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split()) or type(error).__name__


def _driver_message(error: exc.DBAPIError) -> str:
    """The driver's own message, one line, without the SQL or its parameters."""
    original = error.orig if error.orig is not None else error
    return _one_line(original)


def retryable(error: exc.DBAPIError) -> bool:
    """Whether a failed write may be run again as it was."""
    sqlstate = getattr(error.orig, "sqlstate", None)
    if sqlstate in RETRY_SQLSTATES:
        return True
    return isinstance(error.orig, sqlite3.OperationalError) and "locked" in str(error.orig)


@contextlib.contextmanager
def errors_as_registry_errors(name: str) -> Iterator[None]:
    """Turn any database failure in the block into a one-line RegistryError naming ``name``."""
    try:
        yield
    except exc.DBAPIError as error:
        message = _driver_message(error)
        if "not a database" in message or "malformed" in message:
            message = f"not a meshwm registry or damaged ({message})"
        raise RegistryError(f"{name}: {message}") from None
    except exc.SQLAlchemyError as error:
        raise RegistryError(f"{name}: {_one_line(error)}") from None
