"""Read the geometry-image grid back from the connectivity of a received mesh.

Blind extraction gets a mesh and nothing else: no vertex order (files are re-indexed, an STL
round trip un-indexes and re-welds every vertex), no side file, and maybe not the whole mesh
(a crop removes part of the surface and can split the rest into pieces).  What survives is the
connectivity of what is left, and meshwm writes that connectivity itself
(:func:`meshwm.gim.code.grid_faces`): two triangles per grid cell with alternating
diagonals (a 4-8 mesh: interior samples with i + j even have 8 neighbours, the others 4),
welded along the cut seams, and a *position code*: the code cells (i and j even, off the
border) whose public bit is 1 have their diagonal flipped
(:func:`meshwm.gim.code.flipped_cells`).

:func:`recover_grid` finds which vertex is grid sample (i, j):

1. **Sizes**: N from the face count (the grid has 2 (N-1)^2 triangles, a few fewer where a
   welded cut end collapsed some), then 2N and 4N (a cropped mesh has fewer faces), up to
   2048; or the ``size`` given.  The code decides which N is right: each N has its own bits.
2. **Seeds**: in each connected component large enough to hold a few dozen code cells, the
   flipped code cells found by their valence signature (a diagonal between two valence-5
   vertices whose triangles' third corners have valence 7).  A handful are taken, spread over
   the component.
3. **Local reading**: around each seed, a walk that knows nothing of the code lays out a
   window of 11 x 11 code cells.  Vertices are classed E (valence 7 or 8) or O (4 or 5) when
   their fan is closed; the face with the directed grid edge A -> B of a cell (corners A, B,
   C, D counter-clockwise) has third vertex C if it is of A's class (diagonal A-C), D
   otherwise, and the cell's other face then gives the fourth corner.  Each cell of the
   window then reads as flipped (diagonal between its O corners) or not.
4. **Matching**: the window is looked up in the code of each candidate N, in the 4 rotations
   (faces as given) and the 4 mirror images (winding reversed), at every position: exact
   keys of 5 x 5 code cells (25 bits, a few per window) give the candidate positions, and a
   candidate is kept if at least 40 code cells that agree with the code are connected to
   the seed cell through agreeing code cells, the seed cell being a flipped code cell.  (The
   local walk can cross a welded seam and come back into the grid elsewhere; what it reads
   there is ignored rather than fatal.)  A match gives the seed's absolute position, its
   orientation, N and the winding.
5. **Propagation by oriented triangles**: when two samples p, q of a grid triangle (p, q, r)
   are known as vertices u, v, the one face of the oriented manifold mesh with the directed
   edge u -> v is that triangle, and its third vertex is sample r.  The interior goes first,
   breadth first from the seeds (a cell per step), then the border ring, most trusted
   triangles first, then back into the interior through the border where a piece of it is
   connected to the rest only that way.  Grid triangles on both sides of a welded seam are
   distinct faces with distinct directed edges, so the walk never confuses the two sides.
   On a partial grid the border is read more cautiously (see
   :func:`~meshwm.gim.recover.propagate._sound`): next to a cut end the tip of the fold is
   no vertex, and only the complete interior could tell a face of the other side of the fold
   from the missing one.
6. **Verification**, per component: no sample reached as two vertices, no interior sample
   sharing its vertex, no face explained twice, and every face between three interior
   samples explained.  A wrong match fails this.  On a complete grid this is the old test:
   every face is exactly one grid triangle and every vertex a sample.
7. **Pieces**: the walk cannot cross a welded seam (it does not know which border samples
   are welded), and a crop can leave parts of the grid connected only across one.  The seed
   cells not read yet are seeded again with N and winding known (a wider window, a key of
   the 16 read code cells nearest the seed compared at every flipped code cell, 24 agreeing
   bits), until nothing large enough is left.  Components read with the same N are merged;
   a sample claimed by two components, or another N, drops the smaller one.  Components and
   pieces too small or without a match are left out.

**Fast path.**  Before all this, :func:`recover_grid` tries the faces in the order meshwm
wrote them (:func:`~meshwm.gim.recover.fast._read_in_order`), which most pipelines keep: each
row of interior cells is then a contiguous run of faces, found from the run above it, and the
border ring is read from the known interior by the same border phase as step 5, with the same
rules.  It reads only complete grids in the writer's orientation, verifies every face, and
otherwise gives way to the steps above; its reading, hypotheses count included, is the one they
make of the same mesh, so the face order saves time (about 10 ms instead of 125 ms at N = 256)
and never decides a sample.

A welded mesh (close vertices merged, e.g. by MeshLab's ``meshing_merge_close_vertices``)
can have grid samples merged where the remesh crowded them;
:func:`~meshwm.gim.recover.repair.drop_irregular` removes the faces around every vertex no
meshwm grid has, so each merge reads as a small hole (the extraction in :mod:`meshwm.watermark`
tries it when the mesh does not read as given or cleaned).

Connectivity fixes the grid completely, including which of the eight symmetries of the square
is meant; the geometry is only used to spread the seeds (and to fill ``gim``), never to decide
a position, so any pose, scale or vertex order reads the same.

**Modules**, in the order of the data flow:

- :mod:`~meshwm.gim.recover.adjacency`: the received mesh's tables (directed-edge lookup,
  fans, valence, vertex classes, components);
- :mod:`~meshwm.gim.recover.seeds`: seed cells (step 2) and the local reading (step 3);
- :mod:`~meshwm.gim.recover.matching`: the code of each N and matching a window (step 4);
- :mod:`~meshwm.gim.recover.table`: the grid's triangles and the rows the walk steps by;
- :mod:`~meshwm.gim.recover.propagate`: the walk and the border phase (step 5);
- :mod:`~meshwm.gim.recover.verify`: verification (step 6) and the fold tips;
- :mod:`~meshwm.gim.recover.components`: each component, piece by piece (step 7);
- :mod:`~meshwm.gim.recover.sizes`: the candidate sizes (step 1);
- :mod:`~meshwm.gim.recover.fast`: the fast path;
- :mod:`~meshwm.gim.recover.repair`: :func:`drop_irregular`, for welded meshes;
- :mod:`~meshwm.gim.recover.expect`: what a grid mesh just written reads as, predicted
  without writing it (the embedder marks it while it reads its output back);
- :mod:`~meshwm.gim.recover.rule_out`: :func:`rules_out_grid`, the cheap test that a mesh
  holds no grid (most vertices on six triangles, or most faces without a 4-8 grid face's
  corners), asked before the search;
- :mod:`~meshwm.gim.recover.result` and :mod:`~meshwm.gim.recover.read`:
  :class:`RecoveredGrid` and :func:`recover_grid`, re-exported here.
"""

from meshwm.errors import GridError
from meshwm.gim.recover.read import recover_grid
from meshwm.gim.recover.repair import drop_irregular
from meshwm.gim.recover.result import RecoveredGrid
from meshwm.gim.recover.rule_out import rules_out_grid

__all__ = ["GridError", "RecoveredGrid", "drop_irregular", "recover_grid", "rules_out_grid"]
