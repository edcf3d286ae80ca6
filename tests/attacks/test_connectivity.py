"""Tests for :mod:`meshwm.attacks.connectivity`: flips of nearly flat edges and quad re-splits.

On the bundled spot (closed, genus 0) and kitten (genus 1) and on small hand-made meshes.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from meshwm.attacks import apply_attack
from meshwm.attacks.connectivity import (
    QUAD_DIHEDRAL,
    flat_edges,
    flip_edges,
    flip_flat_edges,
    interior_pairs,
    retriangulate,
)
from meshwm.mesh.clean import edge_topology_counts, euler_characteristic, unique_edges


def _edge_set(faces) -> set[tuple[int, int]]:
    return set(map(tuple, unique_edges(np.asarray(faces))[0].tolist()))


def _dihedral_degrees(v, f, edges) -> np.ndarray:
    """Angle between the normals of the two faces of each edge, in the mesh ``(v, f)``."""
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    around: dict[tuple[int, int], list[int]] = {}
    for face, row in enumerate(f.tolist()):
        for k in range(3):
            p, q = row[k], row[(k + 1) % 3]
            around.setdefault((min(p, q), max(p, q)), []).append(face)
    angles = []
    for p, q in edges.tolist():
        fa, fb = around[(p, q)]
        angles.append(np.degrees(np.arccos(np.clip(normals[fa] @ normals[fb], -1, 1))))
    return np.array(angles)


def _consistently_oriented(faces) -> bool:
    """Every directed edge at most once, and (closed mesh) its reverse present."""
    f = np.asarray(faces)
    directed = np.stack([f, np.roll(f, -1, axis=1)], axis=2).reshape(-1, 2)
    as_set = set(map(tuple, directed.tolist()))
    return len(as_set) == len(directed) and all((q, p) in as_set for p, q in as_set)


def _square():
    """Two triangles of the unit square sharing the diagonal 0-2."""
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def _tetrahedron():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    return v, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


# --- flip_edges ------------------------------------------------------------------------------


@pytest.mark.parametrize("count", [1, 10, 100, 1000])
def test_flips_change_exactly_count_edges(spot_mesh, count):
    v, f = spot_mesh
    result = flip_flat_edges(v, f, seed=3, count=count)
    before, after = _edge_set(f), _edge_set(result.faces)
    assert len(result.removed) == len(result.added) == count
    assert before - after == set(map(tuple, result.removed.tolist()))
    assert after - before == set(map(tuple, result.added.tolist()))
    assert len(result.faces) == len(f)


@pytest.mark.parametrize("fixture", ["spot_mesh", "kitten_mesh"])
def test_flips_keep_vertices_manifoldness_and_orientation(request, fixture):
    v, f = request.getfixturevalue(fixture)
    v2, f2 = flip_edges(v, f, seed=1, count=1000)
    assert_array_equal(v2, v)
    assert f2.shape == f.shape
    assert edge_topology_counts(f2) == edge_topology_counts(f)  # no boundary, non-manifold edge
    assert euler_characteristic(len(v), f2) == euler_characteristic(len(v), f)
    assert _consistently_oriented(f2)
    assert len(np.unique(np.sort(f2, axis=1), axis=0)) == len(f2)  # no face twice


def test_flips_do_not_fold(spot_mesh):
    """Each rewritten face's normal is within 90° of the normal it had before."""
    v, f = spot_mesh
    f2 = flip_edges(v, f, seed=2, count=300)[1]
    changed = np.flatnonzero(np.any(f2 != f, axis=1))
    assert 300 < len(changed) <= 600  # a face may take part in two flips
    old = np.cross(v[f[changed, 1]] - v[f[changed, 0]], v[f[changed, 2]] - v[f[changed, 0]])
    new = np.cross(v[f2[changed, 1]] - v[f2[changed, 0]], v[f2[changed, 2]] - v[f2[changed, 0]])
    assert np.all(np.einsum("ij,ij->i", old, new) > 0)


@pytest.mark.parametrize("max_dihedral", [2.0, 10.0])
def test_only_flat_edges_are_flipped(spot_mesh, max_dihedral):
    v, f = spot_mesh
    result = flip_flat_edges(v, f, seed=5, count=200, max_dihedral=max_dihedral)
    assert len(result.removed) == 200
    assert np.all(_dihedral_degrees(v, f, result.removed) < max_dihedral)
    flat = _edge_set(flat_edges(v, f, max_dihedral=max_dihedral))
    assert set(map(tuple, result.removed.tolist())) <= flat
    assert result.candidates == len(flat)


def test_flat_edges_grow_with_the_angle(spot_mesh):
    counts = [len(flat_edges(*spot_mesh, max_dihedral=a)) for a in (1.0, 5.0, 10.0, 30.0)]
    assert counts == sorted(counts) and counts[0] < counts[-1]
    assert np.all(_dihedral_degrees(*spot_mesh, flat_edges(*spot_mesh, max_dihedral=5.0)) < 5)


def test_flip_of_a_square():
    v, f = _square()
    result = flip_flat_edges(v, f, count=1)
    assert result.faces.tolist() == [[3, 1, 2], [0, 1, 3]]  # two corners of each row kept
    assert result.removed.tolist() == [[0, 2]] and result.added.tolist() == [[1, 3]]


def test_fewer_candidates_than_count_flips_what_it_can():
    v, f = _square()
    result = flip_flat_edges(v, f, count=5)
    assert len(result.removed) == 1 and result.candidates == 1
    tv, tf = _tetrahedron()  # every dihedral is far above 10°
    result = flip_flat_edges(tv, tf, count=5)
    assert result.candidates == 0 and result.removed.shape == (0, 2)
    assert_array_equal(result.faces, tf)


def test_non_convex_quad_is_not_flipped():
    """The flip of a dart's diagonal would fold one triangle over: refused."""
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 0.2, 0.0], [0.0, 1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    assert flat_edges(v, f).shape == (0, 2)
    assert_array_equal(flip_edges(v, f)[1], f)


def test_no_flip_joins_vertices_already_joined():
    """A tetrahedron's flattened fan: the opposite corners are already an edge."""
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 3, 2]])  # edge 1-3 exists already
    pairs = interior_pairs(len(v), f)
    assert [0, 2] in np.sort(np.stack([pairs.a, pairs.b], axis=1), axis=1).tolist()
    assert [0, 2] not in flat_edges(v, f).tolist()


def test_count_zero_changes_nothing(spot_mesh):
    v, f = spot_mesh
    assert_array_equal(flip_edges(v, f, count=0)[1], f)


def test_flips_are_reproducible_and_seeded(spot_mesh):
    v, f = spot_mesh
    assert_array_equal(flip_edges(v, f, seed=7)[1], flip_edges(v, f, seed=7)[1])
    assert not np.array_equal(flip_edges(v, f, seed=7)[1], flip_edges(v, f, seed=8)[1])


def test_flips_run_through_the_registry(spot_mesh):
    v, f = spot_mesh
    assert_array_equal(
        apply_attack("flip_edges", v, f, seed=4, count=25)[1],
        flip_edges(v, f, seed=4, count=25)[1],
    )


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"count": -1}, r"flip_edges: count must be an integer >= 0, got -1"),
        ({"max_dihedral": 0.0}, r"flip_edges: max_dihedral must be a number in \(0, 180\)"),
        ({"max_dihedral": 180.0}, r"max_dihedral must be a number in \(0, 180\), got 180\.0"),
        ({"max_dihedral": -3.0}, r"max_dihedral"),
        ({"max_dihedral": float("nan")}, r"max_dihedral"),
    ],
)
def test_bad_flip_options_raise(spot_mesh, options, match):
    with pytest.raises(ValueError, match=match):
        flip_edges(*spot_mesh, **options)
    with pytest.raises(ValueError, match=match):
        flip_flat_edges(*spot_mesh, **options)


def test_flip_count_must_be_an_integer(spot_mesh):
    with pytest.raises(TypeError, match="count must be an integer"):
        flip_edges(*spot_mesh, count=1.5)


# --- retriangulate ---------------------------------------------------------------------------


@pytest.mark.parametrize("fixture", ["spot_mesh", "kitten_mesh", "plane_mesh"])
def test_retriangulate_keeps_vertices_and_topology(request, fixture):
    v, f = request.getfixturevalue(fixture)
    v2, f2 = retriangulate(v, f, seed=1)
    assert_array_equal(v2, v)
    assert f2.shape == f.shape
    assert euler_characteristic(len(v), f2) == euler_characteristic(len(v), f)
    assert edge_topology_counts(f2) == edge_topology_counts(f)
    removed = _edge_set(f) - _edge_set(f2)
    assert len(removed) == len(_edge_set(f2) - _edge_set(f)) > 0


def test_retriangulate_flips_disjoint_flat_quads(spot_mesh):
    """Each flip rewrites two faces of its own: twice as many faces change as edges."""
    v, f = spot_mesh
    f2 = retriangulate(v, f, seed=2, fraction=1.0)[1]
    removed = np.array(sorted(_edge_set(f) - _edge_set(f2)))
    changed = np.flatnonzero(np.any(np.sort(f2, axis=1) != np.sort(f, axis=1), axis=1))
    assert len(changed) == 2 * len(removed)
    assert np.all(_dihedral_degrees(v, f, removed) < QUAD_DIHEDRAL)
    assert _consistently_oriented(f2)


def test_retriangulate_fraction_scales_the_flips(spot_mesh):
    v, f = spot_mesh
    flips = {
        frac: len(_edge_set(f) - _edge_set(retriangulate(v, f, seed=3, fraction=frac)[1]))
        for frac in (0.2, 1.0)
    }
    assert flips[0.2] == pytest.approx(0.2 * flips[1.0], abs=2)


def test_retriangulate_is_seeded(spot_mesh):
    v, f = spot_mesh
    assert_array_equal(retriangulate(v, f, seed=5)[1], retriangulate(v, f, seed=5)[1])
    assert not np.array_equal(retriangulate(v, f, seed=5)[1], retriangulate(v, f, seed=6)[1])


@pytest.mark.parametrize("fraction", [0.0, 1.5, -0.1])
def test_bad_retriangulate_fraction_raises(spot_mesh, fraction):
    with pytest.raises(ValueError, match=r"retriangulate: fraction must be a number in \(0, 1\]"):
        retriangulate(*spot_mesh, fraction=fraction)
