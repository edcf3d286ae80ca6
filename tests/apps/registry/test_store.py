"""Tests for :mod:`meshwm.apps.registry.store`: every method's round trip, on SQLite and on a
real PostgreSQL server (the ``target`` fixture of ``tests/_fixtures_registry.py``)."""

from __future__ import annotations

import sqlite3
import time

import numpy as np
import pytest
from _fixtures_registry import DESCRIPTOR_LENGTH, execute_sql, make_asset, make_copy

from meshwm.apps.registry import AssetEntry, AssetRecord, CopyRecord, Registry, RegistryError
from meshwm.apps.registry.entries import encode_descriptor


def test_record_embed_round_trip(target):
    asset, copy = make_asset(1, reference_bytes=300_000), make_copy(1)
    with Registry.open(target) as registry:
        assert registry.assets() == []
        asset_id, copy_id = registry.record_embed(asset, copy)
        (record,) = registry.assets()
        assert record == AssetRecord(
            id=asset_id,
            name="asset1.ply",
            input_sha256=asset.input_sha256,
            vertices=1001,
            faces=2001,
            created=record.created,
            copies=1,
        )
        assert record.created.endswith("+00:00") and record.created[:4].isdigit()
        assert registry.asset(asset_id) == record
        (stored,) = registry.copies()
        assert stored == CopyRecord(
            id=copy_id,
            asset_id=asset_id,
            payload=copy.payload,
            recipient="vendor",
            output_name="copy1.ply",
            output_sha256=copy.output_sha256,
            n=64,
            created=stored.created,
            params={"profile": "robust", "strength": 1.0, "index": 1},
        )
        assert registry.copies(asset_id) == [stored]
        assert registry.references(asset_id) == asset.references
        assert registry.reference_sizes(asset_id) == {64: 300_000, 128: 300_000}
        ids, descriptors = registry.descriptors()
        assert ids.dtype == np.int64 and ids.tolist() == [asset_id]
        assert descriptors.dtype == np.float64 and descriptors.shape == (1, DESCRIPTOR_LENGTH)
        assert descriptors[0].tobytes() == asset.descriptor.tobytes()  # bit for bit


def test_a_second_embed_of_the_same_input_adds_a_copy_not_an_asset(target):
    with Registry.open(target) as registry:
        first = registry.record_embed(make_asset(1), make_copy(1))
        base = make_asset(1)  # n = 64 is stored already: kept as it was; n = 256 is added
        references = {64: b"other", 256: b"new"}
        later = AssetEntry(
            base.name, base.input_sha256, base.vertices, base.faces, base.descriptor, references
        )
        second = registry.record_embed(later, make_copy(2, recipient=None))
        assert first[0] == second[0] and first[1] != second[1]
        assert [a.copies for a in registry.assets()] == [2]
        references = registry.references(first[0])
        assert references[64] == make_asset(1).references[64]
        assert references[256] == b"new" and set(references) == {64, 128, 256}
        assert [c.recipient for c in registry.copies(first[0])] == ["vendor", None]


def test_references_of_many_assets_in_one_read(target):
    """The probes (n = 0) of several assets at once: those that have one; a later embed of an
    asset recorded before probes adds its probe."""
    with Registry.open(target) as registry:
        a, _ = registry.record_embed(make_asset(1, sizes=(0, 128)), make_copy(1))
        b, _ = registry.record_embed(make_asset(2), make_copy(2))  # recorded without a probe
        c, _ = registry.record_embed(make_asset(3, sizes=(0, 128)), make_copy(3))
        got = registry.references_of([c, b, a, a, 10**6], n=0)
        assert got == {
            a: make_asset(1, sizes=(0, 128)).references[0],
            c: make_asset(3, sizes=(0, 128)).references[0],
        }
        assert registry.references_of([b], n=256) == {}
        assert registry.references_of([b], n=128) == {b: make_asset(2).references[128]}
        assert registry.references_of([], n=0) == {}
        later = make_asset(2, sizes=(0,))
        registry.record_embed(later, make_copy(4))
        assert registry.references_of([b], n=0) == {b: later.references[0]}
        with pytest.raises(TypeError, match="asset_id must be an int"):
            registry.references_of(["1"], n=0)  # type: ignore[list-item]


def test_add_references_keeps_what_is_stored(target):
    with Registry.open(target) as registry:
        a, _ = registry.record_embed(make_asset(1), make_copy(1))
        assert registry.add_references(a, {0: b"probe", 64: b"other", 256: b"new"}) == [0, 256]
        stored = registry.references(a)
        assert stored[0] == b"probe" and stored[256] == b"new"
        assert stored[64] == make_asset(1).references[64]  # kept as it was
        assert registry.add_references(a, {0: b"again"}) == []
        assert registry.references(a)[0] == b"probe"
        with pytest.raises(RegistryError, match="no asset"):
            registry.add_references(a + 1, {0: b"x"})
        with pytest.raises(ValueError, match="reference n must be >= 0"):
            registry.add_references(a, {-1: b"x"})
        with pytest.raises(TypeError, match="must be bytes"):
            registry.add_references(a, {0: "text"})  # type: ignore[dict-item]


def test_find_copies_by_payload(target):
    mark = "mark:" + "ab" * 32
    with Registry.open(target) as registry:
        a, _ = registry.record_embed(make_asset(1), make_copy(1, payload="C0FFEE42C0FFEE42"))
        registry.record_embed(make_asset(1), make_copy(2, payload=mark))
        b, _ = registry.record_embed(make_asset(2), make_copy(3, payload="c0ffee42c0ffee42"))
        found = registry.find_copies(a, "c0ffee42C0FFEE42")
        assert [c.output_name for c in found] == ["copy1.ply"]
        assert [c.payload for c in registry.find_copies(a, mark.upper())] == [mark]
        assert [c.asset_id for c in registry.find_copies(b, "c0ffee42c0ffee42")] == [b]
        assert registry.find_copies(b, mark) == []
        with pytest.raises(ValueError, match="payload must be"):
            registry.find_copies(a, "0x1234")


def test_descriptors_stacked_by_id(target):
    assets = [make_asset(index) for index in range(5)]
    with Registry.open(target) as registry:
        empty_ids, empty = registry.descriptors()
        assert empty_ids.shape == (0,) and empty.shape == (0, 0)
        ids = [registry.record_embed(asset, make_copy(i))[0] for i, asset in enumerate(assets)]
        registry.remove_asset(ids[2])
        got_ids, got = registry.descriptors()
        keep = [0, 1, 3, 4]
        assert got_ids.tolist() == [ids[i] for i in keep]
        np.testing.assert_array_equal(got, np.stack([assets[i].descriptor for i in keep]))
        for index in keep:
            registry.remove_asset(ids[index])
        assert registry.descriptors()[1].shape == (0, DESCRIPTOR_LENGTH)


def test_a_descriptor_of_another_length_is_refused(target):
    other = make_asset(2)
    other = AssetEntry(
        other.name, other.input_sha256, other.vertices, other.faces, np.ones(3), other.references
    )
    with Registry.open(target) as registry:
        registry.record_embed(make_asset(1), make_copy(1))
        with pytest.raises(RegistryError, match="descriptor has 3 values; this registry's have 8"):
            registry.record_embed(other, make_copy(2))
        assert len(registry.assets()) == 1 and len(registry.copies()) == 1  # nothing half-done


def test_remove_asset_cascades(target):
    with Registry.open(target) as registry:
        kept, _ = registry.record_embed(make_asset(1), make_copy(1))
        gone, _ = registry.record_embed(make_asset(2), make_copy(2))
        registry.record_embed(make_asset(2), make_copy(3))
        registry.remove_asset(gone)
        assert [a.id for a in registry.assets()] == [kept]
        assert [c.asset_id for c in registry.copies()] == [kept]
        with pytest.raises(RegistryError, match=f"no asset with id {gone}"):
            registry.references(gone)
        for table in ("copies", '"references"'):
            rows = execute_sql(target, f"SELECT count(*) FROM {table} WHERE asset_id = {gone}")
            assert rows == [(0,)], table
        # a new asset with the same input starts without the old references
        again, _ = registry.record_embed(make_asset(2, sizes=(64,)), make_copy(4))
        assert again != gone and set(registry.references(again)) == {64}


def test_remove_copy(target):
    with Registry.open(target) as registry:
        asset_id, first = registry.record_embed(make_asset(1), make_copy(1))
        _, second = registry.record_embed(make_asset(1), make_copy(2))
        registry.remove_copy(first)
        assert [c.id for c in registry.copies()] == [second]
        assert registry.asset(asset_id).copies == 1
        with pytest.raises(RegistryError, match=f"no copy with id {first}"):
            registry.remove_copy(first)
        _, third = registry.record_embed(make_asset(1), make_copy(3))
        assert third > second  # a removed id is never given again


@pytest.mark.parametrize(
    "call",
    [
        lambda r: r.asset(99),
        lambda r: r.copies(99),
        lambda r: r.find_copies(99, "0" * 16),
        lambda r: r.references(99),
        lambda r: r.reference_sizes(99),
        lambda r: r.remove_asset(99),
        lambda r: r.remove_copy(99),
    ],
)
def test_an_absent_id_raises(target, call):
    with Registry.open(target) as registry:
        registry.record_embed(make_asset(1), make_copy(1))
        with pytest.raises(RegistryError, match=r"no (asset|copy) with id 99") as info:
            call(registry)
    assert "\n" not in str(info.value)


def test_ids_must_be_ints(tmp_path):
    with Registry.open(tmp_path / "r.db") as registry, pytest.raises(TypeError, match="asset_id"):
        registry.asset("1")  # type: ignore[arg-type]


def test_closed_registry_refuses(tmp_path):
    registry = Registry.open(tmp_path / "r.db")
    registry.close()
    registry.close()
    with pytest.raises(RegistryError, match="closed"):
        registry.assets()


def test_reopening_keeps_everything(target):
    with Registry.open(target) as registry:
        asset_id, _ = registry.record_embed(make_asset(1), make_copy(1))
    with Registry.open(target, create=False) as registry:
        assert registry.references(asset_id) == make_asset(1).references
        assert len(registry.copies(asset_id)) == 1


def test_sqlite_settings(tmp_path):
    path = tmp_path / "r.db"
    with Registry.open(path) as registry:
        registry.record_embed(make_asset(1), make_copy(1))
        with registry._engine.connect() as connection:  # the pool's own connection
            pragma = connection.exec_driver_sql
            assert pragma("PRAGMA journal_mode").scalar() == "wal"
            assert pragma("PRAGMA foreign_keys").scalar() == 1
            assert pragma("PRAGMA busy_timeout").scalar() == 30_000
    assert registry.dialect == "sqlite" and registry.name == str(path)


def test_descriptors_of_thousands_of_assets_read_fast(tmp_path):
    """3,000 assets written straight into the file; descriptors() reads them in one query."""
    path = tmp_path / "r.db"
    Registry.open(path).close()
    rng = np.random.default_rng(0)
    descriptors = rng.normal(size=(3000, 64))
    rows = [
        (f"a{i}", f"{i:064x}", 1, 1, "2025-01-01T00:00:00+00:00", encode_descriptor(d))
        for i, d in enumerate(descriptors)
    ]
    with sqlite3.connect(path) as connection:
        connection.executemany(
            "INSERT INTO assets (name, input_sha256, vertices, faces, created, descriptor) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            rows,
        )
        connection.execute("INSERT INTO meta VALUES ('descriptor_length', '64')")
    connection.close()
    with Registry.open(path) as registry:
        began = time.perf_counter()
        ids, got = registry.descriptors()
        seconds = time.perf_counter() - began
    np.testing.assert_array_equal(got, descriptors)
    assert ids.tolist() == list(range(1, 3001))
    assert seconds < 1.0, seconds
