"""Tests for :mod:`meshwm.signal.fuzzy`: the fuzzy perceptual mask (paper section 2, section 3, 7).

The reference is scikit-fuzzy's own ``ControlSystemSimulation`` run on the control system
:func:`meshwm.signal.fuzzy.build_control_system` builds from the same description, one point at a
time.
"""

from __future__ import annotations

import itertools
import warnings
from pathlib import Path

import numpy as np
import pytest
import skfuzzy
from numpy.testing import assert_allclose, assert_array_equal
from skfuzzy import control

from meshwm.signal.fuzzy import (
    EMBEDDING_CLASSES,
    INPUT_LABELS,
    INPUT_NAMES,
    PERCEPTUAL_FIS,
    WEIGHT_LABELS,
    FuzzyRule,
    FuzzySystem,
    LinguisticVariable,
    MembershipFunction,
    build_control_system,
    infer_strength,
    strength_class,
)

DOCS = Path(__file__).parent.parent.parent / "docs" / "fuzzy.md"

#: Agreement with skfuzzy (the brief's bound; measured: a few 1e-16).
ATOL_SKFUZZY = 1e-9
#: Rounding differences between our own code paths (chunking, broadcasting).
ATOL_ROUNDING = 1e-14
#: Largest drop of the weight when ONE input increases (measured 0.042 on a 101^3 grid): max
#: aggregation + centroid is not monotone where two rules with the same conclusion hand over.
MONOTONE_SLACK = 0.05

#: scikit-fuzzy 0.5 calls np.maximum(a, b, out) positionally, deprecated in NumPy 2.4.
SKFUZZY_NUMPY_WARNING = r"Passing more than 2 positional arguments to np\.maximum"

#: Breakpoints of the input sets, the universe ends and points between them.
SPECIAL = (0.0, 0.2, 0.35, 0.5, 0.65, 0.8, 1.0)
#: Values within rounding of a breakpoint, and outside the universe (clipped).
NEAR = (0.2 - 1e-12, 0.2 + 1e-12, 0.5 - 1e-12, 0.5 + 1e-12, 0.8 - 1e-13, 1e-15, -0.5, 1.5)


def skfuzzy_weights(points: np.ndarray, system: FuzzySystem = PERCEPTUAL_FIS) -> np.ndarray:
    """The reference: skfuzzy with its default options, one point at a time; NaN where it gives
    no output.

    Each distinct point is computed once: skfuzzy's cache would answer a repeated point that has
    no output with the output of the point before it.
    """
    unique, inverse = np.unique(points, axis=0, return_inverse=True)
    simulation = control.ControlSystemSimulation(build_control_system(system))
    out = np.empty(len(unique))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", SKFUZZY_NUMPY_WARNING, DeprecationWarning)
        for i, point in enumerate(unique):
            for name, value in zip(INPUT_NAMES, point, strict=True):
                simulation.input[name] = float(value)
            simulation.compute()
            out[i] = simulation.output.get("weight", np.nan)
    return out[inverse.ravel()]


def ours(points: np.ndarray, **kwargs) -> np.ndarray:
    return infer_strength(points[:, 0], points[:, 1], points[:, 2], **kwargs)


def cube(*axes: np.ndarray) -> np.ndarray:
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


# --- agreement with scikit-fuzzy ---------------------------------------------------------------


@pytest.mark.slow
def test_matches_skfuzzy_on_random_inputs():
    points = np.random.default_rng(20240603).random((1000, 3))
    assert_allclose(ours(points), skfuzzy_weights(points), rtol=0, atol=ATOL_SKFUZZY)


@pytest.mark.slow
def test_matches_skfuzzy_on_edges_breakpoints_and_rule_centres():
    """Every combination of 0, 1, the breakpoints and points between them (343, including the
    27 centres of the rules' cells), plus 200 combinations with values within 1e-12 of a
    breakpoint or outside [0, 1]."""
    grid = cube(*[np.array(SPECIAL)] * 3)
    values = np.array(SPECIAL + NEAR)
    mixed = np.random.default_rng(7).choice(values, size=(200, 3))
    points = np.vstack([grid, mixed])
    assert_allclose(ours(points), skfuzzy_weights(points), rtol=0, atol=ATOL_SKFUZZY)


def _sparse_system() -> FuzzySystem:
    """A different FIS: coarse universes, a trapezoidal output with plateaus, unused output
    sets, an OR over three sets and a rule that leaves two inputs out."""
    steps = LinguisticVariable(
        "curvature",
        (
            MembershipFunction("LOW", (0.0, 0.0, 0.3)),
            MembershipFunction("HIGH", (0.1, 0.6, 0.9, 1.0)),
        ),
        samples=21,
    )
    return FuzzySystem(
        curvature=steps,
        area=LinguisticVariable("area", PERCEPTUAL_FIS.area.terms, samples=11),
        bumpiness=PERCEPTUAL_FIS.bumpiness,
        weight=LinguisticVariable(
            "weight",
            (
                MembershipFunction("UNUSED", (0.0, 0.0, 0.5)),
                MembershipFunction("SOME", (0.0, 0.25, 0.5, 0.75)),
                MembershipFunction("MORE", (0.5, 0.75, 1.0)),
                MembershipFunction("ALSO_UNUSED", (0.75, 1.0, 1.0)),
            ),
            samples=41,
        ),
        rules=(
            FuzzyRule(("HIGH",), ("LOW", "MEDIUM", "HIGH"), ("HIGH",), "MORE"),
            FuzzyRule(("LOW",), (), (), "SOME"),
            FuzzyRule((), ("HIGH",), ("MEDIUM",), "SOME"),
        ),
    )


@pytest.mark.slow
def test_matches_skfuzzy_on_another_system():
    points = np.vstack(
        [np.random.default_rng(11).random((250, 3)), cube(*[np.array(SPECIAL)] * 3)[::5]]
    )
    expected = skfuzzy_weights(points, _sparse_system())
    assert np.isnan(expected).any() and not np.isnan(expected).all()  # both cases covered
    assert_allclose(ours(points, system=_sparse_system()), expected, rtol=0, atol=ATOL_SKFUZZY)


def test_no_rule_fires_gives_nan_where_skfuzzy_gives_no_output():
    system = _sparse_system()  # curvature 0.5 is not LOW: rules 1 and 3 need more bumpiness
    points = np.array([[0.5, 0.0, 0.0], [0.5, 0.2, 0.3], [0.0, 0.0, 0.0], [0.7, 1.0, 1.0]])
    expected = skfuzzy_weights(points, system)
    assert_array_equal(np.isnan(expected), [True, True, False, False])
    assert_allclose(ours(points, system=system), expected, rtol=0, atol=ATOL_SKFUZZY)


def test_sampled_sets_are_skfuzzys_trimf_and_trapmf():
    for variable in (*PERCEPTUAL_FIS.inputs, PERCEPTUAL_FIS.weight):
        for term, row in zip(variable.terms, variable.table(), strict=True):
            make = skfuzzy.trimf if len(term.points) == 3 else skfuzzy.trapmf
            assert_array_equal(row, make(variable.universe, list(term.points)))


def test_every_breakpoint_is_a_sample_so_sets_peak_at_one():
    for variable in (*PERCEPTUAL_FIS.inputs, PERCEPTUAL_FIS.weight):
        assert np.all(variable.table().max(axis=1) == 1.0)
        for term in variable.terms:
            assert set(term.points) <= set(variable.universe.tolist())


def test_control_system_is_built_from_the_description():
    system = build_control_system()
    rules = list(system.rules)
    assert len(rules) == 15
    assert {str(rule.label) for rule in rules} == {f"rule {k}" for k in range(1, 16)}
    assert sorted(a.label for a in system.antecedents) == sorted(INPUT_NAMES)
    (weight,) = system.consequents
    assert weight.label == "weight" and weight.defuzzify_method == "centroid"
    assert list(weight.terms) == list(WEIGHT_LABELS)
    assert_array_equal(weight.universe, np.arange(121) / 120)
    for antecedent in system.antecedents:
        assert list(antecedent.terms) == list(INPUT_LABELS)
        assert_array_equal(antecedent.universe, np.arange(101) / 100)


# --- the rule base -----------------------------------------------------------------------------


def _level(rule: FuzzyRule) -> int:
    return WEIGHT_LABELS.index(rule.weight)


def _matching(combo: tuple[str, str, str]) -> list[int]:
    return [
        number
        for number, rule in enumerate(PERCEPTUAL_FIS.rules, start=1)
        if all(not c or label in c for c, label in zip(rule.conditions(), combo, strict=True))
    ]


def test_fifteen_rules_including_the_papers():
    rules = PERCEPTUAL_FIS.rules
    assert len(rules) == 15
    paper = FuzzyRule(("MEDIUM",), ("LOW",), ("MEDIUM",), "LOW")
    assert any(rule.conditions() == paper.conditions() and rule.weight == "LOW" for rule in rules)
    assert str(rules[4]) == (
        "IF curvature is MEDIUM AND area is LOW AND bumpiness is MEDIUM THEN weight is LOW"
    )
    assert {rule.weight for rule in rules} == set(WEIGHT_LABELS)  # all seven sets are used
    assert all(rule.reason for rule in rules)


@pytest.mark.parametrize("combo", list(itertools.product(INPUT_LABELS, repeat=3)))
def test_rules_partition_the_27_combinations(combo):
    """Exactly one rule covers each combination of input sets, so with the Ruspini inputs every
    input fires some rule at degree >= 0.5 and no two rules disagree about a cell."""
    assert len(_matching(combo)) == 1


def test_crisp_rule_table_is_monotone_in_each_input():
    level = {}
    for combo in itertools.product(range(3), repeat=3):
        (number,) = _matching(tuple(INPUT_LABELS[i] for i in combo))
        level[combo] = _level(PERCEPTUAL_FIS.rules[number - 1])
    for combo, value in level.items():
        for axis in range(3):
            if combo[axis] < 2:
                up = tuple(c + (k == axis) for k, c in enumerate(combo))
                assert level[up] >= value, (combo, axis)


@pytest.mark.parametrize("combo", list(itertools.product(range(3), repeat=3)))
def test_rule_centres_give_the_rules_conclusion(combo):
    """At a cell's centre (inputs 0, 0.5 or 1) exactly one rule fires, at degree 1: the weight
    is the centroid of its output set and the class is that set."""
    point = [(0.0, 0.5, 1.0)[i] for i in combo]
    (number,) = _matching(tuple(INPUT_LABELS[i] for i in combo))
    k = _level(PERCEPTUAL_FIS.rules[number - 1])
    centroid = {0: 1 / 18, 6: 17 / 18}.get(k, k / 6)
    weight = infer_strength(*point)
    assert_allclose(weight, centroid, rtol=0, atol=1e-12)
    assert strength_class(weight) == k


def test_docs_list_every_rule():
    text = DOCS.read_text(encoding="utf-8")
    for number, rule in enumerate(PERCEPTUAL_FIS.rules, start=1):
        cells = [" or ".join(labels) or "any" for labels in rule.conditions()]
        row = f"| {number} | " + " | ".join([*cells, rule.weight]) + " |"
        assert row in text, row


# --- perceptual sanity -------------------------------------------------------------------------


def test_papers_rule_alone_gives_low():
    weight = infer_strength(0.5, 0.0, 0.5)  # curvature MEDIUM, area LOW, bumpiness MEDIUM
    assert_allclose(weight, 2 / 6, rtol=0, atol=1e-12)
    assert WEIGHT_LABELS[strength_class(weight)] == "LOW"


def test_more_curvature_and_bumpiness_together_never_lowers_the_weight():
    t = np.linspace(0.0, 1.0, 201)[:, None]
    area = np.linspace(0.0, 1.0, 51)[None, :]
    weight = infer_strength(t, area, t)
    assert np.all(np.diff(weight, axis=0) >= -1e-12)
    assert np.all(weight[-1] - weight[0] > 0.6)  # and it does rise, for any area


@pytest.mark.parametrize("axis", [0, 1, 2], ids=INPUT_NAMES)
def test_weight_is_nearly_monotone_in_each_input(axis):
    g = np.linspace(0.0, 1.0, 41)
    weight = infer_strength(*np.meshgrid(g, g, g, indexing="ij"))
    drop = np.maximum.accumulate(weight, axis=axis) - weight
    assert drop.max() <= MONOTONE_SLACK
    # From the bottom of an input's range to the top the weight never falls.
    first, last = np.take(weight, 0, axis=axis), np.take(weight, -1, axis=axis)
    assert np.all(last >= first - 1e-12)


def test_flat_and_smooth_is_at_most_low():
    g = np.linspace(0.0, 0.2, 9)  # curvature and bumpiness fully LOW, any area
    classes = strength_class(infer_strength(*np.meshgrid(g, np.linspace(0, 1, 21), g)))
    assert classes.max() <= WEIGHT_LABELS.index("LOW")
    assert classes.max() <= WEIGHT_LABELS.index("LOWER")  # what the rules actually give


def test_curved_and_bumpy_is_at_least_high():
    g = np.linspace(0.8, 1.0, 9)  # curvature and bumpiness fully HIGH, any area
    classes = strength_class(infer_strength(*np.meshgrid(g, np.linspace(0, 1, 21), g)))
    assert classes.min() >= WEIGHT_LABELS.index("HIGH")
    assert classes.min() >= WEIGHT_LABELS.index("HIGHER")


def test_bumpiness_masks_more_than_curvature():
    """Rules 8/9 and 10-13: swapping a HIGH bumpiness for a HIGH curvature lowers the weight."""
    for area in (0.0, 0.5, 1.0):
        for other in (0.0, 0.5):
            assert infer_strength(other, area, 1.0) > infer_strength(1.0, area, other)


def test_large_cells_never_lower_the_weight_at_the_cell_centres():
    for c, b in itertools.product((0.0, 0.5, 1.0), repeat=2):
        weights = infer_strength(c, np.array([0.0, 0.5, 1.0]), b)
        assert np.all(np.diff(weights) >= 0)


def test_every_corner_centre_and_random_input_has_an_output():
    corners = cube(*[np.array([0.0, 0.5, 1.0])] * 3)
    random = np.random.default_rng(3).random((100_000, 3))
    for points in (corners, random):
        weight = ours(points)
        assert np.all(np.isfinite(weight))
        assert np.all((weight >= 1 / 18 - 1e-12) & (weight <= 17 / 18 + 1e-12))


def test_some_but_not_most_coefficients_carry_bits():
    weight = ours(np.random.default_rng(5).random((20_000, 3)))
    carrying = np.isin(strength_class(weight), EMBEDDING_CLASSES).mean()
    assert 0.1 < carrying < 0.5  # measured 0.27 for uniform inputs


# --- shapes, dtypes, chunks --------------------------------------------------------------------


def test_scalars_give_a_0d_array():
    weight = infer_strength(0.5, 0.5, 0.5)
    assert isinstance(weight, np.ndarray) and weight.shape == () and weight.dtype == np.float64
    assert strength_class(weight).shape == ()


def test_inputs_broadcast():
    c = np.linspace(0, 1, 3)[:, None]
    b = np.linspace(0, 1, 4)[None, :]
    weight = infer_strength(c, 0.3, b)
    assert weight.shape == (3, 4)
    expected = infer_strength(*np.broadcast_arrays(c, np.full((3, 4), 0.3), b))
    assert_allclose(weight, expected, rtol=0, atol=ATOL_ROUNDING)


def test_empty_input_gives_empty_output():
    assert infer_strength([], [], []).shape == (0,)
    assert infer_strength(np.zeros((0, 5)), 0.5, 0.5).shape == (0, 5)
    assert strength_class([]).shape == (0,)


def test_lists_ints_bools_and_float32_are_accepted():
    expected = infer_strength(np.array([0.0, 1.0]), np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    for args in (
        ([0, 1], [1, 0], [0, 1]),
        ([False, True], [True, False], [False, True]),
        (np.array([0, 1], np.float32), np.array([1, 0], np.int8), np.array([0, 1], np.uint16)),
    ):
        assert_allclose(infer_strength(*args), expected, rtol=0, atol=ATOL_ROUNDING)


def test_inputs_are_not_modified():
    c, a, b = (np.array([-0.5, 0.3, 1.7]) for _ in range(3))
    copies = [x.copy() for x in (c, a, b)]
    infer_strength(c, a, b)
    strength_class(c)
    for x, copy in zip((c, a, b), copies, strict=True):
        assert_array_equal(x, copy)


def test_values_outside_the_unit_interval_are_clipped():
    assert_allclose(
        infer_strength([-0.3, 1.2], [2.0, -1e-9], [1.5, -7.0]),
        infer_strength([0.0, 1.0], [1.0, 0.0], [1.0, 0.0]),
        rtol=0,
        atol=0,
    )
    assert_array_equal(strength_class([-1.0, 2.0]), [0, 6])


@pytest.mark.parametrize("chunk_size", [1, 7, 64, 1000, 10**6])
def test_result_does_not_depend_on_chunk_size(chunk_size):
    points = np.random.default_rng(9).random((300, 3))
    assert_allclose(ours(points, chunk_size=chunk_size), ours(points), rtol=0, atol=ATOL_ROUNDING)


# --- errors ------------------------------------------------------------------------------------


@pytest.mark.parametrize("position", range(3), ids=INPUT_NAMES)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_inputs_are_refused_by_name(position, bad):
    args = [np.full(4, 0.5) for _ in range(3)]
    args[position][2] = bad
    with pytest.raises(ValueError, match=rf"^{INPUT_NAMES[position]} has 1 NaN or infinite"):
        infer_strength(*args)


def test_shapes_that_do_not_broadcast_are_refused():
    with pytest.raises(ValueError, match=r"curvature \(3,\), area \(4,\), bumpiness \(\)"):
        infer_strength(np.zeros(3), np.zeros(4), 0.5)


@pytest.mark.parametrize("bad", ["0.5", [1j], [None], {"a": 1}])
def test_non_numbers_are_a_type_error(bad):
    with pytest.raises(TypeError, match=r"^area must be real numbers"):
        infer_strength(0.5, bad, 0.5)
    with pytest.raises(TypeError, match=r"^weight must be real numbers"):
        strength_class(bad)


@pytest.mark.parametrize(
    ("chunk_size", "error"), [(0, ValueError), (2.5, TypeError), (True, TypeError)]
)
def test_bad_chunk_size(chunk_size, error):
    with pytest.raises(error, match="chunk_size"):
        infer_strength(0.5, 0.5, 0.5, chunk_size=chunk_size)


def test_bad_system_is_a_type_error():
    with pytest.raises(TypeError, match="system must be a FuzzySystem"):
        infer_strength(0.5, 0.5, 0.5, system=build_control_system())
    with pytest.raises(TypeError, match="system must be a FuzzySystem"):
        strength_class(0.5, system="PERCEPTUAL_FIS")


def test_strength_class_refuses_nan():
    with pytest.raises(ValueError, match=r"^weight has 1 NaN"):
        strength_class([0.5, np.nan])


# --- strength_class ----------------------------------------------------------------------------


def test_strength_class_at_peaks_and_between():
    k = np.arange(7)
    assert_array_equal(strength_class(k / 6), k)
    halfway = (2 * k[:-1] + 1) / 12
    assert_array_equal(strength_class(halfway), k[:-1])  # ties go to the lower class
    assert_array_equal(strength_class(halfway + 1e-9), k[:-1] + 1)
    assert_array_equal(strength_class(halfway - 1e-9), k[:-1])


def test_strength_class_keeps_shape_and_is_int8():
    classes = strength_class(np.linspace(0, 1, 12).reshape(3, 4))
    assert classes.dtype == np.int8 and classes.shape == (3, 4)
    assert np.all(np.diff(classes.ravel()) >= 0)


def test_embedding_classes_are_high_and_higher():
    assert [WEIGHT_LABELS[k] for k in EMBEDDING_CLASSES] == ["HIGH", "HIGHER"]


# --- the description's own checks --------------------------------------------------------------


def _with(**changes) -> dict:
    fields = {
        "curvature": PERCEPTUAL_FIS.curvature,
        "area": PERCEPTUAL_FIS.area,
        "bumpiness": PERCEPTUAL_FIS.bumpiness,
        "weight": PERCEPTUAL_FIS.weight,
        "rules": PERCEPTUAL_FIS.rules,
    }
    fields.update(changes)
    return fields


@pytest.mark.parametrize(
    ("make", "error", "match"),
    [
        (lambda: MembershipFunction("LOW", (0.5, 0.2, 0.8)), ValueError, "sorted"),
        (lambda: MembershipFunction("LOW", (0.0, 0.5, 1.5)), ValueError, r"in \[0, 1\]"),
        (lambda: MembershipFunction("LOW", (0.0, 1.0)), ValueError, "needs 3 points"),
        (lambda: MembershipFunction("LOW", (0.5, 0.5, 0.5)), ValueError, "degenerate"),
        (lambda: MembershipFunction("*", (0.0, 0.5, 1.0)), ValueError, "label"),
        (
            lambda: LinguisticVariable("area", (MembershipFunction("LOW", (0, 0.333, 1)),), 101),
            ValueError,
            r"breakpoints \[0\.333\] are not samples",
        ),
        (
            lambda: LinguisticVariable("area", PERCEPTUAL_FIS.area.terms * 2, 101),
            ValueError,
            "labels repeat",
        ),
        (lambda: LinguisticVariable("area", PERCEPTUAL_FIS.area.terms, 1), ValueError, ">= 2"),
        (lambda: LinguisticVariable("area", PERCEPTUAL_FIS.area.terms, 1.5), TypeError, "int"),
        (lambda: FuzzyRule("LOW", (), (), "LOW"), TypeError, "tuple of labels"),
        (lambda: FuzzyRule((), (), (), "LOW"), ValueError, "at least one input"),
        (
            lambda: FuzzySystem(**_with(rules=(FuzzyRule(("TINY",), (), (), "LOW"),))),
            ValueError,
            "curvature has no set 'TINY'; valid: LOW, MEDIUM, HIGH",
        ),
        (
            lambda: FuzzySystem(**_with(rules=(FuzzyRule(("LOW",), ("LOW",), ("LOW",), "MAX"),))),
            ValueError,
            "weight has no set 'MAX'",
        ),
        (
            lambda: FuzzySystem(**_with(rules=(FuzzyRule(("LOW",), (), ("LOW",), "LOW"),))),
            ValueError,
            "no rule uses input 'area'",
        ),
        (
            lambda: FuzzySystem(**_with(area=PERCEPTUAL_FIS.curvature)),
            ValueError,
            "area must be a LinguisticVariable named 'area'",
        ),
        (lambda: FuzzySystem(**_with(rules=())), ValueError, "at least one rule"),
    ],
)
def test_bad_descriptions_are_refused(make, error, match):
    with pytest.raises(error, match=match):
        make()
