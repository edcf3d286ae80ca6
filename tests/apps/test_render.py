"""Tests for :mod:`meshwm.apps.render` and ``meshwm render``.

What the pictures guarantee (and these tests check): PNG bytes, exactly ``size`` pixels wide,
``size / views`` plus a few title and colorbar bands high; the same bytes for the same input;
the same picture (up to antialiasing rounding) for a translated and uniformly scaled copy.
"""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from meshwm.apps.cli import main
from meshwm.apps.render import (
    SIZE_RANGE,
    VIEWS_RANGE,
    distance_to_surface,
    render_comparison,
    render_views,
    view_azimuths,
)
from meshwm.mesh.io import write_mesh

ASSETS = Path(__file__).parent.parent.parent / "assets"
SPOT = ASSETS / "spot.ply"


def _image(png: bytes) -> np.ndarray:
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(io.BytesIO(png)) as im:
        return np.asarray(im.convert("RGB"), dtype=np.float64)


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat n×n grid of vertices in the unit square (z = 0), two triangles per cell."""
    xs = np.linspace(0.0, 1.0, n)
    x, y = np.meshgrid(xs, xs)
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1]
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d.ravel()])])
    return v, f


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith("meshwm: error: ")
    assert captured.err.count("\n") == 1 and captured.err.endswith("\n")
    return captured.err


# --- pictures -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("views", "size"), [(1, 300), (3, 900), (4, 333)])
def test_png_width_is_exact_and_height_follows_the_panels(spot_mesh, views, size):
    image = _image(render_views(*spot_mesh, views=views, size=size))
    height, width, _ = image.shape
    assert width == size
    assert size / views < height <= size / views + 120


def test_picture_is_not_blank(spot_mesh):
    image = _image(render_views(*spot_mesh, views=3, size=600))
    assert image.var() > 0
    background = np.all(image == 255.0, axis=2)
    assert np.allclose(image[0, 0], 255.0)  # white corner
    mesh = 1.0 - background.mean()
    assert 0.15 < mesh < 0.8  # the mesh fills a good part of the panels
    grey = image[~background].mean(axis=1)
    assert grey.std() > 10  # shaded: faces turned away from the light are darker


def test_same_input_same_bytes(spot_mesh):
    assert render_views(*spot_mesh, size=300) == render_views(*spot_mesh, size=300)


def test_translated_and_scaled_copy_gives_the_same_picture(spot_mesh):
    v, f = spot_mesh
    a = _image(render_views(v, f, size=450))
    b = _image(render_views(v * 37.5 + np.array([1e3, -20.0, 7.0]), f, size=450))
    assert a.shape == b.shape
    diff = np.abs(a - b).max(axis=2)
    assert diff.mean() < 0.5
    assert np.mean(diff > 40) < 0.002


def test_up_axis_is_a_relabelling_of_the_coordinates(spot_mesh):
    v, f = spot_mesh
    rolled = np.roll(v, 1, axis=1)  # old y is the new z
    assert render_views(v, f, size=200) == render_views(rolled, f, size=200, up="z")
    assert render_views(v, f, size=200) != render_views(v, f, size=200, up="z")


def test_values_colour_the_faces_and_add_a_colorbar(spot_mesh):
    v, f = spot_mesh
    plain = _image(render_views(v, f, size=300))
    coloured = _image(render_views(v, f, values=v[:, 1], size=300, value_label="height"))
    assert coloured.shape[0] > plain.shape[0]  # the colorbar band
    panels = coloured[: plain.shape[0] - 1]
    saturation = panels.max(axis=2) - panels.min(axis=2)
    assert np.mean(saturation > 60) > 0.05  # viridis colours, not the grey-blue mesh
    assert np.mean(plain.max(axis=2) - plain.min(axis=2) > 60) < 0.001


def test_constant_values_are_drawn(spot_mesh):
    v, f = spot_mesh
    _image(render_views(v, f, values=np.zeros(len(v)), size=200))


def test_view_azimuths_are_evenly_spaced():
    assert view_azimuths(1) == [150.0]
    assert view_azimuths(4) == [150.0, 240.0, 330.0, 60.0]


# --- distances ----------------------------------------------------------------------------------


def test_mesh_against_itself_is_at_distance_zero(spot_mesh):
    v, f = spot_mesh
    assert distance_to_surface(v, f, v, f).max() <= 1e-12
    png, stats = render_comparison(v, f, v, f, size=300)
    _image(png)
    assert stats["max_rel"] <= 1e-12 and stats["mean_rel"] <= 1e-12 and stats["rms_rel"] <= 1e-12
    assert stats["diagonal"] == pytest.approx(np.linalg.norm(np.ptp(v, axis=0)))


def test_one_moved_vertex_gives_its_displacement():
    v, f = _grid(21)
    moved = v.copy()
    d = 0.0123
    moved[10 * 21 + 7, 2] += d  # an interior vertex, perpendicular to the flat grid
    distances = distance_to_surface(moved, f, v, f)
    assert distances.argmax() == 10 * 21 + 7
    assert distances.max() == pytest.approx(d, rel=1e-12)
    assert np.delete(distances, 10 * 21 + 7).max() <= 1e-15
    _, stats = render_comparison(moved, f, v, f, views=1, size=200)
    assert stats["max_rel"] == pytest.approx(d / np.sqrt(2.0), rel=1e-12)
    assert stats["mean_rel"] == pytest.approx(d / np.sqrt(2.0) / len(v), rel=1e-12)


def test_distance_is_measured_to_the_faces_not_the_vertices():
    v, f = _grid(3)  # vertices at 0, 0.5, 1: the point (0.25, 0.25, 0) lies on a face
    points = np.array([[0.25, 0.25, 0.0], [0.25, 0.25, -0.5], [2.0, 0.5, 0.0]])
    got = distance_to_surface(points, [[0, 1, 2]], v, f)
    np.testing.assert_allclose(got, [0.0, 0.5, 1.0], atol=1e-15)


# --- bad input ----------------------------------------------------------------------------------

TETRA_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


@pytest.mark.parametrize(
    ("vertices", "faces", "options", "match"),
    [
        (np.zeros((0, 3)), np.zeros((0, 3), int), {}, "no faces"),
        (TETRA_V * np.array([1, np.nan, 1]), TETRA_F, {}, "NaN"),
        (np.zeros((4, 3)), TETRA_F, {}, "degenerate"),
        (TETRA_V, TETRA_F + 1, {}, "indices"),
        (TETRA_V, TETRA_F, {"values": np.zeros(3)}, "one number per vertex"),
        (TETRA_V, TETRA_F, {"values": np.array([0, 1, np.nan, 2])}, "NaN"),
        (TETRA_V, TETRA_F, {"values": np.zeros(4), "value_range": (1, 0)}, "value_range"),
        (TETRA_V, TETRA_F, {"views": 0}, "views"),
        (TETRA_V, TETRA_F, {"views": VIEWS_RANGE[1] + 1}, "views"),
        (TETRA_V, TETRA_F, {"size": SIZE_RANGE[0] - 1}, "size"),
        (TETRA_V, TETRA_F, {"size": SIZE_RANGE[1] + 1}, "size"),
        (TETRA_V, TETRA_F, {"up": "w"}, "up"),
    ],
)
def test_bad_input_raises_value_error(vertices, faces, options, match):
    with pytest.raises(ValueError, match=match):
        render_views(vertices, faces, **options)


@pytest.mark.parametrize("options", [{"views": 2.0}, {"views": True}, {"size": "900"}])
def test_non_integer_counts_raise_type_error(options):
    with pytest.raises(TypeError):
        render_views(TETRA_V, TETRA_F, **options)


def test_comparison_checks_both_meshes():
    with pytest.raises(ValueError, match="NaN"):
        render_comparison(TETRA_V, TETRA_F, TETRA_V * np.nan, TETRA_F)
    with pytest.raises(ValueError, match="degenerate"):
        render_comparison(TETRA_V, TETRA_F, np.zeros((4, 3)), TETRA_F)


# --- speed --------------------------------------------------------------------------------------


def test_130k_faces_render_in_seconds():
    v, f = _grid(256)  # 130 050 faces, bent into a wave so that the shading varies
    v[:, 2] = 0.1 * np.sin(8 * v[:, 0]) * np.cos(5 * v[:, 1])
    started = time.perf_counter()
    png = render_views(v, f, values=v[:, 2], size=900)
    seconds = time.perf_counter() - started
    assert _image(png).shape[1] == 900
    assert seconds < 10  # about 0.8 s on the development machine; docs/render.md


# --- command line -------------------------------------------------------------------------------


def test_cli_render_writes_a_png(tmp_path, capsys):
    out = tmp_path / "spot.PNG"
    assert main(["render", str(SPOT), "-o", str(out), "--views", "2", "--size", "400"]) == 0
    line = capsys.readouterr().out
    assert line.count("\n") == 1 and "2 views" in line and str(out) in line
    assert _image(out.read_bytes()).shape[1] == 400


def test_cli_render_compare_json(tmp_path, capsys):
    moved = tmp_path / "moved.ply"
    v, f = _grid(11)
    v2 = v.copy()
    v2[5 * 11 + 5, 2] = 0.05
    write_mesh(moved, v2, f)
    write_mesh(tmp_path / "flat.obj", v, f)
    out = tmp_path / "diff.png"
    argv = ["render", str(moved), "--compare", str(tmp_path / "flat.obj"), "-o", str(out)]
    assert main([*argv, "--json", "--views", "1", "--size", "300"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["max_rel"] == pytest.approx(0.05 / np.sqrt(2.0), rel=1e-5)
    assert 0 < report["rms_rel"] < report["max_rel"]
    assert report["views"] == 1 and report["size"] == 300 and report["width"] == 300
    assert report["compare"] == str(tmp_path / "flat.obj")
    assert report["seconds"] > 0
    with Image.open(out) as image:
        assert (report["width"], report["height"]) == image.size


def test_cli_view_and_size_limits_match_the_library(tmp_path, capsys):
    out = tmp_path / "a.png"
    low, high = VIEWS_RANGE
    assert main(["render", str(SPOT), "-o", str(out), "--views", str(high), "--size", "100"]) == 0
    assert main(["render", str(SPOT), "-o", str(out), "--size", str(SIZE_RANGE[1])]) == 0
    capsys.readouterr()
    for bad in (["--views", str(low - 1)], ["--views", str(high + 1)]):
        assert main(["render", str(SPOT), "-o", str(out), *bad]) == 2
        _one_line_error(capsys)
    for bad in (["--size", str(SIZE_RANGE[0] - 1)], ["--size", str(SIZE_RANGE[1] + 1)]):
        assert main(["render", str(SPOT), "-o", str(out), *bad]) == 2
        _one_line_error(capsys)


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["{missing}", "-o", "{out}"], "missing.ply"),
        (["{spot}", "-o", "{tmp}/out.jpg"], "suffix"),
        (["{spot}", "-o", "{tmp}/out"], "suffix"),
        (["{spot}", "-o", "{tmp}/nowhere/out.png"], "does not exist"),
        (["{spot}", "--compare", "{missing}", "-o", "{out}"], "missing.ply"),
        (["{spot}", "-o", "{out}", "--views", "0"], "--views"),
        (["{spot}", "-o", "{out}", "--views", "three"], "--views"),
        (["{spot}", "-o", "{out}", "--size", "50"], "--size"),
        (["{spot}", "-o", "{out}", "--size", "5000"], "--size"),
        (["{spot}"], "--output"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line_and_no_file(tmp_path, capsys, argv, match):
    names = {"missing": tmp_path / "missing.ply", "out": tmp_path / "out.png", "spot": SPOT}
    argv = [a.format(tmp=tmp_path, **names) for a in argv]
    assert main(["render", *argv]) == 2
    assert match in _one_line_error(capsys)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("which", ["input", "compare"])
def test_cli_never_overwrites_an_input_without_force(tmp_path, capsys, which):
    mesh = tmp_path / "mesh.ply"
    mesh.write_bytes(SPOT.read_bytes())
    link = tmp_path / "mesh.png"  # the output, a link to the input
    link.symlink_to(mesh)
    argv = ["render", str(mesh), "-o", str(link)]
    if which == "compare":
        other = tmp_path / "other.ply"
        other.write_bytes(SPOT.read_bytes())
        link.unlink()
        link.symlink_to(other)
        argv += ["--compare", str(other)]
    before = sorted(tmp_path.iterdir())
    assert main(argv) == 2
    assert "--force" in _one_line_error(capsys)
    assert sorted(tmp_path.iterdir()) == before
    assert mesh.read_bytes() == SPOT.read_bytes()
    assert main([*argv, "--force", "--size", "200"]) == 0
    assert link.read_bytes()[:4] == b"\x89PNG"
