"""What a reader gives the decoder: a sampled geometry image and what it cost to find it."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["LazyImages", "Reader", "SampledImage"]


class SampledImage(NamedTuple):
    """A geometry image re-derived from a received mesh.

    Attributes
    ----------
    samples : (N, N, 3) float64 ndarray
        The received surface at the grid's samples; NaN where the mesh lost a sample.
    hypotheses : int
        How many hypotheses the reader tried to find the grid (sizes, orientations, offsets,
        pieces); the decision divides its false-positive budget by them (Bonferroni).
    reader : str
        The name of the reader that produced it (a key of :data:`meshwm.readers.READERS`).
    smoothing_undone : callable or None
        ``smoothing_undone()`` returns ``[(k, samples_k), ...]``: the samples after undoing
        ``k`` steps of uniform Laplacian smoothing of the received mesh, for the decoder to
        try when the image as received decodes weakly; ``None`` if the reader cannot.
    """

    samples: NDArray[np.float64]
    hypotheses: int
    reader: str
    smoothing_undone: Callable[[], Sequence[tuple[int, NDArray[np.float64]]]] | None = None

    @property
    def n(self) -> int:
        """The grid size N."""
        return int(self.samples.shape[0])

    @property
    def missing(self) -> NDArray[np.bool_]:
        """(N, N) bool: the samples the received mesh lost."""
        return ~np.all(np.isfinite(self.samples), axis=-1)


class Reader(Protocol):
    """A blind reader: ``reader(vertices, faces, *, max_faces) -> SampledImage`` (or a tuple).

    Raises :class:`meshwm.errors.GridError` when it finds no geometry image in the mesh and
    :class:`meshwm.errors.MeshError` for unusable arrays.
    """

    def __call__(
        self, vertices: NDArray, faces: NDArray, *, max_faces: int
    ) -> SampledImage | Sequence[SampledImage]: ...


class LazyImages(Sequence[SampledImage]):
    """Images a reader offers, each made the first time it is asked for.

    A reader whose later hypotheses cost a map each (the surface reader's runner-up cut
    starts) offers them this way: a decoder that stops at the first image that decodes never
    pays for the others, and counts each of them as one image of ``hypotheses`` 1.

    Parameters
    ----------
    count : int
        How many images.
    make : callable
        ``make(k)`` returns image ``k``.
    """

    def __init__(self, count: int, make: Callable[[int], SampledImage]) -> None:
        self._count = int(count)
        self._make = make
        self._made: dict[int, SampledImage] = {}

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, k: int) -> SampledImage:  # type: ignore[override]
        if not -self._count <= k < self._count:
            raise IndexError(k)
        k %= self._count
        if k not in self._made:
            self._made[k] = self._make(k)
        return self._made[k]

    def hypotheses_of(self, k: int) -> int:
        """Image ``k``'s hypotheses, without making it (1 until it is made)."""
        return self._made[k].hypotheses if k in self._made else 1
