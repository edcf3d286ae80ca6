"""Dense sampling of border edges, the brute reference for the distances along them."""

from __future__ import annotations

import igl
import numpy as np

from meshwm.mesh.edges import border_half_edges


def border_reach(vertices, faces, vertices_to, count=1001):
    """The largest distance of ``count`` points along each border edge of
    ``(vertices, faces)`` to the surface ``(vertices_to, faces)``."""
    border = border_half_edges(faces)
    t = np.linspace(0.0, 1.0, count)[:, None, None]
    points = ((1 - t) * vertices[border[:, 0]] + t * vertices[border[:, 1]]).reshape(-1, 3)
    return float(np.sqrt(igl.point_mesh_squared_distance(points, vertices_to, faces)[0].max()))
