"""Meshes in and out: the first stage of the pipeline, before any geometry image.

:mod:`meshwm.mesh.io` reads and writes triangle mesh files as ``(vertices, faces)`` arrays,
one module per format behind a registry by suffix, refusing malformed files with a one-line
:class:`~meshwm.errors.MeshError`; :mod:`meshwm.mesh.clean` then makes the mesh one connected,
edge-manifold, consistently oriented surface without moving a vertex.  Importing this package
imports neither (and no mesh library); import the module you need.
"""
