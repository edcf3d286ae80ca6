"""A mesh with fins: triangles standing on far-apart edges (edges of three faces)."""

from __future__ import annotations

import numpy as np

from meshwm.mesh.edges import unique_edges


def with_fins(vertices, faces, count=12):
    """``(vertices, faces)`` with ``count`` fins: each a triangle on an edge (taken evenly
    along the sorted edges) to a new vertex above its midpoint (+0.05 in y), half of them
    running the edge each way round."""
    edges, _ = unique_edges(faces)
    pick = edges[:: len(edges) // count][:count]
    tips = vertices[pick].mean(axis=1) + np.array([0.0, 0.05, 0.0])
    fins = np.stack([pick[:, 0], pick[:, 1], len(vertices) + np.arange(count)], axis=1)
    fins[::2, :2] = fins[::2, 1::-1]
    return np.vstack([vertices, tips]), np.vstack([faces, fins])
