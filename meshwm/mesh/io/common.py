"""What every format module and both entry points share: errors, limits, the quiet context.

Error messages are one line and start with the file name (:func:`mesh_error`); loader
exceptions are quoted short (:func:`describe`).  The vertex limit that goes with a face limit
is :func:`vertex_limit`.  :class:`Declared` is what a format's pre-check promises about the
loaded mesh.  Nothing here imports trimesh.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from meshwm.errors import MeshError

__all__ = [
    "COUNT",
    "VERTEX_SLACK",
    "Declared",
    "PathLike",
    "check_destination",
    "describe",
    "mesh_error",
    "quiet_trimesh",
    "read_file_bytes",
    "suffix_error",
    "vertex_limit",
]

PathLike = str | os.PathLike[str]

#: Longest exception text from a loader that is quoted in an error message.
MAX_DETAIL = 160
#: Extra vertices allowed on top of three per face (unreferenced vertices).
VERTEX_SLACK = 1024
#: An element count in a header: a non-negative decimal integer.
COUNT = re.compile(r"\+?\d+")


def mesh_error(path: PathLike, detail: str) -> MeshError:
    """Build a one-line :class:`MeshError` ``"<path>: <detail>"``."""
    message = f"{os.fspath(path)}: {detail}"
    return MeshError(" ".join(message.splitlines()))


def suffix_error(path: PathLike, valid: tuple[str, ...] | list[str]) -> MeshError:
    """The one-line error for a file whose suffix is unknown or missing, listing ``valid``."""
    suffix = Path(path).suffix.lower()
    shown = f"unknown mesh file suffix {suffix!r}" if suffix else "file name has no suffix"
    return mesh_error(path, f"{shown}; valid suffixes are {', '.join(valid)}")


def read_file_bytes(path: PathLike) -> bytes:
    """The bytes of an existing, readable, non-empty file.

    Raises
    ------
    MeshError
        No such file, a directory, unreadable, or empty; one line naming the file.
    """
    if not os.path.lexists(path):
        raise mesh_error(path, "no such file")
    if os.path.isdir(path):
        raise mesh_error(path, "is a directory, not a mesh file")
    try:
        with open(path, "rb") as stream:
            data = stream.read()
    except OSError as exc:
        raise mesh_error(path, f"cannot read file ({exc.strerror or describe(exc)})") from exc
    if not data:
        raise mesh_error(path, "file is empty (0 bytes)")
    return data


def check_destination(
    path: PathLike, *, overwrite_input: PathLike | None = None, force: bool = False
) -> None:
    """Raise unless ``path``'s folder exists and, without ``force``, ``path`` is not the
    same file as ``overwrite_input`` (:func:`os.path.samefile`: links and relative paths
    count)."""
    parent = Path(path).resolve().parent
    if not parent.is_dir():
        raise mesh_error(path, f"folder {parent} does not exist")
    if (
        overwrite_input is not None
        and not force
        and os.path.exists(path)
        and os.path.exists(overwrite_input)
        and os.path.samefile(path, overwrite_input)
    ):
        raise mesh_error(path, "would overwrite the input; use --force")


def describe(exc: BaseException) -> str:
    """Short one-line ``"Type: message"`` description of an exception from a loader."""
    text = " ".join(str(exc).split())
    if len(text) > MAX_DETAIL:
        text = text[: MAX_DETAIL - 3] + "..."
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def vertex_limit(max_faces: int) -> int:
    """Most vertices accepted for a file limited to ``max_faces`` faces."""
    return 3 * max_faces + VERTEX_SLACK


@contextlib.contextmanager
def quiet_trimesh() -> Iterator[None]:
    """Silence warnings and trimesh's log output while trimesh loads or exports.

    Malformed files make trimesh log at WARNING level (printed on stderr when no logging is
    configured) and make NumPy emit ``RuntimeWarning``/``DeprecationWarning``; the reader
    reports problems through :class:`MeshError` instead.  Not thread-safe: it changes the
    global warning filters and the level of the ``trimesh`` logger for its duration.
    """
    logger = logging.getLogger("trimesh")
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            yield
    finally:
        logger.setLevel(level)


@dataclass(frozen=True)
class Declared:
    """What a file's header (or a cheap scan of it) says the loaded mesh must contain.

    ``vertices``: exact vertex count, or None if unknown.  ``polygons``: the number of faces in
    the file; each yields at least one triangle (``exact_triangles``: exactly one).
    ``check_list_counts``: verify that every PLY list has the length trimesh assumed.
    ``text``: the data is text; invalid UTF-8 is replaced before trimesh decodes it (trimesh
    would otherwise need the optional ``charset_normalizer`` to guess an encoding).
    """

    vertices: int | None = None
    polygons: int | None = None
    exact_triangles: bool = False
    check_list_counts: bool = False
    text: bool = False
