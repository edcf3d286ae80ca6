"""What the commands share on the way out: exit codes, report rounding, checks of a PNG output."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["EXIT_ABSENT", "EXIT_ERROR", "EXIT_OK", "check_png", "rounded", "together_text"]

#: Success (for ``verify``: the mark is present).
EXIT_OK = 0
#: ``verify``: the mark is absent.
EXIT_ABSENT = 1
#: Any error: a bad option, an unreadable input, a mesh that holds no grid.
EXIT_ERROR = 2


def rounded(report: dict[str, Any]) -> dict[str, Any]:
    """Floats to 6 significant digits (not decimals: p-values and thresholds are tiny).

    Examples
    --------
    >>> rounded({"p_value": 1.23456789e-9, "n": 3})
    {'p_value': 1.23457e-09, 'n': 3}
    """
    return {k: float(f"{v:.6g}") if isinstance(v, float) else v for k, v in report.items()}


def check_png(
    path: Path, inputs: Sequence[Path | None], *, what: str, force: bool | None = None
) -> None:
    """Refuse, before any work, a PNG output that is misnamed, homeless or an input.

    ``force=None``: the command has no ``--force``; the input is never overwritten.
    """
    if path.suffix.lower() != ".png":
        raise ValueError(f"{path}: the {what} is written as PNG; give the file a .png suffix")
    if not path.resolve().parent.is_dir():
        raise ValueError(f"{path}: folder {path.parent} does not exist")
    for source in inputs:
        if source is not None and not force and path.exists() and source.exists():
            if path.samefile(source):
                hint = "" if force is None else "; use --force"
                raise ValueError(f"{path}: would overwrite the input{hint}")


def together_text(joined: dict[str, Any]) -> str:
    """How a mesh read as one with others of its file says so (a row's ``together``)."""
    others = len(joined["meshes"]) - 1
    return (
        f"read as one mesh with the file's {others} other mesh{'es' if others > 1 else ''}, "
        f"{joined['vertices']} vertices"
    )
