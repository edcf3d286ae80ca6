"""Atomic file writes (private): a file is either written whole or not touched."""

from __future__ import annotations

import contextlib
import os
import tempfile

__all__ = ["write_atomic"]


def _new_file_mode() -> int:
    """Permissions a new file gets: ``0o666`` minus the process umask."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _fsync_directory(directory: str) -> None:
    """Make the rename durable where the platform allows (best effort)."""
    flags = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0)
    try:
        fd = os.open(directory, flags)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_atomic(path: str | os.PathLike[str], payload: bytes) -> None:
    """Write ``payload`` to ``path`` atomically.

    The bytes go to a temporary file in the target's directory, are fsynced and moved onto
    ``path`` with :func:`os.replace`.  On any failure the temporary file is removed, ``path`` is
    left as it was and the error (an :class:`OSError` for I/O problems) propagates.  A new file
    gets ``0o666`` minus the umask; an overwritten one keeps its permissions.
    """
    target = os.path.abspath(os.fspath(path))
    directory = os.path.dirname(target)
    mode = os.stat(target).st_mode & 0o7777 if os.path.isfile(target) else _new_file_mode()
    stream = tempfile.NamedTemporaryFile(
        mode="wb", dir=directory, prefix=f".{os.path.basename(target)}.", suffix=".tmp",
        delete=False,
    )  # fmt: skip
    temp_name = stream.name
    try:
        with stream:
            stream.write(payload)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(temp_name, mode)
        os.replace(temp_name, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temp_name)
        raise
    _fsync_directory(directory)
