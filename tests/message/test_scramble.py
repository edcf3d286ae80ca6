"""Tests for :mod:`meshwm.message.scramble`: the Arnold cat map of the paper, section 2.

The vectorised functions are checked against ``_loop_scramble``/``_loop_unscramble`` below:
a pixel-by-pixel transcription of the paper's formula, ``P' = (P + Q) mod N``,
``Q' = (P + 2Q) mod N`` (P the row, Q the column), and of its inverse
``P = (2P' - Q') mod N``, ``Q = (Q' - P') mod N``, applied once per iteration.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from meshwm.message.scramble import arnold_period, arnold_scramble, arnold_unscramble

PROPERTY = settings(max_examples=60, deadline=None)

#: Arnold periods, from Dyson & Falk (1992) / the Pisano periods (π(n)/2 for n > 2).
KNOWN_PERIODS = {
    1: 1, 2: 3, 3: 4, 4: 3, 5: 10, 6: 12, 7: 8, 8: 6, 10: 30, 16: 12, 32: 24, 50: 150, 64: 48,
    100: 150, 101: 25, 128: 96, 256: 192,
}  # fmt: skip

#: arnold_scramble(np.arange(16).reshape(4, 4), iterations=k), worked out by hand from the
#: formula: value 4P + Q goes to row (P + Q) mod 4, column (P + 2Q) mod 4.  For k = 5 (the
#: paper's key) the period is 3, so it is the map applied twice, matrix [[2, 3], [3, 1]] mod 4.
GOLDEN_4X4 = {
    1: [[0, 13, 10, 7], [11, 4, 1, 14], [2, 15, 8, 5], [9, 6, 3, 12]],
    5: [[0, 6, 8, 14], [5, 11, 13, 3], [10, 12, 2, 4], [15, 1, 7, 9]],
}


def _loop_scramble(image: np.ndarray, iterations: int) -> np.ndarray:
    current = np.array(image)
    n = current.shape[0]
    for _ in range(iterations):
        moved = np.empty_like(current)
        for p in range(n):
            for q in range(n):
                moved[(p + q) % n, (p + 2 * q) % n] = current[p, q]
        current = moved
    return current


def _loop_unscramble(image: np.ndarray, iterations: int) -> np.ndarray:
    current = np.array(image)
    n = current.shape[0]
    for _ in range(iterations):
        moved = np.empty_like(current)
        for p in range(n):
            for q in range(n):
                moved[(2 * p - q) % n, (q - p) % n] = current[p, q]
        current = moved
    return current


def _distinct(n: int, seed: int = 0) -> np.ndarray:
    """An n×n array of distinct values in a random order: pins the permutation fully."""
    return np.random.default_rng(seed).permutation(n * n).reshape(n, n)


# ---------------------------------------------------------------------------
# Golden values and the reference implementation


@pytest.mark.parametrize("iterations", sorted(GOLDEN_4X4))
def test_golden_4x4(iterations: int) -> None:
    image = np.arange(16).reshape(4, 4)
    expected = np.array(GOLDEN_4X4[iterations])
    np.testing.assert_array_equal(arnold_scramble(image, iterations=iterations), expected)
    np.testing.assert_array_equal(_loop_scramble(image, iterations), expected)
    np.testing.assert_array_equal(arnold_unscramble(expected, iterations=iterations), image)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 7, 8, 13, 16, 17, 32])
@pytest.mark.parametrize("iterations", [0, 1, 2, 5, 13])
def test_matches_loop_reference(n: int, iterations: int) -> None:
    image = _distinct(n, seed=n)
    np.testing.assert_array_equal(
        arnold_scramble(image, iterations=iterations), _loop_scramble(image, iterations)
    )
    np.testing.assert_array_equal(
        arnold_unscramble(image, iterations=iterations), _loop_unscramble(image, iterations)
    )


def test_paper_key_on_32x32_matches_loop_reference() -> None:
    image = _distinct(32, seed=5)
    np.testing.assert_array_equal(arnold_scramble(image, iterations=5), _loop_scramble(image, 5))


# ---------------------------------------------------------------------------
# Round trip and periodicity


@pytest.mark.parametrize("n", [1, 2, 3, 8, 31, 32, 64, 100, 256])
@pytest.mark.parametrize("iterations", [0, 1, 5, 23, 24, 1000])
def test_round_trip_exact(n: int, iterations: int) -> None:
    image = _distinct(n)
    scrambled = arnold_scramble(image, iterations=iterations)
    np.testing.assert_array_equal(arnold_unscramble(scrambled, iterations=iterations), image)
    np.testing.assert_array_equal(
        arnold_scramble(arnold_unscramble(image, iterations=iterations), iterations=iterations),
        image,
    )


@pytest.mark.parametrize(
    "dtype", [np.uint8, np.bool_, np.int64, np.float32, np.float64, np.complex128, "U3", object]
)
def test_any_dtype_round_trip(dtype: object) -> None:
    image = (_distinct(9) % 7).astype(dtype)
    scrambled = arnold_scramble(image, iterations=5)
    assert scrambled.dtype == image.dtype
    np.testing.assert_array_equal(np.sort(scrambled, axis=None), np.sort(image, axis=None))
    np.testing.assert_array_equal(arnold_unscramble(scrambled, iterations=5), image)


@given(
    image=hnp.arrays(
        dtype=st.sampled_from([np.uint8, np.int32, np.float64]),
        shape=st.integers(2, 64).map(lambda n: (n, n)),
    ),
    iterations=st.integers(0, 100),
)
@PROPERTY
def test_round_trip_property(image: np.ndarray, iterations: int) -> None:
    before = image.copy()
    scrambled = arnold_scramble(image, iterations=iterations)
    np.testing.assert_array_equal(arnold_unscramble(scrambled, iterations=iterations), image)
    np.testing.assert_array_equal(image, before)  # input untouched


@given(n=st.integers(2, 64), iterations=st.integers(0, 10**6))
@PROPERTY
def test_iterations_modulo_period(n: int, iterations: int) -> None:
    image = _distinct(n)
    period = arnold_period(n)
    scrambled = arnold_scramble(image, iterations=iterations)
    np.testing.assert_array_equal(arnold_scramble(image, iterations=iterations + period), scrambled)
    np.testing.assert_array_equal(arnold_scramble(image, iterations=iterations % period), scrambled)
    moved = not np.array_equal(scrambled, image)
    assert moved == (iterations % period != 0)


@pytest.mark.parametrize("n", [2, 3, 4, 8, 32, 64])
def test_scramble_moves_pixels_until_the_period(n: int) -> None:
    image = _distinct(n)
    period = arnold_period(n)
    unchanged = [
        k
        for k in range(2 * period + 1)
        if np.array_equal(arnold_scramble(image, iterations=k), image)
    ]
    assert unchanged == [0, period, 2 * period]


def test_scramble_scatters_a_block() -> None:
    """A cropped-out 8×8 corner of a 32×32 mark lands all over the scrambled image."""
    mark = np.zeros((32, 32), dtype=np.uint8)
    mark[:8, :8] = 1
    rows, cols = np.nonzero(arnold_scramble(mark, iterations=5))
    assert len(rows) == 64
    assert np.ptp(rows) >= 24 and np.ptp(cols) >= 24


@pytest.mark.parametrize("iterations", [10**18, 2**100, np.uint64(2**63 + 5), np.int8(5)])
def test_huge_and_numpy_integer_iterations(iterations: object) -> None:
    image = _distinct(32)
    reduced = int(iterations) % arnold_period(32)
    expected = arnold_scramble(image, iterations=reduced)
    np.testing.assert_array_equal(arnold_scramble(image, iterations=iterations), expected)
    np.testing.assert_array_equal(arnold_unscramble(expected, iterations=iterations), image)


# ---------------------------------------------------------------------------
# Period


@pytest.mark.parametrize("n", sorted(KNOWN_PERIODS))
def test_known_periods(n: int) -> None:
    assert arnold_period(n) == KNOWN_PERIODS[n]


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 16, 20, 25, 32])
def test_period_matches_brute_force_on_the_image(n: int) -> None:
    image = _distinct(n)
    current = _loop_scramble(image, 1)
    k = 1
    while not np.array_equal(current, image):
        current = _loop_scramble(current, 1)
        k += 1
    assert arnold_period(n) == k


def test_period_bound() -> None:
    """Dyson & Falk: the period is at most 3n, with equality exactly for n = 2·5^j."""
    periods = {n: arnold_period(n) for n in range(1, 400)}
    assert all(period <= 3 * n for n, period in periods.items())
    assert [n for n, period in periods.items() if period == 3 * n] == [10, 50, 250]


# ---------------------------------------------------------------------------
# Arrays in, arrays out


def test_input_not_modified_and_output_is_new() -> None:
    image = _distinct(16)
    before = image.copy()
    for function in (arnold_scramble, arnold_unscramble):
        out = function(image, iterations=0)
        np.testing.assert_array_equal(out, image)
        assert not np.shares_memory(out, image)
        out[0, 0] = -1
        np.testing.assert_array_equal(image, before)


def test_array_like_and_non_contiguous_input() -> None:
    base = _distinct(16)
    view = base.T[::2, ::2]
    np.testing.assert_array_equal(
        arnold_scramble(view, iterations=3), arnold_scramble(view.copy(), iterations=3)
    )
    as_list = arnold_scramble(base.tolist(), iterations=3)
    np.testing.assert_array_equal(as_list, arnold_scramble(base, iterations=3))


# ---------------------------------------------------------------------------
# Errors


@pytest.mark.parametrize("function", [arnold_scramble, arnold_unscramble])
@pytest.mark.parametrize(
    ("shape", "shown"),
    [((3, 4), r"\(3, 4\)"), ((0, 0), r"\(0, 0\)"), ((9,), r"\(9,\)"), ((4, 4, 3), r"\(4, 4, 3\)")],
)
def test_bad_shape(function: object, shape: tuple[int, ...], shown: str) -> None:
    with pytest.raises(ValueError, match=f"square N×N array, got shape {shown}"):
        function(np.zeros(shape), iterations=1)


@pytest.mark.parametrize("function", [arnold_scramble, arnold_unscramble])
def test_negative_iterations(function: object) -> None:
    with pytest.raises(ValueError, match="iterations must be >= 0, got -1"):
        function(np.zeros((4, 4)), iterations=-1)


@pytest.mark.parametrize("function", [arnold_scramble, arnold_unscramble])
@pytest.mark.parametrize("iterations", [5.0, "5", True, None, np.float64(5)])
def test_non_integer_iterations(function: object, iterations: object) -> None:
    with pytest.raises(TypeError, match="iterations must be an integer"):
        function(np.zeros((4, 4)), iterations=iterations)


def test_iterations_is_keyword_only() -> None:
    with pytest.raises(TypeError):
        arnold_scramble(np.zeros((4, 4)), 5)  # type: ignore[misc]


@pytest.mark.parametrize(
    ("n", "error", "message"),
    [
        (0, ValueError, "n must be at least 1, got 0"),
        (-3, ValueError, "n must be at least 1, got -3"),
        (4.0, TypeError, "n must be an integer, got float"),
        (True, TypeError, "n must be an integer, got bool"),
    ],
)
def test_bad_period_size(n: object, error: type[Exception], message: str) -> None:
    with pytest.raises(error, match=message):
        arnold_period(n)
