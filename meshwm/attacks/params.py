"""The options of every attack: :class:`AttackParam`, the :data:`ATTACK_PARAMS` table, the check.

Each option is described once, with its type, default, meaning (unit) and allowed range; the
attacks check their options against it (:func:`check_options`) and the CLI parses and lists
them from it.  Pure data: importing this module loads no mesh library, so the registry and the
command line can read it without importing a single attack.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io import WRITE_SUFFIXES

__all__ = ["ATTACK_PARAMS", "AttackParam", "Mesh", "check_options"]

#: What every attack returns: ``(vertices (n, 3) float64, faces (m, 3) int64)``.
Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]


@dataclass(frozen=True)
class AttackParam:
    """One option of an attack: its type, default, meaning (with unit) and allowed values.

    Attributes
    ----------
    name : str
        Keyword name (and ``--name`` on the command line).
    type : type
        ``int``, ``float`` or ``str``.
    default : int, float, str or None
        Value used when the option is not given (``None``: see ``meaning``).
    meaning : str
        What the value means, with its unit.
    low, high : float, optional
        Bounds of the allowed range (``None``: unbounded).
    open_low, open_high : bool
        The bound itself is not allowed.
    choices : tuple of str, optional
        The allowed strings (``type`` is ``str``).
    odd : bool
        Only odd integers are allowed.
    """

    name: str
    type: type
    default: Any
    meaning: str
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    choices: tuple[str, ...] | None = None
    odd: bool = False

    @property
    def allowed(self) -> str:
        """The allowed values in words, e.g. ``'a number in (0, 1]'``."""
        if self.choices is not None:
            return f"one of {', '.join(self.choices)}"
        what = {int: "an odd integer" if self.odd else "an integer", float: "a number"}[self.type]
        if self.type is int and self.low is not None and self.high is not None:
            return f"{what} in {self.low:g}..{self.high:g}"
        if self.low is not None and self.high is not None:
            left = "(" if self.open_low else "["
            right = ")" if self.open_high else "]"
            return f"{what} in {left}{self.low:g}, {self.high:g}{right}"
        if self.low is not None:
            return f"{what} {'>' if self.open_low else '>='} {self.low:g}"
        return what

    def check(self, value: Any, attack: str) -> Any:
        """Return ``value`` as this parameter's type, or raise.

        Raises
        ------
        TypeError
            Wrong type (``bool`` is not an integer here).
        ValueError
            Outside the allowed range; the message names the attack, the parameter, the
            allowed values and the value received.
        """
        if value is None and self.default is None:
            return None
        expected = {int: "an integer", float: "a number", str: "a string"}[self.type]
        if self.type is str:
            ok_type = isinstance(value, str)
        elif self.type is int:
            ok_type = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        else:
            ok_type = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                value, bool
            )
        if not ok_type:
            raise TypeError(f"{attack}: {self.name} must be {expected}, got {type(value).__name__}")
        value = self.type(value)
        if self._in_range(value):
            return value
        raise ValueError(f"{attack}: {self.name} must be {self.allowed}, got {value!r}")

    def _in_range(self, value: Any) -> bool:
        if self.choices is not None:
            return value in self.choices
        if self.type is float and not math.isfinite(value):
            return False
        if self.odd and value % 2 == 0:
            return False
        if self.low is not None and (value <= self.low if self.open_low else value < self.low):
            return False
        return not (
            self.high is not None and (value >= self.high if self.open_high else value > self.high)
        )

    def parse(self, text: str, attack: str) -> Any:
        """Convert command-line text to a checked value (``ValueError`` if it is not one)."""
        if self.type is str:
            return self.check(text, attack)
        try:
            value = self.type(text)
        except ValueError:
            raise ValueError(
                f"{attack}: {self.name} must be {self.allowed}, got {text!r}"
            ) from None
        return self.check(value, attack)


_ITERATIONS = "number of iterations"

#: The options of every attack in :data:`~meshwm.attacks.ATTACKS` (``seed`` aside: every
#: attack takes it).
ATTACK_PARAMS: dict[str, tuple[AttackParam, ...]] = {
    "similarity": (
        AttackParam(
            "scale",
            float,
            None,
            "uniform scale factor (default: log-uniform in [0.01, 100] from the seed)",
            low=0,
            open_low=True,
        ),
    ),
    "rotation": (),
    "mirror": (),
    "translation": (
        AttackParam(
            "distance",
            float,
            10.0,
            "length of the move, in bounding-box diagonals",
            low=0,
            open_low=True,
        ),
    ),
    "scaling": (
        AttackParam(
            "factor",
            float,
            2.0,
            "uniform scale factor about the centroid of the vertices",
            low=0,
            open_low=True,
        ),
    ),
    "reorder": (),
    "noise": (
        AttackParam(
            "amplitude",
            float,
            0.001,
            "noise bound as a fraction of d̄, the mean vertex-to-centroid distance",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "float32": (),
    "round_trip": (
        AttackParam("suffix", str, ".stl", "file format written and read", choices=WRITE_SUFFIXES),
    ),
    "laplacian": (
        AttackParam("lam", float, 0.1, "step λ per iteration", low=0, high=1, open_low=True),
        AttackParam("iterations", int, 5, _ITERATIONS, low=1, high=1000),
    ),
    "meshlab_laplacian": (
        AttackParam("iterations", int, 3, "MeshLab stepsmoothnum", low=1, high=1000),
    ),
    "taubin": (
        AttackParam("lam", float, 0.5, "shrinking step λ", low=0, high=1, open_low=True),
        AttackParam("mu", float, -0.53, "inflating step μ", low=-1, high=0, open_high=True),
        AttackParam("iterations", int, 10, "MeshLab stepsmoothnum (λ|μ pairs)", low=1, high=1000),
    ),
    "quantize": (
        AttackParam("bits", int, 9, "bits per bounding-box axis (2**bits levels)", low=7, high=16),
    ),
    "crop": (
        AttackParam(
            "fraction",
            float,
            0.1,
            "fraction of the surface area removed",
            low=0,
            high=1,
            open_low=True,
            open_high=True,
        ),
    ),
    "simplify": (
        AttackParam(
            "keep_fraction",
            float,
            0.5,
            "fraction of the faces kept",
            low=0,
            high=1,
            open_low=True,
            open_high=True,
        ),
    ),
    "subdivide_midpoint": (AttackParam("iterations", int, 1, _ITERATIONS, low=1, high=3),),
    "subdivide_loop": (AttackParam("iterations", int, 1, _ITERATIONS, low=1, high=3),),
    "remesh_isotropic": (AttackParam("iterations", int, 3, "remeshing rounds", low=1, high=10),),
    "poisson": (
        AttackParam("depth", int, 8, "octree depth of the reconstruction", low=5, high=11),
    ),
    "flip_edges": (
        AttackParam("count", int, 10, "number of edges flipped (fewer if fewer qualify)", low=0),
        AttackParam(
            "max_dihedral",
            float,
            10.0,
            "largest angle between the two faces' normals of a flipped edge, degrees",
            low=0,
            high=180,
            open_low=True,
            open_high=True,
        ),
    ),
    "retriangulate": (
        AttackParam(
            "fraction",
            float,
            0.2,
            "fraction of the flat quads (face pairs, dihedral < 10°) given the other diagonal",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "split_seams": (
        AttackParam("paths", int, 3, "number of seams cut (vertex paths duplicated)", low=1),
        AttackParam("length", int, 20, "edges per seam", low=2),
    ),
    "merge_load": (),
    "weld_stl": (),
    "gim_gaussian": (
        AttackParam("hsize", int, 3, "kernel side, samples", low=3, high=31, odd=True),
        AttackParam(
            "sigma",
            float,
            10.0,
            "Gaussian standard deviation, samples",
            low=0,
            high=100,
            open_low=True,
        ),
    ),
    "gim_log": (
        AttackParam("hsize", int, 5, "kernel side, samples", low=3, high=31, odd=True),
        AttackParam(
            "sigma",
            float,
            0.5,
            "Gaussian standard deviation, samples",
            low=0,
            high=10,
            open_low=True,
        ),
    ),
    "gim_laplacian": (
        AttackParam(
            "alpha", float, 1.0, "weight of the diagonal neighbours (fspecial)", low=0, high=1
        ),
    ),
    "gim_salt_pepper": (
        AttackParam(
            "density",
            float,
            0.05,
            "probability that a sample of a matrix is hit (half min, half max)",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "gim_noise": (
        AttackParam(
            "amplitude",
            float,
            0.1,
            "noise bound as a fraction of each matrix's range (max - min)",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "gim_crop": (
        AttackParam(
            "fraction",
            float,
            0.09,
            "fraction of the geometry-image samples in the cropped square",
            low=0,
            high=1,
            open_low=True,
            open_high=True,
        ),
    ),
}


def check_options(attack: str, **values: Any) -> dict[str, Any]:
    """Check an attack's options against :data:`ATTACK_PARAMS`; the converted values.

    Raises
    ------
    TypeError, ValueError
        See :meth:`AttackParam.check`.
    """
    spec = {p.name: p for p in ATTACK_PARAMS[attack]}
    return {name: spec[name].check(value, attack) for name, value in values.items()}
