"""The attack registry: :data:`ATTACKS` (name -> function) and :func:`apply_attack`.

An attack is one function in the module of its kind plus one entry in :data:`_MODULES` and
one in :data:`~meshwm.attacks.params.ATTACK_PARAMS`.  :data:`ATTACKS` imports a kind's module
the first time one of its attacks is looked up, so listing the names (the CLI's ``choices=``)
loads no mesh library: pymeshlab, SciPy and libigl come with the attacks that use them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from typing import Any

from numpy.typing import NDArray

from meshwm.attacks.params import ATTACK_PARAMS, Mesh

__all__ = ["ATTACKS", "apply_attack"]

_TRANSFORMS = "meshwm.attacks.transforms"
_SMOOTHING = "meshwm.attacks.smoothing"
_TESSELLATION = "meshwm.attacks.tessellation"
_IMAGE = "meshwm.attacks.image"
_CONNECTIVITY = "meshwm.attacks.connectivity"
_SEAMS = "meshwm.attacks.seams"

#: Attack name -> the module that defines the function of that name.
_MODULES: dict[str, str] = {
    "similarity": _TRANSFORMS,
    "rotation": _TRANSFORMS,
    "mirror": _TRANSFORMS,
    "translation": _TRANSFORMS,
    "scaling": _TRANSFORMS,
    "reorder": _TRANSFORMS,
    "noise": _TRANSFORMS,
    "float32": _TRANSFORMS,
    "round_trip": _TRANSFORMS,
    "laplacian": _SMOOTHING,
    "meshlab_laplacian": _SMOOTHING,
    "taubin": _SMOOTHING,
    "quantize": _TRANSFORMS,
    "crop": _TRANSFORMS,
    "simplify": _TESSELLATION,
    "subdivide_midpoint": _TESSELLATION,
    "subdivide_loop": _TESSELLATION,
    "remesh_isotropic": _TESSELLATION,
    "poisson": _TESSELLATION,
    "flip_edges": _CONNECTIVITY,
    "retriangulate": _CONNECTIVITY,
    "split_seams": _SEAMS,
    "merge_load": _SEAMS,
    "weld_stl": _SEAMS,
    "gim_gaussian": _IMAGE,
    "gim_log": _IMAGE,
    "gim_laplacian": _IMAGE,
    "gim_salt_pepper": _IMAGE,
    "gim_noise": _IMAGE,
    "gim_crop": _IMAGE,
}


class _Registry(Mapping[str, Callable[..., Mesh]]):
    """Read-only mapping name -> attack function; a function's module is imported on lookup.

    Iterating, ``len`` and ``in`` import nothing.
    """

    def __init__(self, modules: dict[str, str]) -> None:
        self._modules = modules
        self._functions: dict[str, Callable[..., Mesh]] = {}

    def __getitem__(self, name: str) -> Callable[..., Mesh]:
        function = self._functions.get(name)
        if function is None:
            module = importlib.import_module(self._modules[name])
            function = self._functions[name] = getattr(module, name)
        return function

    def __contains__(self, name: object) -> bool:
        return name in self._modules

    def __iter__(self) -> Iterator[str]:
        return iter(self._modules)

    def __len__(self) -> int:
        return len(self._modules)

    def __repr__(self) -> str:
        return f"<attack registry: {', '.join(self._modules)}>"


#: Every attack: ``attack(vertices, faces, *, seed=0, **options) -> (vertices, faces)``.
ATTACKS: Mapping[str, Callable[..., Mesh]] = _Registry(_MODULES)


def apply_attack(name: str, vertices: NDArray, faces: NDArray, **options: Any) -> Mesh:
    """Run the attack called ``name`` (a key of :data:`ATTACKS`).

    Parameters
    ----------
    name : str
        The attack.
    vertices, faces : array_like
        The mesh.
    **options
        ``seed`` and the attack's options (:data:`~meshwm.attacks.params.ATTACK_PARAMS`).

    Raises
    ------
    ValueError
        Unknown attack or option (the message lists the valid ones), or a bad option value.

    Examples
    --------
    >>> import numpy as np
    >>> v = np.eye(3); f = np.array([[0, 1, 2]])
    >>> v2, f2 = apply_attack("float32", v, f)
    >>> bool(np.array_equal(v2, v))
    True
    """
    if name not in ATTACKS:
        raise ValueError(f"unknown attack {name!r}; valid: {', '.join(sorted(ATTACKS))}")
    valid = ["seed", *(p.name for p in ATTACK_PARAMS[name])]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ValueError(
            f"{name}: unknown option {', '.join(map(repr, unknown))}; valid: {', '.join(valid)}"
        )
    return ATTACKS[name](vertices, faces, **options)
