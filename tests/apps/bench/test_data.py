"""Tests for :mod:`meshwm.apps.bench.data`: the paper's tables, the rows and their attacks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from meshwm.apps import bench
from meshwm.apps.bench.data import paper_attacks_of
from meshwm.attacks import ATTACK_PARAMS, ATTACKS

REPO = Path(__file__).resolve().parents[3]
#: Tamane & Deshmukh's Tables 2-4 as JSON, next to the repository (absent in a bare clone).
SEED_TABLES = REPO.parent / "shared" / "seed" / "paper_tables.json"


@pytest.mark.skipif(not SEED_TABLES.is_file(), reason="the paper's JSON is not next to the repo")
def test_paper_tables_are_the_seed_json():
    assert json.loads(SEED_TABLES.read_text())["models"] == bench.PAPER_TABLES


def test_every_paper_row_maps_to_a_checked_attack():
    by_key = {a.key: a for a in bench.PAPER_ATTACKS}
    for model, rows in bench.PAPER_TABLES.items():
        assert model in {m for m, _, _ in bench.PAPER_MODELS}
        assert set(rows) <= set(by_key), set(rows) - set(by_key)
    for attack in bench.PAPER_ATTACKS:
        if attack.name is None:
            assert attack.key == "none"
        elif attack.name in ("rotation", "translation", "scaling"):
            assert attack.key not in bench.PAPER_TABLES["model1"]  # no figure in the JSON
            spec = {p.name: p for p in ATTACK_PARAMS[attack.name]}
            assert set(attack.params) <= set(spec)
        else:
            assert attack.name.startswith("gim_"), attack
            spec = {p.name: p for p in ATTACK_PARAMS[attack.name]}
            for name, value in attack.params.items():
                assert spec[name].check(value, attack.name) == value
    # The paper's section 5 transformations are rows too.
    assert {"rotation", "translation", "scaling"} <= set(by_key)
    assert set(bench.CURVE_ATTACKS) == set(bench.PAPER_TABLES["model1"]) - {"none"}
    assert "none" in bench.QUICK_PAPER_ATTACKS and set(bench.QUICK_PAPER_ATTACKS) <= set(by_key)


def test_mesh_attacks_cover_the_issue():
    required = {a.key for a in bench.MESH_ATTACKS if a.required}
    assert {
        "none",
        "noise_0.05",
        "noise_0.1",
        "noise_0.3",
        "laplacian_5",
        "laplacian_10",
        "laplacian_30",
        "meshlab_laplacian_3",
        "quantize_11",
        "quantize_10",
        "quantize_9",
        "quantize_8",
        "crop_10",
        "crop_30",
        "similarity",
        "reorder",
        "round_trip_obj",
        "round_trip_ply",
        "round_trip_stl",
    } <= required
    beyond = {a.key for a in bench.MESH_ATTACKS if not a.required}
    assert {
        "noise_0.5",
        "laplacian_50",
        "crop_50",
        "simplify_70",
        "simplify_50",
        "simplify_10",
        "subdivide_midpoint",
        "subdivide_loop",
    } <= beyond
    keys = [a.key for a in bench.MESH_ATTACKS]
    assert len(keys) == len(set(keys))
    assert set(bench.QUICK_MESH_ATTACKS) <= set(keys)
    for attack in bench.MESH_ATTACKS:
        if attack.name is None:
            continue
        assert attack.name in ATTACKS
        spec = {p.name: p for p in ATTACK_PARAMS[attack.name]}
        for name, value in attack.params.items():
            assert spec[name].check(value, attack.name) == value
    lam = [a.params["lam"] for a in bench.MESH_ATTACKS if a.name == "laplacian"]
    assert lam and set(lam) == {0.1}


def test_attack_seeds_are_fixed_by_the_row_id():
    a = bench.Attack("noise_0.1", "noise", "0.1 %", "noise", {"amplitude": 0.001})
    b = a._replace(label="another label")
    assert a.seed == b.seed == bench.Attack("noise_0.1", "", "", None, {}).seed
    assert a.seed != bench.Attack("noise_0.3", "", "", None, {}).seed


def test_section_5_transformations_are_registry_attacks():
    """Rotation, translation and scaling rows run the attacks registry's, with their seeds."""
    rng = np.random.default_rng(0)
    v = rng.normal(size=(20, 3))
    f = np.array([[0, 1, 2]])
    rows = {a.key: a for a in bench.PAPER_ATTACKS}
    rv, rf = bench.apply_bench_attack(rows["rotation"], v, f)
    assert np.array_equal(rf, f)
    d0 = np.linalg.norm(v[:, None] - v[None], axis=-1)
    d1 = np.linalg.norm(rv[:, None] - rv[None], axis=-1)
    assert np.allclose(d0, d1) and not np.allclose(rv, v)
    assert np.allclose(rv.mean(axis=0), v.mean(axis=0))
    tv, _ = bench.apply_bench_attack(rows["translation"], v, f)
    shift = tv - v
    assert np.allclose(shift, shift[0])
    diag = np.linalg.norm(np.ptp(v, axis=0))
    assert np.linalg.norm(shift[0]) == pytest.approx(10 * diag)
    sv, _ = bench.apply_bench_attack(rows["scaling"], v, f)
    centre = v.mean(axis=0)
    assert np.allclose(sv, 0.1 * (v - centre) + centre)
    again, _ = bench.apply_bench_attack(rows["rotation"], v, f)
    assert np.array_equal(again, rv)


def test_apply_bench_attack_none_returns_the_mesh():
    v, f = np.eye(3), np.array([[0, 1, 2]])
    none = next(a for a in bench.PAPER_ATTACKS if a.key == "none")
    assert bench.apply_bench_attack(none, v, f) == (v, f)


def test_paper_attacks_of_keeps_the_paper_order():
    quick = {"attacks": list(reversed(bench.QUICK_PAPER_ATTACKS))}
    assert [a.key for a in paper_attacks_of(quick)] == [
        a.key for a in bench.PAPER_ATTACKS if a.key in bench.QUICK_PAPER_ATTACKS
    ]
    assert paper_attacks_of({}) == list(bench.PAPER_ATTACKS)  # a result without the field
