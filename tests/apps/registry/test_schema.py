"""Tests for :mod:`meshwm.apps.registry.schema` and the checks of
:meth:`~meshwm.apps.registry.Registry.open`: what is refused, with one line naming the registry."""

from __future__ import annotations

import os
import sqlite3

import pytest
from _fixtures_registry import execute_sql, make_asset, make_copy

from meshwm.apps.registry import SCHEMA_VERSION, Registry, RegistryError
from meshwm.apps.registry.schema import TABLES


def _refused(target, *, create: bool = True, match: str) -> str:
    with pytest.raises(RegistryError, match=match) as info:
        Registry.open(target, create=create)
    message = str(info.value)
    assert "\n" not in message
    return message


def _registry_with_data(path, assets: int = 3) -> None:
    with Registry.open(path) as registry:
        for index in range(assets):
            registry.record_embed(make_asset(index, reference_bytes=200_000), make_copy(index))


def test_a_new_registry_has_the_tables_and_the_version(target):
    Registry.open(target).close()
    assert SCHEMA_VERSION == 1
    assert set(TABLES) == {"meta", "assets", "references", "copies"}
    if "://" not in target:
        with sqlite3.connect(target) as connection:
            names = {row[0] for row in connection.execute("SELECT name FROM sqlite_master")}
            version = connection.execute("SELECT value FROM meta").fetchall()
        connection.close()
        assert names >= {*TABLES, "ix_copies_asset_id", "ix_copies_payload"}
        assert version == [("1",)]


def test_another_schema_version_is_refused(target):
    Registry.open(target).close()
    execute_sql(target, "UPDATE meta SET value = '2' WHERE key = 'schema_version'")
    message = _refused(target, match="schema version 2; this meshwm reads version 1")
    assert message.split(": ")[0].endswith(target.split("@")[-1])  # names the registry first
    execute_sql(target, "DELETE FROM meta WHERE key = 'schema_version'")
    _refused(target, match="no schema version")


def test_a_registry_with_a_table_missing_is_refused(target):
    Registry.open(target).close()
    execute_sql(target, 'DROP TABLE "references"')
    _refused(target, match="not a complete meshwm registry .table references missing")


def test_a_database_of_something_else_is_refused(target):
    execute_sql(target, "CREATE TABLE orders (id INTEGER PRIMARY KEY)")
    _refused(target, match=r"not a meshwm registry \(it holds orders\)")


def test_an_empty_database_becomes_a_registry_only_with_create(target):
    if "://" not in target:
        sqlite3.connect(target).execute("PRAGMA user_version = 7").connection.close()
        assert os.path.getsize(target) > 0
    _refused(target, create=False, match="not a meshwm registry")
    Registry.open(target).close()
    Registry.open(target, create=False).close()


def test_a_missing_file_is_refused_without_create_and_not_made(tmp_path):
    path = tmp_path / "none.db"
    assert _refused(path, create=False, match="no such registry") == f"{path}: no such registry"
    assert not path.exists()
    _refused(tmp_path / "no" / "r.db", match="folder .* does not exist")
    _refused(tmp_path, match="is a folder")


def test_an_empty_file_is_a_new_database(tmp_path):
    """What SQLite makes of a new file; another process may be creating the registry in it."""
    path = tmp_path / "r.db"
    path.touch()
    _refused(path, create=False, match=f"{path}: not a meshwm registry")
    assert path.stat().st_size == 0
    Registry.open(path).close()


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (os.urandom(4096), "not an SQLite database"),
        (b"SQLite format 3\x00" + os.urandom(4080), "not a meshwm registry or damaged"),
        (b"SQLite format 3\x00", "truncated"),
        (b"SQLite", "not an SQLite database"),
        (b"ply\nformat ascii 1.0\n", "not an SQLite database"),
    ],
    ids=["random", "random_after_magic", "header_only", "short", "a_mesh"],
)
def test_a_file_that_is_no_database_is_refused(tmp_path, content, match):
    path = tmp_path / "r.db"
    path.write_bytes(content)
    for create in (True, False):
        assert _refused(path, create=create, match=match).startswith(f"{path}: ")
    assert path.read_bytes() == content  # untouched


@pytest.mark.parametrize("fraction", [0.5, 0.9, 0.01])
def test_a_truncated_registry_is_refused(tmp_path, fraction):
    path = tmp_path / "r.db"
    _registry_with_data(path)
    assert not path.with_name("r.db-wal").exists()  # checkpointed on close
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * fraction)])
    _refused(path, match=f"{path}: .*(truncated|damaged)")


def test_a_damaged_page_is_a_registry_error(tmp_path):
    path = tmp_path / "r.db"
    _registry_with_data(path)
    data = bytearray(path.read_bytes())
    page = 4096
    for start in range(page, len(data), page):  # every page after the first: garbage
        data[start : start + page] = os.urandom(page)
    path.write_bytes(bytes(data))
    with pytest.raises(RegistryError, match=f"{path}: ") as info:
        with Registry.open(path) as registry:
            registry.assets()
            registry.copies()
            registry.references(1)
    assert "\n" not in str(info.value)


def test_a_postgresql_server_that_is_not_there(tmp_path):
    pytest.importorskip("psycopg")
    url = "postgresql://meshwm:sekrit@127.0.0.1:1/registry"
    message = _refused(url, match="127.0.0.1:1/registry")
    assert "sekrit" not in message and "***" in message
    _refused("mysql://host/db", match="unknown registry URL scheme 'mysql'")
