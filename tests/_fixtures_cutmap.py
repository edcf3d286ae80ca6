"""Small synthetic meshes for the geometric cut and map tests (fast, asymmetric)."""

from __future__ import annotations

import igl
import numpy as np
import pytest


def bumpy_sphere(levels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A closed genus-0 mesh: a subdivided octahedron on a lumpy, asymmetric sphere."""
    v = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    f = np.array(
        [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    )
    for _ in range(levels):
        v, f = igl.loop(v, f)
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    r = 1.0 + 0.3 * v[:, 0] ** 2 + 0.15 * v[:, 1] + 0.1 * np.sin(2.0 * v[:, 2] + 0.4 * v[:, 0])
    return np.asarray(v * r[:, None]), np.asarray(f, dtype=np.int64)


def torus(nu: int = 24, nv: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A closed genus-1 mesh: an asymmetric torus on an nu x nv grid, jittered."""
    u, w = np.meshgrid(np.arange(nu) * 2 * np.pi / nu, np.arange(nv) * 2 * np.pi / nv)
    u, w = u.ravel(), w.ravel()
    r = 0.35 + 0.08 * np.cos(u)
    v = np.stack([(1 + r * np.cos(w)) * np.cos(u), (1 + r * np.cos(w)) * np.sin(u), r * np.sin(w)])
    i, j = np.meshgrid(np.arange(nu), np.arange(nv))
    i, j = i.ravel(), j.ravel()
    a, b = j * nu + i, j * nu + (i + 1) % nu
    c, d = ((j + 1) % nv) * nu + (i + 1) % nu, ((j + 1) % nv) * nu + i
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    jitter = np.random.default_rng(0).normal(scale=0.01, size=(len(u), 3))  # no exact ties
    return v.T + jitter, f.astype(np.int64)


@pytest.fixture(scope="session")
def sphere_mesh() -> tuple[np.ndarray, np.ndarray]:
    return bumpy_sphere()


@pytest.fixture(scope="session")
def torus_mesh() -> tuple[np.ndarray, np.ndarray]:
    return torus()
