"""The boundary map: the disk's boundary loop laid on the perimeter of the unit square.

The disk's boundary loop is split into *chains* at the nodes of the cut graph (vertices where
cuts branch or meet a boundary).  A cut chain appears twice on the loop, once per side; a border
chain once.  Each chain gets a whole number of grid steps, the same on both of its sides,
proportional to its length, and the perimeter of the square (4(N-1) steps) is filled by arc
length.  So both sides of every cut fall on the same grid samples: the two samples are computed
from the same 3-D point and welded when the mesh is rebuilt, which makes the output of a closed
genus-0 mesh watertight and keeps the genus of a closed genus-g mesh.  For a single cut
``A -> B`` this gives ``A`` at (0, 0), ``B`` at (N-1, N-1), the cut's midpoint at the two other
corners, and sample (i, 0) = (0, i), (N-1, j) = (j, N-1).

References
----------
.. [1] X. Gu, S. J. Gortler, H. Hoppe, "Geometry images", ACM TOG 21(3), 2002,
   doi:10.1145/566654.566589.
"""

from __future__ import annotations

from typing import NamedTuple

import igl
import numpy as np
from numpy.typing import NDArray

from meshwm.errors import MeshError
from meshwm.gim.cut import argmax_stable
from meshwm.mesh.edges import border_half_edges, border_loop

__all__ = ["Chains", "Disk", "boundary_chains", "chain_points_at", "split_corners", "unit_to_uv"]


class Chains(NamedTuple):
    """The boundary loop of a cut mesh as runs of chains, with their grid steps.

    A *run* is a stretch of the loop between two consecutive nodes; a *chain* is a run's vertex
    sequence, shared by the two runs on either side of a cut.
    """

    loop: NDArray[np.int64]  # cut-mesh vertex ids, oriented, starting at the start node
    unit: NDArray[np.float64]  # perimeter position (grid steps) of each loop vertex
    run_chain: list[int]  # chain id of each run along the loop
    run_reversed: list[bool]  # run traverses its chain backwards
    run_start: NDArray[np.int64]  # loop index where each run starts (len = runs + 1)
    run_unit: NDArray[np.int64]  # integer perimeter position where each run starts (+ total)
    chain_points: list[NDArray[np.float64]]  # per chain: 3-D points at its grid steps
    chain_keys: list[list[tuple]]  # per chain: weld key of each grid step
    chain_steps: NDArray[np.int64]
    chain_multiplicity: NDArray[np.int64]


class Disk(NamedTuple):
    """The cut mesh with a boundary vertex at each corner of the square (:func:`split_corners`).

    Attributes
    ----------
    vertices : (k, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
    loop : (b,) int64 ndarray
        The boundary loop, oriented, from the start node.
    unit : (b,) float64 ndarray
        Perimeter position (grid steps, counter-clockwise from (0, 0)) of each loop vertex.
    origin : (k,) int64 ndarray
        The input vertex of each vertex (a corner vertex counts as its edge's nearer end).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    loop: NDArray[np.int64]
    unit: NDArray[np.float64]
    origin: NDArray[np.int64]


class _Runs(NamedTuple):
    loop: NDArray[np.int64]  # the oriented loop, rotated to start at the start node
    orig: NDArray[np.int64]  # input vertex of each loop vertex
    mult: NDArray[np.int64]  # 2: the loop edge from here is a cut edge, 1: a border edge
    node_pos: NDArray[np.int64]  # sorted loop indices of the nodes (the first is 0)


def _oriented_loop(faces_cut: NDArray[np.int64]) -> NDArray[np.int64]:
    """The boundary loop in the faces' direction, from its smallest vertex index.

    ``igl.boundary_loop``'s loop (the same start and direction) from the border half-edges
    (10M faces: 1.5 s against 6.4 s); a border that is not one simple loop asks igl.
    """
    border = border_half_edges(faces_cut)
    loop = border_loop(border, int(border[:, 0].min())) if len(border) else None
    return _igl_loop(faces_cut) if loop is None else loop


def _igl_loop(faces_cut: NDArray[np.int64]) -> NDArray[np.int64]:
    """``igl.boundary_loop``'s longest loop, turned to run in the faces' direction."""
    loop = np.asarray(igl.boundary_loop(faces_cut), dtype=np.int64)
    if len(loop) < 3:
        raise MeshError("could not cut the mesh open into a disk (no boundary loop)")
    # Interior on the left: the loop must follow the faces' own edge directions.
    a, b = loop[0], loop[1]
    has_ab = np.any((faces_cut == a) & (np.roll(faces_cut, -1, axis=1) == b))
    return loop if has_ab else loop[::-1].copy()


def _polyline_points(pts: NDArray[np.float64], steps: int) -> NDArray[np.float64]:
    """``steps + 1`` points evenly spaced by arc length along a polyline (ends exact)."""
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if total == 0:
        return np.repeat(pts[:1], steps + 1, axis=0)
    target = total * np.arange(steps + 1) / steps
    k = np.clip(np.searchsorted(s, target, side="right") - 1, 0, len(seg) - 1)
    t = np.where(seg[k] > 0, (target - s[k]) / np.where(seg[k] > 0, seg[k], 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    out = pts[k] + t[:, None] * (pts[k + 1] - pts[k])
    out[0], out[-1] = pts[0], pts[-1]
    return out


def _allocate(lengths: NDArray, multiplicity: NDArray, total: int) -> NDArray[np.int64]:
    """Whole grid steps per chain, at least one each, with sum(multiplicity * steps) == total."""
    need = int(multiplicity.sum())
    if need > total:
        raise MeshError(
            f"the cut has {len(lengths)} chains needing {need} boundary samples, more than the "
            f"{total} a grid of this size has; use a larger --size"
        )
    weight = (multiplicity * lengths).sum()
    ideal = total * lengths / weight if weight > 0 else np.full(len(lengths), total / need)
    steps = np.maximum(1, np.floor(ideal)).astype(np.int64)
    while (multiplicity * steps).sum() > total:
        # Rounding up the minimum overshot: take steps back from the most over-served chains.
        over = np.where(steps > 1, steps - ideal, -np.inf)
        steps[int(np.argmax(over))] -= 1
    rest = total - int((multiplicity * steps).sum())
    while rest > 0:
        deficit = np.where(multiplicity <= rest, ideal - steps, -np.inf)
        c = int(np.argmax(deficit))
        if not np.isfinite(deficit[c]):
            break
        steps[c] += 1
        rest -= int(multiplicity[c])
    if rest != 0:
        raise MeshError("could not distribute the boundary samples evenly over the cut")
    return steps


def _runs(
    vertices_cut: NDArray[np.float64],
    faces_cut: NDArray[np.int64],
    origin: NDArray[np.int64],
    n_orig: int,
    radial: NDArray[np.float64],
) -> _Runs:
    """The oriented boundary loop, its nodes, and the loop rotated to start at the start node."""
    loop = _oriented_loop(faces_cut)
    orig = origin[loop]
    nl = len(loop)
    nxt = np.roll(orig, -1)
    key = np.minimum(orig, nxt) * n_orig + np.maximum(orig, nxt)
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    mult = cnt[inv]  # 2: a cut edge (both sides on the loop), 1: an original border edge
    if np.any(mult > 2):
        raise MeshError("the cut is not a valid disk boundary (an edge appears 3+ times)")
    # Degree of each original vertex in the graph of loop edges.
    uniq_edges = np.unique(np.sort(np.stack([orig, nxt], 1), axis=1), axis=0)
    degree = np.bincount(uniq_edges.ravel(), minlength=n_orig)
    prev_mult = np.roll(mult, 1)
    is_node = (degree[orig] != 2) | (mult != prev_mult)
    if not is_node.any():
        # One closed loop with no node (a disk's own boundary): start at the vertex farthest
        # from the centroid.
        is_node[argmax_stable(radial[orig], -np.arange(nl, dtype=float))] = True
    node_pos = np.flatnonzero(is_node)
    # Start node: farthest from the centroid; among its occurrences, the one whose run is
    # longest (a run's length is pose-invariant, its loop index is not).
    seg = np.linalg.norm(vertices_cut[np.roll(loop, -1)] - vertices_cut[loop], axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    run_len = np.empty(len(node_pos))
    for r, p in enumerate(node_pos):
        q = node_pos[(r + 1) % len(node_pos)]
        run_len[r] = cum[q] - cum[p] if q > p else cum[nl] - cum[p] + cum[q]
    start_r = int(np.lexsort((run_len, radial[orig[node_pos]]))[-1])
    shift = node_pos[start_r]
    loop = np.roll(loop, -shift)
    orig = np.roll(orig, -shift)
    mult = np.roll(mult, -shift)
    node_pos = np.sort((node_pos - shift) % nl)
    return _Runs(loop, orig, mult, node_pos)


def _group_runs(
    orig: NDArray[np.int64], mult: NDArray[np.int64], bounds: NDArray[np.int64]
) -> tuple[list[int], list[bool], list[NDArray[np.int64]], NDArray[np.int64]]:
    """Chain id and direction of each run; each chain's input vertices and multiplicity."""
    closed_orig = np.concatenate([orig, orig[:1]])
    # Group runs into chains: a cut chain's second run is its first reversed.
    chain_of: dict[tuple, int] = {}
    run_chain: list[int] = []
    run_reversed: list[bool] = []
    chain_seq: list[NDArray[np.int64]] = []
    chain_mult: list[int] = []
    for r in range(len(bounds) - 1):
        seq = tuple(closed_orig[bounds[r] : bounds[r + 1] + 1].tolist())
        if seq[::-1] in chain_of and mult[bounds[r]] == 2:
            run_chain.append(chain_of[seq[::-1]])
            run_reversed.append(True)
        else:
            chain_of[seq] = len(chain_seq)
            run_chain.append(len(chain_seq))
            run_reversed.append(False)
            chain_seq.append(np.asarray(seq, dtype=np.int64))
            chain_mult.append(int(mult[bounds[r]]))
    chain_multiplicity = np.asarray(chain_mult, dtype=np.int64)
    if np.bincount(run_chain).tolist() != chain_multiplicity.tolist():
        raise MeshError("the cut is not a valid disk boundary (unmatched cut sides)")
    return run_chain, run_reversed, chain_seq, chain_multiplicity


def _chain_keys(chain_seq: list[NDArray[np.int64]], steps: NDArray[np.int64]) -> list[list[tuple]]:
    """Weld key of each grid step of each chain: its end nodes by vertex, the rest by chain."""
    chain_keys = []
    for c, s in enumerate(chain_seq):
        k = int(steps[c])
        keys: list[tuple] = [("v", int(s[0]))]
        keys += [("c", c, t) for t in range(1, k)]
        keys.append(("v", int(s[-1])))
        chain_keys.append(keys)
    return chain_keys


def _loop_units(
    vertices_cut: NDArray[np.float64],
    loop: NDArray[np.int64],
    bounds: NDArray[np.int64],
    run_chain: list[int],
    run_unit: NDArray[np.int64],
    steps: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Perimeter position of every loop vertex: arc length within its run."""
    nl = len(loop)
    unit = np.empty(nl)
    for r in range(len(bounds) - 1):
        i0, i1 = bounds[r], bounds[r + 1]
        idx = np.arange(i0, i1 + 1) % nl
        pts = vertices_cut[loop[idx]]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        frac = s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(s))
        unit[i0:i1] = run_unit[r] + frac[:-1] * steps[run_chain[r]]
    return unit


def boundary_chains(
    vertices_cut: NDArray[np.float64],
    faces_cut: NDArray[np.int64],
    origin: NDArray[np.int64],
    n: int,
    radial: NDArray[np.float64],
) -> Chains:
    """Split the cut mesh's boundary loop into chains and give each its grid steps.

    Parameters
    ----------
    vertices_cut, faces_cut, origin : ndarray
        The cut mesh (:class:`meshwm.gim.cut.CutMesh`).
    n : int
        Grid size N: the perimeter has 4(N-1) steps.
    radial : (v,) float64 ndarray
        Distance of each input vertex to the area centroid (picks the start node).
    """
    n_orig = int(origin.max()) + 1
    loop, orig, mult, node_pos = _runs(vertices_cut, faces_cut, origin, n_orig, radial)
    bounds = np.concatenate([node_pos, [len(loop)]])
    run_chain, run_reversed, chain_seq, chain_multiplicity = _group_runs(orig, mult, bounds)
    orig_vertices = np.zeros((n_orig, 3))
    orig_vertices[origin] = vertices_cut
    lengths = np.array(
        [np.linalg.norm(np.diff(orig_vertices[s], axis=0), axis=1).sum() for s in chain_seq]
    )
    total = 4 * (n - 1)
    steps = _allocate(lengths, chain_multiplicity, total)
    chain_points = [
        _polyline_points(orig_vertices[s], int(k)) for s, k in zip(chain_seq, steps, strict=True)
    ]
    chain_keys = _chain_keys(chain_seq, steps)
    run_unit = np.concatenate([[0], np.cumsum([steps[c] for c in run_chain])]).astype(np.int64)
    unit = _loop_units(vertices_cut, loop, bounds, run_chain, run_unit, steps)
    return Chains(
        loop,
        unit,
        run_chain,
        run_reversed,
        bounds,
        run_unit,
        chain_points,
        chain_keys,
        steps,
        chain_multiplicity,
    )


def chain_points_at(
    chains: Chains, origin: NDArray[np.int64], positions: NDArray[np.float64]
) -> list[NDArray[np.float64]]:
    """``chains.chain_points`` again, each chain's vertices at ``positions``: the same grid
    steps per chain (``chains.chain_steps``), spaced by arc length along the moved polyline.

    The remesh makes its choices on snapped coordinates and takes its samples from finer ones
    (:func:`meshwm.gim.remesh.mesh_to_geometry_image`): the steps of each chain are a choice,
    their points along it are not.

    Parameters
    ----------
    chains : Chains
    origin : (k,) int64 ndarray
        The input vertex of each cut-mesh vertex (the cut the chains were made on).
    positions : (v, 3) float64 ndarray
        A position for every input vertex.
    """
    orig = origin[chains.loop]
    closed = np.concatenate([orig, orig[:1]])
    seen: set[int] = set()
    points: list[NDArray[np.float64]] = [np.zeros((0, 3))] * len(chains.chain_steps)
    for r, c in enumerate(chains.run_chain):
        if c in seen or chains.run_reversed[r]:
            continue
        seen.add(c)
        seq = closed[chains.run_start[r] : chains.run_start[r + 1] + 1]
        points[c] = _polyline_points(positions[seq], int(chains.chain_steps[c]))
    return points


def unit_to_uv(t: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Perimeter position (grid steps, counter-clockwise from (0, 0)) to (u, v) in [0, 1]²."""
    side = n - 1
    t = np.asarray(t, dtype=np.float64) % (4 * side)
    s = np.minimum(t // side, 3)
    r = (t - s * side) / side
    u = np.select([s == 0, s == 1, s == 2, s == 3], [r, 1.0 + 0 * r, 1.0 - r, 0 * r])
    v = np.select([s == 0, s == 1, s == 2, s == 3], [0 * r, r, 1.0 + 0 * r, 1.0 - r])
    return np.stack([u, v], axis=1)


def split_corners(
    vertices_cut: NDArray[np.float64],
    faces_cut: NDArray[np.int64],
    origin: NDArray[np.int64],
    chains: Chains,
    n: int,
) -> Disk:
    """Insert a boundary vertex at each square corner that falls inside a boundary edge.

    Returns the new vertices, faces, boundary loop, the loop's perimeter positions and the
    original vertex of each new vertex (a corner vertex counts as the edge's nearer end), as a
    :class:`Disk`.
    """
    loop, unit = chains.loop, chains.unit
    side = n - 1
    v_list = [vertices_cut]
    faces = faces_cut.copy()
    new_loop, new_unit = [], []
    new_origin = list(origin.tolist())
    nv = len(vertices_cut)
    total = 4 * side
    nl = len(loop)
    for k in range(nl):
        new_loop.append(int(loop[k]))
        new_unit.append(float(unit[k]))
        t0 = unit[k]
        t1 = unit[(k + 1) % nl] if k + 1 < nl else float(total)
        for corner in (side, 2 * side, 3 * side):
            if t0 < corner < t1:
                a, b = int(loop[k]), int(loop[(k + 1) % nl])
                w = (corner - t0) / (t1 - t0)
                p = vertices_cut[a] + w * (vertices_cut[b] - vertices_cut[a])
                v_list.append(p[None, :])
                # Split the one face holding the directed boundary edge a -> b.
                hit = (faces == a) & (np.roll(faces, -1, axis=1) == b)
                fi, kk = np.argwhere(hit)[0]
                c = int(faces[fi, (kk + 2) % 3])
                faces[fi] = [a, nv, c]
                faces = np.vstack([faces, [[nv, b, c]]])
                new_loop.append(nv)
                new_unit.append(float(corner))
                new_origin.append(int(origin[a] if w < 0.5 else origin[b]))
                nv += 1
                t0 = corner
    return Disk(
        np.vstack(v_list),
        faces,
        np.asarray(new_loop, dtype=np.int64),
        np.asarray(new_unit, dtype=np.float64),
        np.asarray(new_origin, dtype=np.int64),
    )
