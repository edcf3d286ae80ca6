"""Write a document: same format (only moved positions change) or converted; atomically."""

from __future__ import annotations

from pathlib import Path

from meshwm._atomic import write_atomic
from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset
from meshwm.mesh.asset.registry import ASSET_SUFFIXES, FORMATS
from meshwm.mesh.io.common import PathLike, check_destination, describe, mesh_error

__all__ = ["asset_bytes", "check_asset_output", "missing_sidecars", "write_asset"]


def check_asset_output(
    path: PathLike, *, overwrite_input: PathLike | None = None, force: bool = False
) -> None:
    """Raise early if :func:`write_asset` would refuse ``path``: suffix, folder, the input.

    Raises
    ------
    MeshError
        An unknown suffix (the message lists the valid ones), a missing folder, or ``path``
        is ``overwrite_input`` (:func:`os.path.samefile`) without ``force``.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        what = f"{suffix!r} files" if suffix else "files without a suffix"
        raise mesh_error(
            path, f"cannot write {what}; valid output suffixes are {', '.join(ASSET_SUFFIXES)}"
        )
    check_destination(path, overwrite_input=overwrite_input, force=force)


def asset_bytes(asset: Asset, suffix: str | None = None) -> bytes:
    """The bytes of ``asset`` as a ``suffix`` file (default: its own format).

    In its own format only the moved positions differ from the file read; in another the
    document is converted (:func:`meshwm.mesh.asset.convert.convert`).
    """
    own = FORMATS[asset.suffix].write(asset)
    suffix = (suffix or asset.suffix).lower()
    if suffix == asset.suffix:
        return own
    from meshwm.mesh.asset.convert import convert

    return convert(asset, own, suffix)


def missing_sidecars(asset: Asset, output: PathLike) -> list[str]:
    """Files the document names (material libraries, textures, buffers) that sit next to the
    input but not next to ``output``: they must be copied along for the output to be whole."""
    if asset.path is None:
        return []
    source, target = asset.path.resolve().parent, Path(output).resolve().parent
    if source == target:
        return []
    return [
        name for name in asset.sidecars if (source / name).exists() and not (target / name).exists()
    ]


def write_asset(
    path: PathLike,
    asset: Asset,
    *,
    overwrite_input: PathLike | None = None,
    force: bool = False,
) -> Asset:
    """Write ``asset`` to ``path`` atomically; return the document as written (read back).

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its suffix picks the format (the document's own keeps every byte but the
        moved positions).
    asset : Asset
        The document (:meth:`~meshwm.mesh.asset.document.Asset.with_positions`).
    overwrite_input : str or os.PathLike, optional
        The file read; writing onto it is refused unless ``force``.
    force : bool, optional
        Allow overwriting ``overwrite_input``.

    Returns
    -------
    Asset
        The written bytes parsed again, before they replace ``path``: its
        :attr:`~meshwm.mesh.asset.document.Asset.summary` says what the file holds.

    Raises
    ------
    MeshError
        Any refusal of :func:`check_asset_output`, a conversion that fails, or an I/O error;
        ``path`` is then left as it was.
    """
    check_asset_output(path, overwrite_input=overwrite_input, force=force)
    suffix = Path(path).suffix.lower()
    try:
        payload = asset_bytes(asset, suffix)
        written = FORMATS[suffix].read(payload, asset.path)
    except MeshError as exc:
        raise mesh_error(path, str(exc)) from None
    try:
        write_atomic(path, payload)
    except OSError as exc:
        raise mesh_error(path, f"cannot write file ({exc.strerror or describe(exc)})") from exc
    return written
