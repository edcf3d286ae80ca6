"""The surface reader: the geometry image re-derived from any received mesh, blind.

For a mesh meshwm marked in place (its own vertices and faces, :mod:`meshwm.watermark.keep`):
the received mesh is cleaned, cut and mapped exactly as the embedder did
(:func:`meshwm.gim.surface.surface_of`), from its geometry and connectivity alone: no vertex
order, file metadata or side information is used, and the map is one the mark, noise, smoothing,
quantisation and similarities do not move.  The mesh is then sampled at every size of
:data:`meshwm.gim.surface.SURFACE_SIZES` (the embedder picked one; the decoder tries each, and
each counts as a hypothesis).  The map's one geometric choice, the cut's start (the vertex
farthest from the centroid on a smoothed copy), can be a near-tie that the mark or noise tips;
the runner-up starts (:data:`meshwm.gim.surface.SURFACE_RANKS`) are offered too, mapped only if
the decoder gets that far, and so is the runner-up first edge of a tip whose two longest edges
are a near-tie (:attr:`meshwm.gim.stable.StableCut.near_ties`: the genus-8 plate's corner).
Where the received mesh has coincident vertices, which the cleaning merges, the connectivity as
given is offered too (quantisation makes vertices coincide, and merging them changes the
connectivity the cut is made of).  Where the received mesh has split seams (an export's UV
seams) whose copies drifted apart (noise, a smoothing), or whose copies the cleaning merges
along with vertices that quantisation made coincide, the mesh with its borders zipped and
nothing else merged (:func:`meshwm.mesh.zip.zip_borders`) is offered too, from each candidate
start.  The decoder is also offered the received mesh with uniform Laplacian smoothing undone,
and with MeshLab's (cotangent) Laplacian smoothing undone (:mod:`meshwm.mesh.unsmooth`),
sampled the same way.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm._digest import arrays_key
from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import GridError, MeshError
from meshwm.gim.stable import TIPS
from meshwm.gim.surface import (
    SURFACE_RANKS,
    SURFACE_SIZES,
    Surface,
    SurfaceImage,
    remap_surface,
    same_cleaning,
    sample_surface,
    surface_of,
)
from meshwm.mesh.clean import shared_memo
from meshwm.mesh.edges import distinct_rows
from meshwm.mesh.unsmooth import cotangent_unsmoothed
from meshwm.mesh.zip import zip_borders
from meshwm.readers.base import MIRROR, LazyImages, SampledImage
from meshwm.readers.connectivity import unsmoothed

__all__ = ["MOST_IMAGES", "MOST_MIRRORED", "read_surface"]

#: The most images this reader offers: every size for the candidate starts, the near-tie starts
#: (:attr:`meshwm.gim.stable.StableCut.near_ties`, at most ``2 * TIPS``), where vertices
#: coincide the candidate starts again on the connectivity as given, and where borders zip the
#: candidate starts on the zipped mesh.
MOST_IMAGES = (3 * len(SURFACE_RANKS) + 2 * TIPS) * len(SURFACE_SIZES)
#: The most images it offers with ``canonical`` (the mirror image's reading,
#: :data:`meshwm.readers.MIRRORED`): every size for the canonical start and the near-ties.
MOST_MIRRORED = (1 + 2 * TIPS) * len(SURFACE_SIZES)


Unsmoothed = list[tuple[int | str, NDArray[np.float64]]]


def _unsmoothed(positions: NDArray[np.float64], faces: NDArray[np.int64]) -> Unsmoothed:
    """The positions with k uniform steps undone (label k), then with MeshLab's (cotangent)
    steps undone (:func:`meshwm.mesh.unsmooth.cotangent_unsmoothed`'s labels)."""
    found: Unsmoothed = list(unsmoothed(positions, faces))
    found += list(cotangent_unsmoothed(positions, faces))
    return found


def _unsmoothed_once(
    positions: NDArray[np.float64], faces: NDArray[np.int64], memo: dict | None
) -> tuple[Unsmoothed, NDArray[np.float64] | None]:
    """:func:`_unsmoothed`, computed and kept once for a mesh and its mirror image within one
    memo (:func:`meshwm.mesh.clean.shared_memo`: the readers of one received mesh and of its
    mirror image, :data:`meshwm.readers.MIRRORED`), and the reflection to apply to what is
    sampled of them (None: none).

    Both undoings commute with a reflection (the uniform step depends on the connectivity
    alone, MeshLab's on the angles), and the mirror image's surface is the mesh's reflected,
    position for position and face for face turned over, so its positions undone are the
    mesh's reflected; the samples of them through a matrix are the samples of the mesh's
    reflected, bit for bit (a reflection negates a coordinate, and a sum of negated terms is
    the sum negated).  Kept once, not once reflected: at 537k vertices the reflected copy was
    284 MB, a sixth of an unmarked read's memory."""
    if memo is None:
        return _unsmoothed(positions, faces), None
    key = ("unsmoothed", *arrays_key(positions, faces))
    if key in memo:
        return memo[key], None
    mirror = np.ascontiguousarray(faces[:, ::-1])
    image = ("unsmoothed", *arrays_key(positions * MIRROR, mirror))
    if image in memo:
        return memo[image], MIRROR
    memo[key] = _unsmoothed(positions, faces)
    found: Unsmoothed = memo[key]
    return found, None


def _smoothed_faces(
    surface_faces: NDArray[np.int64],
    inverse: NDArray[np.int64],
    used: NDArray[np.bool_],
    faces: NDArray[np.int64],
) -> NDArray[np.int64]:
    """The faces a smoothing of the received mesh ran over near a surface (its faces,
    ``inverse`` and ``used``, :class:`~meshwm.gim.surface.Surface`), on its positions: every
    received face that touches the surface (a fin standing on it, which the cleaning takes
    off, still pulled its edge's two vertices along its border), but those that use a
    position twice; other components' faces, which no step couples to it, are left out."""
    if faces.shape[1] != 3:
        return surface_faces
    over = inverse[faces]
    keep = (over[:, 0] != over[:, 1]) & (over[:, 1] != over[:, 2]) & (over[:, 0] != over[:, 2])
    keep &= used[over].any(axis=1)
    return over[keep]


def _undone(
    found: tuple[Unsmoothed, NDArray[np.float64] | None], image: SurfaceImage
) -> Unsmoothed:
    """The image of each of :func:`_unsmoothed`'s position sets, reflected where
    :func:`_unsmoothed_once` says."""
    sets, reflection = found
    out: Unsmoothed = []
    for label, x in sets:
        samples = np.asarray(image.matrix @ x).reshape(image.samples.shape)
        if reflection is not None:
            samples *= reflection
        samples[~image.covered] = np.nan
        out.append((label, samples))
    return out


class _Undoings:
    """The positions of a received mesh's connectivities with a smoothing undone, made once
    for each (the starts and sizes of one connectivity share its positions and faces) and
    kept once for a mesh and its mirror image (:func:`_unsmoothed_once`).

    Parameters
    ----------
    meshes : mapping
        Each connectivity's received vertices and faces, by name (the faces a smoothing ran
        over).
    memo : dict or None
        The memo shared with the mirror image's reader.
    """

    def __init__(self, meshes: dict[str, tuple[NDArray, NDArray]], memo: dict | None) -> None:
        self._meshes = meshes
        self._memo = memo
        self._done: dict[tuple[int, int], tuple[tuple, tuple[Unsmoothed, NDArray | None]]] = {}

    def of(
        self, over: tuple[NDArray, NDArray, NDArray, NDArray], variant: str
    ) -> tuple[Unsmoothed, NDArray | None]:
        """The positions undone over a surface's ``(positions, faces, inverse, used)``, of
        connectivity ``variant``, and the reflection to sample them with."""
        positions, surface_faces, inverse, used = over
        key = (id(positions), id(surface_faces))
        if key not in self._done:  # the arrays are kept with it, so the ids stay their own
            faces = self._meshes[variant][1]
            smoothed = _smoothed_faces(surface_faces, inverse, used, faces)
            self._done[key] = (over, _unsmoothed_once(positions, smoothed, self._memo))
        return self._done[key][1]


def read_surface(
    vertices: NDArray,
    faces: NDArray,
    *,
    max_faces: int = DEFAULT_MAX_FACES,
    like: Surface | None = None,
    canonical: bool = False,
) -> LazyImages:
    """Sample a received mesh through its re-derived stable map, at every size and start.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any vertex and face order, any pose).
    max_faces : int, optional
        Refuse larger inputs.
    like : Surface, optional
        A speed hint, not information: the map of a mesh with the same faces, reused only
        where it is provably the one this mesh gives (:func:`~meshwm.gim.surface.surface_of`).
    canonical : bool, optional
        Offer the canonical start and the near-ties only (a runner-up farthest vertex, a tip's
        runner-up first edge: the genus-8 plate's marked copy starts at the second farthest
        vertex along its runner-up edge), not the runner-up tips nor the connectivity as
        given: one map on most meshes where the full set makes four or more (the reader of a
        mirror image, :data:`meshwm.readers.MIRRORED`).

    Returns
    -------
    LazyImages
        For each candidate start of :data:`~meshwm.gim.surface.SURFACE_RANKS` (the farthest
        vertex first), then each near-tie start of the received mesh, one image per size of
        :data:`~meshwm.gim.surface.SURFACE_SIZES`, each one hypothesis, then those of the
        connectivity as given and of the zipped mesh where they are offered; the maps of the
        runner-up starts are made only when asked for.  Each connectivity's canonical start
        is ``primary`` (decoded with every candidate however weakly it reads as received).  A
        start whose image another start gave already (a connectivity as given that falls back
        to the cleaned one, a near-tie start that cuts as a runner-up tip does) offers that
        image object again, for a decoder to decode once; it still counts as a hypothesis.

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        A surface the map cannot open (non-manifold, non-orientable, too small).
    """
    v, f = check_mesh(vertices, faces, max_faces=max_faces, frozen=True)  # else MeshError
    memo = shared_memo()  # the undoing shared with the mirror image's reader, if any
    try:
        first = surface_of(v, f, max_faces=max_faces, like=like)
    except MeshError as merged:
        # Coarse quantisation makes distinct vertices coincide; merged, they can pinch the
        # surface into a non-manifold: read the connectivity as given instead.
        try:
            first = surface_of(v, f, max_faces=max_faces, merge=False)
        except MeshError:  # a surface the map cannot open: nothing to read
            raise GridError(f"the surface cannot be mapped: {merged}") from merged
    # The connectivities read: the cleaned mesh ("merged"), the one as given, the zipped one.
    surfaces: dict[tuple[str, int], Surface] = {("merged", SURFACE_RANKS[0]): first}
    # The embedder's read-back: the input's map, restarted wherever a start is its start.
    welded = bool(first.report.get("merged", True))
    same = welded and same_cleaning(like, first.inverse, first.clean_to_position, first.faces)
    restart = like.map if like is not None and same else None
    # Tips whose first edge is a near-tie are also started along the runner-up edge.
    ranks = (*SURFACE_RANKS, *(r for r in first.map.cut.near_ties if r not in SURFACE_RANKS))
    if canonical:  # the first start and the near-ties, not the runner-up tips
        ranks = (SURFACE_RANKS[0], *ranks[len(SURFACE_RANKS) :])
    starts = [("merged", r) for r in ranks]
    if int(first.report.get("vertices_merged", 0)) > 0 and not canonical:
        # Coincident vertices were merged: a UV seam welded back, or two vertices that coarse
        # quantisation made coincide, which merged change the connectivity (igea at 10 bits:
        # 16 merges move the cut).  The connectivity as given is offered too.
        starts += [("given", r) for r in SURFACE_RANKS]
    # The received faces each connectivity's smoothing ran over, on its own vertices.
    meshes = {"merged": (v, f), "given": (v, f)}
    if not canonical:
        zipped = zip_borders(v, f)
        # Offered where it is another connectivity than the cleaned one: where the zipping
        # glued other vertices than the cleaning merged (seams whose copies drifted apart, or
        # vertices off the borders that quantisation made coincide).
        if zipped.glued and len(zipped.vertices) != len(first.positions):
            meshes["zipped"] = (zipped.vertices, zipped.faces)
            starts += [("zipped", r) for r in SURFACE_RANKS]

    def base_of(variant: str) -> Surface:
        """The connectivity's surface from the canonical start (made once), or ``first``
        where the connectivity has none (an STL soup as given)."""
        if (variant, SURFACE_RANKS[0]) not in surfaces:
            mv, mf = meshes[variant]
            # As given, only a connectivity that holds most of the merged surface (not a
            # soup).  The zipped mesh is cleaned as the received one is, unless vertices off
            # its borders coincide (quantisation): those it keeps apart, as given.
            given = variant == "given" or (
                variant == "zipped" and len(distinct_rows(mv)[0]) < len(mv)
            )
            least = int(first.used.sum()) // 2
            try:
                surfaces[(variant, SURFACE_RANKS[0])] = surface_of(
                    mv, mf, max_faces=max_faces, merge=not given, min_used=least if given else 0
                )
            except MeshError:
                surfaces[(variant, SURFACE_RANKS[0])] = first
        return surfaces[(variant, SURFACE_RANKS[0])]

    # Each connectivity's canonical map is kept (its other starts are remapped from it);
    # another start's map only while its sizes are sampled (the decoder asks for the images
    # in order), then let go: its images keep only what undoing a smoothing needs, which the
    # starts of a connectivity share.  Kept, every start's cut mesh and UVs were about 0.5 GB
    # of an unmarked 537k-vertex mesh's read (15 maps with the mirror image's).
    recent: dict[tuple[str, int], Surface] = {}

    def surface_at(variant: str, rank: int) -> Surface:
        base = base_of(variant)
        if rank == SURFACE_RANKS[0]:
            return base
        if (variant, rank) not in recent:
            recent.clear()
            try:
                hint = restart if variant == "merged" else None
                recent[(variant, rank)] = remap_surface(base, base.positions, rank=rank, like=hint)
            except MeshError:
                recent[(variant, rank)] = first  # no such start: the first again
        return recent[(variant, rank)]

    undoings = _Undoings(meshes, memo)

    # Starts that give an image already made (one that fell back to another's surface, a
    # near-tie start whose cut is a ranked start's) offer that image object itself, which a
    # decoder decodes once (:class:`meshwm.watermark.extract.Decoder`); the hypotheses still
    # count every start.
    made: dict[tuple, SampledImage] = {}
    # Each start's image of each size, for a connectivity with no surface of its own (the
    # cleaned one's, start for start, without mapping its starts again).
    offered: dict[tuple[str, int, int], SampledImage] = {}

    def make(k: int) -> SampledImage:
        variant, rank = starts[k // len(SURFACE_SIZES)]
        size = SURFACE_SIZES[k % len(SURFACE_SIZES)]
        if variant != "merged" and base_of(variant) is first:
            if ("merged", rank, size) in offered:
                return offered[("merged", rank, size)]
            variant = "merged"
        surface = surface_at(variant, rank)
        if surface is first:
            variant = "merged"  # a start that fell back to the first surface
        image = sample_surface(surface, size=size)
        # The same samples through the same matrix over the same positions and faces: the
        # same image, and the same smoothing undone (:class:`_Undoings`' key).
        key = (
            id(surface.positions),
            id(surface.faces),
            *arrays_key(
                image.samples, image.matrix.indptr, image.matrix.indices, image.matrix.data
            ),
        )
        if key not in made:
            over = (surface.positions, surface.faces, surface.inverse, surface.used)
            made[key] = SampledImage(
                samples=image.samples,
                hypotheses=1,
                reader="surface",
                smoothing_undone=lambda: _undone(undoings.of(over, variant), image),
                primary=rank == SURFACE_RANKS[0],  # each connectivity's canonical start
            )
        offered.setdefault((variant, rank, size), made[key])
        return made[key]

    return LazyImages(len(starts) * len(SURFACE_SIZES), make)
