"""Readers: a received mesh -> a sampled geometry image, blind.

A reader re-derives the geometry image from the received mesh alone (and the public
parameters): which samples it has, which it lost, and how many hypotheses finding them took,
which the detection decision counts.  The decoder of every profile takes its output
(:class:`~meshwm.readers.base.SampledImage`).  Readers are tried in the order of
:data:`READERS`; the first that finds an image wins.

To add a reader: one module with a function ``read_x(vertices, faces, *, max_faces) ->
SampledImage`` (or a sequence of them, one per hypothesis it offers) that raises
:class:`meshwm.errors.GridError` when it finds nothing, a constant ``MOST_IMAGES`` (the most
images it offers), optionally ``EXCLUDES`` (readers not to run once it found an image) and
``MOST_MIRRORED`` (the most images it offers with :data:`MIRRORED`'s options), and one entry in
:data:`READERS`.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import GridError
from meshwm.mesh.clean import shared_cleaning
from meshwm.readers.base import MIRROR, ChainedImages, LazyImages, SampledImage

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from meshwm.readers.base import Reader

__all__ = [
    "MIRRORED",
    "READERS",
    "get_reader",
    "most_images",
    "read_all",
    "read_received",
    "reader_names",
]

#: Blind readers, in the order they are tried: name -> "module:function".  The grid meshwm
#: writes (``--grid``) first; then, for a mesh kept as it is, the spherical image of its
#: vertices (cheap, and unmoved by edits of the connectivity), then its surface map.
READERS: dict[str, str] = {
    "connectivity": "meshwm.readers.connectivity:read_connectivity",
    "radial": "meshwm.readers.radial:read_radial",
    "surface": "meshwm.readers.surface:read_surface",
}


#: Readers also run on the received mesh's mirror image (x negated, faces turned over), after
#: every reader on the mesh itself, each with these extra keyword arguments.  A change of
#: handedness (an engine's import of a right-handed asset negates one axis and turns the faces
#: over to keep them facing out) mirrors the mesh, which no rotation undoes: the point set's
#: pose and the surface map then see the mark's mirror image; mirrored back, it reads again.
#: Their images count as hypotheses like any other's.  The surface reader's mirror image is
#: read from its canonical start and near-ties only: a mirrored copy is the marked mesh's
#: mirror image exactly, whose canonical start is the embedder's, and an unmarked mesh is read
#: to the end (with every start verify took 1.9 times as long, igea 16.6 -> 30.9 s; so, its
#: smoothing undone shared with the mesh's: kitten 2.9-3.4 -> 3.9 s, igea 14.5-15.6 ->
#: 21.2-21.9 s).  (The grid reader tries the grid's mirror images already.)
MIRRORED: dict[str, dict[str, Any]] = {"radial": {}, "surface": {"canonical": True}}
#: What a mirrored reader's name and images are labelled with.
_MIRROR_LABEL = " (mirrored)"


def _mirrored(found: SampledImage | Sequence[SampledImage]) -> Sequence[SampledImage]:
    """A reader's images on the mirrored mesh, each labelled so (made as lazily as given)."""

    # One labelled object per image: a reader that offers an image twice (the surface
    # reader's starts that give one image) offers it twice labelled, for a decoder to decode
    # once.  The images found keeps stay alive with it, so their ids stay their own.
    labelled: dict[int, SampledImage] = {}

    def label(image: SampledImage) -> SampledImage:
        if id(image) not in labelled:
            labelled[id(image)] = image._replace(reader=image.reader + _MIRROR_LABEL)
        return labelled[id(image)]

    if isinstance(found, SampledImage):
        return (label(found),)
    if isinstance(found, LazyImages):
        return LazyImages(len(found), lambda k: label(found[k]))
    return [label(image) for image in found]


def reader_names() -> list[str]:
    """Every name :func:`read_all`'s ``readers`` takes: each reader of :data:`READERS`, then
    each mirror image's reading (``"radial (mirrored)"``), in the order they are tried."""
    return [*READERS, *(n + _MIRROR_LABEL for n in READERS if n in MIRRORED)]


def get_reader(name: str) -> Reader:
    """The reader called ``name`` (a key of :data:`READERS`)."""
    if name not in READERS:
        raise ValueError(f"unknown reader {name!r}; valid: {', '.join(READERS)}")
    module, function = READERS[name].split(":")
    reader: Reader = getattr(importlib.import_module(module), function)
    return reader


def most_images(name: str) -> int:
    """The most images the reader ``name`` offers (its module's ``MOST_IMAGES``)."""
    module = READERS[name].split(":")[0]
    return int(importlib.import_module(module).MOST_IMAGES)


def _declared(name: str, attribute: str, default: Any) -> Any:
    """A reader module's constant (``EXCLUDES``: readers not to run once it found an image;
    ``SCHEME``: what decodes its images)."""
    module = READERS[name].split(":")[0]
    return getattr(importlib.import_module(module), attribute, default)


def read_received(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES
) -> SampledImage:
    """The geometry image of a received mesh, from the first reader in :data:`READERS` that
    finds one.

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No reader found a geometry image (the first reader's message).
    """
    return read_all(vertices, faces, max_faces=max_faces)[0]


def read_all(
    vertices: NDArray,
    faces: NDArray,
    *,
    max_faces: int = DEFAULT_MAX_FACES,
    hints: Mapping[str, Mapping[str, Any]] | None = None,
    readers: Sequence[str] | None = None,
    mirror: bool = True,
) -> ChainedImages:
    """Every image the readers of :data:`READERS` offer, in order, each reader run lazily.

    A reader may offer several images (the surface reader: one per size and start); the decoder
    tries them in order, counts each as a hypothesis, and runs a reader only when it gets to
    its images.  ``hints`` maps a reader's name to extra keyword arguments for it that change
    its speed, never its result (the embedder's read-back hands the surface reader the input's
    map: :func:`meshwm.gim.surface.surface_of`'s ``like``).  The readers share one cleaning of
    the mesh (:func:`meshwm.mesh.clean.shared_cleaning`).  ``readers`` (names, kept in
    :data:`READERS`' order) limits the readers tried: the embedder checks each carrier on its
    own.  With ``mirror`` (the default) the readers of :data:`MIRRORED` among them then read
    the mesh's mirror image too (the embedder's read-back of its own output does not); a
    mirror image's reading alone is asked for by its label (``"surface (mirrored)"``: a null
    study of those images, counted alone).

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No reader found a geometry image (every reader's message, in order).
    """
    check_mesh(vertices, faces, max_faces=max_faces)  # unusable arrays: MeshError, up front
    memo: dict = {}  # the cleanings and the smoothing undone, of the mesh and its mirror image

    def runner(name: str) -> Any:
        def run() -> SampledImage | Sequence[SampledImage]:
            extra = dict((hints or {}).get(name, {}))
            with shared_cleaning(memo):
                found: SampledImage | Sequence[SampledImage] = get_reader(name)(
                    vertices, faces, max_faces=max_faces, **extra
                )
            return found

        return run

    def mirror_runner(name: str) -> Any:
        def run() -> Sequence[SampledImage]:
            v = np.asarray(vertices, dtype=np.float64) * MIRROR
            f = np.ascontiguousarray(np.asarray(faces)[:, ::-1])
            with shared_cleaning(memo):
                found = get_reader(name)(v, f, max_faces=max_faces, **MIRRORED[name])
            return _mirrored(found)

        return run

    unknown = sorted(set(readers or ()) - set(reader_names()))
    if unknown:
        raise ValueError(f"unknown readers {unknown}; valid: {', '.join(reader_names())}")
    names = [name for name in READERS if readers is None or name in readers]
    entries = [(n, runner(n), most_images(n), _declared(n, "SCHEME", None)) for n in names]
    excludes = {n: tuple(_declared(n, "EXCLUDES", ())) for n in names}
    if mirror:
        for n in READERS:
            if n in MIRRORED and (readers is None or n in readers or n + _MIRROR_LABEL in readers):
                entries.append(
                    (
                        n + _MIRROR_LABEL,
                        mirror_runner(n),
                        _declared(n, "MOST_MIRRORED", most_images(n)),
                        _declared(n, "SCHEME", None),
                    )
                )
        excludes = {n: (*e, *(x + _MIRROR_LABEL for x in e)) for n, e in excludes.items()}
    if not entries:
        raise ValueError(f"no reader to run: {list(readers or ())} without the mirror image")
    chain = ChainedImages(entries, excludes=excludes)
    try:
        chain[0]
    except IndexError:
        raise GridError("; ".join(chain.errors)) from None
    return chain
