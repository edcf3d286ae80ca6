"""Attacks on marked meshes: what pipelines and adversaries do to a file.

Every attack is a function ``attack(vertices, faces, *, seed=0, **options) -> (vertices,
faces)``: pure, seeded, deterministic.  :data:`ATTACKS` maps names to them and
:data:`ATTACK_PARAMS` describes every option (type, default, unit, allowed range), which the
attacks check and the CLI parses; :func:`apply_attack` runs one by name.  Import them from here::

    from meshwm.attacks import ATTACKS, ATTACK_PARAMS, apply_attack

The attacks live in one module per kind (docs/attacks.md has the full table and every choice
made):

:mod:`~meshwm.attacks.transforms`
    ``similarity``, ``rotation``, ``scaling``, ``reorder``, ``noise``, ``float32``,
    ``round_trip`` (pose, element order, file formats and coordinate noise, which blind
    extraction must survive exactly or nearly), ``quantize`` and ``crop``.
:mod:`~meshwm.attacks.smoothing`
    ``laplacian``, ``meshlab_laplacian``, ``taubin``.
:mod:`~meshwm.attacks.tessellation`
    ``simplify``, ``subdivide_midpoint``, ``subdivide_loop``.
:mod:`~meshwm.attacks.connectivity`
    ``flip_edges``, ``retriangulate`` (flips of nearly flat edges; no vertex moves).
:mod:`~meshwm.attacks.seams`
    ``split_seams``, ``merge_load``, ``weld_stl`` (vertices split along seams or merged).
:mod:`~meshwm.attacks.image`
    The paper's section 5 attacks (``gim_`` prefix), on the three N×N coordinate matrices of
    the geometry image with MATLAB's kernels; the mesh must be one meshwm wrote.

The mesh attacks follow the MEPP 3D watermarking benchmark (Wang et al., "A benchmark for 3D
mesh watermarking", SMI 2010, doi:10.1109/SMI.2010.33) and use MeshLab's filters (pymeshlab)
where MeshLab has them.  Importing this package loads no mesh library: a kind's module is
imported when one of its attacks is first looked up in :data:`ATTACKS`.
"""

from __future__ import annotations

from meshwm.attacks.params import ATTACK_PARAMS, AttackParam, Mesh
from meshwm.attacks.registry import ATTACKS, apply_attack

__all__ = ["ATTACKS", "ATTACK_PARAMS", "AttackParam", "Mesh", "apply_attack"]
