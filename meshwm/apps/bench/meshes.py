"""The meshes a bench run reads: the bundled ones, a folder of them, each loaded once."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io import READ_SUFFIXES, read_mesh


class Model(NamedTuple):
    """A mesh as read: its name (the file's stem), path, (n, 3) vertices and (m, 3) faces."""

    name: str
    path: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]


def load_model(name: str, path: Path) -> Model:
    """Read the mesh at ``path`` (:func:`meshwm.mesh.io.read_mesh`) as ``name``."""
    v, f = read_mesh(path)
    return Model(name, str(path), v, f)


def bundled_models() -> list[tuple[str, Path]]:
    """The bundled meshes: ``assets/`` of a source checkout, else the packaged spot only."""
    assets = Path(__file__).resolve().parents[3] / "assets"  # meshwm/apps/bench/meshes.py
    found = [(n, assets / f"{n}.ply") for n in ("spot", "kitten", "plane_holes")]
    if all(p.is_file() for _, p in found):
        return found
    return [("spot", packaged_spot())]


def packaged_spot() -> Path:
    """The spot mesh shipped inside the package (``meshwm/data/spot.ply``)."""
    return Path(str(resources.files("meshwm") / "data" / "spot.ply"))


def meshes_in(folder: str | os.PathLike) -> list[tuple[str, Path]]:
    """Every mesh file of a folder (by suffix), sorted by name; ``ValueError`` if none."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder")
    found = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in READ_SUFFIXES)
    if not found:
        raise ValueError(f"{folder}: no mesh files ({', '.join(READ_SUFFIXES)})")
    return [(p.stem, p) for p in found]


def show_path(path: Path) -> str:
    """A mesh path for the record: relative to the working folder when inside it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)
