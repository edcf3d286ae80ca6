"""Tests for the watermarking commands of :mod:`meshwm.apps.cli`: ``embed``, ``extract``, ``verify``
and ``demo``, run in-process through ``main(argv)``.

The marked meshes are built once per module from ``assets/spot.ply`` at N = 64 (about half a
second each), so the whole file stays fast; only the demo (N = 256) is marked slow.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from _malformed import make_malformed_cases
from PIL import Image

from meshwm.apps.cli import main
from meshwm.apps.cli.output import rounded as _rounded
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.message.mark import default_mark, load_mark, save_mark

ASSETS = Path(__file__).parents[3] / "assets"
SPOT = ASSETS / "spot.ply"
LOGO = ASSETS / "mark32.png"
KEY = "cli-test-key"
#: Options every embedding in this module uses (distances are measured in one test only).
EMBED_OPTIONS = ["--key", KEY, "--size", "128", "--no-distance", "--grid"]

#: A few files from tests/_malformed.py that read_mesh must refuse, one per failure family.
MALFORMED_IDS = (
    "ply_bin_truncated_face_middle",
    "ply_bin_face_flip_index_high_0x7f",
    "ply_bin_vertex_nan",
    "obj_truncated_inside_face_line",
    "stl_binary_truncated",
    "empty_ply",
    "png_renamed_ply",
    "directory_named_ply",
)


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """spot marked with the logo (PLY, OBJ, STL) and with a random 16×16 mark, plus bad inputs.

    Everything lives outside the tests' own ``tmp_path``, so a test can check that a failed
    command left its ``tmp_path`` empty.
    """
    d = tmp_path_factory.mktemp("cli_watermark")
    paths: dict[str, Path] = {}
    for suffix in (".ply", ".obj", ".stl"):
        out = d / f"spot_marked{suffix}"
        assert main(["embed", str(SPOT), "-o", str(out), *EMBED_OPTIONS]) == 0
        paths[f"marked{suffix}"] = out

    rng = np.random.default_rng(20240601)
    paths["custom16.png"] = d / "custom16.png"
    save_mark(paths["custom16.png"], rng.integers(0, 2, size=(16, 16)))
    paths["custom_marked.ply"] = d / "spot_custom.ply"
    code = main(
        [
            "embed",
            str(SPOT),
            "-o",
            str(paths["custom_marked.ply"]),
            "--mark",
            str(paths["custom16.png"]),
            "--mark-size",
            "16",
            *EMBED_OPTIONS,
        ]
    )
    assert code == 0
    paths["other32.png"] = d / "other32.png"
    save_mark(paths["other32.png"], rng.integers(0, 2, size=(32, 32)))

    # Bad mark images.
    paths["truncated.png"] = d / "truncated.png"
    paths["truncated.png"].write_bytes(LOGO.read_bytes()[:40])
    paths["uniform.png"] = d / "uniform.png"
    Image.new("L", (32, 32), 255).save(paths["uniform.png"])
    paths["missing.png"] = d / "missing.png"
    # Bad meshes: a truncated copy of the input and of the marked mesh, and malformed files.
    paths["truncated_spot.ply"] = d / "truncated_spot.ply"
    paths["truncated_spot.ply"].write_bytes(SPOT.read_bytes()[:700])
    data = paths["marked.ply"].read_bytes()
    paths["truncated_marked.ply"] = d / "truncated_marked.ply"
    paths["truncated_marked.ply"].write_bytes(data[: len(data) // 2])
    paths["missing.ply"] = d / "missing.ply"
    malformed_dir = d / "malformed"
    malformed_dir.mkdir()
    for case in make_malformed_cases(malformed_dir):
        if case.case_id in MALFORMED_IDS:
            assert case.must_fail_on_read
            paths[case.case_id] = case.path
    return paths


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    err = capsys.readouterr().err
    assert err.endswith("\n")
    assert err.count("\n") == 1, err
    assert err.startswith("meshwm: error: "), err
    assert "Traceback" not in err
    return err


def _json(capsys: pytest.CaptureFixture) -> dict:
    captured = capsys.readouterr()
    assert captured.err == ""
    return json.loads(captured.out)


# --------------------------------------------------------------------------------------------
# embed then extract
# --------------------------------------------------------------------------------------------


def test_extract_returns_the_default_logo(files, tmp_path, capsys):
    out = tmp_path / "found.png"
    code = main(["extract", str(files["marked.ply"]), "--key", KEY, "-o", str(out)])
    assert code == 0
    assert str(out) in capsys.readouterr().out
    found = load_mark(out)
    np.testing.assert_array_equal(found, load_mark(LOGO))
    np.testing.assert_array_equal(found, default_mark(32))
    with Image.open(out) as image:
        assert image.format == "PNG"
        assert image.mode == "1"
        assert image.size == (32, 32)


def test_extract_json_with_the_original_mark(files, tmp_path, capsys):
    out = tmp_path / "found.png"
    argv = ["extract", str(files["marked.ply"]), "--key", KEY, "-o", str(out)]
    assert main([*argv, "--mark", str(LOGO), "--json"]) == 0
    report = _json(capsys)
    assert report["ber"] == 0
    assert report["correlation"] == 1
    assert report["bits"] == 1024
    assert report["mark_size"] == 32
    assert report["output"] == str(out)


def test_extract_returns_a_custom_mark(files, tmp_path, capsys):
    out = tmp_path / "found16.png"
    argv = ["extract", str(files["custom_marked.ply"]), "--key", KEY, "-o", str(out)]
    assert main([*argv, "--mark-size", "16", "--mark", str(files["custom16.png"]), "--json"]) == 0
    report = _json(capsys)
    assert (report["ber"], report["correlation"], report["bits"]) == (0, 1, 256)
    found = load_mark(out)
    assert found.shape == (16, 16)
    np.testing.assert_array_equal(found, load_mark(files["custom16.png"]))


def test_extract_finds_n_from_the_mesh(files, tmp_path, capsys):
    """Embedded at --size 128; extract has no --size and must not assume the default 256."""
    out = tmp_path / "found.png"
    assert main(["extract", str(files["marked.ply"]), "--key", KEY, "-o", str(out), "--json"]) == 0
    report = _json(capsys)
    assert report["n"] == 128
    assert "ber" not in report  # no --mark, nothing to compare with
    assert report["logo"] is True and report["drawing"] is True
    np.testing.assert_array_equal(load_mark(out), default_mark(32))


def test_extract_tells_another_drawing_from_noise(tmp_path, capsys):
    # Without --mark a 32×32 mark is compared with the bundled logo; one that is not it is
    # another drawing (its neighbouring pixels agree) or no drawing (here: a wrong key).
    i, j = np.mgrid[:32, :32]
    ring = (np.abs(np.hypot(i - 15.5, j - 15.5) - 10) < 3).astype(np.uint8)
    ring[3:7, 4:28] = 1  # a bar on one side: not symmetric
    png = tmp_path / "ring.png"
    save_mark(png, ring)
    marked = tmp_path / "ring.ply"
    assert main(["embed", str(SPOT), "-o", str(marked), "--mark", str(png), *EMBED_OPTIONS]) == 0
    capsys.readouterr()
    assert main(["extract", str(marked), "--key", KEY]) == 0
    assert "(not the bundled logo: another mark, which reads as a drawing)" in (
        capsys.readouterr().out
    )
    assert main(["extract", str(marked), "--key", "a wrong key", "--json"]) == 0
    report = _json(capsys)
    assert report["logo"] is False and report["drawing"] is False


@pytest.mark.parametrize("ident", [None, "0xC0FFEE42"], ids=["mark", "id"])
def test_extract_json_reads_the_mesh_once(ident, files, tmp_path, capsys, monkeypatch):
    """One Decoder serves the id and the mark; the figures are the library's."""
    import meshwm.watermark
    import meshwm.watermark.assets
    from meshwm.mesh.io import read_mesh
    from meshwm.params import WatermarkParams

    marked = files["marked.ply"]
    if ident is not None:
        marked = tmp_path / "id.ply"
        assert main(["embed", str(SPOT), "-o", str(marked), *EMBED_OPTIONS, "--id", ident]) == 0
        capsys.readouterr()
    vertices, faces = read_mesh(marked)
    params = WatermarkParams(size=128)
    expected = meshwm.watermark.extract(vertices, faces, key=KEY, params=params).report
    found_id = meshwm.watermark.extract_id(vertices, faces, key=KEY, params=params).id
    assert found_id == (None if ident is None else ident[2:].lower().rjust(16, "0"))

    built = []

    class CountingReader(meshwm.watermark.Decoder):
        def __init__(self, *args, **kwargs):
            built.append(args)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(meshwm.watermark.assets, "Decoder", CountingReader)
    assert main(["extract", str(marked), "--key", KEY, "--json"]) == 0
    report = _json(capsys)
    assert len(built) == 1
    assert report["id"] == found_id
    assert report["input"] == str(marked) and report["output"] is None
    assert report["kind"] == ("mark" if ident is None else "id")
    if ident is None:
        for name in ("n", "reader", "hypotheses"):
            assert report[name] == _rounded(expected)[name], name
        assert report["logo"] is True


@pytest.mark.parametrize("suffix", [".obj", ".stl"])
def test_marked_obj_and_stl_read_back_exactly(suffix, files, tmp_path, capsys):
    marked = files[f"marked{suffix}"]
    out = tmp_path / "found.png"
    assert main(["extract", str(marked), "--key", KEY, "-o", str(out)]) == 0
    np.testing.assert_array_equal(load_mark(out), default_mark(32))
    capsys.readouterr()
    assert main(["verify", str(marked), "--key", KEY, "--mark", str(LOGO), "--json"]) == 0
    report = _json(capsys)
    assert report["detected"] is True
    assert report["ber"] == 0


# --------------------------------------------------------------------------------------------
# embed report
# --------------------------------------------------------------------------------------------


def test_embed_json_report_with_distances(tmp_path, capsys):
    out = tmp_path / "marked.ply"
    code = main(
        ["embed", str(SPOT), "-o", str(out), "--key", KEY, "--size", "128", "--json", "--grid"]
    )
    assert code == 0
    report = _json(capsys)
    for name in ("psnr", "mrms_rel", "hausdorff_rel", "rms_rel", "seconds"):
        assert isinstance(report[name], float), name
    for name in ("n", "capacity_bits", "used_bits"):
        assert isinstance(report[name], int) and not isinstance(report[name], bool), name
    assert report["n"] == 128
    assert report["used_bits"] == 1024
    assert report["capacity_bits"] > 0
    assert report["psnr"] > 40
    assert 0 < report["mrms_rel"] < 0.0005
    assert 0 < report["rms_rel"] <= report["hausdorff_rel"] <= 0.05
    assert report["seconds"] > 0
    assert (report["input"], report["output"]) == (str(SPOT), str(out))
    assert out.is_file()


def test_embed_text_report_without_distances(tmp_path, capsys):
    out = tmp_path / "marked.ply"
    assert main(["embed", str(SPOT), "-o", str(out), *EMBED_OPTIONS]) == 0
    text = capsys.readouterr().out
    assert "PSNR" in text and "1024 bits" in text and "N=128" in text
    assert "Hausdorff" not in text  # --no-distance


def test_embed_json_without_distances_has_no_distance_fields(tmp_path, capsys):
    out = tmp_path / "marked.ply"
    assert main(["embed", str(SPOT), "-o", str(out), *EMBED_OPTIONS, "--json"]) == 0
    report = _json(capsys)
    assert report["psnr"] > 40
    assert not {"mrms_rel", "hausdorff_rel", "rms_rel"} & set(report)


# --------------------------------------------------------------------------------------------
# verify
# --------------------------------------------------------------------------------------------


def test_verify_present_with_the_right_key_and_mark(files, capsys):
    code = main(["verify", str(files["marked.ply"]), "--key", KEY, "--mark", str(LOGO), "--json"])
    assert code == 0
    report = _json(capsys)
    assert report["detected"] is True
    assert report["ber"] == 0
    assert report["correlation"] == 1
    assert report["bits"] == 1024
    assert report["fpr"] == 1e-6
    # Bonferroni: the false-positive budget is shared by every hypothesis the decoder tried.
    assert report["hypotheses"] >= 1
    assert report["threshold"] == pytest.approx(1e-6 / report["hypotheses"], rel=1e-5)
    assert report["p_value"] < report["threshold"]


def test_verify_present_text(files, capsys):
    assert main(["verify", str(files["marked.ply"]), "--key", KEY, "--mark", str(LOGO)]) == 0
    assert "mark present" in capsys.readouterr().out


def test_verify_custom_mark(files, capsys):
    argv = ["verify", str(files["custom_marked.ply"]), "--key", KEY]
    code = main([*argv, "--mark", str(files["custom16.png"]), "--mark-size", "16", "--json"])
    assert code == 0
    report = _json(capsys)
    assert (report["detected"], report["ber"], report["bits"]) == (True, 0, 256)


def test_verify_absent_with_a_wrong_key(files, capsys):
    argv = ["verify", str(files["marked.ply"]), "--key", "not-the-key", "--mark", str(LOGO)]
    assert main([*argv, "--json"]) == 1
    report = _json(capsys)
    assert report["detected"] is False
    assert report["ber"] > 0.25
    assert report["p_value"] > 1e-6


def test_verify_absent_with_a_different_mark(files, capsys):
    argv = ["verify", str(files["marked.ply"]), "--key", KEY, "--mark", str(files["other32.png"])]
    assert main([*argv, "--json"]) == 1
    report = _json(capsys)
    assert report["detected"] is False
    assert report["ber"] > 0.25


@pytest.mark.parametrize("json_flag", [True, False])
def test_verify_unmarked_mesh_is_absent_not_an_error(json_flag, capsys):
    argv = ["verify", str(SPOT), "--key", KEY, "--mark", str(LOGO)]
    assert main([*argv, "--json"] if json_flag else argv) == 1
    if json_flag:
        report = _json(capsys)
        # Any mesh is read now (the surface reader): an unmarked one reads as coin flips.
        assert report["detected"] is False
        assert 0.3 < report["ber"] < 0.7
        assert report["bits"] == 1024
        assert report["p_value"] > 1e-3
    else:
        captured = capsys.readouterr()
        assert captured.err == ""
        assert "absent" in captured.out


def test_verify_json_reports_a_small_threshold_unrounded(files, capsys):
    argv = ["verify", str(files["marked.ply"]), "--key", KEY, "--mark", str(LOGO)]
    assert main([*argv, "--fpr", "1e-9", "--json"]) == 0
    report = _json(capsys)
    assert report["fpr"] == 1e-9
    assert report["threshold"] == pytest.approx(1e-9 / report["hypotheses"], rel=1e-5)


def test_verify_missing_file_is_an_error(tmp_path, capsys):
    missing = tmp_path / "nope.ply"
    assert main(["verify", str(missing), "--key", KEY, "--mark", str(LOGO), "--json"]) == 2
    assert "nope.ply" in _one_line_error(capsys)
    assert capsys.readouterr().out == ""


# --------------------------------------------------------------------------------------------
# bad input: exit 2, one line on stderr, no output
# --------------------------------------------------------------------------------------------


def _argv(command: str, src: Path, out: Path, extra: list[str]) -> list[str]:
    """A valid command line for ``command``; ``extra`` comes last, so it overrides options."""
    if command == "embed":
        return ["embed", str(src), "-o", str(out), *EMBED_OPTIONS, *extra]
    if command == "extract":
        return ["extract", str(src), "-o", str(out), "--key", KEY, *extra]
    return ["verify", str(src), "--key", KEY, "--mark", str(LOGO), *extra]


#: (case id, extra options, text the error must contain); ``@name`` stands for ``files[name]``.
BAD_OPTIONS = [
    ("empty_key", ["--key", ""], "--key"),
    ("channels_w", ["--channels", "w"], "--channels"),
    ("channels_empty", ["--channels", ","], "--channels"),
    ("channels_duplicate", ["--channels", "x,x"], "channels"),
    ("step_nan", ["--step", "nan"], "--step"),
    ("step_inf", ["--step", "inf"], "--step"),
    ("step_negative", ["--step", "-1"], "step"),
    ("step_zero", ["--step", "0"], "step"),
    ("step_text", ["--step", "abc"], "--step"),
    ("arnold_negative", ["--arnold-iterations", "-1"], "arnold_iterations"),
    ("arnold_text", ["--arnold-iterations", "x"], "--arnold-iterations"),
    ("mark_size_4", ["--mark-size", "4"], "--mark-size"),
    ("mark_size_512", ["--mark-size", "512"], "--mark-size"),
    ("max_faces_0", ["--max-faces", "0"], "--max-faces"),
    ("max_faces_too_small", ["--max-faces", "100"], "limit of 100 (--max-faces raises it)"),
    ("mark_missing", ["--mark", "@missing.png"], "missing.png"),
    ("mark_truncated", ["--mark", "@truncated.png"], "truncated.png"),
    ("mark_uniform", ["--mark", "@uniform.png"], "uniform.png"),
    ("mark_is_a_mesh", ["--mark", str(SPOT)], "spot.ply"),
    ("unknown_option", ["--bogus"], "--bogus"),
]
COMMANDS = ("embed", "extract", "verify")


def _check_no_output(tmp_path: Path) -> None:
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize(
    ("case_id", "extra", "message"), BAD_OPTIONS, ids=[case[0] for case in BAD_OPTIONS]
)
def test_bad_option_exits_2(command, case_id, extra, message, files, tmp_path, capsys):
    extra = [str(files[e[1:]]) if e.startswith("@") else e for e in extra]
    src = SPOT if command == "embed" else files["marked.ply"]
    out = tmp_path / ("out.ply" if command == "embed" else "out.png")
    assert main(_argv(command, src, out, extra)) == 2
    assert message in _one_line_error(capsys)
    assert capsys.readouterr().out == ""
    assert not out.exists()
    _check_no_output(tmp_path)


@pytest.mark.parametrize(
    "extra",
    [["--size", "100"], ["--size", "32"], ["--size", "4096"], ["--size", "abc"]],
    ids=["size_100", "size_32", "size_4096", "size_text"],
)
def test_embed_bad_size_exits_2(extra, tmp_path, capsys):
    out = tmp_path / "out.ply"
    assert main(_argv("embed", SPOT, out, extra)) == 2
    assert "--size" in _one_line_error(capsys)
    _check_no_output(tmp_path)


@pytest.mark.parametrize("command", ("extract", "verify"))
def test_extract_and_verify_have_no_size_option(command, files, tmp_path, capsys):
    out = tmp_path / "out.png"
    assert main(_argv(command, files["marked.ply"], out, ["--size", "64"])) == 2
    _one_line_error(capsys)
    _check_no_output(tmp_path)


@pytest.mark.parametrize("fpr", ["0", "1", "-0.5", "nan", "abc"])
def test_verify_bad_fpr_exits_2(fpr, files, tmp_path, capsys):
    assert main(_argv("verify", files["marked.ply"], tmp_path / "unused", ["--fpr", fpr])) == 2
    assert "--fpr" in _one_line_error(capsys)


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize(
    "name", ["missing.ply", "truncated_spot.ply", "truncated_marked.ply", *MALFORMED_IDS]
)
def test_bad_input_mesh_exits_2(command, name, files, tmp_path, capsys):
    out = tmp_path / ("out.ply" if command == "embed" else "out.png")
    assert main(_argv(command, files[name], out, [])) == 2
    _one_line_error(capsys)
    assert capsys.readouterr().out == ""
    assert not out.exists()
    _check_no_output(tmp_path)


def test_missing_input_names_the_file(tmp_path, capsys):
    out = tmp_path / "out.ply"
    assert main(_argv("embed", tmp_path / "nope.ply", out, [])) == 2
    assert "nope.ply" in _one_line_error(capsys)
    _check_no_output(tmp_path)


@pytest.mark.parametrize("name", ["out.jpg", "out.PNG.txt", "out"])
def test_extract_refuses_a_non_png_output(name, files, tmp_path, capsys):
    out = tmp_path / name
    assert main(_argv("extract", files["marked.ply"], out, [])) == 2
    assert "PNG" in _one_line_error(capsys)
    _check_no_output(tmp_path)


def test_extract_refuses_a_missing_output_folder(files, tmp_path, capsys):
    out = tmp_path / "no_such_dir" / "out.png"
    assert main(_argv("extract", files["marked.ply"], out, [])) == 2
    _one_line_error(capsys)
    _check_no_output(tmp_path)


def test_extract_of_a_mesh_no_reader_can_map_exits_2(tmp_path, capsys):
    """extract, unlike verify, has no 'absent' answer: a mesh no reader maps is an error."""
    import trimesh

    src_dir = tmp_path / "in"
    src_dir.mkdir()
    src = src_dir / "fin.ply"  # three sheets on one edge: not a surface, no grid
    v = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, -1, 0]], float)
    f = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    trimesh.Trimesh(v, f, process=False).export(src)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    assert main(_argv("extract", src, out_dir / "out.png", [])) == 2
    _one_line_error(capsys)
    _check_no_output(out_dir)


@pytest.mark.parametrize("suffix", [".xyz", ".fbx", ""])
def test_embed_refuses_an_unwritable_suffix(suffix, tmp_path, capsys):
    out = tmp_path / f"out{suffix}"
    assert main(_argv("embed", SPOT, out, [])) == 2
    _one_line_error(capsys)
    _check_no_output(tmp_path)


def test_embed_mark_too_large_for_the_grid_exits_2(tmp_path, capsys):
    """A 64×64 mark is 4096 bits; a size-128 geometry image has 1764 robust slots."""
    out = tmp_path / "out.ply"
    assert main(_argv("embed", SPOT, out, ["--mark-size", "64"])) == 2
    assert "do not fit" in _one_line_error(capsys)
    _check_no_output(tmp_path)


def test_embed_missing_output_folder_exits_2(tmp_path, capsys):
    out = tmp_path / "no_such_dir" / "out.ply"
    assert main(_argv("embed", SPOT, out, [])) == 2
    _one_line_error(capsys)
    _check_no_output(tmp_path)


def test_embed_never_overwrites_its_input_without_force(tmp_path, capsys):
    src = tmp_path / "spot.ply"
    shutil.copy(SPOT, src)
    before = src.read_bytes()
    assert main(["embed", str(src), "-o", str(src), *EMBED_OPTIONS]) == 2
    assert "--force" in _one_line_error(capsys)
    assert src.read_bytes() == before
    assert list(tmp_path.iterdir()) == [src]
    assert main(["embed", str(src), "-o", str(src), *EMBED_OPTIONS, "--force"]) == 0
    assert src.read_bytes() != before


# --------------------------------------------------------------------------------------------
# demo
# --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_demo(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert "wrong key" in captured.out
    assert "STL round trip" in captured.out
    assert "5ca1ab1e0ddba11f" in captured.out and "same vertices and faces" in captured.out
    table = captured.out.split("detected")[-1].splitlines()
    rows = [line for line in table if line.strip() and not line.startswith("where")]
    assert all(line.endswith("yes") for line in rows[:-1]) and rows[-1].endswith("no"), rows
    assert (out / "spot_marked.ply").is_file()
    with Image.open(out / "compare.png") as image:
        image.verify()
    with Image.open(out / "compare.png") as image:
        assert image.format == "PNG"
        assert image.width > image.height > 0


# --------------------------------------------------------------------------------------------
# the user's mesh kept (the default)


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".stl"])
def test_embed_keeps_the_input_mesh_in_each_format(suffix, tmp_path, capsys):
    from meshwm.mesh.io import read_mesh, write_mesh

    v, f = read_mesh(SPOT)
    src = tmp_path / f"in{suffix}"
    write_mesh(src, v, f)
    out = tmp_path / f"out{suffix}"
    argv = ["embed", str(src), "-o", str(out), "--key", KEY, "--id", "0xC0FFEE42", "--json"]
    assert main([*argv, "--no-distance"]) == 0
    report = _json(capsys)
    assert report["mode"] == "kept" and report["n"] in (128, 256)
    vi, fi = read_mesh(src)
    vo, fo = read_mesh(out)
    assert vo.shape == vi.shape and np.array_equal(fo, fi)
    assert 0 < np.abs(vo - vi).max() < 0.01 * np.ptp(vi, axis=0).max()
    assert main(["verify", str(out), "--key", KEY, "--id", "0xC0FFEE42"]) == 0
    assert main(["verify", str(out), "--key", "not the key", "--id", "0xC0FFEE42"]) == 1


@pytest.mark.parametrize(
    "payload, read_ber, says",
    [
        ({"mark_size": 32}, 14 / 1024, "its surface map reads back 1.4% of its bits wrong"),
        ({"id": "00000000c0ffee42"}, 3 / 256, "1.2% of its bits wrong, which its code corrects"),
        ({"mark_size": 32}, 0.0, None),
    ],
)
def test_the_embed_line_says_how_many_bits_read_back_wrong(payload, read_ber, says):
    from meshwm.apps.cli.embed import _mesh_line

    row = {"name": "mesh", "marked": True, "vertices": 9447, "n": 256, "psnr": 90.0}
    line = _mesh_line({**row, **payload, "read_ber": read_ber})
    if says is None:
        assert "wrong" not in line
    else:
        assert line.endswith(says)


def test_embed_says_what_the_surface_map_left_out(tmp_path, capsys):
    # spot with a fin: the fin comes off the surface (a part of its own, one face detached).
    v, f = read_mesh(ASSETS / "spot.ply")
    e = f[0]
    fin_v = np.vstack([v, v[e[:2]].mean(axis=0) + np.array([0.0, 0.05, 0.0])])
    fin_f = np.vstack([f, [[e[1], e[0], len(v)]]])
    src, out = tmp_path / "fin.ply", tmp_path / "out.ply"
    write_mesh(src, fin_v, fin_f)
    assert (
        main(["embed", str(src), "-o", str(out), "--key", KEY, "--id", "0x12", "--no-distance"])
        == 0
    )
    said = capsys.readouterr().out
    assert "1 smaller part kept off the surface map" in said
    assert "1 face on non-manifold edges detached" in said
    assert main(["verify", str(out), "--key", KEY, "--id", "0x12"]) == 0
    plain = tmp_path / "plain.ply"
    assert (
        main(
            [
                "embed",
                str(ASSETS / "spot.ply"),
                "-o",
                str(plain),
                "--key",
                KEY,
                "--id",
                "0x12",
                "--no-distance",
            ]
        )
        == 0
    )
    assert "surface map" not in capsys.readouterr().out
