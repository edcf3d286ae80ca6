"""Tests for :mod:`meshwm.readers`: the registry and the connectivity reader."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.errors import GridError, MeshError
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.clean import uniform_smoothing_operator
from meshwm.readers import READERS, get_reader, read_received
from meshwm.readers.connectivity import UNSMOOTH_LAMBDA, UNSMOOTH_STEPS, read_connectivity


def _sheet(n: int = 64) -> np.ndarray:
    i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    return np.stack([i, j, 0.1 * np.sin(6 * i) * np.cos(5 * j)], axis=-1)


def test_registry_lists_the_connectivity_reader_first():
    assert next(iter(READERS)) == "connectivity"
    assert get_reader("connectivity") is read_connectivity
    with pytest.raises(ValueError, match="unknown reader 'x'; valid: connectivity"):
        get_reader("x")


@pytest.mark.parametrize("seed", range(5))
def test_connectivity_reader_gives_the_samples_under_any_vertex_order(seed):
    gim = _sheet()
    v, f = geometry_image_to_mesh(gim)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(v))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(v))
    image = read_received(v[perm], inverse[f][rng.permutation(len(f))])
    assert image.reader == "connectivity" and image.n == 64 and image.hypotheses >= 1
    assert not image.missing.any()
    # The grid may be read in any of its 8 symmetries; the samples are the same set.
    candidates = [np.rot90(g, k) for g in (gim, gim.transpose(1, 0, 2)) for k in range(4)]
    assert any(np.array_equal(image.samples, c) for c in candidates)


def test_smoothing_undone_inverts_uniform_laplacian_steps():
    gim = _sheet()
    v, f = geometry_image_to_mesh(gim)
    mean, moved = uniform_smoothing_operator(len(v), f)
    smoothed = v.copy()
    for _ in range(UNSMOOTH_STEPS[1]):
        step = mean @ smoothed - smoothed
        smoothed = smoothed + UNSMOOTH_LAMBDA * np.where(moved[:, None], step, 0.0)
    image = read_connectivity(smoothed, f)
    assert image.smoothing_undone is not None
    undone = dict(image.smoothing_undone())
    assert sorted(undone) == list(UNSMOOTH_STEPS[1:])
    direct = read_connectivity(v, f).samples
    # k = 5 undoes the 5 steps (to the fixed point's accuracy), better than the received mesh.
    assert_allclose(undone[5], direct, rtol=0, atol=1e-6)
    assert np.abs(image.samples - direct).max() > 1e-4


def test_no_grid_and_bad_arrays_are_refused():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(400, 3))
    f = rng.integers(0, 400, size=(300, 3))
    # A random soup is no grid and no surface; its points still have a spherical image.
    for name in ("connectivity", "surface"):
        with pytest.raises((GridError, MeshError)):
            get_reader(name)(v, f, max_faces=10**6)
    assert read_received(v, f).reader == "radial"
    flat = v * [1.0, 1.0, 0.0]  # a flat one has not even that, nor a small one
    with pytest.raises(GridError, match="plane"):
        read_received(flat, f)
    with pytest.raises(GridError, match="too few"):
        read_received(v, f % 40)
    with pytest.raises(MeshError):
        read_received(np.full((3, 3), np.nan), np.array([[0, 1, 2]]))
    assert_array_equal(read_connectivity(*geometry_image_to_mesh(_sheet())).missing, False)


def test_surface_reader_offers_the_connectivity_as_given_when_vertices_coincide(spot_mesh):
    from meshwm.attacks import apply_attack
    from meshwm.gim.surface import SURFACE_RANKS, SURFACE_SIZES, surface_of
    from meshwm.readers.surface import read_surface

    v, f = spot_mesh
    plain = read_surface(v, f)
    near = surface_of(v, f).map.cut.near_ties
    assert len(plain) == (len(SURFACE_RANKS) + len(near)) * len(SURFACE_SIZES)
    sv, sf = apply_attack("split_seams", v, f, seed=3)  # copies of positions: merged on read
    split = read_surface(sv, sf)
    assert len(split) == len(plain) + len(SURFACE_RANKS) * len(SURFACE_SIZES)
    # The merged reading is the input's; the extra ones are the split connectivity's own.
    assert_array_equal(split[0].samples, plain[0].samples)
    assert not np.array_equal(split[len(plain)].samples, plain[0].samples, equal_nan=True)


def test_a_near_tie_of_the_farthest_vertex_is_offered():
    from meshwm.gim.stable import TIPS, stable_cut

    # An octahedron whose +x corner is 1e-5 farther out than the others: the other corners
    # are its neighbours (not tips of their own) within RADIAL_MARGIN of it.
    v = np.array([[1.00001, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])
    f = np.array(
        [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    )
    cut = stable_cut(v, f, steps=0)
    assert cut.order[0] == 0 and 2 * TIPS in cut.near_ties
    runner = stable_cut(v, f, steps=0, rank=2 * TIPS)
    assert runner.order[0] != 0  # the runner-up corner
    clear = v.copy()
    clear[0, 0] = 1.2
    far = stable_cut(clear, f, steps=0)  # a clear winner: no near-tie
    assert not any(r >= 2 * TIPS for r in far.near_ties)


def test_readers_run_lazily_and_an_early_stop_counts_what_it_skipped(spot_mesh):
    from meshwm.message.payload import encode_id
    from meshwm.watermark import Decoder
    from meshwm.watermark.radial import embed_radial

    assert list(READERS) == ["connectivity", "radial", "surface"]
    v, f = spot_mesh
    ident = bytes.fromhex("00112233aabbccdd")
    marked = embed_radial(v, f, encode_id(ident), key="k").vertices
    decoder = Decoder(marked, f)
    found = decoder.extract_id(key="k")
    assert found.id == ident.hex() and found.report["reader"] == "radial"
    assert decoder.images.errors and decoder.images.errors[0].startswith("connectivity")
    assert len(decoder.images._done) == 2  # the surface reader never ran
    # Stopping at the radial image counts every image the surface reader could offer, at
    # the robust profile's most; another key, or another decoder, counts the same.
    assert found.report["hypotheses"] > 32 * 5000
    again = Decoder(marked, f)
    again.extract_id(key="another key")
    assert again.hypotheses == decoder.hypotheses == found.report["hypotheses"]


def test_the_canonical_surface_reading_is_the_first_start_and_the_near_ties(spot_mesh):
    from meshwm.attacks import apply_attack
    from meshwm.gim.surface import SURFACE_RANKS, SURFACE_SIZES, surface_of
    from meshwm.readers.surface import MOST_MIRRORED, read_surface

    v, f = spot_mesh
    plain = read_surface(v, f)
    near = surface_of(v, f).map.cut.near_ties
    assert near  # spot's start has near-ties
    canonical = read_surface(v, f, canonical=True)
    sizes = len(SURFACE_SIZES)
    assert len(canonical) == (1 + len(near)) * sizes <= MOST_MIRRORED
    # The same images as the full reading's first start and near-ties, in the same order.
    same = list(range(sizes)) + list(range(len(SURFACE_RANKS) * sizes, len(plain)))
    for k, j in enumerate(same):
        assert_array_equal(canonical[k].samples, plain[j].samples)
        assert canonical[k].primary == plain[j].primary
    # Coincident vertices: no reading of the connectivity as given either.
    sv, sf = apply_attack("split_seams", v, f, seed=3)
    assert len(read_surface(sv, sf, canonical=True)) == len(canonical)


def test_the_mirror_image_undoes_smoothing_once_with_the_mesh(spot_mesh, monkeypatch):
    """Its positions undone are the mesh's reflected (the undoings commute with a
    reflection): computed once for both, and what a reading of the mirror image alone makes."""
    from meshwm.attacks import apply_attack
    from meshwm.readers import read_all
    from meshwm.readers import surface as module

    v, f = spot_mesh
    sv, sf = apply_attack("meshlab_laplacian", v, f, iterations=1)
    calls: list[int] = []
    real = module._unsmoothed
    monkeypatch.setattr(module, "_unsmoothed", lambda p, fa: calls.append(len(p)) or real(p, fa))
    images = read_all(sv, sf, readers=["surface"])
    readers = [image.reader for image in images]
    assert "surface" in readers and "surface (mirrored)" in readers
    plain = images[readers.index("surface")].smoothing_undone()
    shared = images[readers.index("surface (mirrored)")].smoothing_undone()
    assert len(calls) == 1 and len(shared) == len(plain) > 1
    mv, mf = sv * [-1.0, 1.0, 1.0], np.ascontiguousarray(sf[:, ::-1])
    alone = module.read_surface(mv, mf, canonical=True)[0].smoothing_undone()
    assert len(calls) == 2  # outside a shared memo: computed
    scale = float(np.ptp(sv, axis=0).max())
    assert [label for label, _ in shared] == [label for label, _ in alone]
    for (_, got), (_, want) in zip(shared, alone, strict=True):
        assert_allclose(got, want, rtol=0, atol=1e-12 * scale)


def test_a_mirror_images_reading_is_asked_for_by_its_label(spot_mesh):
    from meshwm.readers import read_all, reader_names

    v, f = spot_mesh
    assert reader_names() == [*READERS, "radial (mirrored)", "surface (mirrored)"]
    alone = read_all(v, f, readers=["surface (mirrored)"])
    assert {image.reader for image in alone} == {"surface (mirrored)"}
    both = read_all(v, f, readers=["surface"])
    assert [image.reader for image in both] == ["surface"] * (len(both) - len(alone)) + [
        "surface (mirrored)"
    ] * len(alone)
    with pytest.raises(ValueError, match="unknown readers"):
        read_all(v, f, readers=["surface (mirror)"])
    with pytest.raises(ValueError, match="no reader to run"):
        read_all(v, f, readers=["surface (mirrored)"], mirror=False)


def test_a_start_that_gives_an_image_already_made_offers_it_and_is_decoded_once(
    spot_mesh, monkeypatch
):
    """An STL soup's connectivity as given has no surface of its own, so its starts are the
    cleaned mesh's; spot's near-tie starts cut as runner-up tips do.  Each such start offers
    the image already made (the same object, so the same smoothing undone), the hypotheses
    still count every start, and a decoder reads each image once as received and once at
    most with every candidate."""
    from meshwm.readers.surface import read_surface
    from meshwm.watermark.extract import Decoder

    v, f = spot_mesh
    soup_v, soup_f = v[f.ravel()], np.arange(3 * len(f)).reshape(-1, 3)
    for mv, mf in ((v, f), (soup_v, soup_f)):
        images = read_surface(mv, mf)
        firsts = {id(images[k]): k for k in reversed(range(len(images)))}
        assert len(firsts) < len(images)
        # No two image objects are the same image.
        made = [images[k] for k in sorted(firsts.values())]
        for i, a in enumerate(made):
            for b in made[i + 1 :]:
                assert not np.array_equal(a.samples, b.samples, equal_nan=True)
    # The soup's first image is the PLY's (to the solver's rounding in another vertex order).
    assert_allclose(images[0].samples, read_surface(v, f)[0].samples, atol=1e-9)

    prepared: list[int] = []
    original_prepare = Decoder._prepare

    def prepare(self, k):
        prepared.append(k)
        return original_prepare(self, k)

    monkeypatch.setattr(Decoder, "_prepare", prepare)
    decoder = Decoder(soup_v, soup_f)
    found = decoder.extract_id(key="a key it was never marked with")
    assert found.id is None
    # Every image offered again was decoded as its first place only.
    images = list(decoder.images)
    first_place = {id(image): k for k, image in reversed(list(enumerate(images)))}
    assert set(prepared) == set(first_place.values())
    assert len(images) > len(first_place)
    # The hypotheses count every start the reader offers.
    assert found.report["hypotheses"] == decoder.images.bound(
        lambda s: decoder._decoder(s).max_hypotheses
    )


def test_a_mirror_image_offered_twice_is_one_labelled_image():
    """The mirrored readers label each image once, so an image a reader offers twice (the
    surface reader's near-tie start of igea's mirror image cuts as its canonical start)
    stays one object, which a decoder decodes once."""
    from meshwm.readers import _mirrored
    from meshwm.readers.base import LazyImages, SampledImage

    made = [
        SampledImage(samples=np.full((8, 8, 3), float(k)), hypotheses=1, reader="surface")
        for k in range(2)
    ]
    offered = LazyImages(4, lambda k: made[k % 2])  # images 2 and 3 are 0 and 1 again
    mirrored = _mirrored(offered)
    assert [image.reader for image in mirrored] == ["surface (mirrored)"] * 4
    assert mirrored[2] is mirrored[0] and mirrored[3] is mirrored[1]
    assert mirrored[0] is not mirrored[1]
    assert_array_equal(mirrored[1].samples, made[1].samples)


def test_a_runner_up_starts_map_is_let_go_once_its_images_are_made(spot_mesh, monkeypatch):
    """Each start's cut mesh and UVs are as large as the mesh: an unmarked mesh's read maps
    every start, so only each connectivity's canonical map is kept, and the images of the
    others still undo a smoothing as a fresh reading does."""
    import gc
    import weakref

    from meshwm.attacks import apply_attack
    from meshwm.readers import surface as module

    v, f = spot_mesh
    sv, sf = apply_attack("meshlab_laplacian", v, f, iterations=1)
    maps: list[weakref.ref] = []
    real = module.remap_surface

    def remap(*args, **kwargs):
        surface = real(*args, **kwargs)
        maps.append(weakref.ref(surface.map.uv))
        return surface

    monkeypatch.setattr(module, "remap_surface", remap)
    images = module.read_surface(sv, sf)
    made = list(images)
    gc.collect()
    alive = [ref() is not None for ref in maps]
    assert len(maps) >= 3 and not any(alive[:-1])  # the last start's, until the next one
    # The first runner-up start's image, undone after its map was let go, against a fresh
    # reading's same image, asked for before any other (its map made and still held).
    k = len(module.SURFACE_SIZES)  # the second start's first size
    assert not made[k].primary
    got = made[k].smoothing_undone()
    fresh = module.read_surface(sv, sf)[k].smoothing_undone()
    assert [label for label, _ in got] == [label for label, _ in fresh] and len(got) > 1
    for (_, a), (_, b) in zip(got, fresh, strict=True):
        assert_array_equal(a, b)
