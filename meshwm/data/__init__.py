"""Files shipped inside the package, found from any folder: the spot mesh, the logo, the docs.

:func:`path` gives a bundled file by name (``"spot"``: Keenan Crane's cow, public domain,
2930 vertices; ``"mark32"``: the 32×32 logo :func:`meshwm.message.mark.default_mark` draws).
:func:`doc_topics` lists the documentation pages that ``meshwm docs TOPIC`` prints: in an
installed wheel they are package data (copied from ``docs/`` when the wheel is built, see
``setup.py``); in a source checkout they are read from ``docs/`` itself.

Examples
--------
>>> from meshwm import data
>>> data.path("spot").name, data.path("spot").is_file()
('spot.ply', True)
>>> "assets" in doc_topics()
True
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["BUNDLED", "doc_topics", "path"]

#: Bundled file name by short name.
BUNDLED = {"spot": "spot.ply", "mark32": "mark32.png"}


def _here() -> Path:
    return Path(str(resources.files("meshwm") / "data"))


def path(name: str) -> Path:
    """The path of the bundled file ``name`` (see :data:`BUNDLED`).

    Raises
    ------
    ValueError
        An unknown name; the message lists the known ones.
    """
    file = BUNDLED.get(name)
    if file is None:
        raise ValueError(f"no bundled file {name!r}; the bundled files are {', '.join(BUNDLED)}")
    return _here() / file


def _docs_dir() -> Path | None:
    packaged = _here() / "docs"
    if packaged.is_dir():
        return packaged
    checkout = Path(__file__).resolve().parents[2] / "docs"
    return checkout if (checkout / "architecture.md").is_file() else None


def doc_topics() -> dict[str, Path]:
    """Documentation page by topic (the file's stem), sorted; empty if none is installed."""
    folder = _docs_dir()
    if folder is None:
        return {}
    return {p.stem: p for p in sorted(folder.glob("*.md"))}
