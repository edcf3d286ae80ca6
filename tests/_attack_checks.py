"""Helpers of the attack tests: which attacks are random or keep the faces, mesh comparisons,
the geometry-image mesh of spot."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from meshwm.attacks import ATTACKS
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.clean import unique_edges
from meshwm.mesh.io import read_mesh

SPOT = Path(__file__).parent.parent / "assets" / "spot.ply"

RANDOM = [
    "similarity",
    "mirror",
    "rotation",
    "translation",
    "reorder",
    "noise",
    "crop",
    "flip_edges",
    "retriangulate",
    "split_seams",
    "gim_salt_pepper",
    "gim_noise",
    "gim_crop",
]
SEEDLESS = sorted(set(ATTACKS) - set(RANDOM))
GIM = sorted(name for name in ATTACKS if name.startswith("gim_"))
#: Attacks that keep the vertex count and the face list as they are.
SAME_FACES = [
    "similarity",
    "rotation",
    "translation",
    "scaling",
    "noise",
    "float32",
    "laplacian",
    "meshlab_laplacian",
    "taubin",
]
SAME_FACES += ["quantize", *GIM]
#: Attacks that move no vertex: the order, the format or the connectivity changes, not the shape.
NO_MOVE = ["reorder", "float32", "round_trip", "flip_edges", "retriangulate", "merge_load"]
NO_MOVE += ["weld_stl"]


def _oriented_faces(v: np.ndarray, f: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The faces as sorted rows of position ids, each rotated to start at its smallest id.

    Two meshes that are the same up to vertex order, face order and cyclic rotation of corners
    give the same array (orientation is kept: a reversed face gives another row).
    """
    ids = np.unique(positions, axis=0, return_inverse=True)[1].ravel()
    lookup = {tuple(p): i for p, i in zip(positions.tolist(), ids.tolist(), strict=True)}
    fid = np.array([lookup[tuple(p)] for p in v.tolist()])[f]
    start = np.argmin(fid, axis=1)
    fid = np.take_along_axis(fid, (start[:, None] + np.arange(3)) % 3, axis=1)
    return fid[np.lexsort(fid.T[::-1])]


def _same_mesh(v1, f1, v2, f2) -> bool:
    both = np.vstack([v1, v2])
    return np.array_equal(_oriented_faces(v1, f1, both), _oriented_faces(v2, f2, both))


def _edge_lengths(v, f) -> np.ndarray:
    return np.linalg.norm(v[f] - v[np.roll(f, -1, axis=1)], axis=-1).ravel()


def _signed_volume(v, f) -> float:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c))) / 6)


def _areas(v, f) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def _roughness(v, f) -> float:
    """Mean length of the uniform umbrella vector (mean of the neighbours minus the vertex)."""
    edges, _ = unique_edges(f)
    n = len(v)
    rows, cols = np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]
    adjacency = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return float(np.mean(np.linalg.norm(adjacency @ v / degree[:, None] - v, axis=1)))


def _mean_centroid_distance(v) -> float:
    return float(np.mean(np.linalg.norm(v - v.mean(axis=0), axis=1)))


def _square_fan():
    """A flat 3×3 grid of vertices (spacing 1, centre 4) in 8 triangles: one interior vertex."""
    i, j = np.divmod(np.arange(9), 3)
    v = np.stack([j, i, np.zeros(9)], axis=1).astype(float)
    f = []
    for r in range(2):
        for c in range(2):
            p = 3 * r + c
            f += [[p, p + 1, p + 4], [p, p + 4, p + 3]]
    return v, np.array(f)


@functools.cache
def spot_gim_mesh() -> tuple[np.ndarray, np.ndarray]:
    """A geometry-image mesh of spot as meshwm writes it (N = 64, cut seams welded), built once
    per test process (the fixtures of several modules share it; never modify it)."""
    g = mesh_to_geometry_image(*read_mesh(SPOT), size=64)
    return geometry_image_to_mesh(g.gim, g.weld)
