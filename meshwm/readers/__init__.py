"""Readers: a received mesh -> a sampled geometry image, blind.

A reader re-derives the geometry image from the received mesh alone (and the public
parameters): which samples it has, which it lost, and how many hypotheses finding them took,
which the detection decision counts.  The decoder of every profile takes its output
(:class:`~meshwm.readers.base.SampledImage`).  Readers are tried in the order of
:data:`READERS`; the first that finds an image wins.

To add a reader: one module with a function ``read_x(vertices, faces, *, max_faces) ->
SampledImage`` (or a tuple of them, one per hypothesis it offers) that raises
:class:`meshwm.errors.GridError` when it finds nothing, and one entry in :data:`READERS`.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from meshwm._validate import DEFAULT_MAX_FACES
from meshwm.errors import GridError
from meshwm.mesh.clean import shared_cleaning
from meshwm.readers.base import SampledImage

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    from meshwm.readers.base import Reader

__all__ = ["READERS", "get_reader", "read_all", "read_received"]

#: Blind readers, in the order they are tried: name -> "module:function".
READERS: dict[str, str] = {
    "connectivity": "meshwm.readers.connectivity:read_connectivity",
    "surface": "meshwm.readers.surface:read_surface",
}


def get_reader(name: str) -> Reader:
    """The reader called ``name`` (a key of :data:`READERS`)."""
    if name not in READERS:
        raise ValueError(f"unknown reader {name!r}; valid: {', '.join(READERS)}")
    module, function = READERS[name].split(":")
    reader: Reader = getattr(importlib.import_module(module), function)
    return reader


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
) -> Sequence[SampledImage]:
    """Every image the first reader in :data:`READERS` that finds any offers.

    A reader may offer several images (the surface reader: one per size); the decoder tries
    each and counts each as a hypothesis.  ``hints`` maps a reader's name to extra keyword
    arguments for it that change its speed, never its result (the embedder's read-back hands
    the surface reader the input's map: :func:`meshwm.gim.surface.surface_of`'s ``like``).

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No reader found a geometry image (every reader's message, in order).
    """
    with shared_cleaning():  # every reader cleans the same mesh: once
        return _read_all(vertices, faces, max_faces=max_faces, hints=hints)


def _read_all(
    vertices: NDArray,
    faces: NDArray,
    *,
    max_faces: int,
    hints: Mapping[str, Mapping[str, Any]] | None,
) -> Sequence[SampledImage]:
    errors: list[str] = []
    for name in READERS:
        try:
            extra = dict((hints or {}).get(name, {}))
            found = get_reader(name)(vertices, faces, max_faces=max_faces, **extra)
        except GridError as exc:
            errors.append(f"{name}: {exc}")
            continue
        # A SampledImage is a NamedTuple itself: test for it, not for tuple.
        return (found,) if isinstance(found, SampledImage) else found
    raise GridError("; ".join(errors))
