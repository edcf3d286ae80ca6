"""Tests for meshwm.mesh.manifold: corner groups and face components against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from meshwm._vector import face_cross, row_norm
from meshwm.mesh.clean import _drop_bad_faces
from meshwm.mesh.edges import corner_edges_by_edge, unique_edges
from meshwm.mesh.manifold import _corner_labels, face_components, large_pieces


def _find(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _numbered_by_first(roots: list[int]) -> np.ndarray:
    """Union-find roots renumbered 0, 1, ... in order of first appearance."""
    number: dict[int, int] = {}
    return np.array([number.setdefault(r, len(number)) for r in roots], dtype=np.int64)


def _glued_pairs(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The corner-edge pairs of edges with exactly two corner-edges (as the cleaning glues)."""
    edges, inverse = unique_edges(faces)
    count = np.bincount(inverse, minlength=len(edges))
    order = corner_edges_by_edge(faces)
    along = inverse[order]
    same = (along[1:] == along[:-1]) & (count[along[:-1]] == 2)
    return order[:-1][same], order[1:][same]


def _random_faces(rng: np.random.Generator, trial: int) -> np.ndarray:
    n = int(rng.integers(3, 25))
    faces = rng.integers(0, n, (int(rng.integers(1, 50)), 3))
    if trial % 3:  # mostly proper triangles; the rest keeps repeated corners
        faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])]
        faces = faces[faces[:, 0] != faces[:, 2]]
    if trial % 4 == 0 and len(faces):  # some faces twice, turned over
        faces = np.concatenate([faces, faces[: len(faces) // 3, ::-1]])
    return faces.astype(np.int64)


@pytest.mark.parametrize("seed", range(4))
def test_corner_groups_are_the_corners_joined_where_glued_faces_share_the_vertex(seed: int):
    rng = np.random.default_rng(seed)
    tried = 0
    for trial in range(100):
        faces = _random_faces(rng, trial)
        if len(faces) == 0:
            continue
        first, second = _glued_pairs(faces)
        flat = faces.reshape(-1)
        parent = list(range(flat.size))
        for c1, c2 in zip(first.tolist(), second.tolist(), strict=True):
            ends1 = (c1, 3 * (c1 // 3) + (c1 % 3 + 1) % 3)
            ends2 = (c2, 3 * (c2 // 3) + (c2 % 3 + 1) % 3)
            for a in ends1:
                for b in ends2:
                    if flat[a] == flat[b]:
                        parent[_find(parent, a)] = _find(parent, b)
        expected = _numbered_by_first([_find(parent, i) for i in range(flat.size)])
        count, labels = _corner_labels(faces, first, second)
        assert count == expected.max() + 1
        assert_array_equal(labels, expected)
        tried += 1
    assert tried > 80


@pytest.mark.parametrize("seed", range(3))
def test_face_components_join_faces_through_shared_vertices(seed: int):
    rng = np.random.default_rng(100 + seed)
    for trial in range(120):
        faces = _random_faces(rng, trial)
        if len(faces) == 0:
            continue
        n = int(faces.max()) + 1 + trial % 3  # some vertices on no face
        parent = list(range(n))
        for a, b, c in faces.tolist():
            parent[_find(parent, a)] = _find(parent, b)
            parent[_find(parent, a)] = _find(parent, c)
        expected = _numbered_by_first([_find(parent, int(a)) for a in faces[:, 0]])
        assert_array_equal(face_components(n, faces), expected)


def test_face_components_of_polygons_and_of_no_faces():
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [3, 8, 9, 4]])
    assert face_components(10, quads).tolist() == [0, 0, 0]
    assert face_components(10, quads[:2]).tolist() == [0, 1]
    assert face_components(3, np.zeros((0, 3), dtype=np.int64)).tolist() == []


def test_dropped_faces_areas_are_the_kept_faces_areas_bit_for_bit():
    rng = np.random.default_rng(7)
    v = rng.normal(size=(30, 3))
    v[5] = v[4]  # a zero-area face below
    faces = rng.integers(0, 30, (200, 3))
    faces[:5] = [[4, 5, 6], [1, 1, 2], [7, 8, 9], [9, 7, 8], [8, 7, 9]]
    kept, counts, area = _drop_bad_faces(v, faces)
    assert counts["faces_zero_area"] >= 1 and counts["faces_duplicate"] >= 2
    assert_array_equal(area, 0.5 * row_norm(face_cross(v, kept)))


def _closed_surfaces():
    """Closed, consistently oriented surfaces, and the same pinched at a vertex."""
    import igl
    import trimesh

    tet = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    box = np.asarray(trimesh.creation.box().faces, dtype=np.int64)
    sphere = np.asarray(trimesh.creation.icosphere(subdivisions=2).faces, dtype=np.int64)
    torus = np.asarray(trimesh.creation.torus(1.0, 0.3, 24, 12).faces, dtype=np.int64)
    _, f = igl.loop(np.asarray(trimesh.creation.box().vertices), box)
    out = [tet, box, sphere, torus, np.asarray(f, dtype=np.int64)]
    # Two surfaces sharing one vertex (two fans there), and a sphere pinched to itself.
    out.append(np.concatenate([tet, tet + 3]))  # vertex 3 is in both
    pinched = sphere.copy()
    pinched[pinched == sphere.max()] = 0  # two far vertices made one
    out.append(pinched)
    return out


def test_one_fan_each_is_what_the_corner_groups_say_where_it_answers():
    from meshwm.mesh.manifold import _one_fan_each

    answered = 0
    for faces in _closed_surfaces():
        n = int(faces.max()) + 1
        first, second = _glued_pairs(faces)
        groups, _ = _corner_labels(faces, first, second)
        quick = _one_fan_each(faces, first, second, n)
        assert quick == (groups == n)  # closed and oriented: it always answers
        answered += quick
        # Turned over in part, or opened: it declines, whatever the components say.
        flipped = faces.copy()
        flipped[0] = flipped[0, ::-1]
        assert not _one_fan_each(flipped, *_glued_pairs(flipped), n)
        opened = faces[1:]
        assert not _one_fan_each(opened, *_glued_pairs(opened), n)
    assert answered == 5  # the five unpinched surfaces
    rng = np.random.default_rng(3)
    for trial in range(300):  # random soups: never a wrong yes
        faces = _random_faces(rng, trial)
        if len(faces) == 0:
            continue
        n = int(faces.max()) + 1
        first, second = _glued_pairs(faces)
        if _one_fan_each(faces, first, second, n):
            assert _corner_labels(faces, first, second)[0] == n


@pytest.mark.parametrize("seed", range(3))
def test_large_pieces_are_the_same_pieces_in_any_vertex_and_face_order(seed: int):
    rng = np.random.default_rng(40 + seed)
    # Three strips of 9, 14 and 5 vertices (fans over a path), one isolated vertex.
    v, f = [], []
    for size in (9, 14, 5):
        start = len(v)
        v += rng.normal(size=(size, 3)).tolist()
        f += [[start, start + i, start + i + 1] for i in range(1, size - 1)]
    v.append([9.0, 9.0, 9.0])
    v, f = np.array(v), np.array(f, dtype=np.int64)
    pieces = large_pieces(v, f, least=6)
    assert [len(p.vertices) for p in pieces] == [14, 9]  # the largest first; 5 is too few
    for p in pieces:  # each piece's own faces, over its own vertices
        assert p.faces.min() == 0 and p.faces.max() == len(p.vertices) - 1
        assert np.array_equal(p.vertices, v[p.used])
    for _ in range(10):
        order = rng.permutation(len(v))
        moved = large_pieces(v[order], np.argsort(order)[f][rng.permutation(len(f))], least=6)
        assert len(moved) == len(pieces)
        for (_, pv, pf), (_, mv, mf) in zip(pieces, moved, strict=True):
            # The same vertices and the same triangles (as position triples), in any order.
            assert sorted(map(tuple, pv)) == sorted(map(tuple, mv))
            assert sorted(map(sorted, pv[pf].tolist())) == sorted(map(sorted, mv[mf].tolist()))
    assert large_pieces(v, np.zeros((0, 3), dtype=np.int64), least=1) == []
