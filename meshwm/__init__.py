"""meshwm: blind, robust watermarking of 3D triangle meshes through geometry images.

The method follows Tamane & Deshmukh, *Blind 3D model watermarking based on multi-resolution
representation and fuzzy logic*.  The public API is this module's ``__all__``; the stages live in
sub-packages (see ``docs/architecture.md``)::

    mesh (files, cleaning) -> gim (geometry images, grid recovery) -> signal (wavelets, fuzzy
    mask) -> message (mark, payload, keying) -> profiles (embed / decode a sampled image) ->
    readers (received mesh -> sampled image) -> watermark (composition) -> detect (decision)
    -> apps (cli, batch, demo, render, bench)

Names are imported on first use, so ``import meshwm`` (and ``meshwm --help``) loads no mesh
library.

Examples
--------
>>> import meshwm
>>> meshwm.WatermarkParams().size
256
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> the module that defines it.
_API = {
    "embed": "meshwm.watermark",
    "extract": "meshwm.watermark",
    "extract_id": "meshwm.watermark",
    "verify": "meshwm.watermark",
    "read_mesh": "meshwm.mesh.io",
    "write_mesh": "meshwm.mesh.io",
    "parse_id": "meshwm.message.payload",
    "format_id": "meshwm.message.payload",
    "read_asset": "meshwm.mesh.asset",
    "write_asset": "meshwm.mesh.asset",
    "embed_asset": "meshwm.watermark.assets",
    "verify_asset": "meshwm.watermark.assets",
    "extract_asset": "meshwm.watermark.assets",
    "WatermarkParams": "meshwm.params",
    "Verdict": "meshwm.detect",
    "CapacityError": "meshwm.errors",
    "GridError": "meshwm.errors",
    "MeshError": "meshwm.errors",
    "RegistryError": "meshwm.errors",
}

#: Sub-packages reachable as attributes without an import (``meshwm.data.path("spot")``).
_SUBPACKAGES = ("data",)

__all__ = [
    "CapacityError",
    "GridError",
    "MeshError",
    "RegistryError",
    "Verdict",
    "WatermarkParams",
    "__version__",
    "data",
    "embed",
    "embed_asset",
    "extract",
    "extract_asset",
    "extract_id",
    "format_id",
    "parse_id",
    "read_asset",
    "read_mesh",
    "verify",
    "verify_asset",
    "write_asset",
    "write_mesh",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from meshwm import data
    from meshwm.detect import Verdict
    from meshwm.errors import CapacityError, GridError, MeshError, RegistryError
    from meshwm.mesh.asset import read_asset, write_asset
    from meshwm.mesh.io import read_mesh, write_mesh
    from meshwm.message.payload import format_id, parse_id
    from meshwm.params import WatermarkParams
    from meshwm.watermark import embed, extract, extract_id, verify
    from meshwm.watermark.assets import embed_asset, extract_asset, verify_asset


def __getattr__(name: str) -> Any:
    if name in _SUBPACKAGES:
        return importlib.import_module(f"meshwm.{name}")
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'meshwm' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_API, *_SUBPACKAGES])
