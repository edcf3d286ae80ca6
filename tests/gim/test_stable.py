"""meshwm.gim.stable (the cut) and meshwm.gim.tutte (the map): what does not move them."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.attacks.transforms import noise
from meshwm.errors import MeshError
from meshwm.gim.stable import TIPS, canonical_labelling, cut_start, smoothed_copy, stable_cut
from meshwm.gim.tutte import (
    StableMap,
    boundary_loop,
    restart_map,
    stable_parameterize,
    tutte_map,
)

MESHES = ["spot_mesh", "kitten_mesh", "plane_mesh"]  # closed genus 0, closed genus 1, 27 holes

TETRA_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def _similarity(vertices: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    scale = np.exp(rng.uniform(np.log(0.01), np.log(100.0)))
    return scale * vertices @ _rotation(rng).T + rng.uniform(-100.0, 100.0, size=3)


def _corner_uv(result: StableMap) -> np.ndarray:
    """(m, 3, 2): the UV at each face corner, which names the same point whatever the order."""
    return result.uv[result.cut.mesh.faces]


@pytest.fixture(scope="module")
def reference(request: pytest.FixtureRequest) -> dict[str, tuple]:
    out = {}
    for name in MESHES:
        v, f = request.getfixturevalue(name)
        out[name] = (v, f, stable_parameterize(v, f))
    return out


def test_smoothed_copy_moves_with_a_similarity(spot_mesh):
    v, f = spot_mesh
    rng = np.random.default_rng(3)
    rot = _rotation(rng)
    moved = smoothed_copy(2.5 * v @ rot.T + [1.0, -2.0, 3.0], f)
    np.testing.assert_allclose(
        moved, 2.5 * smoothed_copy(v, f) @ rot.T + [1.0, -2.0, 3.0], atol=1e-12
    )


@pytest.mark.parametrize(("steps", "lam"), [(-1, 0.5), (2.5, 0.5), (5, 0.0), (5, 1.5)])
def test_smoothed_copy_rejects_bad_options(steps, lam):
    with pytest.raises(ValueError, match="steps" if lam == 0.5 else "lam"):
        smoothed_copy(TETRA_V, TETRA_F, steps=steps, lam=lam)


def test_labelling_follows_a_permutation():
    rng = np.random.default_rng(0)
    order, parent = canonical_labelling(4, TETRA_F, source=0, first=1)
    assert order[0] == 0 and order[1] == 1 and parent[0] == -1
    perm = rng.permutation(4)  # new vertex i is old perm[i]
    inv = np.argsort(perm)
    order2, _ = canonical_labelling(4, inv[TETRA_F], source=int(inv[0]), first=int(inv[1]))
    np.testing.assert_array_equal(perm[order2], order)


def _labelling_one_by_one(n, faces, source, first):
    """The traversal as first written (one vertex at a time, in Python): the reference the
    level-by-level :func:`canonical_labelling` must equal bit for bit."""
    a, b, c = faces.ravel(), faces[:, [1, 2, 0]].ravel(), faces[:, [2, 0, 1]].ravel()
    keys = np.unique(np.concatenate([a * n + b, a * n + c]))
    from_key = np.searchsorted(keys, a * n + b)
    succ = np.full(len(keys), -1)
    succ[from_key] = np.searchsorted(keys, a * n + c)
    pred = np.full(len(keys), -1)
    pred[succ[from_key]] = from_key
    twin = np.searchsorted(keys, (keys % n) * n + keys // n)
    target, succ, pred, twin = (keys % n).tolist(), succ.tolist(), pred.tolist(), twin.tolist()

    def ring(entry):
        out, h = [entry], succ[entry]
        while h not in (-1, entry):
            out.append(h)
            h = succ[h]
        if h == -1:
            back, h = [], pred[entry]
            while h != -1:
                back.append(h)
                h = pred[h]
            out.extend(back[::-1])
        return out

    parent = [-2] * n
    parent[source] = -1
    order, entries, head = [source], [int(np.searchsorted(keys, source * n + first))], 0
    while head < len(order):
        for h in ring(entries[head]):
            if parent[target[h]] == -2:
                parent[target[h]] = order[head]
                order.append(target[h])
                entries.append(twin[h])
        head += 1
    return np.asarray(order), np.asarray(parent)


@pytest.mark.parametrize("name", MESHES)
def test_labelling_equals_the_one_vertex_at_a_time_traversal(request, name):
    from meshwm.gim.holes import boundary_loops, fill_holes
    from meshwm.mesh.clean import clean_mesh

    v, f = request.getfixturevalue(name)
    clean = clean_mesh(v, f)
    filled = fill_holes(clean.vertices, clean.faces, boundary_loops(clean.faces))
    faces = filled.faces
    n = len(clean.vertices) + len(filled.centres)
    rng = np.random.default_rng(5)
    for _ in range(3):
        perm = rng.permutation(n)  # a random relabelling and face order too
        inv = np.argsort(perm)
        relabelled = inv[faces][rng.permutation(len(faces))]
        source = int(rng.integers(n))
        ring = relabelled[np.any(relabelled == source, axis=1)].ravel()
        first = int(rng.choice(ring[ring != source]))
        got = canonical_labelling(n, relabelled, source=source, first=first)
        want = _labelling_one_by_one(n, relabelled, source, first)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_labelling_rejects_bad_input():
    with pytest.raises(ValueError, match="first"):
        canonical_labelling(5, np.array([[0, 1, 2], [0, 2, 3]]), source=1, first=3)
    with pytest.raises(MeshError, match="not connected"):
        canonical_labelling(6, np.array([[0, 1, 2], [3, 4, 5]]), source=0, first=1)
    with pytest.raises(MeshError, match="oriented"):
        canonical_labelling(4, np.array([[0, 1, 2], [0, 1, 3]]), source=0, first=1)


def test_stable_cut_of_a_fin_raises_the_labellings_error():
    """The rotation system is found beside the smoothed copy (a second thread): its error on a
    fin (three faces on one edge) still reaches the caller, after the start was found."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0.3, 0.3, 0.9]])
    f = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 2, 5], [2, 1, 5], [1, 4, 5], [4, 0, 5]])
    cut_start(v, f)  # the start is found
    with pytest.raises(MeshError, match="not edge-manifold"):
        stable_cut(v, f)


def test_tutte_map_of_a_fan():
    faces = np.array([[0, 1, 5], [1, 2, 5], [2, 3, 5], [3, 4, 5], [4, 0, 5]])
    uv = tutte_map(faces, np.array([3, 0, 1, 2, 4, 5]))
    np.testing.assert_array_equal(
        boundary_loop(faces, np.array([3, 0, 1, 2, 4, 5])), [1, 2, 3, 4, 0]
    )
    np.testing.assert_allclose(uv[1], [0.0, 0.0])  # the start (smallest rank) at the origin
    np.testing.assert_allclose(uv[5], uv[:5].mean(axis=0))
    with pytest.raises(MeshError, match="fewer than 4"):
        tutte_map(np.array([[0, 1, 2]]), np.arange(3))


@pytest.mark.parametrize("name", MESHES)
def test_map_is_a_disk_in_the_unit_square(reference, name):
    _, f, result = reference[name]
    assert result.uv.min() >= 0.0 and result.uv.max() <= 1.0
    assert len(result.cut.mesh.faces) == len(f)
    a, b, c = (result.uv[result.cut.mesh.faces[:, k]] for k in range(3))
    area = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert (area > -1e-15).all()  # Tutte: no fold-over


@pytest.mark.slow
@pytest.mark.parametrize("name", MESHES)
def test_similarities_move_nothing(reference, name):
    v, f, result = reference[name]
    rng = np.random.default_rng(13)
    for _ in range(20):
        moved = stable_parameterize(_similarity(v, rng), f)
        np.testing.assert_array_equal(moved.cut.edges, result.cut.edges)
        np.testing.assert_allclose(_corner_uv(moved), _corner_uv(result), rtol=0, atol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("name", MESHES)
def test_reordering_moves_nothing(reference, name):
    v, f, result = reference[name]
    rng = np.random.default_rng(7)
    corners = np.arange(3)
    for _ in range(5):
        perm = rng.permutation(len(v))  # new vertex i is old perm[i]
        face_perm = rng.permutation(len(f))  # new face j is old face_perm[j]
        shift = rng.integers(0, 3, size=len(f))  # and its corners rotated by shift[j]
        roll = (corners[None, :] + shift[:, None]) % 3
        new_f = np.take_along_axis(np.argsort(perm)[f[face_perm]], roll, axis=1)
        moved = stable_parameterize(v[perm], new_f)
        uv = np.empty_like(_corner_uv(result))
        back = np.empty_like(roll)
        np.put_along_axis(back, roll, corners[None, :].repeat(len(f), axis=0), axis=1)
        uv[face_perm] = np.take_along_axis(_corner_uv(moved), back[:, :, None], axis=1)
        np.testing.assert_allclose(uv, _corner_uv(result), rtol=0, atol=1e-9)
        edges = np.sort(perm[moved.cut.edges], axis=1)
        np.testing.assert_array_equal(edges[np.lexsort(edges.T[::-1])], result.cut.edges)


@pytest.mark.parametrize("name", MESHES)
def test_noise_keeps_the_cut_and_the_map(reference, name):
    v, f, result = reference[name]
    for seed in range(3):
        noisy, _ = noise(v, f, seed=seed, amplitude=0.001)
        moved = stable_parameterize(noisy, f)
        np.testing.assert_array_equal(moved.cut.edges, result.cut.edges)
        # in samples at N = 256; measured 0 (the map depends on the connectivity only)
        assert np.abs(_corner_uv(moved) - _corner_uv(result)).max() * 256 < 0.1


def test_stable_cut_of_a_tetrahedron_is_a_disk():
    cut = stable_cut(TETRA_V, TETRA_F, steps=0)  # 50 steps shrink a tetrahedron to a point
    assert len(cut.edges) == 2 and len(cut.mesh.vertices) == 5  # the middle one split


def test_cut_start_is_the_cuts_first_half_edge(reference):
    for name in MESHES:
        v, f, result = reference[name]
        (source, first), near_ties = cut_start(v, f)
        assert (source, first) == (int(result.cut.order[0]), int(result.cut.order[1]))
        assert near_ties == result.cut.near_ties


def test_a_near_tie_of_first_edges_is_offered_and_started_along_the_runner_up():
    from meshwm.apps.bench.synthetic import make

    v, f = make("genus8")  # the plate's corner tip: its two longest edges 8e-4 apart
    cut = stable_cut(v, f)
    assert TIPS in cut.near_ties  # tip 0's runner-up edge
    other = stable_cut(v, f, rank=TIPS)
    assert other.order[0] == cut.order[0] and other.order[1] != cut.order[1]
    with pytest.raises(MeshError, match="no start of rank"):
        stable_cut(v, f, rank=3 * TIPS)


@pytest.mark.parametrize("name", MESHES)
def test_restart_map_is_the_map_of_the_moved_mesh(reference, name):
    v, f, result = reference[name]
    rng = np.random.default_rng(11)
    diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    reused = 0
    for k in range(6):  # small and mark-sized moves: reused exactly where the start holds
        moved = v + rng.normal(size=v.shape) * (1e-7 if k < 3 else 2e-4) * diag
        again = restart_map(result, moved, f)
        fresh = stable_parameterize(moved, f)
        if again is None:  # spot's tips are 8e-6 of the radius apart: a mark can swap them
            assert (int(fresh.cut.order[0]), int(fresh.cut.order[1])) != (
                int(result.cut.order[0]),
                int(result.cut.order[1]),
            )
            continue
        reused += 1
        np.testing.assert_array_equal(again.uv, fresh.uv)
        np.testing.assert_array_equal(again.cut.mesh.vertices, fresh.cut.mesh.vertices)
        np.testing.assert_array_equal(again.cut.mesh.faces, fresh.cut.mesh.faces)
        assert again.cut.near_ties == fresh.cut.near_ties
    assert reused >= 3
    # A start that moves (here: a different rank's) is not reused.
    assert restart_map(result, v, f, rank=1) is None


def test_smoothing_a_large_mesh_in_local_order_gives_the_plain_loops_bits():
    # Above _LOCAL_ROWS rows the steps run renumbered for locality: the same sums in the
    # same order, so the same bits as the plain loop (the cut's start depends on them).
    from meshwm.gim import stable
    from meshwm.gim.code import grid_faces

    n = 260
    rng = np.random.default_rng(4)
    faces = grid_faces(n)
    shuffle = rng.permutation(n * n)  # a scattered vertex order, as subdivision leaves
    faces = np.argsort(shuffle)[faces]
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    v = np.column_stack([i.ravel(), j.ravel(), np.sin(i.ravel() / 9.0)])[shuffle]
    v = v + rng.normal(scale=0.01, size=v.shape)
    assert len(v) > stable._LOCAL_ROWS
    step = stable._smoothing_step(len(v), faces, 0.5)
    plain = v.copy()
    for _ in range(50):
        plain = step @ plain
    np.testing.assert_array_equal(stable.smoothed_copy(v, faces), plain)


@pytest.mark.parametrize("rows", [65_000, 400])
def test_the_transposed_steps_from_a_few_vertices_give_the_whole_products_bits(rows):
    # nudge_start's Pᵀg starts on two vertices: only the rows it reaches are multiplied, and
    # the result is the whole product's bit for bit (signed zeros included), in local order
    # (a large mesh) and as given (a small one, where the reach soon passes an eighth and
    # the whole product takes over).
    from meshwm.gim import stable
    from meshwm.gim.code import grid_faces

    n = int(np.sqrt(rows)) + 1
    rng = np.random.default_rng(5)
    faces = np.argsort(rng.permutation(n * n))[grid_faces(n)]
    localised = stable._localised(stable._smoothing_step(n * n, faces, 0.5))
    assert (localised[0] is not None) == (n * n > stable._LOCAL_ROWS)
    x = np.zeros((n * n, 3))
    x[rng.choice(n * n, 2, replace=False)] = rng.normal(size=(2, 3))
    x[rng.integers(n * n), 1] = -0.0
    order, local = localised
    whole = stable._repeat((order, local.T.tocsr()), x, 50)
    near = stable._repeat_near(localised, x, 50)
    np.testing.assert_array_equal(near.view(np.uint64), whole.view(np.uint64))
    reached = np.count_nonzero(np.any(near != 0, axis=1))
    assert 0 < reached < n * n if n * n > stable._LOCAL_ROWS else reached == n * n


def _bumpy_sphere() -> tuple[np.ndarray, np.ndarray]:
    """A 163,842-vertex closed surface: over the 50,000 rows above which the smoothing is
    renumbered for locality."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=7)
    v = np.asarray(ico.vertices, dtype=np.float64)
    x, y, z = v.T
    return v * (1 + 0.2 * x * y + 0.1 * np.sin(5 * z))[:, None], np.asarray(ico.faces)


def _strip() -> tuple[np.ndarray, np.ndarray]:
    """An open, wavy 30 × 1200 grid of 36,000 vertices: under those 50,000 rows, and long
    enough that two steps' worth of rings around one end is a small part of it."""
    i, j = np.meshgrid(np.arange(30.0), np.arange(1200.0), indexing="ij")
    v = np.stack([i, j, 0.3 * np.sin(0.7 * i) * np.cos(0.05 * j)], axis=-1).reshape(-1, 3)
    k = (np.arange(29)[:, None] * 1200 + np.arange(1199)[None, :]).ravel()
    f = np.concatenate(
        [np.stack([k, k + 1200, k + 1], 1), np.stack([k + 1, k + 1200, k + 1201], 1)]
    )
    return v, f.astype(np.int64)


def _memoised(vertices, faces):
    from meshwm.gim import stable

    return stable._MEMO[(*stable.arrays_key(vertices, faces), 50, 0.5)]


def test_smoothing_the_rows_a_change_reaches_is_the_whole_smoothing():
    # The embedder's check after a bump (keep_start) smooths only the rows the bump reaches:
    # bit for bit the smoothed copy, sources and near-ties of the whole mesh, on a mesh whose
    # smoothing is renumbered for locality (a bump from nudge_start, a few moved vertices) and
    # on an open one, whose boundary rows read their boundary neighbours only.
    from meshwm.gim import stable

    rng = np.random.default_rng(3)
    sphere = _bumpy_sphere()
    cases = []
    v, f = sphere
    far = int(np.argmax(np.linalg.norm(v - v.mean(axis=0), axis=1)))
    cases.append((v, f, v + stable.nudge_start(v, f, far, margin=2e-3)))
    cases.append((v, f, v + np.where(np.arange(len(v))[:, None] % 100_000 == 7, 1e-4, 0.0)))
    v, f = _strip()
    moved = v.copy()
    moved[[0, 31, 65]] += rng.normal(size=(3, 3)) * 1e-3  # on and near the border
    cases.append((v, f, moved))
    for base, faces, new in cases:
        assert 0 < np.any(new != base, axis=1).sum() < len(base) // 8
        stable._MEMO.clear()
        cut_start(base, faces)
        assert stable.smoothed_near(base, new, faces)
        got = _memoised(new, faces)
        stable._MEMO.clear()
        want = stable._smoothed_sources(new, faces, steps=50, lam=0.5)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[0], smoothed_copy(new, faces))
        for a, b in zip(got[1], want[1], strict=True):
            np.testing.assert_array_equal(a, b)
        assert got[2] == want[2]


def test_smoothing_near_a_change_declines_without_its_base_or_for_a_wide_change(spot_mesh):
    from meshwm.gim import stable

    v, f = spot_mesh
    moved = v.copy()
    moved[0] += 1e-3
    stable._MEMO.clear()
    assert not stable.smoothed_near(v, moved, f)  # the base's copy is not memoised
    cut_start(v, f)
    assert not stable.smoothed_near(v, v + 1e-3, f)  # every row moved: the cone is the mesh
    assert not stable.smoothed_near(v, v.copy(), f)  # nothing moved
    assert (*stable.arrays_key(v + 1e-3, f), 50, 0.5) not in stable._MEMO


def _start_of(v: np.ndarray, f: np.ndarray) -> tuple:
    """The cut start of a mesh made afresh, the memo left empty."""
    from meshwm.gim import stable

    stable._MEMO.clear()
    want = cut_start(v, f)
    stable._MEMO.clear()
    return want


def test_the_smoothing_made_ahead_is_waited_for_and_used_once(spot_mesh, monkeypatch):
    # A cut start of the same arrays inside the block takes the second thread's smoothed copy
    # (one smoothing in all, the same start); another mesh's start is made as before.
    from meshwm.gim import stable

    v, f = spot_mesh
    want = _start_of(v, f)
    calls = []
    plain = stable.smoothed_copy

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(len(args[0]))
        return plain(*args, **kwargs)

    monkeypatch.setattr(stable, "smoothed_copy", counted)
    other = v * 2.0
    with stable.smoothing_ahead(v, f):
        assert cut_start(v.copy(), f.copy()) == want
        cut_start(other, f)
    assert calls == [len(v), len(v)]  # the mesh's once (ahead), the other's once
    assert not stable._AHEAD
    stable._MEMO.clear()
    assert cut_start(other, f) == cut_start(other, f)


def test_a_smoothing_ahead_that_fails_is_made_again_where_asked(spot_mesh, monkeypatch):
    from meshwm.gim import stable

    v, f = spot_mesh
    want = _start_of(v, f)
    plain = stable.smoothed_copy
    state = {"first": True}

    def fails_once(*args, **kwargs):  # type: ignore[no-untyped-def]
        if state.pop("first", False):
            raise MemoryError("the second thread ran out of memory")
        return plain(*args, **kwargs)

    monkeypatch.setattr(stable, "smoothed_copy", fails_once)
    with stable.smoothing_ahead(v, f):
        assert cut_start(v, f) == want
    assert not stable._AHEAD


def test_a_surface_is_the_same_with_its_smoothing_made_ahead(request, monkeypatch):
    # surface_of starts the cut's smoothing beside the cleaning: the same surface as without
    # (a clean closed mesh, whose cleaning returns it as given, and one with holes and its
    # faces reordered, whose cleaning does not).
    from meshwm.gim import stable, surface

    for name in MESHES:
        v, f = request.getfixturevalue(name)
        f = f[np.random.default_rng(5).permutation(len(f))]
        stable._MEMO.clear()
        ahead = surface.surface_of(v, f)
        stable._MEMO.clear()
        monkeypatch.setattr(surface, "AHEAD_VERTICES", 0)
        plain = surface.surface_of(v, f)
        monkeypatch.undo()
        np.testing.assert_array_equal(ahead.map.uv, plain.map.uv)
        np.testing.assert_array_equal(ahead.map.cut.mesh.faces, plain.map.cut.mesh.faces)


def test_a_smoothing_ahead_whose_digest_fails_is_passed_over(spot_mesh, monkeypatch):
    import threading

    from meshwm.gim import stable

    v, f = spot_mesh
    want = _start_of(v, f)
    plain = stable.arrays_key

    def fails_beside(*arrays):  # type: ignore[no-untyped-def]
        if threading.current_thread() is not threading.main_thread():
            raise MemoryError("no memory for the digest")
        return plain(*arrays)

    monkeypatch.setattr(stable, "arrays_key", fails_beside)
    with stable.smoothing_ahead(v, f):
        assert cut_start(v, f) == want
    assert not stable._AHEAD
