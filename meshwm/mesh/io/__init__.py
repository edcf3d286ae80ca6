"""Read and write triangle meshes (OBJ, PLY, STL, OFF, GLB) as ``(vertices, faces)`` arrays.

Reading goes through :mod:`trimesh` with ``process=False``, so vertices are neither merged nor
reordered; cleaning is the caller's job.  Every failure, whatever trimesh or NumPy raised, comes
out as a :class:`~meshwm.errors.MeshError` whose one-line message starts with the file name.
Before trimesh sees a file, a cheap check of its header (PLY, OFF, binary STL, GLB) or of its
face lines (OBJ, ASCII STL) refuses absurd element counts, counts the file is too short to hold
and a few defects trimesh would silently accept (OBJ index 0, short faces, inconsistent PLY
list lengths).

Writing serialises to bytes (PLY, OBJ and OFF by this package, float64-exact; STL and GLB by
trimesh), then replaces the target atomically.  This package reads and writes bare triangle
meshes; :mod:`meshwm.mesh.asset` keeps everything else a file carries.

Layout: :mod:`~meshwm.mesh.io.registry` maps each suffix to its format module (``ply``,
``obj``, ``stl``, ``off``, ``glb``: pre-check and writer), :mod:`~meshwm.mesh.io.read` and
:mod:`~meshwm.mesh.io.write` are the two entry points, :mod:`~meshwm.mesh.io.load` the
trimesh loader and :mod:`~meshwm.mesh.io.common` the shared errors and limits.  A new format
is one module plus one registry entry.  Importing this package loads no mesh library: trimesh
is imported when a file is read or an STL file written.
"""

from __future__ import annotations

from meshwm.mesh.io.read import read_mesh
from meshwm.mesh.io.registry import READ_SUFFIXES, WRITE_SUFFIXES
from meshwm.mesh.io.write import check_output, check_output_suffix, write_mesh

__all__ = [
    "READ_SUFFIXES",
    "WRITE_SUFFIXES",
    "check_output",
    "check_output_suffix",
    "read_mesh",
    "write_mesh",
]
