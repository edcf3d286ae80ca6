"""What a reader gives the decoder: a sampled geometry image and what it cost to find it."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["MIRROR", "ChainedImages", "LazyImages", "Reader", "SampledImage"]

#: The reflection a mirror image is read through (:data:`meshwm.readers.MIRRORED`): x negated,
#: the faces turned over.  One constant, so that the surface reader's shared smoothing undone
#: finds the mesh's under the very positions the mirror image is made of.
MIRROR = np.array([-1.0, 1.0, 1.0])


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
        ``smoothing_undone()`` returns ``[(label, samples), ...]``: the samples with steps of
        a known smoothing of the received mesh undone (``label`` k: k uniform Laplacian steps;
        ``"cotangent k/i"``: k of MeshLab's), for the decoder to try when the image as received
        decodes weakly; ``None`` if the reader cannot.
    scheme : str or None
        What decodes the image when it is not the embedding's profile: ``"radial"`` for the
        spherical image of the radial carrier (:data:`meshwm.profiles.CARRIERS`).
    primary : bool
        One of the reader's first hypotheses (the grid it found; the surface map from the
        canonical cut start, of each connectivity the surface reader offers): a decoder tries
        it with every candidate, however weakly it reads as received.
    """

    samples: NDArray[np.float64]
    hypotheses: int
    reader: str
    smoothing_undone: Callable[[], Sequence[tuple[int | str, NDArray[np.float64]]]] | None = None
    scheme: str | None = None
    primary: bool = False

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
    pays for the others.

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


class ChainedImages(Sequence[SampledImage]):
    """The images of several readers, in order, each reader run only when first needed.

    A decoder that stops at the first image that decodes never runs the readers after it (the
    surface reader's map is the costly part of a read).  A reader that finds nothing
    (:class:`meshwm.errors.GridError`) offers no image; :attr:`errors` keeps its message.

    Parameters
    ----------
    readers : sequence of (name, make, most, scheme)
        ``make()`` returns the reader's images (a :class:`SampledImage` or a sequence), or
        raises :class:`meshwm.errors.GridError`; ``most`` bounds the number of images it can
        offer and ``scheme`` is theirs (:meth:`bound`).
    excludes : mapping, optional
        Reader name -> the names of the readers not to run once it found an image.
    """

    def __init__(
        self,
        readers: Sequence[
            tuple[str, Callable[[], SampledImage | Sequence[SampledImage]], int, str | None]
        ],
        *,
        excludes: Mapping[str, Sequence[str]] | None = None,
    ) -> None:
        self._readers = list(readers)
        self._excludes = {k: tuple(v) for k, v in (excludes or {}).items()}
        self._done: list[Sequence[SampledImage]] = []
        self._skipped: list[bool] = []
        #: ``"name: message"`` of each reader that found nothing or was not run, in order.
        self.errors: list[str] = []

    def _skip(self, r: int) -> str | None:
        """The earlier reader that excludes reader ``r`` (running the readers that could),
        or None."""
        name = self._readers[r][0]
        could = [i for i in range(r) if name in self._excludes.get(self._readers[i][0], ())]
        while could and len(self._done) <= max(could):
            self._run_next()
        found = [i for i in could if len(self._done[i]) and not self._skipped[i]]
        return self._readers[found[0]][0] if found else None

    def _run_next(self) -> bool:
        from meshwm.errors import GridError

        r = len(self._done)
        if r == len(self._readers):
            return False
        name, make, _, _ = self._readers[r]
        found: SampledImage | Sequence[SampledImage] = ()
        by = self._skip(r)  # the readers before r have all run
        if by is not None:
            self.errors.append(f"{name}: not run, the {by} reader found the mesh")
        else:
            try:
                found = make()
            except GridError as exc:
                self.errors.append(f"{name}: {exc}")
        self._skipped.append(by is not None)
        self._done.append((found,) if isinstance(found, SampledImage) else found)
        return True

    def _locate(self, k: int) -> tuple[int, int] | None:
        """(reader, index in it) of image ``k``, running readers as needed; None past the end."""
        seen = 0
        r = 0
        while True:
            while r >= len(self._done):
                if not self._run_next():
                    return None
            size = len(self._done[r])
            if k < seen + size:
                return r, k - seen
            seen += size
            r += 1

    def __getitem__(self, k: int) -> SampledImage:  # type: ignore[override]
        if k < 0:
            k += len(self)
        where = self._locate(k) if k >= 0 else None
        if where is None:
            raise IndexError(k)
        return self._done[where[0]][where[1]]

    def __len__(self) -> int:
        """Every reader's images (runs them all)."""
        while self._run_next():
            pass
        return sum(len(d) for d in self._done)

    def __iter__(self) -> Iterator[SampledImage]:
        k = 0
        while (where := self._locate(k)) is not None:
            yield self._done[where[0]][where[1]]
            k += 1

    def bound(self, most: Callable[[str | None], int]) -> int:
        """The most hypotheses the images of every reader can take, whatever is tried.

        ``most(scheme)`` is a decoder's most hypotheses per image.  A reader that offers
        its images made (the grid reader's one grid) counts their own hypotheses; a reader
        whose images are made lazily, or which has not run, counts its ``most`` images at one
        hypothesis each and its ``scheme``; a reader an earlier one excluded counts nothing.
        The sum depends on the mesh alone, not on what a decoder tried before (runs the
        readers that exclude others, so that what they exclude is known).
        """
        total = 0
        for r, (_, _, count, scheme) in enumerate(self._readers):
            if self._skip(r) is not None:
                continue
            done = self._done[r] if r < len(self._done) else None
            if done is not None and not isinstance(done, LazyImages):
                total += sum(image.hypotheses * most(image.scheme) for image in done)
            else:
                total += count * most(scheme)
        return total
