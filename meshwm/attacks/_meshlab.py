"""Run a pymeshlab filter on ``(vertices, faces)``: the one bridge to MeshLab of the attacks."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pymeshlab
from numpy.typing import NDArray

from meshwm._validate import check_mesh
from meshwm.attacks.params import Mesh

__all__ = ["run_meshlab"]


def run_meshlab(
    vertices: NDArray, faces: NDArray, apply: Callable[[pymeshlab.MeshSet], None]
) -> Mesh:
    """Load the mesh into a ``MeshSet``, call ``apply`` on it, return its current mesh."""
    v, f = check_mesh(vertices, faces)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f.astype(np.int32)))
    apply(ms)
    m = ms.current_mesh()
    return (
        np.array(m.vertex_matrix(), dtype=np.float64),
        np.array(m.face_matrix(), dtype=np.int64),
    )
