"""Write a mesh file: check the target, serialise with the suffix's writer, replace atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from meshwm._atomic import write_atomic
from meshwm._validate import check_mesh
from meshwm.errors import MeshError
from meshwm.mesh.io.common import PathLike, check_destination, describe, mesh_error
from meshwm.mesh.io.registry import WRITE_SUFFIXES, WRITERS

__all__ = ["check_output", "check_output_suffix", "write_mesh"]


def check_output_suffix(path: PathLike) -> None:
    """Raise early if ``path`` has a suffix :func:`write_mesh` cannot write.

    Parameters
    ----------
    path : str or os.PathLike
        Intended output file.

    Raises
    ------
    MeshError
        The (case-insensitive) suffix is not one of ``WRITE_SUFFIXES``; the message lists
        the valid ones.

    Examples
    --------
    >>> check_output_suffix("out.PLY")
    >>> check_output_suffix("out.fbx")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    meshwm.errors.MeshError: out.fbx: cannot write '.fbx' files; valid output suffixes are ...
    """
    suffix = Path(path).suffix.lower()
    if suffix not in WRITERS:
        what = f"{suffix!r} files" if suffix else "files without a suffix"
        valid = ", ".join(WRITE_SUFFIXES)
        raise mesh_error(path, f"cannot write {what}; valid output suffixes are {valid}")


def check_output(
    path: PathLike, *, overwrite_input: PathLike | None = None, force: bool = False
) -> None:
    """Raise early if :func:`write_mesh` would refuse to write ``path``.

    Checks the suffix (:func:`check_output_suffix`) and, unless ``force``, that ``path`` is not
    the same file as ``overwrite_input`` (:func:`os.path.samefile`, so links and relative paths
    count).  The CLI calls it before any expensive work; :func:`write_mesh` calls it again.

    Raises
    ------
    MeshError
        Unsupported suffix, or the output would overwrite the input.
    """
    check_output_suffix(path)
    check_destination(path, overwrite_input=overwrite_input, force=force)


def write_mesh(
    path: PathLike,
    vertices: NDArray,
    faces: NDArray,
    *,
    overwrite_input: PathLike | None = None,
    force: bool = False,
) -> None:
    """Write a triangle mesh to an OBJ, PLY, STL, OFF or GLB file, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; the (case-insensitive) suffix picks the format: ``.ply`` (binary
        little-endian, float64 coordinates), ``.obj`` (text, every coordinate written with
        the shortest representation that reads back exactly), ``.stl`` (binary), ``.off``
        (text, exact like OBJ) or ``.glb`` (float32).  No file names the tool that wrote it.
    vertices : (n, 3) array_like of float
        Vertex positions; must be finite.
    faces : (m, 3) array_like of int
        Triangles as indices into ``vertices``.
    overwrite_input : str or os.PathLike, optional
        The file the mesh was read from.  If ``path`` is that same file (checked with
        :func:`os.path.samefile`, so links and relative paths count), writing is refused
        unless ``force`` is true.
    force : bool, optional
        Allow overwriting ``overwrite_input``.

    Raises
    ------
    MeshError
        Unknown suffix, invalid arrays (see :func:`~meshwm._validate.check_mesh`), ``path``
        is ``overwrite_input`` without ``force``, or the file cannot be written.  The
        message is one line and starts with ``path``.

    Notes
    -----
    The bytes are written to a temporary file in the target's directory, flushed and
    fsynced, then moved onto ``path`` with :func:`os.replace`; on any failure the temporary
    file is removed and ``path`` is left as it was.  Output is byte-for-byte deterministic
    for the same arrays (no timestamps).  PLY and OBJ round-trip float64 exactly through
    :func:`read_mesh`.  STL stores float32 coordinates, one vertex triple per triangle, so
    reading it back gives rounded, un-indexed vertices.  A new file gets the usual
    permissions (``0o666`` minus the umask); an overwritten one keeps its permissions.
    """
    check_output(path, overwrite_input=overwrite_input, force=force)
    try:
        vertices, faces = check_mesh(vertices, faces, max_faces=np.iinfo(np.int64).max)
    except MeshError as exc:
        raise mesh_error(path, f"cannot write: {exc}") from None

    try:
        payload = WRITERS[Path(path).suffix.lower()](vertices, faces)
    except MeshError as exc:
        raise mesh_error(path, str(exc)) from None

    try:
        write_atomic(path, payload)
    except OSError as exc:
        raise mesh_error(path, f"cannot write file ({exc.strerror or describe(exc)})") from exc
