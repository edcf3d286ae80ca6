"""Attacks that change the connectivity: simplification, subdivision, remeshing (MeshLab).

MEPP simplification (Wang et al., "A benchmark for 3D mesh watermarking", SMI 2010,
doi:10.1109/SMI.2010.33) and midpoint and Loop subdivision, as MeshLab's filters (pymeshlab).
"""

from __future__ import annotations

import numpy as np
import pymeshlab
from numpy.typing import NDArray

from meshwm._validate import check_mesh
from meshwm.attacks._meshlab import run_meshlab
from meshwm.attacks.params import Mesh, check_options

__all__ = ["poisson", "remesh_isotropic", "simplify", "subdivide_loop", "subdivide_midpoint"]


def simplify(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, keep_fraction: float = 0.5
) -> Mesh:
    """Quadric edge-collapse simplification to ``keep_fraction`` of the faces (MEPP: 70/50/10 %).

    MeshLab ``meshing_decimation_quadric_edge_collapse`` with ``targetfacenum =
    round(keep_fraction · faces)`` (``keep_fraction`` in (0, 1)) and these options:
    ``preserveboundary=True`` (``boundaryweight=1``), ``preservenormal=True`` (no face flips),
    ``preservetopology=True`` (no genus change), ``optimalplacement=True``,
    ``planarquadric=True`` (better on flat regions), ``qualitythr=0.3`` and
    ``autoclean=True``, i.e. MeshLab's defaults plus the three ``preserve*`` options.  The
    result has the target face count up to a face or two.  ``seed`` is ignored.

    The mesh is decimated in a frame of unit bounding-box diagonal centred on its box, then
    put back: MeshLab's quadric decimation is not scale-invariant (at a diagonal of 0.01 its
    output's area was 1.48× bunny's and 1.62× igea's; at 1 to 100, within 0.1 % of the
    input's), and a random similarity before it must not turn a decimation into a wreck.
    """
    keep = check_options("simplify", keep_fraction=keep_fraction)["keep_fraction"]
    v, f = check_mesh(vertices, faces)
    target = max(1, round(keep * len(f)))
    low, high = v.min(axis=0), v.max(axis=0)
    centre = 0.5 * (low + high)
    size = float(np.linalg.norm(high - low)) or 1.0
    unit, out_faces = run_meshlab(
        (v - centre) / size,
        f,
        lambda ms: ms.meshing_decimation_quadric_edge_collapse(
            targetfacenum=target,
            qualitythr=0.3,
            preserveboundary=True,
            boundaryweight=1.0,
            preservenormal=True,
            preservetopology=True,
            optimalplacement=True,
            planarquadric=True,
            autoclean=True,
        ),
    )
    return unit * size + centre, out_faces


def subdivide_midpoint(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 1
) -> Mesh:
    """Midpoint subdivision (MeshLab ``meshing_surface_subdivision_midpoint``).

    Every edge is split at its midpoint (edge-length threshold 0, absolute), so each
    iteration (``iterations`` 1..3) multiplies the face count by 4; no vertex moves.
    ``seed`` is ignored.
    """
    n = check_options("subdivide_midpoint", iterations=iterations)["iterations"]
    return run_meshlab(
        vertices,
        faces,
        lambda ms: ms.meshing_surface_subdivision_midpoint(
            iterations=n, threshold=pymeshlab.PureValue(0.0)
        ),
    )


def subdivide_loop(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 1
) -> Mesh:
    """Loop subdivision (MeshLab ``meshing_surface_subdivision_loop``, Loop's weights).

    Every edge is split (threshold 0, absolute) and all vertices move by Loop's rules, so
    each iteration (``iterations`` 1..3) multiplies the face count by 4.  ``seed`` is ignored.
    """
    n = check_options("subdivide_loop", iterations=iterations)["iterations"]
    return run_meshlab(
        vertices,
        faces,
        lambda ms: ms.meshing_surface_subdivision_loop(
            loopweight="Loop", iterations=n, threshold=pymeshlab.PureValue(0.0)
        ),
    )


def remesh_isotropic(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 3
) -> Mesh:
    """Isotropic remeshing (MeshLab ``meshing_isotropic_explicit_remeshing``), ``iterations``
    rounds at MeshLab's default target edge length (1 % of the diagonal): every vertex is new.
    ``seed`` is ignored.
    """
    n = check_options("remesh_isotropic", iterations=iterations)["iterations"]
    return run_meshlab(
        vertices, faces, lambda ms: ms.meshing_isotropic_explicit_remeshing(iterations=n)
    )


def poisson(vertices: NDArray, faces: NDArray, *, seed: int = 0, depth: int = 8) -> Mesh:
    """Re-extraction through an implicit surface: screened Poisson reconstruction (MeshLab
    ``generate_surface_reconstruction_screened_poisson``, octree ``depth``) from the vertices
    and their area-weighted normals.  ``seed`` is ignored.
    """
    d = check_options("poisson", depth=depth)["depth"]

    def apply(ms: pymeshlab.MeshSet) -> None:
        ms.compute_normal_per_vertex(weightmode="By Area")
        # One thread: MeshLab's parallel octree build orders the output differently each run.
        ms.generate_surface_reconstruction_screened_poisson(depth=d, preclean=True, threads=1)

    return run_meshlab(vertices, faces, apply)
