"""Vectorised fuzzy inference: the paper's five FIS steps for many points at once.

The same numbers as scikit-fuzzy's ``ControlSystemSimulation`` on
:func:`meshwm.signal.fuzzy.system.build_control_system`, thousands of times faster.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from meshwm._validate import check_integer
from meshwm.signal.fuzzy.system import INPUT_NAMES, PERCEPTUAL_FIS, FuzzySystem

__all__ = ["CLASS_TIE_TOLERANCE", "DEFAULT_CHUNK_SIZE", "infer_strength", "strength_class"]

#: Points evaluated at once by :func:`infer_strength`.  Peak working memory is about
#: ``4 * 8 * chunk_size * output_samples`` bytes: 32 MB for 8192 points and 121 samples
#: (measured with tracemalloc; 237 MB for chunks of 65,536).
DEFAULT_CHUNK_SIZE = 8192
#: Output-set degrees within this of the largest count as a tie in :func:`strength_class`.
CLASS_TIE_TOLERANCE = 1e-12


@dataclass(frozen=True, eq=False)
class _Tables:
    """Everything :func:`infer_strength` needs from a :class:`FuzzySystem`, precomputed.

    ``T`` is the number of output sets some rule concludes (only those take part), ``M`` the
    number of output samples.
    """

    in_universes: tuple[NDArray[np.float64], ...]
    in_tables: tuple[NDArray[np.float64], ...]
    rule_terms: tuple[tuple[tuple[int, ...], ...], ...]  # per rule, per input (empty = any)
    rules_of_term: tuple[NDArray[np.intp], ...]  # per used output set: the rules concluding it
    universe: NDArray[np.float64]  # (M,) output universe
    step: NDArray[np.float64]  # (M - 1,) universe[j + 1] - universe[j]
    mf: NDArray[np.float64]  # (T, M) the used output sets
    dmf: NDArray[np.float64]  # (T, M - 1) mf[:, j + 1] - mf[:, j]
    support: tuple[tuple[int, int], ...]  # per set: samples [start, stop) where mf > 0
    peak: tuple[int, ...]  # per set: first sample where mf is largest
    rising: tuple[NDArray[np.float64], ...]  # per set: mf[:peak + 1], non-decreasing
    falling: tuple[NDArray[np.float64], ...]  # per set: mf[peak:][::-1], non-decreasing
    segment_term: NDArray[np.intp]  # (K, M - 1) sets > 0 at either end of a segment (T = none)
    segment_mf: NDArray[np.float64]  # (K, M - 1) their degree at the segment's left end
    segment_slope: NDArray[np.float64]  # (K, M - 1) their np.interp slope on the segment
    weights: NDArray[np.float64]  # (2, M) trapezoid-rule weights for area and first moment


@functools.lru_cache(maxsize=8)
def _tables(system: FuzzySystem) -> _Tables:
    used = sorted({system.weight.labels.index(rule.weight) for rule in system.rules})
    universe = system.weight.universe
    step = universe[1:] - universe[:-1]
    mf = system.weight.table()[used]
    n_sets, n_samples = mf.shape
    peak = tuple(int(i) for i in np.argmax(mf, axis=1))
    rising = tuple(mf[t, : peak[t] + 1].copy() for t in range(n_sets))
    falling = tuple(mf[t, peak[t] :][::-1].copy() for t in range(n_sets))
    support = []
    for t in range(n_sets):
        # Triangles and trapezoids are unimodal with one run of positive samples; the
        # crossing search and the slices below rely on it.
        positive = np.flatnonzero(mf[t] > 0)
        if np.any(np.diff(rising[t]) < 0) or np.any(np.diff(falling[t]) < 0):
            raise ValueError(f"output set {system.weight.labels[used[t]]!r} is not unimodal")
        support.append((int(positive[0]), int(positive[-1]) + 1))

    # On each segment [u_j, u_j+1] only the sets positive at one of its ends can be positive.
    segment_lists = [
        [t for t in range(n_sets) if mf[t, j] > 0 or mf[t, j + 1] > 0] for j in range(n_samples - 1)
    ]
    width = max(len(items) for items in segment_lists)
    segment_term = np.array(
        [items + [n_sets] * (width - len(items)) for items in segment_lists], dtype=np.intp
    ).T
    padded = np.vstack([mf, np.zeros((1, n_samples))])
    columns = np.arange(n_samples - 1)
    segment_mf = padded[segment_term, columns]
    # np.interp's slope, (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]); 0 for the padding.
    segment_slope = (padded[segment_term, columns + 1] - segment_mf) / step

    # Centroid of the linear interpolant through (x_j, y_j): per segment the area is
    # dx (y_j + y_j+1) / 2 and the first moment dx (y_j + y_j+1) x_j / 2 + dx^2 (y_j + 2 y_j+1) / 6.
    # Both are linear in y, so their sums over the segments are dot products with these weights.
    weight_area = np.zeros_like(universe)
    weight_area[:-1] += 0.5 * step
    weight_area[1:] += 0.5 * step
    weight_moment = np.zeros_like(universe)
    weight_moment[:-1] += 0.5 * step * universe[:-1] + step * step / 6.0
    weight_moment[1:] += 0.5 * step * universe[:-1] + step * step / 3.0

    out_index = [system.weight.labels.index(rule.weight) for rule in system.rules]
    return _Tables(
        in_universes=tuple(var.universe for var in system.inputs),
        in_tables=tuple(var.table() for var in system.inputs),
        rule_terms=tuple(
            tuple(
                tuple(var.labels.index(label) for label in labels)
                for var, labels in zip(system.inputs, rule.conditions(), strict=True)
            )
            for rule in system.rules
        ),
        rules_of_term=tuple(
            np.flatnonzero(np.array(out_index) == used[t]).astype(np.intp) for t in range(n_sets)
        ),
        universe=universe,
        step=step,
        mf=mf,
        dmf=mf[:, 1:] - mf[:, :-1],
        support=tuple(support),
        peak=peak,
        rising=rising,
        falling=falling,
        segment_term=segment_term,
        segment_mf=segment_mf,
        segment_slope=segment_slope,
        weights=np.stack([weight_area, weight_moment]),
    )


def _check_real(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """``value`` as a float64 array; TypeError if not real numbers, ValueError if not finite."""
    array = np.asarray(value)
    if array.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    array = array.astype(np.float64)
    bad = ~np.isfinite(array)
    if bad.any():
        first = array.ravel()[np.argmax(bad.ravel())]
        raise ValueError(
            f"{name} has {int(bad.sum())} NaN or infinite value(s) (first: {first}); "
            "pass finite values normalised to [0, 1]"
        )
    return array


def _segment_integrals(
    x1: NDArray[np.float64],
    x2: NDArray[np.float64],
    y1: NDArray[np.float64],
    y2: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Area and first moment under the line from (x1, y1) to (x2, y2)."""
    dx = x2 - x1
    area = 0.5 * dx * (y1 + y2)
    return area, area * x1 + dx * dx * (y1 + 2.0 * y2) / 6.0


def _crossings(
    tables: _Tables, cuts: NDArray[np.float64], n: int
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The points skfuzzy inserts where each set crosses its cut, and their segments.

    Rows are points, columns the possible crossings (at most two per used set); a missing
    crossing is NaN with segment ``M - 1`` (sorted last).
    """
    universe = tables.universe
    last = len(universe) - 1
    n_sets = len(tables.rules_of_term)
    crossings = []
    for t in range(n_sets):
        cut = cuts[t]
        zero = cut == 0.0
        rising, falling = tables.rising[t], tables.falling[t]
        lo = np.searchsorted(rising, cut, side="left")
        lo[zero] = np.searchsorted(rising, 0.0, side="right")
        count = np.searchsorted(falling, cut, side="left")
        count[zero] = np.searchsorted(falling, 0.0, side="right")
        count = len(falling) - count
        hi = tables.peak[t] + count - 1
        if tables.peak[t] > 0:  # a crossing on the rising side is possible
            crossings.append((t, cut, lo - 1, (count > 0) & (lo > 0)))
        if tables.peak[t] < last:  # a crossing on the falling side is possible
            crossings.append((t, cut, hi, (count > 0) & (hi < last)))
    x = np.empty((n, len(crossings)))
    segment = np.empty((n, len(crossings)), dtype=np.intp)
    for q, (t, cut, j, ok) in enumerate(crossings):
        j = np.where(ok, j, last)
        safe = np.minimum(j, last - 1)
        denominator = np.where(ok, tables.dmf[t, safe], 1.0)
        x[:, q] = universe[safe] + (cut - tables.mf[t, safe]) * tables.step[safe] / denominator
        x[~ok, q] = np.nan
        segment[:, q] = j
    return x, segment


def _infer_chunk(
    tables: _Tables, inputs: tuple[NDArray[np.float64], ...], buffer: NDArray[np.float64]
) -> NDArray[np.float64]:
    """:func:`infer_strength` for 1-D inputs of length n; ``buffer`` holds >= M * n floats.

    Arrays are laid out sets x points (or samples x points).
    """
    n = len(inputs[0])
    columns = np.arange(n)
    universe = tables.universe
    last = len(universe) - 1

    # Steps 1-2: fuzzify (skfuzzy's interp_membership), then AND = min, OR = max per rule.
    degrees = [
        [np.interp(x, xp, row, left=0.0, right=0.0) for row in table]
        for x, xp, table in zip(inputs, tables.in_universes, tables.in_tables, strict=True)
    ]
    firing = np.empty((len(tables.rule_terms), n))
    for r, per_input in enumerate(tables.rule_terms):
        clauses = [
            functools.reduce(np.fmax, [degrees[i][t] for t in terms])
            for i, terms in enumerate(per_input)
            if terms
        ]
        firing[r] = functools.reduce(np.fmin, clauses)

    # Step 3 (implication): each used output set is clipped at the max firing of its rules.
    # Row T of ``cuts`` stays 0; the padding of the segment tables points at it.
    n_sets = len(tables.rules_of_term)
    cuts = np.zeros((n_sets + 1, n))
    for t, rules in enumerate(tables.rules_of_term):
        np.max(firing[rules], axis=0, out=cuts[t])

    # Step 4 (aggregation) at the output samples: y_j = max over sets of min(cut, mf_j).
    aggregated = buffer[: len(universe) * n].reshape(len(universe), n)
    aggregated.fill(0.0)
    for t, (start, stop) in enumerate(tables.support):
        rows = aggregated[start:stop]
        np.maximum(rows, np.minimum(tables.mf[t, start:stop, None], cuts[t]), out=rows)
    # Two matrix-vector products: the (2, M) @ (M, n) matmul goes to a threaded BLAS gemm that
    # is ten times slower here, and its spinning threads slow the NumPy calls that follow.
    area = tables.weights[0] @ aggregated
    moment = tables.weights[1] @ aggregated

    # skfuzzy adds to the universe, for each set, the points where the sampled set crosses its
    # cut (CrispValueCalculator.find_memberships, _interp_universe_fast): at each j where
    # (mf >= cut) changes, (mf > 0) if the cut is 0, the point
    # u_j + (cut - mf_j) (u_j+1 - u_j) / (mf_j+1 - mf_j), which lies on segment j.  The sets are
    # unimodal, so the samples with mf >= cut are one run [lo, hi] and there are at most two
    # such points per set.  Missing points are NaN, their segment ``last`` (sorted last).
    x, segment = _crossings(tables, cuts, n)

    # Integrate the interpolant through samples and inserted points: for each segment
    # [u_j, u_j+1] holding inserted points, add its pieces and take away its whole.  Sorting the
    # points and their segments separately keeps them paired, up to points within an ulp of a
    # segment end, which may be paired with either segment.
    x.sort(axis=1)  # NaN last
    segment.sort(axis=1)
    valid = segment < last  # a prefix of each row
    np.minimum(segment, last - 1, out=segment)
    left_x, right_x = universe.take(segment), universe.take(segment + 1)
    x = np.where(valid, x, left_x)
    flat = segment * n + columns[:, None]
    values = aggregated.ravel()
    left_y, right_y = values.take(flat), values.take(flat + n)
    # The aggregated set at the inserted points, interpolated as np.interp does.
    y = np.zeros_like(x)
    offset = x - left_x
    cut_values = cuts.ravel()
    for k in range(len(tables.segment_term)):
        degree = tables.segment_slope[k].take(segment) * offset + tables.segment_mf[k].take(segment)
        cut = cut_values.take(tables.segment_term[k].take(segment) * n + columns[:, None])
        np.maximum(y, np.minimum(cut, degree), out=y)
    y *= valid
    # Where the previous point is in the same segment a piece starts there, else at u_j.
    after_previous = valid[:, 1:] & (segment[:, 1:] == segment[:, :-1])
    start_x, start_y = left_x.copy(), left_y.copy()
    start_x[:, 1:] = np.where(after_previous, x[:, :-1], left_x[:, 1:])
    start_y[:, 1:] = np.where(after_previous, y[:, :-1], left_y[:, 1:])
    last_in_segment = valid.copy()
    last_in_segment[:, :-1] &= ~after_previous
    piece_area, piece_moment = _segment_integrals(start_x, x, start_y, y)  # 0 if not valid
    tail_area, tail_moment = _segment_integrals(x, right_x, y, right_y)
    whole_area, whole_moment = _segment_integrals(left_x, right_x, left_y, right_y)
    area += piece_area.sum(axis=1) + ((tail_area - whole_area) * last_in_segment).sum(axis=1)
    moment += piece_moment.sum(axis=1)
    moment += ((tail_moment - whole_moment) * last_in_segment).sum(axis=1)

    # Step 5: centroid, skfuzzy's guard included.  Every set peaks at 1 on a sample, so the
    # aggregated set is empty exactly when every cut is 0; skfuzzy then leaves the output out
    # (EmptyMembershipError, skipped by its lenient simulation) and we return NaN.
    weight = moment / np.fmax(area, np.finfo(np.float64).eps)
    weight[cuts.max(axis=0) == 0.0] = np.nan
    return weight


def infer_strength(
    curvature: ArrayLike,
    area: ArrayLike,
    bumpiness: ArrayLike,
    *,
    system: FuzzySystem = PERCEPTUAL_FIS,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
) -> NDArray[np.float64]:
    """Perceptual weighting factor of each coefficient, by Mamdani fuzzy inference.

    Section 3, step 7 of the paper: the three inputs of each wavelet coefficient go through the
    FIS and come out as one weight; only HIGH and HIGHER weights (:func:`strength_class`)
    carry watermark bits.

    Parameters
    ----------
    curvature, area, bumpiness : array_like of float
        The inputs, each normalised to [0, 1] by the caller; any shapes that broadcast together.
        Finite values outside [0, 1] are clipped to it, as skfuzzy's
        ``ControlSystemSimulation`` does by default (``clip_to_bounds=True``).
    system : FuzzySystem, optional
        The FIS; default :data:`PERCEPTUAL_FIS`.
    chunk_size : int, optional
        Points evaluated at once (memory: see :data:`DEFAULT_CHUNK_SIZE`).  The result does not
        depend on it beyond rounding.

    Returns
    -------
    weight : float64 ndarray, the broadcast shape of the inputs
        The defuzzified weight in [0, 1] (0-d for scalar inputs).  For :data:`PERCEPTUAL_FIS` it
        lies in [1/18, 17/18], the centroids of the half triangles LOWEST and HIGHEST.  NaN only
        where no rule fires, which never happens with :data:`PERCEPTUAL_FIS`.

    Raises
    ------
    TypeError
        An input, or ``chunk_size``, of the wrong type.
    ValueError
        NaN or infinite values, shapes that do not broadcast, ``chunk_size < 1``.

    Notes
    -----
    This is the computation ``skfuzzy.control.ControlSystemSimulation.compute`` does for one
    point, evaluated for all points at once; it agrees with it to within 1e-9 (in practice a few
    1e-16).  For each point:

    1. each input x is clipped to [0, 1] and fuzzified: mu_s(x) is the linear interpolation of the
       sampled set s (``np.interp``, 0 outside the universe);
    2. each rule fires at min over its inputs of (max over the sets it accepts of mu);
    3-4. each output set s is clipped at c_s, the max firing of the rules concluding it, and the
       aggregated set is y(u) = max_s min(c_s, mf_s(u));
    5. y is sampled on the output universe, to which skfuzzy adds, for every set, the one or two
       points where the sampled mf_s crosses c_s; the weight is the centroid
       sum(x y dx) / max(sum(y dx), eps) of the piecewise-linear function through those samples.
       If every c_s is 0 there is no output (NaN here).

    Step 5 never builds the merged universe: the function through the samples is integrated
    with two dot products, and each inserted point then replaces the piece of its segment it
    splits.  Only the output sets a rule concludes take part, each over the samples where it is
    non-zero, so a point costs a few passes over the output samples: 2.5 to 4.3 µs per point
    against 8 to 10 ms per point for skfuzzy (``scripts/bench_fuzzy.py``, docs/fuzzy.md).

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on
       multi-resolution representation and fuzzy logic", section 2 (FIS steps 1-5) and
       section 3 step 7.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.fuzzy import infer_strength
    >>> w = infer_strength([0.0, 0.5, 0.9], [0.0, 0.0, 1.0], [0.0, 0.5, 0.95])
    >>> np.round(w, 4)  # flat & smooth; the paper's rule (centroid of LOW); curved & rough
    array([0.0556, 0.3333, 0.9444])
    >>> infer_strength(np.zeros((2, 3)), 0.5, 1.0).shape
    (2, 3)
    """
    arrays = [
        _check_real(value, name)
        for value, name in zip((curvature, area, bumpiness), INPUT_NAMES, strict=True)
    ]
    check_integer(chunk_size, name="chunk_size", low=1)
    if not isinstance(system, FuzzySystem):
        raise TypeError(f"system must be a FuzzySystem, got {type(system).__name__}")
    try:
        shape = np.broadcast_shapes(*(array.shape for array in arrays))
    except ValueError:
        raise ValueError(
            "curvature, area and bumpiness must broadcast to one shape, got shapes "
            + ", ".join(
                f"{name} {array.shape}" for name, array in zip(INPUT_NAMES, arrays, strict=True)
            )
        ) from None
    tables = _tables(system)
    flat = [
        np.clip(np.broadcast_to(array, shape).ravel(), universe[0], universe[-1])
        for array, universe in zip(arrays, tables.in_universes, strict=True)
    ]
    out = np.empty(flat[0].shape, dtype=np.float64)
    chunk = min(int(chunk_size), max(out.size, 1))
    buffer = np.empty(len(tables.universe) * chunk)
    for start in range(0, out.size, chunk):
        stop = start + chunk
        out[start:stop] = _infer_chunk(tables, tuple(x[start:stop] for x in flat), buffer)
    return out.reshape(shape)


def strength_class(weight: ArrayLike, *, system: FuzzySystem = PERCEPTUAL_FIS) -> NDArray[np.int8]:
    """Index of the output set a weight belongs to most (0 = LOWEST ... 6 = HIGHEST).

    Section 3, steps 7-8 of the paper: a coefficient carries a watermark bit when its class is
    HIGH or HIGHER (:data:`EMBEDDING_CLASSES`).

    Parameters
    ----------
    weight : array_like of float
        Weights from :func:`infer_strength`, any shape.  Finite values outside [0, 1] are
        clipped to it.
    system : FuzzySystem, optional
        The FIS whose output sets are used; default :data:`PERCEPTUAL_FIS`.

    Returns
    -------
    classes : int8 ndarray, the shape of ``weight``
        Index into ``system.weight.labels`` (:data:`WEIGHT_LABELS`) of the set with the highest
        membership at ``weight`` (the sampled sets, linearly interpolated).

    Raises
    ------
    TypeError
        ``weight`` is not real numbers.
    ValueError
        ``weight`` has NaN or infinite values.

    Notes
    -----
    Ties go to the lower class: among the sets whose degree is within
    :data:`CLASS_TIE_TOLERANCE` of the largest, the first.  With the seven evenly spaced
    triangles of :data:`PERCEPTUAL_FIS` the class is the nearest peak k/6, and a weight
    half-way between two peaks, (2k + 1)/12 (to within about 1e-12), gets class k: on a boundary
    the less visible choice is made, whatever the rounding of the two degrees.

    Examples
    --------
    >>> from meshwm.signal.fuzzy import strength_class
    >>> strength_class([0.0, 0.3, 1 / 12, 0.62, 0.8, 1.0])
    array([0, 2, 0, 4, 5, 6], dtype=int8)
    """
    array = _check_real(weight, "weight")
    if not isinstance(system, FuzzySystem):
        raise TypeError(f"system must be a FuzzySystem, got {type(system).__name__}")
    universe = system.weight.universe
    clipped = np.clip(array, universe[0], universe[-1])
    degrees = np.stack(
        [np.interp(clipped, universe, row, left=0.0, right=0.0) for row in system.weight.table()]
    )
    best = degrees.max(axis=0)
    return np.argmax(degrees >= best - CLASS_TIE_TOLERANCE, axis=0).astype(np.int8)
