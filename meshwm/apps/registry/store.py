"""The asset registry: every marked copy a studio sends out, and the asset it was made from.

One code path for SQLite and PostgreSQL (SQLAlchemy Core); :mod:`.backends` holds what differs.
Every method runs in one transaction; writes that lose a race on PostgreSQL (serialization
failure, deadlock) are run again.  Any database failure is a one-line
:class:`~meshwm.errors.RegistryError` naming the registry.
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from datetime import datetime, timezone
from types import TracebackType
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray
from sqlalchemy import Connection, Row, Select, delete, exc, func, select
from sqlalchemy.dialects import postgresql, sqlite

from meshwm.apps.registry import backends
from meshwm.apps.registry.entries import (
    AssetEntry,
    AssetRecord,
    CopyEntry,
    CopyRecord,
    check_references,
    decode_params,
    encode_descriptor,
    encode_params,
    normalise_payload,
)
from meshwm.apps.registry.schema import assets, check_schema, copies, lock_schema, meta, references
from meshwm.errors import RegistryError

__all__ = ["Registry"]

_T = TypeVar("_T")

#: How many times a write that lost a race is run before its error is raised.
WRITE_ATTEMPTS = 8


def _now() -> str:
    """The current UTC time as ISO-8601 text, to the second: ``2025-01-31T12:00:00+00:00``."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _row_id(name: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    return int(value)


class Registry:
    """The asset registry of one SQLite file or PostgreSQL database.

    Open it with :meth:`Registry.open`; use it as a context manager or call :meth:`close`.
    It stores no key: a copy's params naming ``key`` or ``secret`` are refused.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> from meshwm.apps.registry import AssetEntry, CopyEntry, Registry
    >>> folder = tempfile.TemporaryDirectory()
    >>> asset = AssetEntry("cow.ply", "ab" * 32, 2930, 5856, np.ones(4), {256: b"ref"})
    >>> copy = CopyEntry("56454e444f525f41", "vendor A", "cow_a.ply", "cd" * 32, 256, {})
    >>> with Registry.open(f"{folder.name}/registry.db") as registry:
    ...     registry.record_embed(asset, copy)
    ...     registry.record_embed(asset, copy)
    ...     [(a.name, a.copies) for a in registry.assets()]
    (1, 1)
    (1, 2)
    [('cow.ply', 2)]
    >>> folder.cleanup()
    """

    def __init__(self, backend: backends.Backend) -> None:
        """Wrap an open backend; :meth:`Registry.open` is the way to get one."""
        self._backend = backend
        self._engine = backend.engine
        self._writer = backend.engine.execution_options(**{backends.WRITE_OPTION: True})
        self._insert = sqlite.insert if backend.dialect == "sqlite" else postgresql.insert
        self._closed = False

    @classmethod
    def open(cls, target: str | os.PathLike[str], *, create: bool = True) -> Registry:
        """Open (or create) the registry at ``target``.

        Parameters
        ----------
        target : str or path-like
            A file path (an SQLite database) or a URL ``postgresql://user@host:port/db``
            (``postgresql+psycopg://`` too; needs ``pip install 'meshwm[postgres]'``).
        create : bool, keyword-only
            Whether a missing file, an empty file or a database without tables becomes a new
            registry (default); with False these raise :class:`RegistryError`.

        Returns
        -------
        Registry

        Raises
        ------
        RegistryError
            When ``target`` is not a registry (not an SQLite database, cut short, holding other
            tables or only some of the registry's), has another schema version, or cannot be
            reached; the message is one line and names ``target`` (never a password).
        """
        backend = backends.connect(target, create=create)
        registry = cls(backend)
        try:
            if create:
                registry._create_or_check()
            else:  # an existing registry only: a read transaction, no write lock taken
                with registry._read() as connection:
                    check_schema(connection, name=backend.name, create=False)
        except BaseException:
            registry.close()
            raise
        return registry

    def _create_or_check(self) -> None:
        """Create the tables if the database has none, else check them, in a write transaction
        (under a lock on PostgreSQL), so processes opening a new registry at once create it
        once; then SQLite's journal goes to WAL (which a transaction cannot change)."""

        def prepare(connection: Connection) -> None:
            if self.dialect == "postgresql":
                lock_schema(connection)
            check_schema(connection, name=self.name, create=True)

        self._write(prepare)
        if self.dialect == "sqlite":
            with backends.errors_as_registry_errors(self.name):
                backends.set_wal(self._backend)

    @property
    def name(self) -> str:
        """The registry as messages name it: its path, or its URL without the password."""
        return self._backend.name

    @property
    def dialect(self) -> str:
        """``"sqlite"`` or ``"postgresql"``."""
        return self._backend.dialect

    def close(self) -> None:
        """Close every connection; the registry cannot be used after this."""
        if not self._closed:
            self._closed = True
            self._engine.dispose()

    def __enter__(self) -> Registry:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc_value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Registry({self.name!r}, {self.dialect})"

    # -- transactions ---------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise RegistryError(f"{self.name}: the registry is closed")

    @contextmanager
    def _read(self) -> Iterator[Connection]:
        self._check_open()
        with backends.errors_as_registry_errors(self.name):
            with self._engine.connect() as connection, connection.begin():
                yield connection

    def _write(self, work: Callable[[Connection], _T]) -> _T:
        """Run ``work`` in one write transaction, again when it lost a race."""
        self._check_open()
        with backends.errors_as_registry_errors(self.name):
            for attempt in range(1, WRITE_ATTEMPTS + 1):
                try:
                    with self._writer.connect() as connection, connection.begin():
                        return work(connection)
                except exc.DBAPIError as error:
                    if attempt == WRITE_ATTEMPTS or not backends.retryable(error):
                        raise
                time.sleep(random.uniform(0.0, 0.02 * 2**attempt))
        raise AssertionError("unreachable")  # pragma: no cover

    def _require_asset(self, connection: Connection, asset_id: int) -> None:
        found = connection.execute(select(assets.c.id).where(assets.c.id == asset_id)).first()
        if found is None:
            raise RegistryError(f"{self.name}: no asset with id {asset_id}")

    # -- writing --------------------------------------------------------------------------

    def record_embed(self, asset: AssetEntry, copy: CopyEntry) -> tuple[int, int]:
        """Record a marked copy, and its asset the first time one is sent out.

        One transaction: the asset is added if its ``input_sha256`` is new (two processes
        recording the same input at once make one asset), its references for any grid size
        not yet stored are added, and the copy is appended.

        Parameters
        ----------
        asset : AssetEntry
            The input.  Its descriptor must have the length of the registry's others.
        copy : CopyEntry
            The marked copy.

        Returns
        -------
        asset_id, copy_id : int

        Raises
        ------
        RegistryError
            When the descriptor's length differs from the registry's, or the database fails.
        """
        if not isinstance(asset, AssetEntry) or not isinstance(copy, CopyEntry):
            raise TypeError("record_embed takes an AssetEntry and a CopyEntry")
        descriptor = encode_descriptor(asset.descriptor)
        params = encode_params(copy.params)

        def work(connection: Connection) -> tuple[int, int]:
            self._check_descriptor_length(connection, asset.descriptor.size)
            created = _now()
            connection.execute(
                self._insert(assets)
                .values(
                    name=asset.name,
                    input_sha256=asset.input_sha256,
                    vertices=asset.vertices,
                    faces=asset.faces,
                    created=created,
                    descriptor=descriptor,
                )
                .on_conflict_do_nothing(index_elements=["input_sha256"])
            )
            asset_id = connection.execute(
                select(assets.c.id).where(assets.c.input_sha256 == asset.input_sha256)
            ).scalar_one()
            self._add_missing(connection, asset_id, asset.references)
            result = connection.execute(
                copies.insert().values(
                    asset_id=asset_id,
                    payload=copy.payload,
                    recipient=copy.recipient,
                    output_name=copy.output_name,
                    output_sha256=copy.output_sha256,
                    n=copy.n,
                    created=created,
                    params=params,
                    signature=copy.signature,
                )
            )
            (copy_id,) = result.inserted_primary_key or (0,)
            return int(asset_id), int(copy_id)

        return self._write(work)

    def add_references(self, asset_id: int, blobs: Mapping[int, bytes]) -> list[int]:
        """Add to a recorded asset the references (``blobs``, by grid size) of the sizes it has
        none of yet.

        One transaction; a grid size already stored is kept as it was (a concurrent writer's
        included).  Returns the grid sizes added, ascending.  RegistryError when there is no
        asset ``asset_id``.
        """
        asset_id = _row_id("asset_id", asset_id)
        given = check_references(blobs)

        def work(connection: Connection) -> list[int]:
            self._require_asset(connection, asset_id)
            return self._add_missing(connection, asset_id, given)

        return self._write(work)

    def _add_missing(
        self, connection: Connection, asset_id: int, blobs: Mapping[int, bytes]
    ) -> list[int]:
        """Insert the references of the grid sizes the asset has none of (inside the caller's
        transaction); the sizes inserted, ascending."""
        stored = set(
            connection.execute(
                select(references.c.n).where(references.c.asset_id == asset_id)
            ).scalars()
        )
        added = [n for n in sorted(blobs) if n not in stored]
        for n in added:
            connection.execute(
                self._insert(references)
                .values(asset_id=asset_id, n=n, data=blobs[n])
                .on_conflict_do_nothing(index_elements=["asset_id", "n"])
            )
        return added

    def _check_descriptor_length(self, connection: Connection, length: int) -> None:
        """The first asset sets the registry's descriptor length; the others must match it."""
        connection.execute(
            self._insert(meta)
            .values(key="descriptor_length", value=str(length))
            .on_conflict_do_nothing(index_elements=["key"])
        )
        stored = connection.execute(
            select(meta.c.value).where(meta.c.key == "descriptor_length")
        ).scalar_one()
        if int(stored) != length:
            raise RegistryError(
                f"{self.name}: descriptor has {length} values; this registry's have {stored}"
            )

    def remove_copy(self, copy_id: int) -> None:
        """Remove one copy.  Raises RegistryError when there is no copy ``copy_id``."""
        copy_id = _row_id("copy_id", copy_id)

        def work(connection: Connection) -> None:
            if connection.execute(delete(copies).where(copies.c.id == copy_id)).rowcount == 0:
                raise RegistryError(f"{self.name}: no copy with id {copy_id}")

        self._write(work)

    def remove_asset(self, asset_id: int) -> None:
        """Remove an asset with its references and copies.  RegistryError when it is absent."""
        asset_id = _row_id("asset_id", asset_id)

        def work(connection: Connection) -> None:
            if connection.execute(delete(assets).where(assets.c.id == asset_id)).rowcount == 0:
                raise RegistryError(f"{self.name}: no asset with id {asset_id}")

        self._write(work)

    # -- reading --------------------------------------------------------------------------

    def _asset_query(self) -> Select[Any]:
        return (
            select(
                assets.c.id,
                assets.c.name,
                assets.c.input_sha256,
                assets.c.vertices,
                assets.c.faces,
                assets.c.created,
                func.count(copies.c.id).label("copies"),
            )
            .select_from(assets.outerjoin(copies, copies.c.asset_id == assets.c.id))
            .group_by(assets.c.id)
            .order_by(assets.c.id)
        )

    def assets(self) -> list[AssetRecord]:
        """Every asset, by id, with how many copies of it were recorded."""
        with self._read() as connection:
            rows = connection.execute(self._asset_query()).all()
        return [AssetRecord(**row._asdict()) for row in rows]

    def asset(self, asset_id: int) -> AssetRecord:
        """The asset ``asset_id``.  Raises RegistryError when it is absent."""
        asset_id = _row_id("asset_id", asset_id)
        with self._read() as connection:
            row = connection.execute(self._asset_query().where(assets.c.id == asset_id)).first()
        if row is None:
            raise RegistryError(f"{self.name}: no asset with id {asset_id}")
        return AssetRecord(**row._asdict())

    def copies(self, asset_id: int | None = None) -> list[CopyRecord]:
        """Every copy, by id; of the asset ``asset_id`` only when given.

        Raises RegistryError when the asset ``asset_id`` is absent.
        """
        query = select(copies).order_by(copies.c.id)
        with self._read() as connection:
            if asset_id is not None:
                asset_id = _row_id("asset_id", asset_id)
                self._require_asset(connection, asset_id)
                query = query.where(copies.c.asset_id == asset_id)
            rows = connection.execute(query).all()
        return [_copy_record(row) for row in rows]

    def find_copies(self, asset_id: int, payload: str) -> list[CopyRecord]:
        """The copies of the asset ``asset_id`` that carry ``payload`` (16 hex digits or
        ``mark:<sha256>``, any case), by id.  RegistryError when the asset is absent."""
        asset_id = _row_id("asset_id", asset_id)
        payload = normalise_payload(payload)
        query = (
            select(copies)
            .where(copies.c.asset_id == asset_id, copies.c.payload == payload)
            .order_by(copies.c.id)
        )
        with self._read() as connection:
            self._require_asset(connection, asset_id)
            rows = connection.execute(query).all()
        return [_copy_record(row) for row in rows]

    def descriptors(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Every asset's id and descriptor, by id, read in one query.

        Returns
        -------
        ids : (k,) int64
        descriptors : (k, d) float64
            Row ``i`` is the descriptor of asset ``ids[i]``; ``d`` is the registry's descriptor
            length (0 before the first asset).
        """
        with self._read() as connection:
            rows = connection.execute(
                select(assets.c.id, assets.c.descriptor).order_by(assets.c.id)
            ).all()
            if not rows:
                stored = connection.execute(
                    select(meta.c.value).where(meta.c.key == "descriptor_length")
                ).scalar_one_or_none()
                length = int(stored) if stored is not None else 0
                return np.zeros(0, np.int64), np.zeros((0, length), np.float64)
        ids = np.fromiter((row[0] for row in rows), dtype=np.int64, count=len(rows))
        if len({len(row[1]) for row in rows}) != 1:
            raise RegistryError(f"{self.name}: descriptors of different lengths are stored")
        blob = b"".join(bytes(row[1]) for row in rows)
        stacked = np.frombuffer(blob, dtype="<f8").reshape(len(rows), -1)
        return ids, stacked.astype(np.float64)

    def references(self, asset_id: int) -> dict[int, bytes]:
        """The reference data of the asset ``asset_id`` by grid size (RegistryError if absent)."""
        asset_id = _row_id("asset_id", asset_id)
        with self._read() as connection:
            self._require_asset(connection, asset_id)
            rows = connection.execute(
                select(references.c.n, references.c.data)
                .where(references.c.asset_id == asset_id)
                .order_by(references.c.n)
            ).all()
        return {int(row[0]): bytes(row[1]) for row in rows}

    def references_of(self, asset_ids: Sequence[int], *, n: int) -> dict[int, bytes]:
        """The reference of grid size ``n`` of each of ``asset_ids`` that has one, read in one
        query (assets that are not registered or have none are left out)."""
        ids = sorted({_row_id("asset_id", a) for a in asset_ids})
        n = _row_id("n", n)
        if not ids:
            return {}
        with self._read() as connection:
            rows = connection.execute(
                select(references.c.asset_id, references.c.data).where(
                    references.c.n == n, references.c.asset_id.in_(ids)
                )
            ).all()
        return {int(row[0]): bytes(row[1]) for row in rows}

    def reference_sizes(self, asset_id: int) -> dict[int, int]:
        """The size in bytes of each reference of ``asset_id`` by grid size, without reading
        the data (RegistryError if absent)."""
        asset_id = _row_id("asset_id", asset_id)
        with self._read() as connection:
            self._require_asset(connection, asset_id)
            rows = connection.execute(
                select(references.c.n, func.length(references.c.data))
                .where(references.c.asset_id == asset_id)
                .order_by(references.c.n)
            ).all()
        return {int(row[0]): int(row[1]) for row in rows}


def _copy_record(row: Row[Any]) -> CopyRecord:
    values = row._asdict()
    values["params"] = decode_params(values["params"])
    if values["signature"] is not None:
        values["signature"] = bytes(values["signature"])
    return CopyRecord(**values)
