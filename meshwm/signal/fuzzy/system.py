"""The fuzzy system as data: membership functions, linguistic variables, rules, the paper's FIS.

Also its translation to scikit-fuzzy (:func:`build_control_system`), the reference that
:mod:`meshwm.signal.fuzzy.inference` reproduces exactly.
"""

from __future__ import annotations

import functools
import operator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # pragma: no cover
    from skfuzzy.control import ControlSystem

from meshwm._validate import check_integer

__all__ = [
    "EMBEDDING_CLASSES",
    "INPUT_LABELS",
    "INPUT_NAMES",
    "PERCEPTUAL_FIS",
    "WEIGHT_LABELS",
    "FuzzyRule",
    "FuzzySystem",
    "LinguisticVariable",
    "MembershipFunction",
    "build_control_system",
]

#: The crisp inputs, in the order :func:`infer_strength` takes them.
INPUT_NAMES = ("curvature", "area", "bumpiness")
#: The three sets of every input, low to high.
INPUT_LABELS = ("LOW", "MEDIUM", "HIGH")
#: The seven output sets, low to high; :func:`strength_class` returns an index into this.
WEIGHT_LABELS = ("LOWEST", "LOWER", "LOW", "MEDIUM", "HIGH", "HIGHER", "HIGHEST")
#: Indices of the output sets that carry watermark bits (the paper's HIGH and HIGHER).
EMBEDDING_CLASSES = (4, 5)

_ANY = "*"


@dataclass(frozen=True)
class MembershipFunction:
    """One fuzzy set of a linguistic variable: a triangle or a trapezoid.

    Parameters
    ----------
    label : str
        Name of the set, e.g. ``"MEDIUM"``.
    points : tuple of float
        ``(a, b, c)`` for a triangle (0 at ``a`` and ``c``, 1 at ``b``) or ``(a, b, c, d)`` for a
        trapezoid (1 on ``[b, c]``).  ``a == b`` or ``c == d`` gives a shoulder.  All points lie
        in [0, 1], sorted, not all equal.
    """

    label: str
    points: tuple[float, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.label, str) or not self.label or self.label == _ANY:
            raise ValueError(
                f"membership function label must be a non-empty name, got {self.label!r}"
            )
        points = tuple(float(p) for p in self.points)
        if len(points) not in (3, 4):
            raise ValueError(
                f"membership function {self.label!r} needs 3 points (triangle) or 4 (trapezoid), "
                f"got {len(points)}"
            )
        if not all(0.0 <= p <= 1.0 for p in points) or list(points) != sorted(points):
            raise ValueError(
                f"membership function {self.label!r} points must be sorted and in [0, 1], "
                f"got {points}"
            )
        if points[0] == points[-1]:
            raise ValueError(f"membership function {self.label!r} is degenerate: {points}")
        object.__setattr__(self, "points", points)

    def sample(self, universe: NDArray[np.float64]) -> NDArray[np.float64]:
        """Membership degree at each sample of ``universe`` (the formula of skfuzzy's trapmf)."""
        if len(self.points) == 3:
            a, b, d = self.points
            c = b
        else:
            a, b, c, d = self.points
        y = np.zeros(universe.shape, dtype=np.float64)
        rising = (universe > a) & (universe < b)
        y[rising] = (universe[rising] - a) / (b - a)
        y[(universe >= b) & (universe <= c)] = 1.0
        falling = (universe > c) & (universe < d)
        y[falling] = (d - universe[falling]) / (d - c)
        return y


@dataclass(frozen=True)
class LinguisticVariable:
    """A crisp quantity on [0, 1] and its fuzzy sets.

    Parameters
    ----------
    name : str
        ``"curvature"``, ``"area"``, ``"bumpiness"`` or ``"weight"``.
    terms : tuple of MembershipFunction
        The fuzzy sets, low to high.
    samples : int
        The universe is ``np.arange(samples) / (samples - 1)``: ``samples`` evenly spaced points
        on [0, 1], each one correctly rounded.  Every breakpoint of every set must be one of them,
        so the sampled, linearly interpolated sets are exactly the triangles and trapezoids.
    """

    name: str
    terms: tuple[MembershipFunction, ...]
    samples: int

    def __post_init__(self) -> None:
        check_integer(self.samples, name=f"{self.name}: samples", low=2)
        object.__setattr__(self, "terms", tuple(self.terms))
        if not self.terms:
            raise ValueError(f"{self.name}: needs at least one membership function")
        labels = self.labels
        if len(set(labels)) != len(labels):
            raise ValueError(f"{self.name}: membership function labels repeat: {labels}")
        universe = self.universe
        for term in self.terms:
            off = [p for p in term.points if p not in universe]
            if off:
                raise ValueError(
                    f"{self.name}[{term.label}]: breakpoints {off} are not samples of the "
                    f"universe np.arange({self.samples}) / {self.samples - 1}; change samples "
                    "or the breakpoints"
                )

    @property
    def labels(self) -> tuple[str, ...]:
        """Labels of the fuzzy sets, in order."""
        return tuple(term.label for term in self.terms)

    @property
    def universe(self) -> NDArray[np.float64]:
        """``(samples,)`` float64: ``np.arange(samples) / (samples - 1)``."""
        return np.arange(self.samples, dtype=np.float64) / (self.samples - 1)

    def table(self) -> NDArray[np.float64]:
        """``(len(terms), samples)`` float64: each set sampled on :attr:`universe`."""
        universe = self.universe
        return np.stack([term.sample(universe) for term in self.terms])


@dataclass(frozen=True)
class FuzzyRule:
    """``IF curvature is ... AND area is ... AND bumpiness is ... THEN weight is ...``.

    Parameters
    ----------
    curvature, area, bumpiness : tuple of str
        The input sets the rule accepts for that input, OR-ed together (max); an empty tuple
        means *any* (the input is left out of the rule).  Conditions on different inputs are
        AND-ed (min).
    weight : str
        The output set the rule clips at its firing degree.
    reason : str, optional
        Why the rule says what it says (listed in ``docs/fuzzy.md``).
    """

    curvature: tuple[str, ...]
    area: tuple[str, ...]
    bumpiness: tuple[str, ...]
    weight: str
    reason: str = ""

    def __post_init__(self) -> None:
        for name in INPUT_NAMES:
            value = getattr(self, name)
            if isinstance(value, str):
                raise TypeError(f"rule {name} must be a tuple of labels, got the string {value!r}")
            object.__setattr__(self, name, tuple(value))
        if not any(self.conditions()):
            raise ValueError("a rule needs a condition on at least one input")

    def conditions(self) -> tuple[tuple[str, ...], ...]:
        """The accepted labels per input, in :data:`INPUT_NAMES` order (``()`` = any)."""
        return tuple(getattr(self, name) for name in INPUT_NAMES)

    def __str__(self) -> str:
        parts = [
            f"{name} is {' or '.join(labels)}"
            for name, labels in zip(INPUT_NAMES, self.conditions(), strict=True)
            if labels
        ]
        return f"IF {' AND '.join(parts)} THEN weight is {self.weight}"


@dataclass(frozen=True)
class FuzzySystem:
    """A Mamdani FIS with the inputs of :data:`INPUT_NAMES` and one output, ``weight``.

    The single source of truth for :func:`build_control_system` and :func:`infer_strength`.

    Parameters
    ----------
    curvature, area, bumpiness : LinguisticVariable
        The inputs (each variable's ``name`` must be the field's name).
    weight : LinguisticVariable
        The output.
    rules : tuple of FuzzyRule
        Every label a rule names must exist, and every input must appear in some rule (skfuzzy
        refuses inputs no rule uses).
    """

    curvature: LinguisticVariable
    area: LinguisticVariable
    bumpiness: LinguisticVariable
    weight: LinguisticVariable
    rules: tuple[FuzzyRule, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "rules", tuple(self.rules))
        for name in (*INPUT_NAMES, "weight"):
            variable = getattr(self, name)
            if not isinstance(variable, LinguisticVariable) or variable.name != name:
                raise ValueError(f"{name} must be a LinguisticVariable named {name!r}")
        if not self.rules:
            raise ValueError("a fuzzy system needs at least one rule")
        for number, rule in enumerate(self.rules, start=1):
            for variable, labels in zip(self.inputs, rule.conditions(), strict=True):
                unknown = [label for label in labels if label not in variable.labels]
                if unknown:
                    raise ValueError(
                        f"rule {number} ({rule}): {variable.name} has no set {unknown[0]!r}; "
                        f"valid: {', '.join(variable.labels)}"
                    )
            if rule.weight not in self.weight.labels:
                raise ValueError(
                    f"rule {number} ({rule}): weight has no set {rule.weight!r}; "
                    f"valid: {', '.join(self.weight.labels)}"
                )
        for index, name in enumerate(INPUT_NAMES):
            if not any(rule.conditions()[index] for rule in self.rules):
                raise ValueError(f"no rule uses input {name!r}")

    @property
    def inputs(self) -> tuple[LinguisticVariable, LinguisticVariable, LinguisticVariable]:
        """The three input variables, in :data:`INPUT_NAMES` order."""
        return (self.curvature, self.area, self.bumpiness)


def _input_variable(name: str) -> LinguisticVariable:
    return LinguisticVariable(
        name,
        (
            MembershipFunction("LOW", (0.0, 0.0, 0.2, 0.5)),
            MembershipFunction("MEDIUM", (0.2, 0.5, 0.8)),
            MembershipFunction("HIGH", (0.5, 0.8, 1.0, 1.0)),
        ),
        samples=101,
    )


def _rule(curvature: str, area: str, bumpiness: str, weight: str, reason: str) -> FuzzyRule:
    """Write a rule compactly: ``"*"`` is any, ``"MEDIUM|HIGH"`` is an OR."""

    def labels(text: str) -> tuple[str, ...]:
        return () if text == _ANY else tuple(text.split("|"))

    return FuzzyRule(labels(curvature), labels(area), labels(bumpiness), weight, reason)


#: The perceptual FIS of the paper (structure and rule 5 from the paper, the rest our design;
#: ``docs/fuzzy.md`` lists the rules with their reasons).
PERCEPTUAL_FIS = FuzzySystem(
    curvature=_input_variable("curvature"),
    area=_input_variable("area"),
    bumpiness=_input_variable("bumpiness"),
    weight=LinguisticVariable(
        "weight",
        tuple(
            MembershipFunction(label, (max(k - 1, 0) / 6, k / 6, min(k + 1, 6) / 6))
            for k, label in enumerate(WEIGHT_LABELS)
        ),
        samples=121,
    ),
    rules=(
        # curvature, area, bumpiness -> weight
        _rule("LOW", "LOW|MEDIUM", "LOW", "LOWEST",
              "flat and smooth: any change shows; small and medium cells do not help"),
        _rule("LOW", "HIGH", "LOW", "LOWER",
              "flat and smooth, but large cells spread the change a little"),
        _rule("LOW", "*", "MEDIUM", "LOWER",
              "flat with a little roughness: weak masking whatever the cell size"),
        _rule("MEDIUM", "*", "LOW", "LOWER",
              "gently curved but smooth: shading still reveals changes"),
        _rule("MEDIUM", "LOW", "MEDIUM", "LOW",
              "the paper's rule: moderate curvature and roughness, small cells"),
        _rule("MEDIUM", "MEDIUM", "MEDIUM", "MEDIUM",
              "moderate everything: the neutral weight"),
        _rule("MEDIUM", "HIGH", "MEDIUM", "HIGH",
              "moderate curvature and roughness on large cells"),
        _rule("LOW", "*", "HIGH", "MEDIUM",
              "flat but rough: texture masks well even without curvature"),
        _rule("HIGH", "*", "LOW", "LOW",
              "strongly curved but smooth: curvature alone masks less than roughness"),
        _rule("MEDIUM", "LOW", "HIGH", "HIGH",
              "rough and moderately curved, small cells"),
        _rule("MEDIUM", "MEDIUM|HIGH", "HIGH", "HIGHER",
              "rough and moderately curved, medium or large cells"),
        _rule("HIGH", "LOW", "MEDIUM", "MEDIUM",
              "strongly curved, moderately rough, small cells"),
        _rule("HIGH", "MEDIUM|HIGH", "MEDIUM", "HIGH",
              "strongly curved, moderately rough, medium or large cells"),
        _rule("HIGH", "LOW", "HIGH", "HIGHER",
              "curved and rough, small cells: strong masking held back one step"),
        _rule("HIGH", "MEDIUM|HIGH", "HIGH", "HIGHEST",
              "curved and rough with medium or large cells: changes hide best"),
    ),
)  # fmt: skip


def build_control_system(system: FuzzySystem = PERCEPTUAL_FIS) -> ControlSystem:
    """Build the scikit-fuzzy control system for a FIS description (the reference).

    Parameters
    ----------
    system : FuzzySystem, optional
        The description; default :data:`PERCEPTUAL_FIS`.

    Returns
    -------
    skfuzzy.control.ControlSystem
        Antecedents ``curvature``, ``area``, ``bumpiness`` and consequent ``weight`` (centroid
        defuzzification), their universes and sampled sets taken from ``system``, one
        ``skfuzzy.control.Rule`` per rule labelled ``rule 1`` ... in order.  Evaluate it with
        ``skfuzzy.control.ControlSystemSimulation`` and its defaults (``clip_to_bounds=True``).

    Notes
    -----
    Under NumPy >= 2.4, ``ControlSystemSimulation.compute`` in scikit-fuzzy 0.5 emits a
    ``DeprecationWarning`` ("Passing more than 2 positional arguments to np.maximum ...");
    callers filter it (see ``tests/test_fuzzy.py``).  The result is unaffected.

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on
       multi-resolution representation and fuzzy logic", section 2.

    Examples
    --------
    >>> from meshwm.signal.fuzzy import build_control_system
    >>> cs = build_control_system()
    >>> len(list(cs.rules)), sorted(v.label for v in cs.antecedents)
    (15, ['area', 'bumpiness', 'curvature'])
    """
    from skfuzzy import control

    def variable(kind: Any, spec: LinguisticVariable) -> Any:
        var = kind(spec.universe, spec.name)
        for term, row in zip(spec.terms, spec.table(), strict=True):
            var[term.label] = row
        return var

    inputs = [variable(control.Antecedent, spec) for spec in system.inputs]
    weight = control.Consequent(system.weight.universe, "weight", defuzzify_method="centroid")
    for term, row in zip(system.weight.terms, system.weight.table(), strict=True):
        weight[term.label] = row
    rules = []
    for number, rule in enumerate(system.rules, start=1):
        clauses = [
            functools.reduce(operator.or_, (var[label] for label in labels))
            for var, labels in zip(inputs, rule.conditions(), strict=True)
            if labels
        ]
        antecedent = functools.reduce(operator.and_, clauses)
        rules.append(control.Rule(antecedent, weight[rule.weight], label=f"rule {number}"))
    return control.ControlSystem(rules)
