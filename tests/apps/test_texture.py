"""Tests for :mod:`meshwm.apps.texture` and ``meshwm render --texture``: a file's look per face."""

from __future__ import annotations

import numpy as np
from PIL import Image

from meshwm.apps.cli import main
from meshwm.apps.texture import texture_colors

OBJ = """mtllib look.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0.1 0.1
vt 0.9 0.1
vt 0.9 0.9
vt 0.1 0.9
usemtl half
f 1/1 2/2 3/3
f 1/1 3/3 4/4
"""


def _textured(tmp_path):
    """A quad whose texture is red left of the diagonal u = v and blue right of it."""
    pixels = np.zeros((64, 64, 3), dtype=np.uint8)
    rows, cols = np.mgrid[0:64, 0:64]
    below = (63 - rows) < cols  # v < u: the first triangle's side
    pixels[below] = [255, 0, 0]
    pixels[~below] = [0, 0, 255]
    Image.fromarray(pixels).save(tmp_path / "look.png")
    (tmp_path / "look.mtl").write_text("newmtl half\nKd 1 1 1\nmap_Kd look.png\n")
    (tmp_path / "look.obj").write_text(OBJ)
    return tmp_path / "look.obj"


def test_each_face_gets_the_texture_at_its_uvs(tmp_path):
    look = texture_colors(_textured(tmp_path))
    assert look.textured == 2 and len(look.faces) == 2
    by_centre = {tuple(np.round(look.vertices[f].mean(axis=0)[:2], 2)): c for f, c in
                 zip(look.faces, look.colors, strict=True)}  # fmt: skip
    np.testing.assert_allclose(by_centre[(0.67, 0.33)], [1, 0, 0])
    np.testing.assert_allclose(by_centre[(0.33, 0.67)], [0, 0, 1])


def test_render_texture_draws_the_colours(tmp_path, capsys):
    png = tmp_path / "look.png.out.png"
    assert main(["render", str(_textured(tmp_path)), "-o", str(png), "--texture", "--views",
                 "1", "--size", "200", "--json"]) == 0  # fmt: skip
    assert '"textured_faces": 2' in capsys.readouterr().out
    rgb = np.asarray(Image.open(png).convert("RGB")).reshape(-1, 3).astype(int)
    reddish = (rgb[:, 0] > 100) & (rgb[:, 2] < 60)
    bluish = (rgb[:, 2] > 100) & (rgb[:, 0] < 60)
    assert reddish.sum() > 500 and bluish.sum() > 500
