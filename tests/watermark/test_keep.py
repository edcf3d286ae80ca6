"""Tests for :mod:`meshwm.watermark.keep`: the user's own mesh marked, the id read back blind."""

from __future__ import annotations

import numpy as np
import pytest
from _fins import with_fins

from meshwm.attacks import apply_attack
from meshwm.errors import CapacityError
from meshwm.gim.surface import sample_surface, surface_of
from meshwm.mesh.zip import Zipped
from meshwm.message.mark import default_mark
from meshwm.metrics import bounding_box_diagonal
from meshwm.watermark import Decoder, embed, verify

KEY = "a studio key"
IDENT = bytes.fromhex("0123456789abcdef")


@pytest.fixture(scope="module")
def kitten_marked(kitten_mesh):
    v, f = kitten_mesh
    return v, f, embed(v, f, key=KEY, ident=IDENT, distances=False)


def test_the_input_mesh_is_kept_and_only_positions_move(kitten_marked):
    v, f, marked = kitten_marked
    assert marked.vertices.shape == v.shape
    np.testing.assert_array_equal(marked.faces, f)
    moved = np.linalg.norm(marked.vertices - v, axis=1)
    diag = bounding_box_diagonal(v)
    assert 0 < moved.max() < 0.005 * diag  # a mark, not a remesh
    assert np.median(moved) > 0  # spread over the mesh, not a few vertices
    assert marked.report["mode"] == "kept" and marked.report["n"] in (128, 256)


def test_the_id_reads_back_blind_and_a_wrong_key_does_not(kitten_marked):
    _, f, marked = kitten_marked
    got = Decoder(marked.vertices, f).extract_id(key=KEY, expected=IDENT)
    assert got.id == IDENT.hex() and got.report["ber"] == 0
    assert got.report["reader"] == "radial"  # the cheap carrier reads first
    # The surface map's carrier holds the id too, on its own.
    alone = Decoder(marked.vertices, f, readers=("surface",)).extract_id(key=KEY)
    assert alone.id == IDENT.hex() and alone.report["reader"] == "surface"
    assert alone.report["hypotheses"] > 2  # both sizes and the gain search are counted
    assert marked.report["radial_ber"] == 0
    assert verify(marked.vertices, f, key=KEY, ident=IDENT).detected
    assert not verify(marked.vertices, f, key="another key", ident=IDENT).detected


def test_the_unmarked_mesh_is_not_detected(kitten_mesh):
    v, f = kitten_mesh
    assert not verify(v, f, key=KEY, ident=IDENT).detected


@pytest.mark.parametrize(
    ("attack", "options"),
    [
        ("reorder", {}),
        ("similarity", {}),
        ("round_trip", {"suffix": ".stl"}),
        ("round_trip", {"suffix": ".obj"}),
        ("float32", {}),
        ("quantize", {"bits": 10}),
        ("noise", {"amplitude": 0.001}),
        ("split_seams", {}),
        ("merge_load", {}),
        ("weld_stl", {}),
        ("laplacian", {"lam": 0.1, "iterations": 10}),
        ("meshlab_laplacian", {"iterations": 3}),
        ("flip_edges", {"count": 100}),
        ("retriangulate", {}),
    ],
)
def test_the_id_survives(kitten_marked, attack, options):
    _, f, marked = kitten_marked
    av, af = apply_attack(attack, marked.vertices, f, seed=3, **options)
    assert Decoder(av, af).extract_id(key=KEY).id == IDENT.hex()


@pytest.mark.parametrize(
    ("then", "options"),
    [
        ("noise", {"amplitude": 0.001}),
        pytest.param("meshlab_laplacian", {"iterations": 3}, marks=pytest.mark.slow),
        ("quantize", {"bits": 10}),
    ],
)
def test_seams_split_then_moved_read_through_the_zipped_surface(
    kitten_marked, then, options, monkeypatch
):
    # An export's UV seams, then noise or a smoothing that moves the copies apart (or coarse
    # quantisation, which merges other vertices too): the surface reader zips the seams.
    _, f, marked = kitten_marked
    sv, sf = apply_attack("split_seams", marked.vertices, f, seed=5)
    av, af = apply_attack(then, sv, sf, seed=5, **options)
    got = Decoder(av, af, readers=("surface",)).extract_id(key=KEY)
    assert got.id == IDENT.hex()
    if then != "quantize":  # without the zipping, the seams stay open and nothing reads
        import meshwm.readers.surface as surface_reader

        monkeypatch.setattr(surface_reader, "zip_borders", lambda v, f: Zipped(v, f, 0))
        assert Decoder(av, af, readers=("surface",)).extract_id(key=KEY).id is None


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_seams_split_then_meshlab_smoothing_reads_through_the_zipped_canonical_start(
    spot_mesh, seed
):
    # MeshLab smooths split seams as borders; the zipped mesh's canonical start undoes it
    # (the decoder tries every connectivity's canonical start with every candidate: decoded
    # only when among the strongest as received, spot read 0.508 and 0.461 wrong here).
    v, f = spot_mesh
    marked = embed(v, f, key=KEY, ident=IDENT, distances=False)
    sv, sf = apply_attack("split_seams", marked.vertices, f, seed=seed)
    av, af = apply_attack("meshlab_laplacian", sv, sf, seed=0, iterations=3)
    got = Decoder(av, af).extract_id(key=KEY, expected=IDENT)
    assert got.id == IDENT.hex() and got.report["ber"] < 0.1


def _mirrored(vertices: np.ndarray, faces: np.ndarray, seed: int) -> tuple:
    """A change of handedness in a random pose (the ``mirror`` attack)."""
    return apply_attack("mirror", vertices, faces, seed=seed)


@pytest.mark.parametrize(
    ("attack", "options"),
    [
        (None, {}),
        ("float32", {}),
        ("round_trip", {"suffix": ".obj"}),
        pytest.param("split_seams", {}, marks=pytest.mark.slow),
        ("flip_edges", {"count": 100}),
        ("weld_stl", {}),
        ("reorder", {}),
    ],
)
def test_a_mirrored_copy_reads_through_the_radial_readers_mirror_image(
    kitten_marked, attack, options
):
    _, f, marked = kitten_marked
    seed = 7 + len(options) + (len(attack) if attack else 0)
    mv, mf = _mirrored(marked.vertices, f, seed)
    if attack is not None:
        mv, mf = apply_attack(attack, mv, mf, seed=seed, **options)
    got = Decoder(mv, mf).extract_id(key=KEY)
    assert got.id == IDENT.hex() and got.report["reader"] == "radial (mirrored)"
    # Without the mirror image no reader finds it: the pose sees the mark's mirror image.
    assert Decoder(mv, mf, mirror=False).extract_id(key=KEY).id != IDENT.hex()


@pytest.mark.parametrize(
    ("attack", "options"),
    [
        ("quantize", {"bits": 16}),
        ("noise", {"amplitude": 0.001}),
        ("meshlab_laplacian", {"iterations": 3}),
    ],
)
def test_a_mirrored_copy_reads_through_the_surface_readers_mirror_image(
    kitten_marked, attack, options
):
    """What the radial carrier does not take after a mirror (noise, smoothing; after 16-bit
    quantisation it reads kitten's id at 0.082, which only ordered statistics decodes) reads
    through the surface map of the mirror image, its smoothing undone as on the mesh itself."""
    _, f, marked = kitten_marked
    seed = 11 + len(attack)
    mv, mf = apply_attack(attack, *_mirrored(marked.vertices, f, seed), seed=seed, **options)
    assert Decoder(mv, mf).extract_id(key=KEY).id == IDENT.hex()
    got = Decoder(mv, mf, readers=("surface (mirrored)",)).extract_id(key=KEY)
    assert got.id == IDENT.hex() and got.report["reader"] == "surface (mirrored)"
    assert Decoder(mv, mf, mirror=False).extract_id(key=KEY).id != IDENT.hex()


@pytest.mark.slow
def test_the_mirror_image_is_counted_and_detects_nothing_unmarked(kitten_mesh, kitten_marked):
    _, f, marked = kitten_marked
    mv, mf = _mirrored(marked.vertices, f, 3)
    both, plain = Decoder(mv, mf), Decoder(mv, mf, mirror=False)
    assert both.hypotheses > plain.hypotheses
    assert verify(mv, mf, key=KEY, ident=IDENT).detected
    assert not verify(mv, mf, key="another key", ident=IDENT).detected
    uv, uf = _mirrored(*kitten_mesh, 4)
    assert not verify(uv, uf, key=KEY, ident=IDENT).detected


def test_the_image_is_the_same_under_random_similarities(kitten_mesh):
    v, f = kitten_mesh
    base = sample_surface(surface_of(v, f), size=128).samples
    diag = bounding_box_diagonal(v)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        q *= np.sign(np.linalg.det(q))
        scale = 10.0 ** rng.uniform(-2, 2)
        shift = rng.uniform(-100, 100, 3)
        moved = scale * v @ q.T + shift
        again = sample_surface(surface_of(moved, f[rng.permutation(len(f))]), size=128).samples
        back = ((again - shift) / scale) @ q
        np.testing.assert_array_equal(np.isnan(back), np.isnan(base))
        assert np.nanmax(np.abs(back - base)) < 1e-9 * diag


def test_a_payload_the_mesh_cannot_carry_is_refused():
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=2)  # 162 vertices
    with pytest.raises(CapacityError, match="payload"):
        embed(np.asarray(sphere.vertices), np.asarray(sphere.faces), key=KEY, distances=False)


@pytest.fixture(scope="module")
def plane_logo(plane_mesh):
    # With this key plane_holes' surface map reads one bit of the logo's 1,024 wrong (the
    # radial carrier reads it whole): refused while a mark had to read back exactly.
    v, f = plane_mesh
    return v, f, embed(v, f, default_mark(32), key="k3", distances=False)


def test_a_logo_read_back_with_a_few_bits_wrong_is_marked_and_reported(plane_logo):
    v, f, marked = plane_logo
    np.testing.assert_array_equal(marked.faces, f)
    assert len(marked.vertices) == len(v)
    assert marked.report["read_ber"] == 1 / 1024
    assert verify(marked.vertices, f, key="k3", mark=default_mark(32)).detected
    assert not verify(marked.vertices, f, key="another key", mark=default_mark(32)).detected


def test_a_copy_marked_with_the_logo_does_not_verify_as_another_mark(plane_logo):
    # The logo is 64 % background: a blank mark agreed with its read on 64 % of the bits (p
    # 2.8e-19, "present"). Marks are now tested given their counts of 1s.
    _, f, marked = plane_logo
    yy, xx = np.mgrid[:32, :32]
    ring = (np.abs(np.hypot(yy - 15.5, xx - 15.5) - 11) < 3).astype(np.uint8)
    thin = ((yy == 16) | (xx == 16)).astype(np.uint8)
    for other in (np.zeros((32, 32), np.uint8), ring, thin, 1 - default_mark(32)):
        assert not verify(marked.vertices, f, key="k3", mark=other).detected
    assert verify(marked.vertices, f, key="k3", mark=default_mark(32)).detected


#: A key with which kitten carries the logo at once (its surface map reads it with 1.4 % of
#: the bits wrong; with ``KEY``, 3 %: its weak bits reinforced).
LOGO_KEY = "studio-key-2026"


@pytest.mark.slow
def test_a_logo_left_with_a_few_bits_wrong_is_reinforced_until_it_reads(kitten_mesh, monkeypatch):
    # With KEY the first mark of the logo reads back with 3 % of its bits wrong (the transfer
    # onto kitten's 9k vertices cannot move every slot of the N = 256 image): refused until
    # 2026-12-06.  Its weak bits reinforced, it reads within the same bounds.
    import meshwm.watermark.keep as keep

    v, f = kitten_mesh
    logo = default_mark(32)
    marked = embed(v, f, logo, key=KEY)
    report = marked.report
    assert report["reinforced"] and report["sizes_tried"]["256"]["ber"] > 0.02
    assert report["read_ber"] <= 0.005
    assert report["mrms_rel"] <= 2e-4 and report["hausdorff_rel"] <= 1.5e-3
    np.testing.assert_array_equal(marked.faces, f)
    assert verify(marked.vertices, f, key=KEY, mark=logo).detected
    assert not verify(marked.vertices, f, key="another key", mark=logo).detected
    monkeypatch.setattr(keep, "_REINFORCE_ROUNDS", 0)
    with pytest.raises(CapacityError, match="wrong bits"):
        embed(v, f, logo, key=KEY, distances=False)


@pytest.fixture(scope="module")
def kitten_logo(kitten_mesh):
    v, f = kitten_mesh
    return v, f, embed(v, f, default_mark(32), key=LOGO_KEY, distances=False)


@pytest.mark.parametrize(
    "attack, options",
    [("quantize", {"bits": 16}), pytest.param("noise", {}, marks=pytest.mark.slow)],
)
def test_a_logo_is_read_at_its_own_size_blind(kitten_logo, attack, options):
    # kitten carries the logo at N = 256; its surface reader also offers N = 128, where a
    # 1,024-bit read of noise scores a mean |confidence| of 0.58 against the marked image's
    # 0.49: images are ranked by what they read above noise (their read with a key no mark
    # was made with), or the blind read after any attack the radial carrier does not survive
    # was noise.
    _, f, marked = kitten_logo
    assert marked.report["n"] == 256
    av, af = apply_attack(attack, marked.vertices, f, seed=3, **options)
    logo = default_mark(32)
    found = Decoder(av, af, readers=("surface",)).extract(key=LOGO_KEY, expected=logo)
    # The N = 128 image's read is noise (about half the bits wrong); the marked image's, after
    # 0.1 % noise, 4-6 % (0.044 before the radial image was made continuous, 0.056 since: the
    # radial carrier's moves on top of the surface mark are others).
    assert found.report["n"] == 256 and found.report["ber"] < 0.1
    assert verify(av, af, key=LOGO_KEY, mark=logo).detected


@pytest.mark.slow
def test_a_logos_image_is_the_one_whose_mark_reads_most_like_a_drawing(kitten_logo, monkeypatch):
    # After 16-bit quantisation the radial carrier reads kitten's logo more strongly above
    # noise than the surface map does (0.55 against 0.28) but with four times the wrong bits:
    # picked by strength, the logo came out with 6 % of its bits wrong; picked as the mark
    # whose neighbouring pixels agree most, with 1.5 %.
    import importlib

    extract = importlib.import_module("meshwm.watermark.extract")
    _, f, marked = kitten_logo
    av, af = apply_attack("quantize", marked.vertices, f, bits=16)
    logo = default_mark(32)
    found = Decoder(av, af).extract(key=LOGO_KEY, expected=logo)
    assert found.report["chosen_by"] == "drawing" and found.report["reader"] == "surface"
    assert found.report["ber"] < 0.03
    monkeypatch.setattr(extract, "_DRAWN_SIGMAS", float("inf"))
    by_strength = Decoder(av, af).extract(key=LOGO_KEY, expected=logo)
    assert by_strength.report["chosen_by"] == "strength"
    assert by_strength.report["ber"] > found.report["ber"] + 0.02


def test_noise_is_not_taken_for_a_drawing(kitten_mesh):
    v, f = kitten_mesh
    found = Decoder(v, f).extract(key=LOGO_KEY, expected=default_mark(32))
    assert found.report["chosen_by"] == "strength" and found.report["ber"] > 0.4


@pytest.mark.parametrize("wrong, ok", [(0, True), (20, True), (21, False), (100, False)])
def test_a_mark_is_accepted_with_at_most_2_percent_of_its_bits_wrong(plane_logo, wrong, ok):
    from meshwm.message.scramble import arnold_scramble
    from meshwm.params import WatermarkParams

    _, f, marked = plane_logo
    bits = arnold_scramble(default_mark(32), iterations=WatermarkParams().arnold_iterations)
    bits = bits.ravel().astype(np.uint8)
    reader = Decoder(marked.vertices, f, readers=("radial",))  # reads this logo whole
    bits[:wrong] ^= 1  # 20 of 1,024 is 1.95 %, 21 is 2.05 %
    assert reader.reads(bits, key="k3") == (ok, wrong / 1024)


@pytest.mark.slow
def test_every_size_is_tried_before_a_payload_is_refused(monkeypatch):
    # A 32×32 logo on the genus-8 plate reads back as another map would (its own map too:
    # 32 % of the bits wrong at N = 256): refused at once as "a symmetric shape" until
    # 2026-12-06, without trying N = 128 (48 %); now both are tried, and the message says
    # the payload may be too large, naming the id.
    import meshwm.watermark.keep as keep
    from meshwm.apps.bench.synthetic import make

    sizes = []
    mark_at = keep._mark_at
    monkeypatch.setattr(
        keep,
        "_mark_at",
        lambda s, image, *a, **k: sizes.append(image.n) or mark_at(s, image, *a, **k),
    )
    v, f = make("genus8")
    # The best read-back's share of wrong bits (32 % and 48 % here until 2026-12-07, 18 % on
    # another machine's rounding) picks the message's first half; either names the id.
    refused = r"(too large for the mesh|wrong bits) \(a 64-bit id .*--id\)"
    with pytest.raises(CapacityError, match=refused):
        embed(v, f, default_mark(32), key=KEY, distances=False)
    assert sizes == [256, 128]


def test_grid_mode_is_the_papers_output(kitten_mesh):
    from meshwm.params import WatermarkParams

    v, f = kitten_mesh
    marked = embed(
        v, f, key=KEY, ident=IDENT, distances=False, grid=True, params=WatermarkParams(size=64)
    )
    assert marked.report["mode"] == "grid" and len(marked.vertices) != len(v)
    assert Decoder(marked.vertices, marked.faces).extract_id(key=KEY).report["reader"] == (
        "connectivity"
    )


def test_a_surface_with_many_holes_is_marked_and_read(plane_mesh):
    v, f = plane_mesh  # 27 boundary loops: filled virtually, islands in the map
    marked = embed(v, f, key=KEY, ident=IDENT, distances=False)
    np.testing.assert_array_equal(marked.faces, f)
    assert Decoder(marked.vertices, f).extract_id(key=KEY).id == IDENT.hex()


@pytest.fixture(scope="module")
def finned_spot(spot_mesh):
    """spot with 12 fins (edges of three faces), marked."""
    v, f = with_fins(*spot_mesh)
    return v, f, embed(v, f, key=KEY, ident=IDENT)


def test_a_mesh_with_fins_is_marked_whole(finned_spot):
    v, f, marked = finned_spot
    np.testing.assert_array_equal(marked.faces, f)
    assert marked.vertices.shape == v.shape
    assert marked.report["faces_detached"] == 12 and marked.report["components"] == 13
    # The fins come off the surface (passed through its map); the radial carrier moves them.
    assert np.abs(marked.vertices[-12:] - v[-12:]).max() < 2e-3
    assert marked.report["mrms_rel"] <= 2e-4 and marked.report["hausdorff_rel"] <= 1.5e-3
    alone = Decoder(marked.vertices, f, readers=("surface",)).extract_id(key=KEY)
    assert alone.id == IDENT.hex()
    assert not verify(marked.vertices, f, key="another key", ident=IDENT).detected


@pytest.mark.parametrize(
    ("attack", "options"),
    [
        ("similarity", {}),
        ("reorder", {}),
        ("weld_stl", {}),
        ("meshlab_laplacian", {"iterations": 3}),
        ("laplacian", {"lam": 0.1, "iterations": 30}),  # undone over the fins too
        ("flip_edges", {"count": 100}),
    ],
)
def test_a_mesh_with_fins_reads_after(finned_spot, attack, options):
    _, f, marked = finned_spot
    av, af = apply_attack(attack, marked.vertices, f, seed=4, **options)
    assert Decoder(av, af).extract_id(key=KEY).id == IDENT.hex()


def test_surface_peak_is_the_two_sided_vertex_distance(spot_mesh):
    import igl

    from meshwm.watermark.keep import _clamp_peaks, surface_peak

    v, f = spot_mesh
    diag = bounding_box_diagonal(v)
    rng = np.random.default_rng(4)
    for seed in range(5):
        d = rng.normal(size=v.shape) * 2e-4 * diag
        d[rng.integers(0, len(v), 10)] *= 10 + seed  # a few spikes, as a mark on few vertices
        there = igl.point_mesh_squared_distance(v + d, v, f)[0].max()
        back = igl.point_mesh_squared_distance(v, v + d, f)[0].max()
        brute = float(np.sqrt(max(there, back))) / diag
        assert surface_peak(v, f, d) == pytest.approx(brute, rel=1e-12)
        clamped, largest = _clamp_peaks(v, f, d)
        peak = surface_peak(v, f, clamped)
        assert peak <= 1.3e-3
        small = np.linalg.norm(d, axis=1) < 1e-3 * diag  # vertices far under the cap keep
        np.testing.assert_array_equal(clamped[small], d[small])  # their whole move
        # The clamp's last round measured the clamped move's peak (spikes brought to the cap).
        assert largest is not None
        assert largest / diag == pytest.approx(peak, rel=1e-12)
        assert surface_peak(v, f, clamped, largest=largest) == largest / diag
        there = igl.point_mesh_squared_distance(v + clamped, v, f)[0].max()
        back = igl.point_mesh_squared_distance(v, v + clamped, f)[0].max()
        assert largest / diag == pytest.approx(float(np.sqrt(max(there, back))) / diag, rel=1e-12)
    # Nothing near the cap: the clamp asks no vertex, and knows no peak.
    quiet = rng.normal(size=v.shape) * 1e-5 * diag
    unchanged, largest = _clamp_peaks(v, f, quiet)
    np.testing.assert_array_equal(unchanged, quiet)
    assert largest is None


def test_the_largest_distance_over_the_clamps_aim_is_the_peak(spot_mesh):
    # After a nudge the peak is measured as the clamp measures it (only vertices whose bound
    # passes its aim): a smooth move of many vertices near the cap, then one far under it.
    from meshwm.watermark.keep import _largest_above, surface_peak

    v, f = spot_mesh
    diag = bounding_box_diagonal(v)
    wave = np.sin(40 * v / diag) * np.cos(25 * v[:, [1, 2, 0]] / diag)
    for scale in (1.2e-3, 1.6e-3):
        d = wave * scale * diag / np.abs(wave).max()
        largest = _largest_above(v, f, d)
        assert largest is not None and largest / diag > 0.97 * 1.3e-3
        assert largest / diag == surface_peak(v, f, d)
    assert _largest_above(v, f, wave * 1e-4 * diag / np.abs(wave).max()) is None


@pytest.mark.parametrize("above", [0.0, 2e-4, 6e-4, 2e-3])
def test_vertex_distances_are_exact_wherever_they_pass_the_threshold(spot_mesh, above, monkeypatch):
    """Each vertex's two-sided distance, against igl's on the whole mesh, for every vertex
    over ``above`` (the ring bound only decides which vertices are queried)."""
    import igl

    from meshwm.watermark import keep
    from meshwm.watermark.keep import _vertex_distances

    monkeypatch.setattr(keep, "_RING_CHUNK", 97)  # the bound in chunks, as on a large mesh

    v, f = spot_mesh
    f = np.concatenate([f, [[0, 0, 1]]])  # a degenerate face does not upset the bound
    diag = bounding_box_diagonal(v)
    rng = np.random.default_rng(7)
    checked = 0
    for scale in (1e-4, 5e-4, 3e-3):  # up to moves larger than spot's edges
        d = rng.normal(size=v.shape) * scale * diag
        there = igl.point_mesh_squared_distance(v + d, v, f)[0]
        back = igl.point_mesh_squared_distance(v, v + d, f)[0]
        brute = np.sqrt(np.maximum(there, back))
        got, got_diag = _vertex_distances(v, f, d, above=above)
        assert got_diag == pytest.approx(diag)
        over = brute > above * diag
        checked += int(over.sum())
        np.testing.assert_allclose(got[over], brute[over], rtol=1e-12, atol=1e-15 * diag)
        assert np.all(got[~over] <= above * diag)
    assert checked > 100


def test_vertex_distances_are_exact_on_a_mesh_of_very_uneven_edges():
    """The faces searched follow each face's own longest edge: on a sheet whose cells grow
    from 1e-4 to 1 of its width, every vertex's distance is still igl's over the whole mesh."""
    import igl

    from meshwm.watermark.keep import _vertex_distances

    x = np.concatenate([[0.0], np.geomspace(1e-4, 1.0, 39)])
    y = np.linspace(0.0, 0.3, 12)
    xx, yy = np.meshgrid(x, y)
    v = np.stack([xx.ravel(), yy.ravel(), 0.05 * np.sin(7 * xx.ravel()) * yy.ravel()], axis=1)
    cols = len(x)
    quads = [
        (r * cols + c, r * cols + c + 1, (r + 1) * cols + c + 1, (r + 1) * cols + c)
        for r in range(len(y) - 1)
        for c in range(cols - 1)
    ]
    f = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.int64)
    diag = bounding_box_diagonal(v)
    rng = np.random.default_rng(11)
    for scale in (1e-5, 1e-3, 2e-2):
        d = rng.normal(size=v.shape) * scale * diag
        there = igl.point_mesh_squared_distance(v + d, v, f)[0]
        back = igl.point_mesh_squared_distance(v, v + d, f)[0]
        brute = np.sqrt(np.maximum(there, back))
        above = float(np.quantile(brute, 0.8)) / diag  # a fifth of the vertices over it
        got, _ = _vertex_distances(v, f, d, above=above)
        over = brute > above * diag
        assert over.sum() > 10
        np.testing.assert_allclose(got[over], brute[over], rtol=1e-12, atol=1e-15 * diag)


@pytest.mark.parametrize("above", [0.0, 6e-4])
def test_border_distances_are_igls_along_the_border_edges(plane_mesh, above):
    """Each border vertex's distance along its border edges, both ways, against igl's on the
    whole mesh at the same points, wherever it passes ``above``; 0 off the border."""
    import igl

    from meshwm.mesh.edges import border_half_edges
    from meshwm.watermark.keep import _BORDER_SAMPLES, _border_distances

    v, f = plane_mesh
    diag = bounding_box_diagonal(v)
    border = border_half_edges(f)
    t = _BORDER_SAMPLES[:, None, None]
    rng = np.random.default_rng(5)
    checked = 0
    for scale in (2e-4, 1e-3):
        d = rng.normal(size=v.shape) * scale * diag
        brute = np.zeros(len(v))
        for a, b in ((v + d, v), (v, v + d)):
            points = ((1 - t) * a[border[:, 0]] + t * a[border[:, 1]]).reshape(-1, 3)
            far = np.sqrt(igl.point_mesh_squared_distance(points, b, f)[0])
            far = far.reshape(len(_BORDER_SAMPLES), -1).max(axis=0)
            np.maximum.at(brute, border[:, 0], far)
            np.maximum.at(brute, border[:, 1], far)
        got = _border_distances(v, f, d, above=above)
        over = brute > above * diag
        checked += int(over.sum())
        np.testing.assert_allclose(got[over], brute[over], rtol=1e-12, atol=1e-15 * diag)
        assert np.all(got[~over] == 0)
    assert checked > 100


def test_a_rim_slid_along_its_hole_is_seen_and_clamped(slid_rim):
    # Every vertex stays on the other surface; the rim's chords span the hole 0.2 % of the
    # diagonal away, over the cap: a clamp that measured vertices alone left it there.
    from _border import border_reach

    from meshwm.watermark.keep import _clamp_peaks, _vertex_distances, surface_peak

    v, f, slid = slid_rim
    diag = bounding_box_diagonal(v)
    d = slid - v
    assert _vertex_distances(v, f, d)[0].max() < 1e-12 * diag
    reach = max(border_reach(slid, f, v), border_reach(v, f, slid))
    assert surface_peak(v, f, d) == pytest.approx(reach / diag, rel=1e-9)
    assert reach > 1.5e-3 * diag
    clamped, _ = _clamp_peaks(v, f, d)
    assert surface_peak(v, f, clamped) <= 1.3e-3
    # Between the samples along an edge the distance may peak higher (here 0.138 %), within
    # the 0.15 % bound.
    moved = v + clamped
    assert max(border_reach(moved, f, v), border_reach(v, f, moved)) <= 1.5e-3 * diag


@pytest.mark.slow
def test_vertex_distances_find_a_long_face_whose_corners_are_all_far():
    """A dense patch over a plane of two large triangles, moved through it: each patch
    vertex's nearest point on the moved surface is on a large triangle (0.01 away, the patch
    0.012), whose corners are all far away."""
    import igl

    from meshwm.watermark.keep import _vertex_distances

    t = np.linspace(0.45, 0.55, 30)
    xx, yy = np.meshgrid(t, t)
    patch = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, 0.01)], axis=1)
    quads = [
        (r * 30 + c, r * 30 + c + 1, (r + 1) * 30 + c + 1, (r + 1) * 30 + c)
        for r in range(29)
        for c in range(29)
    ]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]) + 4
    plane = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    v = np.concatenate([plane, patch])
    f = np.concatenate([[[0, 1, 2], [0, 2, 3]], tris]).astype(np.int64)
    d = np.zeros_like(v)
    d[4:, 2] = -0.012
    there = igl.point_mesh_squared_distance(v + d, v, f)[0]
    back = igl.point_mesh_squared_distance(v, v + d, f)[0]
    brute = np.sqrt(np.maximum(there, back))
    got, diag = _vertex_distances(v, f, d, above=1e-3)
    over = brute > 1e-3 * diag
    assert over.sum() > 800
    np.testing.assert_allclose(got[over], brute[over], rtol=1e-12)
    assert got[4:].max() < 0.0101  # the plane, not the moved patch (0.012)


@pytest.mark.parametrize("shift", [0.0, 1e6])
def test_gaps_are_the_trees_bounded_distances_bit_for_bit(shift):
    """Only points near a query are asked, and each answer is the tree's own, at any limit."""
    from scipy.spatial import cKDTree

    from meshwm.watermark.keep import _gaps

    rng = np.random.default_rng(5)
    points = rng.normal(size=(20_000, 3)) * [1.0, 3.0, 0.01] + shift
    for count in (0, 1, 7, 300):
        query = points[rng.choice(len(points), count)] + rng.normal(size=(count, 3)) * 1e-3
        for limit in (0.0, 1e-3, 0.05, 0.4, 50.0):
            got = _gaps(points, query, limit)
            if count == 0:
                assert np.isinf(got).all()
                continue
            want = cKDTree(query).query(points, k=1, distance_upper_bound=limit)[0]
            np.testing.assert_array_equal(got, want)


def test_the_genus_8_plate_is_marked_within_the_hausdorff_cap():
    from meshwm.apps.bench.synthetic import make

    v, f = make("genus8")  # its corner's first edge is a near-tie the mark tips
    marked = embed(v, f, key=KEY, ident=IDENT, distances=False)
    np.testing.assert_array_equal(marked.faces, f)
    assert marked.report["peak"] <= 1.3e-3
    assert Decoder(marked.vertices, f).extract_id(key=KEY).id == IDENT.hex()


def test_a_mesh_smaller_than_the_payload_is_refused_at_once():
    import trimesh

    box = trimesh.creation.box()  # 8 vertices
    with pytest.raises(CapacityError, match="8 vertices cannot carry a 256-bit"):
        embed(np.asarray(box.vertices), np.asarray(box.faces), key=KEY, ident=IDENT)
    # 20 spheres of 162 vertices: 3,240 in all, but the surface is the largest piece.
    balls = trimesh.util.concatenate(
        [trimesh.creation.icosphere(2, radius=0.1).apply_translation([k, 0, 0]) for k in range(20)]
    )
    with pytest.raises(
        CapacityError, match=r"largest connected piece of this mesh \(162 of its 3240"
    ):
        embed(np.asarray(balls.vertices), np.asarray(balls.faces), key=KEY, ident=IDENT)


@pytest.mark.slow
def test_a_symmetric_shape_is_refused_with_the_reason():
    import trimesh

    # 2048 vertices, every one tied for the start with the others of its ring.  (An icosphere
    # of 2562 vertices was refused until the radial carrier kept the pose: its passes chasing a
    # ball's pose then moved the mesh off the map the mark was made in.)
    torus = trimesh.creation.torus(major_radius=2, minor_radius=0.7, major_sections=64)
    with pytest.raises(CapacityError, match="symmetric shape"):
        embed(np.asarray(torus.vertices), np.asarray(torus.faces), key=KEY, ident=IDENT)


def test_the_marked_mesh_keeps_the_inputs_cut_start(spot_mesh):
    # spot's two farthest vertices are 8e-6 of the radius apart: the mark alone can tip them,
    # and the embedder then puts the start back, so a reader's first map is the embedder's.
    v, f = spot_mesh
    before = surface_of(v, f)
    seen = set()
    for key in ("k1", "k2"):  # (with these keys: tipped and put back; not tipped)
        marked = embed(v, f, key=key, ident=bytes(8), distances=False)
        seen.add(marked.report["start"])
        after = surface_of(marked.vertices, f)
        np.testing.assert_array_equal(after.map.cut.order[:2], before.map.cut.order[:2])
        np.testing.assert_array_equal(after.map.uv, before.map.uv)
    assert seen == {"nudged", "kept"}


def test_the_start_is_checked_after_the_radial_carrier(spot_mesh):
    # With this key and id the radial carrier tipped spot's start again after it had been put
    # back (when the start came first): the start is now checked on the final positions, and
    # the radial carrier still reads every bit.
    v, f = spot_mesh
    before = surface_of(v, f)
    marked = embed(v, f, key="k3", ident=bytes.fromhex("0badc0de5ca1ab1e"), distances=False)
    assert marked.report["start"] == "nudged"
    assert marked.report["radial_ber"] == 0.0
    after = surface_of(marked.vertices, f)
    np.testing.assert_array_equal(after.map.cut.order[:2], before.map.cut.order[:2])


def test_the_start_is_checked_beside_the_last_radial_read_only(spot_mesh, monkeypatch):
    """The start's check runs beside the radial carrier's read-back (a second thread); where
    the read finds a wrong bit and the carrier is made again, the check of the discarded
    displacement is not used: what comes back is the check of the final one."""
    from meshwm.watermark import keep

    v, f = spot_mesh
    surface = surface_of(v, f)
    bits = np.random.default_rng(5).integers(0, 2, 256).astype(np.uint8)
    d0 = np.zeros_like(surface.positions)
    real_read = keep.radial_read
    reads = []

    def read_once_wrong(*args, **kwargs):
        got, confidence, pose = real_read(*args, **kwargs)
        reads.append(1)
        if len(reads) == 1:
            got = got.copy()
            got[0] ^= 1
        return got, confidence, pose

    monkeypatch.setattr(keep, "radial_read", read_once_wrong)
    seen = []

    def check(d):
        seen.append(d.copy())
        return d.copy()

    faces = surface.inverse[f]
    clamped, report, after = keep._carry_radial(
        surface.positions, faces, surface.faces, d0, bits, key=KEY, alongside=check
    )
    assert len(reads) == 2 and len(seen) == 2 and report["radial_ber"] == 0
    assert not np.array_equal(seen[0], seen[1])  # the carrier was made again
    np.testing.assert_array_equal(after, clamped.displacement)
    np.testing.assert_array_equal(after, seen[1])


def test_a_mesh_moved_through_the_grid_basis_reads_blind(kitten_mesh, monkeypatch):
    # The grid basis is for meshes many times finer than the grid (a 0.5M-vertex scan at
    # N = 128: 33 vertices a sample); forced here on kitten (0.6 a sample), it marks within
    # the same bounds and the surface carrier alone reads it, also after noise and smoothing.
    import meshwm.watermark.keep as keep

    monkeypatch.setattr(keep, "_BASIS_DENSITY", 0)
    v, f = kitten_mesh
    marked = embed(v, f, key=KEY, ident=IDENT, distances=True)
    assert marked.report["transfer"] == "grid"
    np.testing.assert_array_equal(marked.faces, f)
    assert marked.report["mrms_rel"] <= 2e-4 and marked.report["hausdorff_rel"] <= 1.5e-3
    for attack, options in [
        ("similarity", {}),
        ("noise", {"amplitude": 0.001}),
        ("laplacian", {"lam": 0.1, "iterations": 10}),
    ]:
        av, af = apply_attack(attack, marked.vertices, f, seed=3, **options)
        got = Decoder(av, af, readers=("surface",)).extract_id(key=KEY)
        assert got.id == IDENT.hex(), attack


def test_the_grid_basis_is_chosen_by_density(kitten_marked):
    assert kitten_marked[2].report["transfer"] == "vertices"  # 9k vertices: their own moves


def test_a_mark_over_the_distortion_target_is_brought_down_to_it(spot_mesh, monkeypatch):
    # Uncalibrated, the profile's first step moves spot a third over the target; the surface
    # mark is scaled down to it (the radial carrier and the peak clamp add under 2 %), and the
    # scaled mark still reads back blind.
    import meshwm.watermark.keep as keep
    from meshwm.params import WatermarkParams

    target = WatermarkParams().options.distortion
    monkeypatch.setattr(keep, "_CALIBRATION_ROUNDS", 0)
    seen = []
    measure = keep._rms_along
    monkeypatch.setattr(keep, "_rms_along", lambda *a: seen.append(measure(*a)) or seen[-1])
    v, f = spot_mesh
    marked = embed(v, f, key=KEY, ident=IDENT, distances=False)
    assert seen[0] > 1.1 * target  # the mark as made: over the target
    assert 0.98 * target <= marked.report["distortion"] <= 1.02 * target
    assert Decoder(marked.vertices, f).extract_id(key=KEY).id == IDENT.hex()
