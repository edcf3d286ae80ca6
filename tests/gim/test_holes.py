"""meshwm.gim.holes: boundary loops and their virtual filling."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.errors import MeshError
from meshwm.gim.holes import boundary_loops, fill_holes, loop_length
from meshwm.mesh.clean import euler_characteristic


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat n x n grid of squares, two triangles each, counter-clockwise seen from +z."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    v = np.stack([i.ravel(), j.ravel(), np.zeros(i.size)], axis=1).astype(float)
    a = (j[:-1, :-1] * (n + 1) + i[:-1, :-1]).ravel()
    f = np.concatenate([np.stack([a, a + 1, a + n + 2], 1), np.stack([a, a + n + 2, a + n + 1], 1)])
    return v, f


def test_loops_of_a_grid_with_a_hole():
    v, f = _grid(6)
    centre = np.all(np.abs(v[f].mean(axis=1)[:, :2] - 3.0) < 1.0, axis=1)
    loops = boundary_loops(f[~centre])
    assert sorted(len(loop) for loop in loops) == [8, 24]
    assert loop_length(v, loops[0]) == pytest.approx(24.0)  # the outer square, listed first


def test_loops_are_kept_for_the_last_faces_and_found_again_for_other_faces():
    from meshwm.gim import holes

    v, f = _grid(6)
    centre = np.all(np.abs(v[f].mean(axis=1)[:, :2] - 3.0) < 1.0, axis=1)
    faces = f[~centre]
    first = boundary_loops(faces)
    again = boundary_loops(faces.copy())  # equal faces: the kept loops, read-only
    assert [a is b for a, b in zip(first, again, strict=True)] == [True, True]
    assert not any(loop.flags.writeable for loop in again)
    fresh = holes._boundary_loops(faces)
    assert [loop.tolist() for loop in again] == [loop.tolist() for loop in fresh]
    assert [len(loop) for loop in boundary_loops(f)] == [24]  # other faces: computed
    again.pop()  # the list handed out is the caller's own
    assert len(boundary_loops(f)) == 1


def test_fill_keeps_the_long_border_and_fills_the_rest():
    v, f = _grid(6)
    centre = np.all(np.abs(v[f].mean(axis=1)[:, :2] - 3.0) < 1.0, axis=1)
    f = f[~centre]
    filled = fill_holes(v, f, boundary_loops(f))
    assert len(filled.outer) == 24 and len(filled.centres) == 1
    np.testing.assert_allclose(filled.centres[0], [3.0, 3.0, 0.0])
    assert euler_characteristic(len(np.unique(filled.faces)), filled.faces) == 1  # a disk
    assert boundary_loops(filled.faces)[0].tolist() == filled.outer.tolist()


def test_a_short_border_is_filled_too():
    v, f = _grid(6)
    filled = fill_holes(v, f, boundary_loops(f), min_border=10.0)  # 24 < 10 * sqrt(36)
    assert len(filled.outer) == 0 and len(filled.centres) == 1


def test_closed_mesh_has_no_loops(sphere_mesh):
    v, f = sphere_mesh
    assert boundary_loops(f) == []
    filled = fill_holes(v, f, [])
    assert len(filled.centres) == 0 and len(filled.outer) == 0


def test_a_bowtie_border_is_refused():
    f = np.array([[0, 1, 2], [0, 3, 4]])  # vertex 0 starts two border edges
    with pytest.raises(MeshError, match="simple loops"):
        boundary_loops(f)
