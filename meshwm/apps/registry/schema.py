"""The registry's tables (SQLAlchemy Core), its schema version, and the checks made on opening.

``meta(key, value)`` holds ``schema_version`` (:data:`SCHEMA_VERSION`) and, once the first
asset is recorded, ``descriptor_length``.  ``assets`` has one row per input file (unique by its
SHA-256), ``references`` the caller's opaque reference blobs per asset and grid size (0: what
holds for every size, the informed reader's probe), ``copies`` one row per marked copy sent
out.  Deleting an asset deletes its references and copies
(``ON DELETE CASCADE``).  Ids only grow: a removed id is never given to another row.
"""

from __future__ import annotations

from sqlalchemy import (
    Column,
    Connection,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    MetaData,
    PrimaryKeyConstraint,
    Table,
    Text,
    inspect,
    select,
    text,
)

from meshwm.errors import RegistryError

__all__ = [
    "SCHEMA_VERSION",
    "TABLES",
    "assets",
    "check_schema",
    "copies",
    "create_schema",
    "lock_schema",
    "meta",
    "metadata",
    "references",
]

#: The version of the tables below; a registry of another version is refused.
SCHEMA_VERSION = 1

metadata = MetaData()

meta = Table(
    "meta",
    metadata,
    Column("key", Text, primary_key=True),
    Column("value", Text, nullable=False),
)

assets = Table(
    "assets",
    metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("name", Text, nullable=False),
    Column("input_sha256", Text, nullable=False, unique=True),
    Column("vertices", Integer, nullable=False),
    Column("faces", Integer, nullable=False),
    Column("created", Text, nullable=False),
    Column("descriptor", LargeBinary, nullable=False),
    sqlite_autoincrement=True,
)

references = Table(
    "references",
    metadata,
    Column("asset_id", Integer, ForeignKey("assets.id", ondelete="CASCADE"), nullable=False),
    Column("n", Integer, nullable=False),
    Column("data", LargeBinary, nullable=False),
    PrimaryKeyConstraint("asset_id", "n"),
)

copies = Table(
    "copies",
    metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("asset_id", Integer, ForeignKey("assets.id", ondelete="CASCADE"), nullable=False),
    Column("payload", Text, nullable=False),
    Column("recipient", Text, nullable=True),
    Column("output_name", Text, nullable=False),
    Column("output_sha256", Text, nullable=False),
    Column("n", Integer, nullable=False),
    Column("created", Text, nullable=False),
    Column("params", Text, nullable=False),
    Column("signature", LargeBinary, nullable=True),
    Index("ix_copies_asset_id", "asset_id"),
    Index("ix_copies_payload", "payload"),
    sqlite_autoincrement=True,
)

#: Every table a registry must have.
TABLES = tuple(metadata.tables)


def create_schema(connection: Connection) -> None:
    """Create the tables and record the schema version (inside the caller's transaction)."""
    metadata.create_all(connection)
    connection.execute(meta.insert().values(key="schema_version", value=str(SCHEMA_VERSION)))


def check_schema(connection: Connection, *, name: str, create: bool) -> None:
    """Make sure the database is a registry of this version, creating it when it is empty.

    Run inside a write transaction (so two processes opening one new registry create it once).

    Parameters
    ----------
    connection : sqlalchemy.Connection
        In a transaction.
    name : str
        The registry as messages name it.
    create : bool
        Whether a database with none of the tables may become a registry.

    Raises
    ------
    RegistryError
        When the database holds other tables or only some of ours, has another schema version,
        or (``create=False``) is not a registry yet.
    """
    present = set(inspect(connection).get_table_names())
    ours = present & set(TABLES)
    if not ours:
        if present or not create:
            others = f" (it holds {', '.join(sorted(present)[:5])})" if present else ""
            raise RegistryError(f"{name}: not a meshwm registry{others}")
        create_schema(connection)
        return
    missing = sorted(set(TABLES) - present)
    if missing:
        raise RegistryError(
            f"{name}: not a complete meshwm registry (table {', '.join(missing)} missing)"
        )
    version = connection.execute(
        select(meta.c.value).where(meta.c.key == "schema_version")
    ).scalar_one_or_none()
    if version != str(SCHEMA_VERSION):
        found = "no schema version" if version is None else f"schema version {version}"
        raise RegistryError(
            f"{name}: registry has {found}; this meshwm reads version {SCHEMA_VERSION}"
        )


def lock_schema(connection: Connection) -> None:
    """PostgreSQL: hold a transaction lock so concurrent openers create the tables once."""
    connection.execute(text("SELECT pg_advisory_xact_lock(7301401)"))
