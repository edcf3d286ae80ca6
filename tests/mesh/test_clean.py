"""Tests for :mod:`meshwm.mesh.clean`: merging, dropping, unpinching, orienting, splitting meshes.

Real meshes come from ``assets/*.ply`` (and ``../shared/meshes/cow.ply`` when it is there); the
small ones (tetrahedra, boxes, fans, strips) are built here from exactly representable
coordinates, so every expected result is exact.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from _dev_meshes import DEV
from _fins import with_fins
from numpy.testing import assert_array_equal

from meshwm.errors import MeshError
from meshwm.mesh.clean import (
    CleanMesh,
    clean_mesh,
    edge_topology_counts,
    euler_characteristic,
    unique_edges,
)
from meshwm.mesh.io import read_mesh
from meshwm.mesh.manifold import structure

ASSETS = Path(__file__).parent.parent.parent / "assets"
COW = DEV / "cow.ply"
ASSET_NAMES = ("spot", "kitten", "plane_holes")
#: (unique edges, boundary edges, non-manifold edges) and Euler characteristic of each asset.
ASSET_EDGES = {"spot": (8784, 0, 0), "kitten": (28341, 0, 0), "plane_holes": (25291, 341, 0)}
ASSET_EULER = {"spot": 2, "kitten": 0, "plane_holes": -25}
#: Report keys that count a change; all are zero for a mesh that needs no cleaning.
CHANGE_KEYS = (
    "vertices_merged",
    "faces_repeated_vertex",
    "faces_zero_area",
    "faces_duplicate",
    "vertices_unreferenced",
    "vertices_split_nonmanifold",
    "edges_unpinched",
    "faces_detached",
    "faces_reoriented",
    "components_passed_through",
)

# Tetrahedron with outward normals (signed volume +1/6), vertex 0 at the origin.
TETRA_V = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0]], dtype=np.float64)
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
# Unit cube with outward normals; vertex i sits at (i & 1, i >> 1 & 1, i >> 2 & 1).
CUBE_V = np.array([[i & 1, i >> 1 & 1, i >> 2 & 1] for i in range(8)], dtype=np.float64)
CUBE_F = np.array(
    [
        [0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6],  # z = 0, z = 1
        [0, 1, 4], [1, 5, 4], [2, 6, 3], [3, 6, 7],  # y = 0, y = 1
        [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5],  # x = 0, x = 1
    ],
    dtype=np.int64,
)  # fmt: skip


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


@cache
def load_asset(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of ``assets/<name>.ply``, read once and made read-only."""
    vertices, faces = read_mesh(ASSETS / f"{name}.ply")
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


def triangle_rows(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Triangles as sorted ``(m, 9)`` corner coordinates, each rotated to start at its smallest
    corner (lexicographic), so two face lists compare equal iff they hold the same oriented
    triangles, whatever the vertex numbering, face order or starting corner."""
    m = len(faces)
    corners = vertices[faces].reshape(-1, 3)
    rank = np.empty(3 * m, dtype=np.int64)
    rank[np.lexsort(corners.T[::-1])] = np.arange(3 * m)
    start = np.argmin(rank.reshape(m, 3), axis=1)
    rotated = faces[np.arange(m)[:, None], (start[:, None] + np.arange(3)) % 3]
    rows = vertices[rotated].reshape(m, 9)
    return rows[np.lexsort(rows.T[::-1])]


def edge_face_counts(faces: np.ndarray) -> np.ndarray:
    """Number of faces on each unique undirected edge."""
    edges, inverse = unique_edges(faces)
    return np.bincount(inverse, minlength=len(edges))


def is_consistently_oriented(faces: np.ndarray) -> bool:
    """True when no directed edge occurs twice: on a manifold mesh, every interior edge is then
    traversed in opposite directions by its two faces."""
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    return len(np.unique(directed, axis=0)) == len(directed)


def assert_closed_manifold(vertices: np.ndarray, faces: np.ndarray, euler: int) -> None:
    """Every edge in exactly two faces, consistently oriented, all vertices used."""
    assert_array_equal(edge_face_counts(faces), 2)
    assert is_consistently_oriented(faces)
    assert_array_equal(np.unique(faces), np.arange(len(vertices)))
    assert euler_characteristic(len(vertices), faces) == euler


def assert_no_changes(report: dict) -> None:
    assert {key: report[key] for key in CHANGE_KEYS} == dict.fromkeys(CHANGE_KEYS, 0)
    assert report["components"] == 1


def soup(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """STL-like copy: every face has its own three vertices."""
    return vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3)


def permute(
    vertices: np.ndarray, faces: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Same mesh with vertices and faces renumbered at random."""
    perm = rng.permutation(len(vertices))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(perm))
    return vertices[perm], inverse[faces][rng.permutation(len(faces))]


def join(*meshes: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate meshes (no vertex shared by index)."""
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
    vertices = np.concatenate([v for v, _ in meshes])
    faces = np.concatenate([f + o for (_, f), o in zip(meshes, offsets, strict=False)])
    return vertices, faces


def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> tuple:
    """Axis-aligned box with outward normals (exact corners)."""
    lo_a, hi_a = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return np.where(CUBE_V == 0, lo_a, hi_a), CUBE_F.copy()


def strip(n: int, *, twist: bool) -> tuple[np.ndarray, np.ndarray]:
    """A closed band of ``2 n`` triangles around the z axis: a Möbius strip if ``twist``."""
    t = np.arange(n) / n * 2 * np.pi
    centre = np.stack([np.cos(t), np.sin(t), np.zeros(n)], axis=1)
    if twist:  # the cross-section turns by half a turn over the loop
        across = np.stack([np.cos(t / 2) * np.cos(t), np.cos(t / 2) * np.sin(t), np.sin(t / 2)], 1)
    else:
        across = np.tile([0.0, 0.0, 1.0], (n, 1))
    vertices = np.concatenate([centre - 0.3 * across, centre + 0.3 * across])
    i = np.arange(n)
    lower, upper = (i + 1) % n, (i + 1) % n + n
    if twist:  # the last quad closes onto the first cross-section upside down
        lower[-1], upper[-1] = n, 0
    faces = np.concatenate(
        [np.stack([i, lower, i + n], axis=1), np.stack([i + n, lower, upper], axis=1)]
    )
    return vertices, faces


# --------------------------------------------------------------------------------------------
# helpers of the module
# --------------------------------------------------------------------------------------------


def test_unique_edges_maps_each_corner_edge_to_its_edge() -> None:
    _, faces = load_asset("spot")
    edges, inverse = unique_edges(faces)
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    assert_array_equal(edges[inverse], np.sort(directed, axis=1))
    assert len(np.unique(edges, axis=0)) == len(edges)


@pytest.mark.parametrize(
    ("faces", "counts", "euler"),
    [
        (TETRA_F, (6, 0, 0), 2),
        (TETRA_F[:1], (3, 3, 0), 1),
        (np.array([[0, 1, 2], [0, 1, 3], [1, 0, 4]]), (7, 6, 1), 1),
    ],
    ids=["tetra", "triangle", "fan"],
)
def test_edge_topology_counts_and_euler(faces: np.ndarray, counts: tuple, euler: int) -> None:
    n_vertices = int(faces.max()) + 1
    assert edge_topology_counts(faces) == counts
    assert euler_characteristic(n_vertices, faces) == euler


# --------------------------------------------------------------------------------------------
# real meshes
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ASSET_NAMES)
def test_clean_asset_is_unchanged(name: str) -> None:
    vertices, faces = load_asset(name)
    result = clean_mesh(vertices, faces)
    assert isinstance(result, CleanMesh)
    assert result.vertices.dtype == np.float64 and result.faces.dtype == np.int64
    assert_array_equal(result.vertices, vertices, strict=True)
    assert_array_equal(result.faces, faces, strict=True)
    assert result.other_vertices.shape == (0, 3) and result.other_faces.shape == (0, 3)
    assert_no_changes(result.report)
    assert result.report["vertices_in"] == len(vertices)
    assert result.report["faces_in"] == len(faces)


@pytest.mark.parametrize("layout", ["soup", "permuted", "permuted_soup"])
@pytest.mark.parametrize("name", ASSET_NAMES)
def test_reindexed_asset_cleans_to_the_same_mesh(name: str, layout: str) -> None:
    vertices, faces = load_asset(name)
    v, f = vertices, faces
    if layout.startswith("permuted"):
        v, f = permute(v, f, np.random.default_rng(0))
    if layout.endswith("soup"):
        v, f = soup(v, f)
    result = clean_mesh(v, f)
    assert result.vertices.shape == vertices.shape
    assert result.faces.shape == faces.shape
    assert_array_equal(triangle_rows(result.vertices, result.faces), triangle_rows(vertices, faces))
    assert edge_topology_counts(result.faces) == ASSET_EDGES[name]
    assert euler_characteristic(len(result.vertices), result.faces) == ASSET_EULER[name]
    assert is_consistently_oriented(result.faces)
    assert result.report["vertices_merged"] == len(v) - len(vertices)
    assert result.report["faces_reoriented"] == 0
    assert result.report["components"] == 1


@pytest.mark.parametrize("name", ["spot", "kitten"])
def test_soup_of_closed_asset_is_watertight(name: str) -> None:
    vertices, faces = load_asset(name)
    result = clean_mesh(*soup(vertices, faces))
    assert_closed_manifold(result.vertices, result.faces, ASSET_EULER[name])


@pytest.mark.parametrize("winding", [1, -1], ids=["as_read", "inverted"])
@pytest.mark.parametrize("name", ASSET_NAMES)
def test_flipped_minority_is_reoriented_to_the_majority(name: str, winding: int) -> None:
    vertices, faces = load_asset(name)
    expected = faces[:, ::winding]
    flipped = expected.copy()
    flipped[::7] = flipped[::7, ::-1]
    result = clean_mesh(vertices, flipped)
    assert is_consistently_oriented(result.faces)
    assert_array_equal(result.vertices, vertices)
    assert_array_equal(result.faces, expected)
    assert result.report["faces_reoriented"] == len(faces[::7])


@pytest.mark.parametrize("name", ASSET_NAMES)
def test_inverted_asset_keeps_its_winding(name: str) -> None:
    vertices, faces = load_asset(name)
    result = clean_mesh(vertices, faces[:, ::-1])
    assert_array_equal(result.faces, faces[:, ::-1])
    assert_no_changes(result.report)


@pytest.mark.skipif(not COW.exists(), reason=f"{COW} not available")
@pytest.mark.parametrize("winding", [1, -1], ids=["as_read", "inverted"])
def test_cow_sheets_touching_along_an_edge_are_separated(winding: int) -> None:
    """``cow.ply``: 2762 vertices, two of them at the same position (README of shared/meshes)."""
    import trimesh

    mesh = trimesh.load(COW, process=False)
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)[:, ::winding]
    assert len(np.unique(vertices, axis=0)) == len(vertices) - 1
    result = clean_mesh(vertices, faces)
    assert result.vertices.shape == (2762, 3) and result.faces.shape == (5520, 3)
    assert_closed_manifold(result.vertices, result.faces, 2)
    # No vertex moved, no face changed: the same oriented triangles come out.
    assert_array_equal(triangle_rows(result.vertices, result.faces), triangle_rows(vertices, faces))
    report = result.report
    assert (report["vertices_merged"], report["edges_unpinched"]) == (1, 1)
    assert (report["vertices_split_nonmanifold"], report["components"]) == (1, 1)
    assert report["faces_reoriented"] == 0


# --------------------------------------------------------------------------------------------
# pinches: two closed sheets touching in a vertex or along an edge
# --------------------------------------------------------------------------------------------

# A bigger tetrahedron sharing only vertex 0 (the origin) with TETRA, on the other side.
BIG_TETRA_AT_VERTEX = (-2.0 * TETRA_V, TETRA_F[:, ::-1].copy())
# A bigger tetrahedron sharing only the edge (0,0,0)-(0,0,1) with TETRA, on the other side.
BIG_TETRA_AT_EDGE = (TETRA_V * [-2.0, -2.0, 1.0], TETRA_F.copy())


@pytest.mark.parametrize("small_first", [True, False], ids=["small_first", "big_first"])
def test_pinched_vertex_is_split_into_two_components(small_first: bool) -> None:
    small, big = (TETRA_V, TETRA_F), BIG_TETRA_AT_VERTEX
    vertices, faces = join(small, big) if small_first else join(big, small)
    result = clean_mesh(vertices, faces)
    report = result.report
    assert report["vertices_merged"] == 1
    assert report["vertices_split_nonmanifold"] == 1
    assert report["edges_unpinched"] == 0
    assert (report["components"], report["components_passed_through"]) == (2, 1)
    # The larger one (by area) is kept, the smaller passed through; both unchanged.
    assert_array_equal(triangle_rows(result.vertices, result.faces), triangle_rows(*big))
    assert_array_equal(
        triangle_rows(result.other_vertices, result.other_faces), triangle_rows(*small)
    )
    assert_closed_manifold(result.vertices, result.faces, 2)
    assert_closed_manifold(result.other_vertices, result.other_faces, 2)


@pytest.mark.parametrize(
    ("small", "big", "winding"),
    [
        pytest.param((TETRA_V, TETRA_F), BIG_TETRA_AT_EDGE, 1, id="tetras"),
        pytest.param(box((0, 0, 0), (1, 1, 1)), box((-2, -2, 0), (0, 0, 1)), 1, id="boxes"),
        pytest.param(
            (TETRA_V, TETRA_F),
            BIG_TETRA_AT_EDGE,
            -1,
            id="tetras_inverted",
        ),
        pytest.param(
            box((0, 0, 0), (1, 1, 1)),
            box((-2, -2, 0), (0, 0, 1)),
            -1,
            id="boxes_inverted",
        ),
    ],
)
def test_sheets_touching_along_an_edge_are_separated(
    small: tuple, big: tuple, winding: int
) -> None:
    small = (small[0], small[1][:, ::winding])
    big = (big[0], big[1][:, ::winding])
    vertices, faces = join(small, big)
    # Merged exactly, the two ends of the shared edge coincide and that edge has 4 faces.
    positions, index = np.unique(vertices, axis=0, return_inverse=True)
    assert len(vertices) - len(positions) == 2
    assert_array_equal(np.sort(edge_face_counts(index.reshape(-1)[faces]))[-2:], [2, 4])
    result = clean_mesh(vertices, faces)
    report = result.report
    assert report["edges_unpinched"] == 1
    assert report["vertices_split_nonmanifold"] == 2
    assert (report["components"], report["components_passed_through"]) == (2, 1)
    assert_closed_manifold(result.vertices, result.faces, 2)
    assert_closed_manifold(result.other_vertices, result.other_faces, 2)
    assert_array_equal(triangle_rows(result.vertices, result.faces), triangle_rows(*big))
    assert_array_equal(
        triangle_rows(result.other_vertices, result.other_faces), triangle_rows(*small)
    )


# --------------------------------------------------------------------------------------------
# refused topology
# --------------------------------------------------------------------------------------------

FAN_V = np.array(
    [[0, 0, 0], [0, 0, 1], [1, 0, 0], [-1, 1, 0], [-1, -1, 0], [1, 1, 0]], dtype=np.float64
)


@pytest.mark.parametrize(
    ("vertices", "faces", "detached", "largest"),
    [
        (FAN_V, np.array([[0, 1, 2], [0, 1, 3], [1, 0, 4]]), 1, 2),
        (FAN_V, np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4], [0, 1, 5]]), 4, 1),
        (np.vstack([TETRA_V, [[-1, -1, 0.5]]]), np.vstack([TETRA_F, [[0, 1, 4]]]), 1, 4),
    ],
    ids=["fan_of_3", "fan_of_4_same_direction", "tetra_with_fin"],
)
def test_non_manifold_edge_is_opened_for_the_faces_left_unpaired(
    vertices: np.ndarray, faces: np.ndarray, detached: int, largest: int
) -> None:
    result = clean_mesh(vertices, faces, min_faces=1)
    assert result.report["edges_unpinched"] == 1
    assert result.report["faces_detached"] == detached
    assert len(result.faces) == largest
    for f in (result.faces, result.other_faces):
        assert edge_topology_counts(f)[2] == 0  # every part edge-manifold
    # Nothing moved: each kept vertex copies an input vertex bit for bit.
    assert_array_equal(result.vertices, vertices[result.source], strict=True)


def test_tetra_with_fin_keeps_the_tetra_closed() -> None:
    vertices = np.vstack([TETRA_V, [[-1, -1, 0.5]]])
    result = clean_mesh(vertices, np.vstack([TETRA_F, [[0, 1, 4]]]), min_faces=1)
    assert edge_topology_counts(result.faces) == (6, 0, 0)
    assert len(result.other_faces) == 1 and result.report["components_passed_through"] == 1


def walled_box(cells: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Two unit cubes side by side whose shared square is kept once: a closed box of 2 x 1 x 1
    with a wall inside, standing on its sides along edges of three faces each.  Each cube face
    is a ``cells`` x ``cells`` grid of split squares (exact coordinates)."""
    t = np.linspace(0.0, 1.0, cells + 1)
    quads, corners = [], {}

    def vid(p: tuple[float, float, float]) -> int:
        return corners.setdefault(p, len(corners))

    for x0 in (0.0, 1.0):
        for axis in range(3):
            for side in (0.0, 1.0):
                if axis == 0 and x0 == 1.0 and side == 0.0:
                    continue  # the shared square, kept once (the first cube's)
                u, w = [a for a in range(3) if a != axis]
                for i in range(cells):
                    for j in range(cells):
                        quad = []
                        for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                            p = [0.0, 0.0, 0.0]
                            p[axis], p[u], p[w] = side, t[i + di], t[j + dj]
                            p[0] += x0
                            quad.append(vid((p[0], p[1], p[2])))
                        quads.append(quad[::-1] if side == 0.0 else quad)
    q = np.asarray(quads)
    faces = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return np.array(list(corners), dtype=np.float64), faces


def test_walled_box_keeps_its_outer_sheet() -> None:
    vertices, faces = walled_box(2)
    result = clean_mesh(vertices, faces, min_faces=1)
    # The box (area 10) is the largest part and closed; the wall comes off it, whole.
    assert edge_topology_counts(result.faces)[1:] == (0, 0)
    assert euler_characteristic(len(result.vertices), result.faces) == 2
    assert len(result.other_faces) == 8 and result.report["faces_detached"] == 8
    assert np.all(np.isclose(result.other_vertices[:, 0], 1.0))


def _finned_spot() -> tuple[np.ndarray, np.ndarray]:
    """spot with 12 fins: triangles standing on far-apart edges, half each way round."""
    return with_fins(*load_asset("spot"))


def _corner_groups(vertices: np.ndarray, faces: np.ndarray, vperm, fperm) -> tuple:
    """Which input corners the cleaning joins, and each input face's part, in the numbering
    of the mesh before ``vperm`` / ``fperm`` renumbered it (numbered by first appearance)."""
    source, out, labels, _ = structure(vertices, faces)
    keys = {}
    for k in range(len(faces)):
        for g in out[k]:
            keys[(int(fperm[k]), int(vperm[source[g]]))] = int(g)
    groups: dict[int, int] = {}
    corner = [groups.setdefault(keys[c], len(groups)) for c in sorted(keys)]
    parts: dict[int, int] = {}
    face_part = np.empty(len(faces), dtype=np.int64)
    face_part[fperm] = labels
    return corner, [parts.setdefault(int(x), len(parts)) for x in face_part]


@pytest.mark.parametrize("make", [lambda: walled_box(3), _finned_spot], ids=["wall", "fins"])
def test_opened_edges_are_the_same_under_random_similarities_and_renumbering(make) -> None:
    vertices, faces = make()
    n, m = len(vertices), len(faces)
    expected = _corner_groups(vertices, faces, np.arange(n), np.arange(m))
    rng = np.random.default_rng(20)
    for _ in range(20):
        rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        rotation *= np.sign(np.linalg.det(rotation))
        moved = vertices @ rotation.T * 10 ** rng.uniform(-2, 2) + rng.uniform(-100, 100, 3)
        vperm, fperm = rng.permutation(n), rng.permutation(m)  # new index -> old index
        inverse = np.empty(n, dtype=np.int64)
        inverse[vperm] = np.arange(n)
        got = _corner_groups(moved[vperm], inverse[faces[fperm]], vperm, fperm)
        assert got == expected


def test_mobius_strip_is_refused() -> None:
    vertices, faces = strip(12, twist=True)
    assert edge_topology_counts(faces) == (48, 24, 0)  # one boundary loop of 24 edges
    with pytest.raises(MeshError, match="not orientable"):
        clean_mesh(vertices, faces)


def test_untwisted_strip_is_accepted() -> None:
    """Control for the Möbius test: the same band without the twist is a clean annulus."""
    vertices, faces = strip(12, twist=False)
    result = clean_mesh(vertices, faces)
    assert_array_equal(result.faces, faces)
    assert_no_changes(result.report)
    assert edge_topology_counts(result.faces) == (48, 24, 0)


# --------------------------------------------------------------------------------------------
# degenerate faces and vertices
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra_vertices", "extra_faces", "changes"),
    [
        ([], [[0, 0, 1]], {"faces_repeated_vertex": 1}),
        ([], [[2, 3, 3], [1, 2, 1]], {"faces_repeated_vertex": 2}),
        ([[0.5, 0, 0]], [[0, 4, 2]], {"faces_zero_area": 1, "vertices_unreferenced": 1}),
        ([[2, 0, 0]], [[0, 2, 4]], {"faces_zero_area": 1, "vertices_unreferenced": 1}),
        ([], [[0, 2, 1]], {"faces_duplicate": 1}),
        ([], [[2, 1, 0]], {"faces_duplicate": 1}),
        ([], [[1, 0, 2], [3, 1, 2]], {"faces_duplicate": 2}),
        ([[0, 0, 0]], [[4, 0, 1]], {"vertices_merged": 1, "faces_repeated_vertex": 1}),
        ([[5, 5, 5], [6, 6, 6]], [], {"vertices_unreferenced": 2}),
    ],
    ids=[
        "repeated_index",
        "two_repeated_indices",
        "collinear_midpoint",
        "collinear_outside",
        "duplicate",
        "duplicate_other_winding",
        "duplicates_rotated",
        "repeated_after_merge",
        "unreferenced",
    ],
)
def test_degenerate_faces_and_vertices_are_dropped(
    extra_vertices: list, extra_faces: list, changes: dict
) -> None:
    vertices = np.vstack([TETRA_V, np.reshape(extra_vertices, (-1, 3))])
    faces = np.vstack([TETRA_F, np.reshape(extra_faces, (-1, 3))]).astype(np.int64)
    result = clean_mesh(vertices, faces)
    assert_array_equal(result.vertices, TETRA_V, strict=True)
    assert_array_equal(result.faces, TETRA_F, strict=True)
    assert {k: result.report[k] for k in CHANGE_KEYS} == dict.fromkeys(CHANGE_KEYS, 0) | changes


def test_unreferenced_vertices_before_the_mesh_are_dropped_and_faces_renumbered() -> None:
    vertices = np.vstack([[[9.0, 9.0, 9.0]], TETRA_V[:2], [[7.0, 7.0, 7.0]], TETRA_V[2:]])
    faces = np.array([1, 2, 4, 5])[TETRA_F]
    result = clean_mesh(vertices, faces)
    assert_array_equal(result.vertices, TETRA_V, strict=True)
    assert_array_equal(result.faces, TETRA_F, strict=True)
    assert result.report["vertices_unreferenced"] == 2


def test_negative_zero_merges_with_zero() -> None:
    vertices, faces = soup(TETRA_V, TETRA_F)
    vertices = vertices.copy()
    vertices[1::2] = np.where(vertices[1::2] == 0, -0.0, vertices[1::2])
    assert np.signbit(vertices).any() and not np.signbit(vertices).all()
    result = clean_mesh(vertices, faces)
    assert result.vertices.shape == (4, 3) and result.faces.shape == (4, 3)
    assert result.report["vertices_merged"] == 12 - 4
    assert_closed_manifold(result.vertices, result.faces, 2)
    assert_array_equal(
        triangle_rows(result.vertices + 0.0, result.faces), triangle_rows(TETRA_V, TETRA_F)
    )


# --------------------------------------------------------------------------------------------
# components
# --------------------------------------------------------------------------------------------

SMALL_TETRA = (TETRA_V * 0.125 + [4.0, 0.0, 0.0], TETRA_F.copy())


@pytest.mark.parametrize("spot_first", [True, False], ids=["spot_first", "tetra_first"])
def test_largest_component_is_kept_and_others_passed_through(spot_first: bool) -> None:
    spot = load_asset("spot")
    vertices, faces = join(spot, SMALL_TETRA) if spot_first else join(SMALL_TETRA, spot)
    result = clean_mesh(vertices, faces)
    assert_array_equal(result.vertices, spot[0], strict=True)
    assert_array_equal(result.faces, spot[1], strict=True)
    assert_array_equal(result.other_vertices, SMALL_TETRA[0], strict=True)
    assert_array_equal(result.other_faces, SMALL_TETRA[1], strict=True)
    assert (result.report["components"], result.report["components_passed_through"]) == (2, 1)


def test_component_is_chosen_by_area_not_face_count() -> None:
    """A big box of 12 faces beats a small annulus of 24 faces."""
    small = strip(12, twist=False)  # 24 faces, area about 2 * pi * 1 * 0.6
    small = (small[0] * 0.25, small[1])
    big = box((10, 10, 10), (13, 13, 13))  # 12 faces, area 54
    result = clean_mesh(*join(small, big))
    assert_array_equal(result.vertices, big[0], strict=True)
    assert_array_equal(result.faces, big[1], strict=True)
    assert_array_equal(result.other_faces, small[1], strict=True)


def test_equal_area_tie_does_not_depend_on_face_order() -> None:
    low, high = (TETRA_V, TETRA_F), (TETRA_V + 8.0, TETRA_F)
    kept_low_first = clean_mesh(*join(low, high)).vertices
    kept_high_first = clean_mesh(*join(high, low)).vertices
    assert_array_equal(kept_low_first, kept_high_first)


# --------------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------------


def _with(index: tuple, value: float) -> np.ndarray:
    vertices = TETRA_V.copy()
    vertices[index] = value
    return vertices


def _faces_with(index: tuple, value: int) -> np.ndarray:
    faces = TETRA_F.copy()
    faces[index] = value
    return faces


@pytest.mark.parametrize(
    ("vertices", "faces", "kwargs", "match"),
    [
        (_with((2, 1), np.nan), TETRA_F, {}, r"^1 vertices have NaN or infinite .*first: 2\)$"),
        (_with((3, 0), np.inf), TETRA_F, {}, r"^1 vertices have NaN or infinite .*first: 3\)$"),
        (_with((1, 2), -np.inf), TETRA_F, {}, r"NaN or infinite"),
        (TETRA_V, _faces_with((3, 2), 4), {}, r"^face indices must lie in \[0, 3\], found 0\.\.4$"),
        (TETRA_V, _faces_with((0, 0), -1), {}, r"face indices must lie in \[0, 3\], found -1\.\.3"),
        (TETRA_V[:, :2], TETRA_F, {}, r"^vertices must have shape \(n, 3\), got \(4, 2\)$"),
        (TETRA_V, np.hstack([TETRA_F, TETRA_F[:, :1]]), {}, r"shape \(m, 3\), got \(4, 4\)$"),
        (TETRA_V, np.zeros((0, 3), dtype=np.int64), {}, r"^mesh has no faces$"),
        (TETRA_V, TETRA_F, {"max_faces": 3}, r"^mesh has 4 faces, more than the limit of 3$"),
        (
            np.vstack([TETRA_V, [[2, 0, 0], [0, 0, 0]]]),
            np.array([[0, 0, 1], [0, 2, 4], [5, 0, 3], [1, 1, 1]]),
            {},
            r"^mesh has no faces of non-zero area$",
        ),
        (TETRA_V, TETRA_F[:1], {}, r"^largest connected component has only 1 faces; .* 4$"),
        (TETRA_V, TETRA_F, {"min_faces": 5}, r"only 4 faces; need at least 5$"),
        (
            *join((TETRA_V, TETRA_F[:2]), (TETRA_V + 5.0, TETRA_F[:3])),
            {},
            r"only 3 faces; need at least 4$",
        ),
    ],
    ids=[
        "nan",
        "inf",
        "minus_inf",
        "index_too_large",
        "index_negative",
        "vertices_n_by_2",
        "faces_m_by_4",
        "no_faces",
        "more_than_max_faces",
        "all_degenerate",
        "one_triangle",
        "below_min_faces",
        "largest_of_two_below_min_faces",
    ],
)
def test_bad_input_is_refused_with_one_line_message(
    vertices: np.ndarray, faces: np.ndarray, kwargs: dict, match: str
) -> None:
    with pytest.raises(MeshError, match=match) as error:
        clean_mesh(vertices, faces, **kwargs)
    assert isinstance(error.value, ValueError)
    assert "\n" not in str(error.value)


def test_huge_float_index_is_refused_without_warning() -> None:
    faces = TETRA_F.astype(np.float64)
    faces[0, 0] = 1e20
    with pytest.raises(MeshError, match=r"^face indices ") as error:
        clean_mesh(TETRA_V, faces)
    assert "-9223372036854775808" not in str(error.value)


# --------------------------------------------------------------------------------------------
# inputs
# --------------------------------------------------------------------------------------------


def _spot_soup_flipped() -> tuple[np.ndarray, np.ndarray]:
    vertices, faces = load_asset("spot")
    faces = faces.copy()
    faces[::7] = faces[::7, ::-1]
    return soup(vertices, faces)


def _tetra_with_defects() -> tuple[np.ndarray, np.ndarray]:
    vertices = np.vstack([[[9.0, 9.0, 9.0]], TETRA_V, [[-0.0, 0.0, 1.0]], [[2.0, 0.0, 0.0]]])
    faces = np.vstack([TETRA_F + 1, [[1, 1, 2], [5, 1, 3], [1, 3, 6], [4, 2, 3]]])
    return vertices, faces


def _pinched_boxes() -> tuple[np.ndarray, np.ndarray]:
    return join(box((0, 0, 0), (1, 1, 1)), box((-2, -2, 0), (0, 0, 1)), SMALL_TETRA)


@pytest.mark.parametrize(
    "make", [_spot_soup_flipped, _tetra_with_defects, _pinched_boxes], ids=lambda f: f.__name__
)
def test_inputs_are_not_modified(make: Callable[[], tuple[np.ndarray, np.ndarray]]) -> None:
    vertices, faces = make()
    vertices_before, faces_before = vertices.copy(), faces.copy()
    result = clean_mesh(vertices, faces)
    assert_array_equal(vertices, vertices_before, strict=True)
    assert_array_equal(faces, faces_before, strict=True)
    assert np.signbit(vertices).sum() == np.signbit(vertices_before).sum()
    assert not np.shares_memory(result.vertices, vertices)
    assert not np.shares_memory(result.faces, faces)
    # Writing to the result must not reach the input either.
    result.vertices[...] = 1.0
    result.faces[...] = 0
    assert_array_equal(vertices, vertices_before, strict=True)
    assert_array_equal(faces, faces_before, strict=True)


@pytest.mark.parametrize(
    "make", [_spot_soup_flipped, _tetra_with_defects, _pinched_boxes], ids=lambda f: f.__name__
)
def test_read_only_inputs_are_accepted(make: Callable[[], tuple[np.ndarray, np.ndarray]]) -> None:
    vertices, faces = make()
    expected = clean_mesh(vertices.copy(), faces.copy())
    vertices.setflags(write=False)
    faces.setflags(write=False)
    result = clean_mesh(vertices, faces)
    assert_array_equal(result.vertices, expected.vertices, strict=True)
    assert_array_equal(result.faces, expected.faces, strict=True)
    assert result.report == expected.report


@pytest.mark.parametrize("as_list", [False, True], ids=["arrays", "lists"])
@pytest.mark.parametrize(
    ("vertex_dtype", "face_dtype"),
    [(np.float32, np.int32), (np.int64, np.uint16), (np.float64, np.float64)],
)
def test_other_dtypes_and_lists_give_the_same_result(
    vertex_dtype: type, face_dtype: type, as_list: bool
) -> None:
    vertices, faces = TETRA_V.astype(vertex_dtype), TETRA_F.astype(face_dtype)
    if as_list:
        vertices, faces = vertices.tolist(), faces.tolist()
    result = clean_mesh(vertices, faces)
    assert_array_equal(result.vertices, TETRA_V, strict=True)
    assert_array_equal(result.faces, TETRA_F, strict=True)


def test_shared_cleaning_cleans_the_same_arrays_once(spot_mesh):
    from meshwm.mesh import clean as clean_module

    v, f = spot_mesh
    plain = clean_module.clean_mesh(v, f)
    with clean_module.shared_cleaning():
        a = clean_module.clean_mesh(v, f)
        b = clean_module.clean_mesh(v.copy(), f.copy())  # same content, other arrays
        c = clean_module.clean_mesh(v + 1.0, f)
    assert a.vertices is b.vertices and c.vertices is not a.vertices
    assert not a.vertices.flags.writeable and a.report is not b.report
    np.testing.assert_array_equal(a.vertices, plain.vertices)
    np.testing.assert_array_equal(a.faces, plain.faces)
    assert a.report == plain.report
    assert clean_module.clean_mesh(v, f).vertices.flags.writeable  # outside: no sharing


@pytest.mark.parametrize("width", [2, 3, 4])
def test_unique_edges_any_polygon_width(width: int) -> None:
    rng = np.random.default_rng(width)
    faces = rng.integers(0, 30, size=(200, width))
    edges, inverse = unique_edges(faces)
    directed = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    expected = np.unique(np.sort(directed, axis=1), axis=0)
    np.testing.assert_array_equal(edges, expected)
    np.testing.assert_array_equal(edges[inverse], np.sort(directed, axis=1))


def _source_cases() -> list[tuple[np.ndarray, np.ndarray]]:
    spot = load_asset("spot")
    rng = np.random.default_rng(3)
    zeros_v, zeros_f = soup(TETRA_V, TETRA_F)
    zeros_v = zeros_v.copy()
    zeros_v[1::2] = np.where(zeros_v[1::2] == 0, -0.0, zeros_v[1::2])
    stray = np.concatenate([rng.normal(size=(5, 3)), spot[0]])  # unreferenced vertices first
    return [
        spot,
        permute(*soup(*spot), rng),  # merged
        join(BIG_TETRA_AT_VERTEX, (TETRA_V, TETRA_F)),  # merged, then a fan split
        join((TETRA_V, TETRA_F), BIG_TETRA_AT_EDGE),  # a pinched edge
        join(SMALL_TETRA, spot),  # the second component kept
        (stray, spot[1] + 5),
        (zeros_v, zeros_f),  # -0.0 and 0.0 merged: the first occurrence's bits
    ]


@pytest.mark.parametrize("case", range(7))
def test_each_kept_vertex_names_an_input_vertex_it_copies_bit_for_bit(case: int) -> None:
    vertices, faces = _source_cases()[case]
    result = clean_mesh(vertices, faces)
    assert result.source.dtype == np.int64 and len(result.source) == len(result.vertices)
    assert_array_equal(
        result.vertices.view(np.uint64),
        np.asarray(vertices, np.float64)[result.source].view(np.uint64),
    )


def test_read_only_input_comes_out_as_the_same_arrays_when_nothing_changes() -> None:
    # A pipeline's frozen arrays are handed on (their digests kept); writable ones are copied,
    # and a mesh that needs cleaning gets new arrays either way.
    from meshwm._digest import freeze

    vertices, faces = load_asset("spot")
    v, f = np.array(vertices, dtype=np.float64), np.array(faces, dtype=np.int64)
    freeze(v, f)
    clean = clean_mesh(v, f)
    assert clean.vertices is v and clean.faces is f
    assert_array_equal(clean.source, np.arange(len(v)))
    writable = clean_mesh(v.copy(), f.copy())
    assert writable.vertices.flags.writeable and writable.faces.flags.writeable
    assert_array_equal(writable.vertices, v)
    assert_array_equal(writable.faces, f)
    doubled = np.concatenate([f, f[:5]])  # five duplicate faces: dropped, new arrays
    freeze(doubled)
    out = clean_mesh(v, doubled)
    assert out.faces is not doubled and out.report["faces_duplicate"] == 5
    assert_array_equal(out.faces, f)
