"""The geometry-image stage: a mesh resampled onto a regular N×N grid, and the grid read back.

A triangle mesh becomes a geometry image (Gu, Gortler and Hoppe, "Geometry images", 2002): the
paper's three N×N matrices x1, x2, x3 (S. C. Tamane, R. R. Deshmukh, "Blind 3D model
watermarking based on multi-resolution representation and fuzzy logic", section 3).
:mod:`~meshwm.gim.remesh` composes the steps of :func:`~meshwm.gim.remesh.mesh_to_geometry_image`,
in data-flow order :mod:`~meshwm.gim.cut` (cut the mesh open into a disk, and extend the cut in
later rounds), :mod:`~meshwm.gim.boundary` (the disk's boundary chains on the square's
perimeter), :mod:`~meshwm.gim.parameterize` (the harmonic map of the interior and its stretch
reweighting) and :mod:`~meshwm.gim.sample` (the map sampled on the grid, with the weld map of
its seams).  :mod:`~meshwm.gim.to_mesh` turns an image back into a mesh on the triangulation of
:mod:`~meshwm.gim.code`, whose flipped diagonals are a position code, and
:mod:`~meshwm.gim.recover` reads that grid back from a received mesh's connectivity alone.
"""
