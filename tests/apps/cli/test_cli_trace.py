"""``embed --registry``, ``trace``, and ``verify``/``extract --registry``: a registered copy
traced after re-tessellation, the key never stored, bad registries refused cleanly."""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from meshwm.apps.cli import main
from meshwm.apps.registry import AssetEntry, CopyEntry, Registry
from meshwm.attacks import apply_attack
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.readers.descriptor import CROP_REFERENCE
from meshwm.readers.informed import REFERENCE_SIZE, Reference, seal_signature
from meshwm.readers.probe import PROBE, make_probe
from meshwm.readers.registration import shape_descriptor
from meshwm.watermark.trace import Tracer, nearest_assets, ranked_assets

KEY = "trace-test-key-5f1c"
IDS = ("0x0123456789abcdef", "0xfedcba9876543210")


@pytest.fixture(scope="module")
def registered(tmp_path_factory, assets_dir):
    """spot sent to two recipients, kitten to one; all recorded in one SQLite registry."""
    root = tmp_path_factory.mktemp("trace")
    db = root / "studio.db"
    outs = []
    for k, (mesh, ident, who) in enumerate(
        [("spot", IDS[0], "alice"), ("spot", IDS[1], "bob"), ("kitten", IDS[0], "carol")]
    ):
        out = root / f"{mesh}_{k}.ply"
        code = main(
            [
                "embed",
                str(assets_dir / f"{mesh}.ply"),
                "-o",
                str(out),
                "--key",
                KEY,
                "--id",
                ident,
                "--registry",
                str(db),
                "--recipient",
                who,
                "--no-distance",
            ]
        )
        assert code == 0
        outs.append(out)
    return root, db, outs


def _attacked(src: Path, dst: Path, attack: str, **options) -> Path:
    v, f = read_mesh(src)
    v2, f2 = apply_attack("similarity", v, f, seed=7)
    v3, f3 = apply_attack(attack, v2, f2, seed=1, **options)
    write_mesh(dst, v3, f3)
    return dst


def test_the_registry_holds_assets_and_copies_never_the_key(registered):
    root, db, _ = registered
    with Registry.open(db, create=False) as registry:
        assets = registry.assets()
        assert sorted(a.copies for a in assets) == [1, 2]
        copies = registry.copies()
        assert [c.recipient for c in copies] == ["alice", "bob", "carol"]
        assert all(c.signature for c in copies)
        assert all("key" not in json.dumps(c.params).lower() for c in copies)
    for path in root.iterdir():
        if path.name.startswith("studio.db"):
            assert KEY.encode() not in path.read_bytes()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("attack", "options"),
    [("simplify", {"keep_fraction": 0.5}), ("subdivide_loop", {}), ("remesh_isotropic", {})],
)
def test_trace_names_the_copy_after_retessellation(registered, tmp_path, capsys, attack, options):
    _, db, outs = registered
    received = _attacked(outs[1], tmp_path / "leak.ply", attack, **options)
    code = main(["trace", str(received), "--key", KEY, "--registry", str(db), "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0, report
    (mesh,) = report["meshes"]
    assert mesh["detected"] and mesh["reader"] == "informed"
    assert mesh["id"] == IDS[1][2:] and mesh["recipient"] == "bob"
    assert mesh["p_value"] * mesh["hypotheses"] < 1e-6


def test_trace_reads_a_smoothed_copy_vertex_by_vertex(registered, tmp_path, capsys):
    """MeshLab's Laplacian on the copy's own mesh: the informed reader matches its vertices to
    the asset's (a similarity and reordering of nothing else) and names the copy."""
    _, db, outs = registered
    v, f = read_mesh(outs[1])
    v, f = apply_attack("similarity", v, f, seed=5)
    v, f = apply_attack("meshlab_laplacian", v, f, iterations=3)
    write_mesh(tmp_path / "smooth.ply", v, f)
    args = ["--key", KEY, "--registry", str(db), "--informed-only"]
    code = main(["trace", str(tmp_path / "smooth.ply"), *args, "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0, report
    (mesh,) = report["meshes"]
    assert mesh["correspondence"] == "vertices" and mesh["recipient"] == "bob"
    assert main(["trace", str(tmp_path / "smooth.ply"), *args]) == 0
    assert "read vertex by vertex" in capsys.readouterr().out


def test_trace_with_a_wrong_key_finds_nothing(registered, tmp_path, capsys):
    _, db, outs = registered
    received = _attacked(outs[0], tmp_path / "leak.ply", "simplify", keep_fraction=0.5)
    code = main(
        ["trace", str(received), "--key", "not the key", "--registry", str(db), "--informed-only"]
    )
    out = capsys.readouterr().out
    assert code == 1 and "NOT traced" in out


def test_trace_of_an_unmarked_mesh_finds_nothing(registered, assets_dir, capsys):
    _, db, _ = registered
    spot = str(assets_dir / "spot.ply")
    code = main(["trace", spot, "--key", KEY, "--registry", str(db), "--informed-only"])
    assert code == 1
    assert "NOT traced" in capsys.readouterr().out


def test_trace_reads_blind_first(registered, capsys):
    _, db, outs = registered
    code = main(["trace", str(outs[2]), "--key", KEY, "--registry", str(db), "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0
    (mesh,) = report["meshes"]
    assert mesh["reader"] != "informed" and mesh["id"] == IDS[0][2:]
    assert [c["recipient"] for c in mesh["copies"]] == ["carol"]


@pytest.mark.slow
def test_verify_and_extract_fall_back_to_the_registry(registered, tmp_path, capsys):
    _, db, outs = registered
    received = _attacked(outs[0], tmp_path / "lod.ply", "simplify", keep_fraction=0.3)
    args = ["--key", KEY]
    assert main(["verify", str(received), "--id", IDS[0], *args]) == 1
    capsys.readouterr()
    assert main(["verify", str(received), "--id", IDS[0], *args, "--registry", str(db)]) == 0
    out = capsys.readouterr().out
    assert "present" in out and "informed reader (registry)" in out and "alice" in out
    assert main(["verify", str(received), "--id", IDS[1], *args, "--registry", str(db)]) == 1
    capsys.readouterr()
    assert main(["extract", str(received), *args, "--registry", str(db), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["id"] == IDS[0][2:] and report["reader"] == "informed (registry)"


def _one_line_error(capsys) -> str:
    captured = capsys.readouterr()
    err = captured.err
    assert err.startswith("meshwm: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


def test_embed_into_a_corrupt_registry_writes_nothing(tmp_path, assets_dir, capsys):
    db = tmp_path / "broken.db"
    db.write_bytes(b"SQLite format 3\x00" + bytes(50))
    out = tmp_path / "out.ply"
    spot = str(assets_dir / "spot.ply")
    code = main(["embed", spot, "-o", str(out), "--key", KEY, "--id", "0x1", "--registry", str(db)])
    assert code == 2
    assert "broken.db" in _one_line_error(capsys)
    assert not out.exists()


def test_recipient_needs_a_registry(tmp_path, assets_dir, capsys):
    out = tmp_path / "out.ply"
    args = ["embed", str(assets_dir / "spot.ply"), "-o", str(out), "--key", KEY]
    assert main([*args, "--recipient", "alice"]) == 2
    assert "--registry" in _one_line_error(capsys)
    assert not out.exists()


@pytest.mark.parametrize("kind", ["missing", "garbage"])
def test_trace_with_a_bad_registry_is_one_line(tmp_path, assets_dir, capsys, kind):
    db = tmp_path / "r.db"
    if kind == "garbage":
        db.write_bytes(np.arange(300, dtype=np.uint8).tobytes())
    code = main(["trace", str(assets_dir / "spot.ply"), "--key", KEY, "--registry", str(db)])
    assert code == 2
    _one_line_error(capsys)
    assert kind == "garbage" or not db.exists()


@pytest.mark.slow
def test_four_embeds_into_one_registry_at_once_lose_no_record(tmp_path, assets_dir):
    """Four ``meshwm embed --registry`` processes started together: four copies recorded."""
    import subprocess
    import sys

    db = tmp_path / "shared.db"
    procs = [
        subprocess.Popen(
            [
                *(sys.executable, "-m", "meshwm", "embed", str(assets_dir / "spot.ply")),
                *("-o", str(tmp_path / f"out{k}.ply"), "--key", KEY, "--id", f"0x{k + 1:x}"),
                *("--registry", str(db), "--recipient", f"r{k}", "--no-distance"),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        for k in range(4)
    ]
    errors = [p.communicate()[1] for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0, 0], errors
    with Registry.open(db, create=False) as registry:
        assert len(registry.assets()) == 1
        copies = registry.copies()
    assert sorted(c.recipient for c in copies) == ["r0", "r1", "r2", "r3"]
    assert sorted(c.payload for c in copies) == [f"{k + 1:016x}" for k in range(4)]


def test_a_copy_with_an_earlier_copys_payload_is_recorded_with_a_warning(
    tmp_path, assets_dir, capsys
):
    """Two recipients given one id cannot be told apart by trace: the second embed says so."""
    db = tmp_path / "studio.db"

    def embed(ident: str, who: str) -> tuple[dict, str]:
        out = tmp_path / f"{who}.ply"
        argv = ["embed", str(assets_dir / "spot.ply"), "-o", str(out), "--key", KEY]
        argv += ["--id", ident, "--registry", str(db), "--recipient", who]
        assert main([*argv, "--no-distance", "--json"]) == 0
        captured = capsys.readouterr()
        return json.loads(captured.out), captured.err

    first, err = embed(IDS[0], "alice")
    assert "warning" not in err and "same_payload_as" not in first["registry"][0]
    other, err = embed(IDS[1], "bob")
    assert "warning" not in err and "same_payload_as" not in other["registry"][0]
    again, err = embed(IDS[0], "carol")
    row = again["registry"][0]
    assert row["same_payload_as"] == first["registry"][0]["copy_id"]
    assert err.count("\n") == 1 and err.startswith("meshwm: warning: ")
    assert "same payload" in err and "for alice" in err and KEY not in err
    with Registry.open(db, create=False) as registry:  # recorded all the same
        assert [c.recipient for c in registry.copies()] == ["alice", "bob", "carol"]


def _looks(report: dict, names: dict[int, str]) -> list[tuple[str, int]]:
    return [(names[c["asset_id"]], c["poses"]) for c in report["candidates"]]


@pytest.mark.parametrize(
    ("crop_seed", "expected"),
    [
        # kitten's descriptor ranks first (with spot's crops, spot's would): it gets its cheap
        # look only, then spot's reads.
        (1, [("kitten", 4), ("spot", 4)]),
        # The crop turns spot's principal axes: every candidate's cheap look first, then the
        # spread over SO(3) for spot (kitten's frames did not fit either, but spot reads first).
        (0, [("spot", 4), ("kitten", 4), ("spot", 76)]),
    ],
)
def test_trace_looks_at_every_candidate_cheaply_before_any_spread(
    registered, tmp_path, crop_seed, expected
):
    """A 30 % crop of bob's copy: no candidate is posed over the 72 spread rotations (about ten
    times the cost of its principal frames) before every candidate has had its cheap look, so
    a wrong asset ranked first costs little (a crop traced against 1,000 assets: see
    docs/bench/trace.md).  The registry without its crop descriptors (as an older meshwm
    recorded it), so that the descriptor ranks the wrong asset first on one crop."""
    _, db, outs = registered
    work = tmp_path / "old.db"
    shutil.copy(db, work)
    with sqlite3.connect(work) as connection:
        connection.execute('DELETE FROM "references" WHERE n = 1')
    v, f = read_mesh(outs[1])
    v, f = apply_attack("similarity", v, f, seed=7)
    v, f = apply_attack("crop", v, f, seed=crop_seed, fraction=0.3)
    with Registry.open(work, create=False) as registry:
        names = {a.id: a.name.removesuffix(".ply") for a in registry.assets()}
        traced = Tracer(v, f, registry).trace(key=KEY)
    assert traced.detected and traced.report["recipient"] == "bob", traced.report
    assert _looks(traced.report, names) == expected
    assert traced.report["p_value"] * traced.report["hypotheses"] < 1e-6


def test_crop_descriptors_rank_a_crop_by_its_own_asset(registered, tmp_path):
    """The crop the test above traces with kitten first: the crop descriptors embed records
    rank spot first, and the trace reads it at the first look."""
    _, db, outs = registered
    v, f = read_mesh(outs[1])
    v, f = apply_attack("similarity", v, f, seed=7)
    v, f = apply_attack("crop", v, f, seed=1, fraction=0.3)
    with Registry.open(db, create=False) as registry:
        names = {a.id: a.name.removesuffix(".ply") for a in registry.assets()}
        assert [names[a] for a in nearest_assets(registry, v, f)] == ["spot", "kitten"]
        traced = Tracer(v, f, registry).trace(key=KEY)
    assert traced.detected and traced.report["recipient"] == "bob", traced.report
    assert _looks(traced.report, names) == [("spot", 4)]


def test_nearest_assets_ranks_by_shape_within_a_choice(registered, assets_dir):
    _, db, outs = registered
    v, f = read_mesh(outs[2])  # kitten's copy, moved
    v, f = apply_attack("similarity", v, f, seed=3)
    with Registry.open(db, create=False) as registry:
        ids = {a.name.removesuffix(".ply"): a.id for a in registry.assets()}
        assert nearest_assets(registry, v, f) == [ids["kitten"], ids["spot"]]
        assert nearest_assets(registry, v, f, count=1) == [ids["kitten"]]
        assert nearest_assets(registry, v, f, among=[ids["spot"]]) == [ids["spot"]]
        assert nearest_assets(registry, v, f, among=[]) == []


def _record_twins(registry: Registry, asset_id: int, descriptor: np.ndarray) -> list[int]:
    """Six near-duplicates of the asset (stretched 4-8 % along one axis), each recorded with
    ``descriptor`` (the received copy's own, so that the descriptor ranks them all first) and
    one copy; their ids."""
    reference = Reference.from_bytes(registry.references(asset_id)[REFERENCE_SIZE])
    assert PROBE in registry.references(asset_id)  # embed recorded it
    centre = reference.anchors.mean(axis=0)
    for k, (axis, factor) in enumerate((a, 1 + e) for a in range(3) for e in (0.04, -0.08)):
        stretch = np.ones(3)
        stretch[axis] = factor
        twin = reference._replace(
            points=(reference.points - centre) * stretch + centre,
            anchors=(reference.anchors - centre) * stretch + centre,
        )
        registry.record_embed(
            AssetEntry(
                name=f"twin-{k}",
                input_sha256=f"{k:064x}",
                vertices=1,
                faces=1,
                descriptor=descriptor,
                references={REFERENCE_SIZE: twin.to_bytes(), PROBE: make_probe(twin.anchors)},
            ),
            CopyEntry(
                payload=f"{k:016x}",
                recipient=None,
                output_name=f"twin-{k}.ply",
                output_sha256="0" * 64,
                n=reference.n,
                signature=seal_signature(
                    np.sin(np.arange(len(twin.cells)) * (k + 1.0)), twin, key=KEY
                ),
            ),
        )
    return [a.id for a in registry.assets() if a.name.startswith("twin-")]


def _among_twins(
    registered, tmp_path: Path, moved: int, attack: str, **options: Any
) -> tuple[Path, np.ndarray, np.ndarray, int]:
    """Bob's copy of spot moved by a similarity (seed ``moved``) and ``attack``ed, and a copy of the
    registry with six twins of spot (:func:`_record_twins`) that the descriptor ranks before
    it: the registry's path, the received mesh and spot's asset id."""
    _, db, outs = registered
    work = tmp_path / "twins.db"
    shutil.copy(db, work)
    v, f = apply_attack("similarity", *read_mesh(outs[1]), seed=moved)
    v, f = apply_attack(attack, v, f, **options)
    with Registry.open(work) as registry:
        (spot,) = [a.id for a in registry.assets() if a.name.startswith("spot")]
        twins = _record_twins(registry, spot, shape_descriptor(v, f))
        assert set(nearest_assets(registry, v, f, count=6)) == set(twins)
    return work, v, f, spot


def _without_probes(work: Path) -> None:
    """The registry as recorded before probes."""
    with sqlite3.connect(work) as connection:
        connection.execute('DELETE FROM "references" WHERE n = 0')


def test_probes_put_the_received_shape_before_its_near_duplicates(registered, tmp_path):
    """Six near-duplicates of spot that the descriptor ranks first (:func:`_among_twins`): the
    probes put spot first, and bob's decimated copy is read at the first look.  Without probes
    (a registry recorded before them) the twins keep their places."""
    work, v, f, spot = _among_twins(registered, tmp_path, 5, "simplify", seed=2, keep_fraction=0.5)
    with Registry.open(work, create=False) as registry:
        assert ranked_assets(registry, v, f)[0] == spot
        traced = Tracer(v, f, registry).trace(key=KEY)
        assert traced.detected and traced.report["recipient"] == "bob", traced.report
        assert [c["asset_id"] for c in traced.report["candidates"]] == [spot]
    _without_probes(work)
    with Registry.open(work, create=False) as registry:
        assert ranked_assets(registry, v, f) == nearest_assets(registry, v, f, count=10)
        assert ranked_assets(registry, v, f).index(spot) >= 6


def test_a_cropped_copy_is_told_from_its_near_duplicates(registered, tmp_path):
    """A 30 % crop of bob's copy among six twins the descriptor ranks first, three candidates
    tried: no probe fits in the crop's frame, the partial fits put spot first, and the copy is
    read at the first look.  Without probes spot is not among the three."""
    work, v, f, spot = _among_twins(registered, tmp_path, 7, "crop", seed=3, fraction=0.3)
    with Registry.open(work, create=False) as registry:
        assert ranked_assets(registry, v, f, count=3)[0] == spot
        traced = Tracer(v, f, registry, candidates=3).trace(key=KEY)
        assert traced.detected and traced.report["recipient"] == "bob", traced.report
        assert [c["asset_id"] for c in traced.report["candidates"]] == [spot]
    _without_probes(work)
    with Registry.open(work, create=False) as registry:
        assert spot not in ranked_assets(registry, v, f, count=3)


def test_registry_upgrade_gives_old_assets_what_embed_records(registered, tmp_path, capsys):
    """A registry recorded before probes and crop descriptors (both deleted): ``registry
    upgrade`` adds the same bytes embed recorded, once, and only what is missing; a damaged
    reference is one line and exit code 2."""
    _, db, _ = registered
    work = tmp_path / "old.db"
    shutil.copy(db, work)
    with Registry.open(work, create=False) as registry:
        ids = [a.id for a in registry.assets()]
        recorded = {n: registry.references_of(ids, n=n) for n in (PROBE, CROP_REFERENCE)}
    assert all(sorted(r) == sorted(ids) for r in recorded.values())
    _without_probes(work)
    with sqlite3.connect(work) as connection:
        connection.execute('DELETE FROM "references" WHERE n = ? AND asset_id = ?', (1, ids[0]))
    assert main(["registry", "upgrade", str(work)]) == 0
    out = capsys.readouterr().out
    assert out == f"probes or crop descriptors added to {len(ids)} of {len(ids)} assets\n"
    with Registry.open(work, create=False) as registry:
        for n in (PROBE, CROP_REFERENCE):
            assert registry.references_of(ids, n=n) == recorded[n]
    assert main(["registry", "upgrade", str(work)]) == 0
    assert (
        capsys.readouterr().out == f"probes or crop descriptors added to 0 of {len(ids)} assets\n"
    )
    assert main(["registry", "show", str(work), str(ids[0])]) == 0
    assert "probe: 6256 bytes, crop descriptors: 6728 bytes, N=" in capsys.readouterr().out
    with sqlite3.connect(work) as connection:
        connection.execute('DELETE FROM "references" WHERE n = 0')
        connection.execute('UPDATE "references" SET data = ? WHERE asset_id = ?', (b"junk", ids[0]))
    assert main(["registry", "upgrade", str(work)]) == 2
    err = _one_line_error(capsys)
    assert f"asset {ids[0]}" in err and "damaged reference" in err


def test_damaged_crop_descriptors_are_one_line_naming_the_asset(registered, tmp_path, capsys):
    _, db, outs = registered
    work = tmp_path / "damaged.db"
    shutil.copy(db, work)
    with Registry.open(work, create=False) as registry:
        victim = registry.assets()[-1].id
    with sqlite3.connect(work) as connection:
        connection.execute(
            'UPDATE "references" SET data = ? WHERE asset_id = ? AND n = 1', (b"junk", victim)
        )
    args = ["trace", str(outs[0]), "--key", KEY, "--registry", str(work)]
    assert main(args) == 2
    err = _one_line_error(capsys)
    assert f"registered asset {victim}: damaged crop descriptors" in err


def test_a_damaged_probe_is_one_line_naming_the_asset(registered, tmp_path, capsys):
    """A decimated copy (the blind readers miss it): the informed reader ranks the candidates
    and stops at the damaged probe, naming its asset."""
    _, db, outs = registered
    work = tmp_path / "damaged.db"
    shutil.copy(db, work)
    with Registry.open(work, create=False) as registry:
        (kitten,) = [a.id for a in registry.assets() if a.name.startswith("kitten")]
    with sqlite3.connect(work) as connection:
        connection.execute(
            'UPDATE "references" SET data = ? WHERE asset_id = ? AND n = 0', (b"junk", kitten)
        )
    leaked = _attacked(outs[1], tmp_path / "lod.ply", "simplify", keep_fraction=0.5)
    code = main(["trace", str(leaked), "--key", KEY, "--registry", str(work)])
    assert code == 2
    err = _one_line_error(capsys)
    assert f"registered asset {kitten}: damaged probe" in err


def test_a_crop_fitted_by_its_asset_has_its_spread_before_the_others_frames(registered, tmp_path):
    """The crop that turns spot's principal axes (the looks test above, crop 0), among six
    twins, three candidates tried: spot's probe fits the crop, so its spread over SO(3)
    follows its own frames look at once, before any twin's frames (each a second on a large
    mesh, that seldom fit such a crop)."""
    work, v, f, spot = _among_twins(registered, tmp_path, 7, "crop", seed=0, fraction=0.3)
    with Registry.open(work, create=False) as registry:
        names = {a.id: a.name.removesuffix(".ply") for a in registry.assets()}
        assert ranked_assets(registry, v, f, count=3)[0] == spot
        traced = Tracer(v, f, registry, candidates=3).trace(key=KEY)
    assert traced.detected and traced.report["recipient"] == "bob", traced.report
    assert _looks(traced.report, names) == [("spot", 4), ("spot", 76)]
