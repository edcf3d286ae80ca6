"""The robust profile on geometry images: exact round trips, invariances, erasures, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial.transform import Rotation

from meshwm.profiles.robust.decode import extract_gim_robust
from meshwm.profiles.robust.embed import embed_gim_robust, normal_distortion
from meshwm.profiles.robust.options import RobustOptions
from meshwm.profiles.robust.slots import local_frames
from meshwm.signal.fill import fill_missing


def _surface(n: int, seed: int = 0) -> np.ndarray:
    """A bumpy, curved sheet sampled on an n × n grid (a stand-in for a geometry image)."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    a, b = rng.uniform(2, 5, size=2)
    z = 0.3 * np.sin(a * u) * np.cos(b * v) + 0.2 * (u**2 - v**2)
    return np.stack([u, v, z], axis=-1)


def _bits(k: int, seed: int = 1) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 2, size=k).astype(np.uint8)


def _params(n: int, **kw) -> RobustOptions:
    """The robust options for an n-sample grid (n is implied by the image; kept for reading)."""
    if "step" in kw:
        kw["tangential_step"] = kw.pop("step")
    return RobustOptions(**kw)


@pytest.mark.parametrize("n, k", [(64, 16), (128, 64), (128, 256), (256, 1024), (512, 2048)])
@pytest.mark.parametrize("key", ["k", "another key"])
def test_round_trip_exact(n, k, key):
    gim = _surface(n)
    bits = _bits(k)
    p = _params(n)
    marked = embed_gim_robust(gim, bits, key=key, options=p).gim
    out = extract_gim_robust(marked, k, key=key, options=p)
    assert out.bits.tolist() == bits.tolist()
    assert np.all(out.confidence[bits == 1] > 0.5) and np.all(out.confidence[bits == 0] < -0.5)


@pytest.mark.parametrize("distortion", [5e-5, 1.6e-4, 5e-4])
def test_calibration_reaches_the_target_and_extraction_needs_no_step(distortion):
    gim = _surface(256, seed=11)
    bits = _bits(1024, seed=12)
    p = _params(256, distortion=distortion)
    res = embed_gim_robust(gim, bits, key="k", options=p)
    assert normal_distortion(gim, res.gim) == pytest.approx(distortion, rel=0.05)
    assert res.report["distortion"] == pytest.approx(distortion, rel=0.05)
    out = extract_gim_robust(res.gim, 1024, key="k", options=_params(256))
    assert out.bits.tolist() == bits.tolist()


def test_explicit_step_is_used_as_given():
    gim = _surface(128)
    p = _params(128, step=0.03)
    res = embed_gim_robust(gim, _bits(64), key="k", options=p)
    assert res.report["step"] == 0.03
    assert extract_gim_robust(res.gim, 64, key="k", options=p).bits.tolist() == _bits(64).tolist()
    assert embed_gim_robust(gim, _bits(64), key="k", options=_params(128, step=0.06)).report[
        "distortion"
    ] == pytest.approx(2 * res.report["distortion"], rel=0.1)


def test_border_samples_do_not_move():
    gim = _surface(128)
    marked = embed_gim_robust(gim, _bits(64), key="k", options=_params(128)).gim
    assert np.array_equal(marked[[0, -1]], gim[[0, -1]])
    assert np.array_equal(marked[:, [0, -1]], gim[:, [0, -1]])
    assert not np.array_equal(marked, gim)


def test_similarity_transform_reads_the_same():
    gim = _surface(128, seed=3)
    bits = _bits(256, seed=4)
    p = _params(128)
    marked = embed_gim_robust(gim, bits, key="k", options=p).gim
    rot = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_matrix()
    moved = 37.5 * marked @ rot.T + np.array([5.0, -2.0, 100.0])
    assert extract_gim_robust(moved, 256, key="k", options=p).bits.tolist() == bits.tolist()


def test_wrong_key_reads_noise():
    gim = _surface(256)
    bits = _bits(1024)
    p = _params(256)
    marked = embed_gim_robust(gim, bits, key="right", options=p).gim
    wrong = extract_gim_robust(marked, 1024, key="wrong", options=p).bits
    assert 0.4 < np.mean(wrong != bits) < 0.6


def test_deterministic_bytes():
    gim = _surface(128)
    p = _params(128)
    a = embed_gim_robust(gim, _bits(64), key="k", options=p).gim
    b = embed_gim_robust(gim.copy(), _bits(64), key="k", options=p).gim
    assert a.tobytes() == b.tobytes()


def test_smoothing_is_survived_by_the_gain_search():
    gim = _surface(256, seed=5)
    bits = _bits(1024, seed=6)
    p = _params(256)
    marked = embed_gim_robust(gim, bits, key="k", options=p).gim
    blurred = np.stack(
        [ndimage.gaussian_filter(marked[..., c], 1.5, mode="nearest") for c in range(3)], -1
    )
    out = extract_gim_robust(blurred, 1024, key="k", options=p)
    assert out.report["gain"] < 0.99 * embedded_gain(gim, bits, p)  # the search saw the blur
    assert np.mean(out.bits != bits) < 0.05


def embedded_gain(gim, bits, p):
    marked = embed_gim_robust(gim, bits, key="k", options=p).gim
    return extract_gim_robust(marked, len(bits), key="k", options=p).report["gain"]


def test_missing_samples_are_erasures():
    gim = _surface(256, seed=7)
    bits = _bits(1024, seed=8)
    p = _params(256)
    marked = embed_gim_robust(gim, bits, key="k", options=p).gim
    cropped = marked.copy()
    cropped[:, 180:] = np.nan  # about 30 % of the samples lost
    out = extract_gim_robust(cropped, 1024, key="k", options=p)
    assert out.report["missing"] == pytest.approx(76 / 256)
    assert np.mean(out.bits != bits) < 0.05


def test_fill_missing_keeps_present_samples_and_is_finite():
    gim = _surface(64)
    holed = gim.copy()
    holed[10:20, 30:50] = np.nan
    filled, missing = fill_missing(holed)
    assert missing.sum() == 200
    assert np.all(np.isfinite(filled))
    assert np.array_equal(filled[~missing], gim[~missing])
    with pytest.raises(ValueError, match="no samples"):
        fill_missing(np.full((8, 8, 3), np.nan))


def test_local_frames_are_orthonormal_and_rotate_with_the_surface():
    approx = _surface(32, seed=2) * 8.0
    frames, scale = local_frames(approx)
    eye = np.einsum("ijab,ijcb->ijac", frames, frames)
    assert np.allclose(eye, np.eye(3), atol=1e-12)
    assert np.all(scale > 0)
    rot = Rotation.from_euler("zyx", [1.0, 0.2, -0.7]).as_matrix()
    frames_r, scale_r = local_frames(3.0 * approx @ rot.T)
    assert np.allclose(frames_r, frames @ rot.T, atol=1e-10)
    assert np.allclose(scale_r, 3.0 * scale)


def test_degenerate_positions_carry_nothing():
    gim = _surface(64)
    gim[:, :, :] = gim[:, :1, :]  # every column the same: tangent along j vanishes
    p = _params(64)
    res = embed_gim_robust(gim, _bits(16), key="k", options=p)
    assert res.report["carriers"] == 0
    assert np.array_equal(res.gim, gim)


@pytest.mark.parametrize(
    "gim, k, match",
    [
        (np.zeros((64, 64)), 16, "N, N, 3"),
        (np.zeros((48, 48, 3)), 16, "power of two"),
        (np.zeros((16, 16, 3)), 16, "power of two"),
        (_surface(64), 0, "positive"),
        (_surface(64), 10_000, "do not fit"),
    ],
)
def test_bad_input(gim, k, match):
    p = _params(64)
    with pytest.raises(ValueError, match=match):
        extract_gim_robust(gim, k, key="k", options=p)


def test_embed_refuses_nan_cover():
    gim = _surface(64)
    gim[5, 5, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        embed_gim_robust(gim, _bits(16), key="k", options=_params(64))


def test_gain_search_matches_the_plain_loop():
    """The vectorised float32 score search picks the gain a float64 loop over GAINS picks."""
    from meshwm.profiles.robust.decode import _FINE, GAINS, _scores, prepare_gim_robust
    from meshwm.profiles.robust.slots import _layout

    gim = _surface(128, seed=3)
    bits = _bits(64, seed=4)
    p = _params(128)
    marked = embed_gim_robust(gim, bits, key="k", options=p).gim
    noisy = marked + np.random.default_rng(0).normal(0, 2e-3, marked.shape)

    def plain(prep, layout, gains):
        out = []
        for g in gains:
            vote = prep.weight * np.cos(2 * np.pi * (prep.x / g - layout.dither))
            out.append(np.abs(np.bincount(layout.bit, weights=vote, minlength=64)).sum())
        return np.array(out)

    for received, key in ((marked, "k"), (noisy, "k"), (marked, "other")):
        prep = prepare_gim_robust(received, options=p)
        layout = _layout(128, key, 64)
        fast = _scores(prep.x, prep.weight, layout, GAINS)
        np.testing.assert_allclose(fast, plain(prep, layout, GAINS), rtol=1e-5)
        fine = GAINS[int(np.argmax(fast))] * _FINE
        got = _scores(prep.x, prep.weight, layout, fine)
        np.testing.assert_allclose(got, plain(prep, layout, fine), rtol=1e-5)


def test_prepared_decoding_equals_one_shot_extraction():
    from meshwm.profiles.robust.decode import decode_robust, prepare_gim_robust

    gim = _surface(128, seed=7)
    bits = _bits(64, seed=8)
    p = _params(128)
    marked = embed_gim_robust(gim, bits, key="k", options=p).gim
    marked[40:60, 10:30] = np.nan  # a crop
    prep = prepare_gim_robust(marked, options=p)
    for key in ("k", "x", "y"):
        one = extract_gim_robust(marked, 64, key=key, options=p)
        two = decode_robust(prep, 64, key=key)
        assert one.bits.tolist() == two.bits.tolist()
        np.testing.assert_array_equal(one.confidence, two.confidence)
        assert one.report == two.report
    assert np.mean(decode_robust(prep, 64, key="k").bits != bits) < 0.05


def test_candidates_decode_many_keys_like_fresh_candidates():
    """Candidates prepare each image once and give what a fresh Candidates gives."""
    from meshwm.gim.to_mesh import geometry_image_to_mesh
    from meshwm.profiles.robust.search import Candidates
    from meshwm.readers.connectivity import read_connectivity

    n = 64
    gim = _surface(n, seed=9)
    p = _params(n)
    marked = embed_gim_robust(gim, _bits(16), key="k", options=p).gim
    v, f = geometry_image_to_mesh(marked)
    image = read_connectivity(v, f)
    received = Candidates(image, options=p)
    for key in ("k", "wrong", "k"):
        a = received.decode(16, key=key)
        b = Candidates(image, options=p).decode(16, key=key)
        assert a.bits.tolist() == b.bits.tolist()
        assert a.report == b.report
    assert received.decode(16, key="k").bits.tolist() == _bits(16).tolist()
    # A weak read (wrong key) went through the unsmoothing candidates, now kept.
    assert received._unsmoothed is not None and len(received._unsmoothed) == 12


@pytest.mark.parametrize("n", [64, 256, 512, 1024])
def test_the_rounds_along_the_border_are_the_whole_images_transforms(n):
    # _embed_at transforms x, y and z at once, reconstructs the whole image once, and follows
    # the rounds' border corrections along the border alone: the marked image is the
    # rounds computed with whole-image transforms, channel by channel (what it computed
    # before), to rounding.
    import pywt

    from meshwm.profiles.robust import embed as module
    from meshwm.profiles.robust.slots import _layout, _split, _steps, _unit, _values, _wavedec

    gim, bits = _surface(n, seed=3), _bits(64, seed=4)
    layout = _layout(n, "k", len(bits))
    cover = _wavedec(gim)
    approx, _ = _split(cover)
    frames, scale = local_frames(approx)
    steps = _steps(approx, layout, 0.05)
    got = module._embed_at(gim, bits, layout, frames, scale, steps, cover)

    per_channel = [
        pywt.wavedec2(gim[..., k], "sym4", mode="periodization", level=3) for k in range(3)
    ]
    np.testing.assert_array_equal(approx, np.stack([c[0] for c in per_channel], axis=-1))
    live = scale[layout.row, layout.col] > 0
    target = bits[layout.bit] / 2.0
    border = np.zeros((n, n), dtype=bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    marked, want = gim.copy(), None
    for _ in range(module._ROUNDS):
        coeffs = [
            pywt.wavedec2(marked[..., k], "sym4", mode="periodization", level=3) for k in range(3)
        ]
        details = np.stack([np.stack([c[1][b] for c in coeffs], axis=-1) for b in range(3)])
        vals = _values(details, frames, scale, layout)
        if want is None:
            t = vals / steps - layout.dither
            want = vals + module.ALPHA * (np.floor(t - target + 0.5) + target - t) * steps
        local = np.zeros((3, *scale.shape, 3))
        local[layout.band, layout.row, layout.col, layout.comp] = np.where(
            live, want - vals, 0.0
        ) * _unit(scale, layout)
        world = np.einsum("ijab,kija->kijb", frames, local)
        for k in range(3):
            zero = [np.zeros_like(coeffs[k][0])] + [
                tuple(np.zeros_like(d) for d in level) for level in coeffs[k][1:]
            ]
            zero[1] = tuple(world[b, ..., k] for b in range(3))
            delta = pywt.waverec2(zero, "sym4", mode="periodization")
            delta[border] = 0.0
            marked[..., k] += delta
    if n < 512:  # the whole image each round: the same operations
        np.testing.assert_array_equal(got, marked)
    np.testing.assert_allclose(got, marked, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(got[border], gim[border])
    assert np.abs(got - gim).max() > 1e-4


@pytest.mark.parametrize("n", [64, 512, 2048])
def test_the_border_operators_are_the_whole_images_transforms(n):
    # _border_of_change and _details_of_border use the 1-D operators of the separable 2-D
    # transforms: the same numbers as pywt's whole-image transforms, to rounding.
    import pywt

    from meshwm.profiles.robust import embed as module

    rng = np.random.default_rng(n)
    m = n >> 3
    world = rng.normal(size=(3, m, m, 3))
    image = np.stack(
        [
            pywt.waverec2(
                [np.zeros((m, m)), tuple(world[b, ..., k] for b in range(3))]
                + [(None, None, None)] * 2,
                "sym4",
                mode="periodization",
            )
            for k in range(3)
        ],
        axis=-1,
    )
    border = module._border_of_change(world, n)
    want = np.stack([image[0], image[-1], image[:, 0], image[:, -1]])
    np.testing.assert_allclose(border, want, rtol=0, atol=1e-13 * np.abs(want).max())

    values = rng.normal(size=(4, n, 3))
    only = np.zeros((n, n, 3))
    only[:, 0], only[:, -1] = values[2], values[3]
    only[0], only[-1] = values[0], values[1]  # the corners are the rows'
    coeffs = [pywt.wavedec2(only[..., k], "sym4", mode="periodization", level=3) for k in range(3)]
    details = np.stack([np.stack([c[1][b] for c in coeffs], axis=-1) for b in range(3)])
    got = module._details_of_border(values, n)
    np.testing.assert_allclose(got, details, rtol=0, atol=1e-13 * np.abs(details).max())


def _fake_calibration(ratios):
    """An embedding whose distortion is the step times ``ratios[k]`` at its k-th call."""
    calls = []

    def embed_at(step):
        calls.append(step)
        return np.array([step * ratios[len(calls) - 1]])

    return calls, embed_at, lambda marked: float(marked[0])


def test_calibration_ends_at_the_first_embedding_within_tolerance():
    from meshwm.profiles.robust.embed import _calibrated

    target = 1.85e-4
    # Proportional to within 0.5 % after the first correction: two embeddings.
    calls, embed_at, distortion = _fake_calibration([0.002, 0.002 * 1.005, 1.0, 1.0])
    step, marked = _calibrated(embed_at, distortion, target, tolerance=0.01)
    assert len(calls) == 2 and step == calls[1]
    assert abs(distortion(marked) - target) <= 0.01 * target


def test_calibration_without_tolerance_makes_every_embedding_and_keeps_the_last():
    from meshwm.profiles.robust.embed import CALIBRATION_EMBEDDINGS, _calibrated
    from meshwm.profiles.robust.slots import _CALIBRATION_START

    target = 1.85e-4
    ratios = [0.002, 0.002 * 1.005, 0.002 * 1.11, 0.002 * 0.95]
    calls, embed_at, distortion = _fake_calibration(ratios)
    step, marked = _calibrated(embed_at, distortion, target, tolerance=0.0)
    assert len(calls) == CALIBRATION_EMBEDDINGS and step == calls[-1]
    assert marked[0] == calls[-1] * ratios[-1]
    # Each step the last one corrected by target / measured (what it always did).
    want = [_CALIBRATION_START]
    for r in ratios[:-1]:
        want.append(min(want[-1] * target / (want[-1] * r), 1.0))
    assert calls == want


def test_calibration_stops_at_a_zero_distortion():
    from meshwm.profiles.robust.embed import _calibrated

    calls, embed_at, distortion = _fake_calibration([0.0] * 4)
    assert _calibrated(embed_at, distortion, 1.85e-4, tolerance=0.0)[0] == calls[0]
    assert len(calls) == 1


@pytest.mark.parametrize(("n", "embeddings"), [(256, 4), (512, 2)])
def test_calibration_ends_early_from_n_512_only(n, embeddings, monkeypatch):
    # From N = 512 the first correction lands within the tolerance (here after one
    # correction); below, all four embeddings are made, as they always were.
    from meshwm.profiles.robust import embed as module

    made = []
    real = module._embed_at
    monkeypatch.setattr(module, "_embed_at", lambda *a, **k: made.append(1) or real(*a, **k))
    gim = _surface(n, seed=5)
    result = embed_gim_robust(gim, _bits(64, seed=6), key="k", options=RobustOptions())
    assert len(made) == embeddings
    measured = normal_distortion(gim, result.gim)
    assert result.report["distortion"] == measured
    if n >= module.CALIBRATION_EARLY_FROM:
        target = RobustOptions().distortion
        assert abs(measured - target) <= module.CALIBRATION_TOLERANCE * target


def test_warm_keeps_the_layout_the_embedding_then_uses_and_leaves_refusals_to_it():
    from meshwm.errors import CapacityError
    from meshwm.profiles.robust.profile import PROFILE
    from meshwm.profiles.robust.slots import _cached_layout

    _cached_layout.cache_clear()
    PROFILE.warm(64, key="warm-key", n_bits=64)
    assert _cached_layout.cache_info().currsize == 1
    gim, bits = _surface(64), _bits(64)
    PROFILE.embed(gim, bits, key="warm-key")
    info = _cached_layout.cache_info()
    assert info.hits >= 1 and info.currsize == 1  # the embedding took the warmed layout
    PROFILE.warm(64, key="warm-key", n_bits=10**6)  # does not fit: nothing kept, no error
    assert _cached_layout.cache_info().currsize == 1
    with pytest.raises(CapacityError):
        PROFILE.embed(gim, np.zeros(10**6, dtype=np.uint8), key="warm-key")


@pytest.mark.parametrize("n", [128, 512])
def test_only_the_given_bits_slots_move(n):
    # A weak bit reinforced: its slots move as the whole embedding moves them, at the same
    # step; every other slot keeps its value (to the border's corrections, 0.3 % of a move).
    from meshwm.profiles.robust.slots import _layout, _split, _values, _wavedec

    gim, bits = _surface(n, seed=3), _bits(64, seed=4)
    options = RobustOptions(tangential_step=0.05)
    whole = embed_gim_robust(gim, bits, key="k", options=options).gim
    weak = np.arange(64) % 5 == 0
    some = embed_gim_robust(gim, bits, key="k", options=options, only=weak).gim
    layout = _layout(n, "k", len(bits))
    approx, _ = _split(_wavedec(gim))
    frames, scale = local_frames(approx)

    def values(image):
        return _values(_split(_wavedec(image))[1], frames, scale, layout)

    cover, full, partial = values(gim), values(whole), values(some)
    moved = weak[layout.bit]
    assert np.abs(partial - cover)[~moved].max() < 3e-3 * np.abs(full - cover).max()
    np.testing.assert_allclose(partial[moved], full[moved], rtol=0, atol=1e-7)
    read = extract_gim_robust(some, len(bits), key="k")
    assert read.bits[weak].tolist() == bits[weak].tolist()
    assert (read.bits[~weak] != bits[~weak]).mean() > 0.2  # the others were not embedded


def test_reinforce_needs_the_embeddings_step():
    # Reinforced at a step of its own calibration, a bit would move on another lattice.
    from meshwm.profiles.robust.profile import PROFILE

    gim, bits = _surface(64, seed=3), _bits(16, seed=4)
    weak = np.ones(16, dtype=bool)
    with pytest.raises(ValueError, match="tangential_step"):
        PROFILE.reinforce(gim, bits, key="k", options=RobustOptions(), weak=weak)
    got = PROFILE.reinforce(
        gim, bits, key="k", options=RobustOptions(tangential_step=0.05), weak=weak
    )
    assert extract_gim_robust(got.marked, 16, key="k").bits.tolist() == bits.tolist()
