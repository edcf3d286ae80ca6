"""Tests for :mod:`meshwm.apps.bench.synthetic`: the generated many-holes and high-genus meshes."""

from __future__ import annotations

import igl
import numpy as np
import pytest

from meshwm.apps.bench.synthetic import holed_plate, make, punch_holes
from meshwm.mesh.clean import edge_topology_counts, euler_characteristic


def test_holed_plate_has_the_genus_asked():
    v, f = holed_plate(holes=(2, 1), cell=2, subdivisions=1, smoothing=2)
    assert euler_characteristic(len(v), f) == 2 - 2 * 2
    assert len(igl.boundary_loop_all(f)) == 0 and edge_topology_counts(f)[2] == 0


def test_punch_holes_makes_that_many_loops(kitten_mesh):
    v, f = kitten_mesh
    pv, pf = punch_holes(v, f, seed=0, count=6)
    assert len(igl.boundary_loop_all(pf)) == 6 and edge_topology_counts(pf)[2] == 0
    assert euler_characteristic(len(pv), pf) == -6
    again = punch_holes(v, f, seed=0, count=6)
    np.testing.assert_array_equal(again[1], pf)


def test_the_named_meshes_meet_the_issue():
    v, f = make("holes35")
    assert len(igl.boundary_loop_all(f)) >= 30
    v, f = make("genus8")
    assert (2 - euler_characteristic(len(v), f)) // 2 >= 8
    with pytest.raises(ValueError, match="unknown synthetic"):
        make("torus")
