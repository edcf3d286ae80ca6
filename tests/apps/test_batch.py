"""IDs on the command line and batch verification: rows, summaries, exit codes, parallel runs."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from meshwm.apps.batch import (
    DASK_CHUNK,
    DASK_TASKS_PER_WORKER,
    Check,
    _chunk_size,
    expand_paths,
    run_local,
    summarise,
    verify_file,
)
from meshwm.apps.cli import main
from meshwm.message.mark import default_mark
from meshwm.params import WatermarkParams

ASSETS = Path(__file__).resolve().parent.parent.parent / "assets"
SPOT = ASSETS / "spot.ply"
LOGO = ASSETS / "mark32.png"
KEY = "batch key"
IDENT = "0x0123456789abcdef"
OPTS = ["--key", KEY, "--size", "128", "--no-distance"]
EMBED_OPTS = [*OPTS, "--grid"]


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    """A small asset library: marked with the logo, marked with an id, unmarked, corrupt."""
    root = tmp_path_factory.mktemp("library")
    (root / "sub").mkdir()
    assert main(["embed", str(SPOT), "-o", str(root / "logo.ply"), *EMBED_OPTS]) == 0
    assert (
        main(["embed", str(SPOT), "-o", str(root / "sub" / "id.obj"), *EMBED_OPTS, "--id", IDENT])
        == 0
    )
    shutil.copy(SPOT, root / "sub" / "plain.ply")
    (root / "sub" / "broken.stl").write_bytes(b"solid x\nfacet normal 0 0")
    return root


def _lines(capsys) -> list[dict]:
    return [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.strip()]


def test_embed_reports_the_id_and_extract_json_decodes_it(library, capsys):
    assert main(["extract", str(library / "sub" / "id.obj"), "--key", KEY, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["id"] == IDENT[2:]
    assert report["output"] is None
    # A logo-marked mesh carries no id: null, never a made-up one.
    assert main(["extract", str(library / "logo.ply"), "--key", KEY, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["id"] is None


def test_extract_without_an_output_says_what_the_mesh_carries(library, capsys):
    assert main(["extract", str(library / "logo.ply"), "--key", KEY]) == 0
    assert capsys.readouterr().out.endswith("logo.ply: 32×32 mark (the bundled logo)\n")


def test_embed_id_and_mark_exclude_each_other(tmp_path, capsys):
    out = tmp_path / "x.ply"
    argv = ["embed", str(SPOT), "-o", str(out), *EMBED_OPTS, "--id", "ab", "--mark", str(LOGO)]
    assert main(argv) == 2
    assert "exclude" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("bad", ["", "this id is far too long", "0x" + "f" * 17])
def test_embed_refuses_a_bad_id(bad, tmp_path, capsys):
    assert main(["embed", str(SPOT), "-o", str(tmp_path / "x.ply"), *EMBED_OPTS, "--id", bad]) == 2
    err = capsys.readouterr().err
    assert err.startswith("meshwm: error:") and len(err.strip().splitlines()) == 1


def test_batch_jsonl_over_a_folder(library, capsys):
    code = main(["verify", str(library), "--key", KEY, "--mark", str(LOGO), "--jsonl"])
    rows = _lines(capsys)
    summary = rows.pop()["summary"]
    by_name = {Path(r["path"]).name: r for r in rows}
    assert set(by_name) == {"logo.ply", "id.obj", "plain.ply", "broken.stl"}
    assert by_name["logo.ply"]["detected"] is True and by_name["logo.ply"]["ber"] == 0
    assert by_name["id.obj"]["detected"] is False
    assert by_name["plain.ply"]["detected"] is False and by_name["plain.ply"]["error"] is None
    assert by_name["broken.stl"]["error"]
    for row in rows:
        assert set(row) >= {"path", "detected", "p_value", "ber", "id", "seconds", "error"}
    assert summary == {**summary, "files": 4, "present": 1, "absent": 2, "errors": 1}
    assert code == 2  # a file could not be read


def test_batch_exit_codes(library, capsys):
    logo = str(library / "logo.ply")
    assert main(["verify", logo, logo, "--key", KEY, "--mark", str(LOGO)]) == 0  # deduplicated
    out = capsys.readouterr().out
    assert "1 files: 1 present" in out
    plain = str(library / "sub" / "plain.ply")
    assert main(["verify", logo, plain, "--key", KEY, "--mark", str(LOGO)]) == 1
    capsys.readouterr()


def test_verify_id_and_any_id(library, capsys):
    target = str(library / "sub" / "id.obj")
    assert main(["verify", target, "--key", KEY, "--id", IDENT, "--jsonl"]) == 0
    row = _lines(capsys)[0]
    assert row["detected"] is True and row["id"] == IDENT[2:] and row["ber"] == 0
    assert main(["verify", target, "--key", KEY, "--id", "0x1", "--jsonl"]) == 1
    row = _lines(capsys)[0]
    assert row["detected"] is False and row["id"] == IDENT[2:]  # whose copy it is, still
    pattern = str(library / "**" / "*.*")
    assert main(["verify", pattern, "--key", KEY, "--any-id", "--jsonl"]) == 2
    rows = _lines(capsys)[:-1]
    found = {Path(r["path"]).name: r["id"] for r in rows if r["detected"]}
    assert found == {"id.obj": IDENT[2:]}


def test_wrong_key_finds_no_id(library, capsys):
    target = str(library / "sub" / "id.obj")
    assert main(["verify", target, "--key", "not the key", "--any-id", "--jsonl"]) == 1
    assert _lines(capsys)[0]["id"] is None


@pytest.mark.slow
def test_jobs_give_the_same_rows_in_the_same_order(library):
    paths = expand_paths([library])
    check = Check(key=KEY, params=WatermarkParams(), mark=default_mark(32))
    one = list(run_local(paths, check, jobs=1))
    two = list(run_local(paths, check, jobs=2))
    strip = [{k: v for k, v in r.items() if k != "seconds"} for r in one]
    assert strip == [{k: v for k, v in r.items() if k != "seconds"} for r in two]
    assert [r["path"] for r in one] == [str(p) for p in paths]


def test_expand_paths(library, tmp_path):
    found = expand_paths([library, library / "logo.ply", str(library / "sub" / "*.ply")])
    names = [p.name for p in found]
    assert sorted(names) == ["broken.stl", "id.obj", "logo.ply", "plain.ply"]
    assert len(names) == len(set(names))
    missing = expand_paths([str(tmp_path / "nothing-*.ply")])
    assert missing == [tmp_path / "nothing-*.ply"]  # reported as a missing file, not dropped


def test_verify_file_never_raises_on_bad_files(tmp_path):
    check = Check(key=KEY, params=WatermarkParams(), any_id=True)
    row = verify_file(tmp_path / "missing.ply", check)
    assert row["error"] and row["detected"] is False
    nan = tmp_path / "nan.obj"
    nan.write_text("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert verify_file(nan, check)["error"]


def test_summary_precedence():
    rows = [
        {"detected": True, "error": None, "seconds": 1.0},
        {"detected": False, "error": None, "seconds": 1.0},
    ]
    assert summarise(rows)["exit_code"] == 1
    assert summarise(rows[:1])["exit_code"] == 0
    assert summarise([*rows, {"detected": False, "error": "bad", "seconds": 0}])["exit_code"] == 2


def test_check_needs_exactly_one_target():
    with pytest.raises(ValueError):
        Check(key=KEY, params=WatermarkParams())
    with pytest.raises(ValueError):
        Check(key=KEY, params=WatermarkParams(), mark=np.zeros((2, 2)), any_id=True)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_rows(library, capsys):
    distributed = pytest.importorskip("distributed")
    from meshwm.apps.batch import run_dask

    paths = expand_paths([library])
    check = Check(key=KEY, params=WatermarkParams(), mark=default_mark(32))
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        rows = list(run_dask(paths, check, scheduler=client))
        # The command line, pointed at the same cluster by address.
        address = cluster.scheduler_address
        argv = ["verify", str(library), "--key", KEY, "--mark", str(LOGO), "--jsonl"]
        code = main([*argv, "--scheduler", address])
    local = list(run_local(paths, check, jobs=1))
    strip = [{k: v for k, v in r.items() if k != "seconds"} for r in rows]
    assert strip == [{k: v for k, v in r.items() if k != "seconds"} for r in local]
    cli_rows = _lines(capsys)
    assert code == 2 and cli_rows[-1]["summary"]["present"] == 1
    # Many files go to the workers in groups; the rows still come back in path order.  (Not
    # the unmarked mesh: its thorough read, 129 times over, is most of a two-minute test.)
    quick = [p for p in paths if p.name != "plain.ply"]
    many = [quick[k % len(quick)] for k in range(2 * DASK_TASKS_PER_WORKER * 2 + 1)]
    assert _chunk_size(len(many), 2) == 2
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        grouped = list(run_dask(many, check, scheduler=client))
    assert [r["path"] for r in grouped] == [str(p) for p in many]
    want = {r["path"]: r for r in strip}
    assert [{k: v for k, v in r.items() if k != "seconds"} for r in grouped] == [
        want[str(p)] for p in many
    ]


def test_dask_chunks_keep_every_worker_busy():
    assert _chunk_size(10, 2) == 1
    assert _chunk_size(200, 2) == 3
    assert _chunk_size(100_000, 2) == DASK_CHUNK
    assert _chunk_size(5, 0) == 1
