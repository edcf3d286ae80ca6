"""Tests for :mod:`meshwm.attacks.registry`: every attack seeded, pure and looked up by name.

Mesh attacks run on the bundled spot mesh; the paper's ``gim_*`` attacks on a meshwm geometry-
image mesh of it at N = 64 (``geometry_image_to_mesh(gim, weld)``).
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _attack_checks import (
    GIM,
    NO_MOVE,
    RANDOM,
    SAME_FACES,
    SEEDLESS,
)
from numpy.testing import assert_array_equal

from meshwm.attacks import ATTACK_PARAMS, ATTACKS, apply_attack
from meshwm.attacks.transforms import (
    similarity,
)


@pytest.fixture(scope="module")
def meshes(mesh, gim_mesh):
    """The input each attack is tested on."""
    return {name: gim_mesh if name in GIM else mesh for name in ATTACKS}


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_attack_is_deterministic_for_a_seed(meshes, name):
    v1, f1 = apply_attack(name, *meshes[name], seed=11)
    v2, f2 = apply_attack(name, *meshes[name], seed=11)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


@pytest.mark.parametrize("name", RANDOM)
def test_random_attack_changes_with_the_seed(meshes, name):
    v1, f1 = apply_attack(name, *meshes[name], seed=1)
    v2, f2 = apply_attack(name, *meshes[name], seed=2)
    assert not (np.array_equal(v1, v2) and np.array_equal(f1, f2))


@pytest.mark.parametrize("name", SEEDLESS)
def test_seedless_attack_ignores_the_seed(meshes, name):
    v1, f1 = apply_attack(name, *meshes[name], seed=1)
    v2, f2 = apply_attack(name, *meshes[name], seed=2)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_attack_leaves_its_input_alone(meshes, name):
    v0, f0 = meshes[name]
    v, f = v0.copy(), f0.copy()
    out_v, out_f = apply_attack(name, v, f, seed=4)
    assert_array_equal(v, v0)
    assert_array_equal(f, f0)
    assert out_v.dtype == np.float64 and out_v.shape[1] == 3
    assert out_f.dtype == np.int64 and out_f.shape[1] == 3
    assert out_f.min() >= 0 and out_f.max() < len(out_v)
    assert np.all(np.isfinite(out_v))


@pytest.mark.parametrize("name", sorted(set(ATTACKS) - set(NO_MOVE)))
def test_attack_changes_the_geometry(meshes, name):
    v, f = meshes[name]
    v2, _ = apply_attack(name, v, f, seed=4)
    assert v2.shape != v.shape or not np.allclose(v2, v, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", SAME_FACES)
def test_attack_keeps_the_connectivity(meshes, name):
    v, f = meshes[name]
    v2, f2 = apply_attack(name, v, f, seed=4)
    assert v2.shape == v.shape
    assert_array_equal(f2, f)


def test_apply_attack_passes_options(mesh):
    v1, f1 = apply_attack("similarity", *mesh, seed=9, scale=3.0)
    v2, f2 = similarity(*mesh, seed=9, scale=3.0)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


def test_unknown_attack_lists_the_valid_names(mesh):
    with pytest.raises(ValueError, match="unknown attack 'smooth'") as info:
        apply_attack("smooth", *mesh)
    assert re.search(re.escape(", ".join(sorted(ATTACKS))), str(info.value))
    for name in ATTACKS:
        assert name in str(info.value)


def test_registry_names_its_functions():
    assert ATTACKS["similarity"] is similarity
    assert set(ATTACKS) == {
        *("similarity", "rotation", "translation", "scaling", "reorder", "noise", "float32"),
        *("mirror", "round_trip"),
        *("laplacian", "meshlab_laplacian", "taubin", "quantize", "crop", "simplify"),
        *("subdivide_midpoint", "subdivide_loop", "remesh_isotropic", "poisson"),
        *("flip_edges", "retriangulate", "split_seams", "merge_load", "weld_stl"),
        *("gim_gaussian", "gim_log", "gim_laplacian", "gim_salt_pepper", "gim_noise", "gim_crop"),
    }
    for name, attack in ATTACKS.items():
        assert attack.__name__ == name


def test_every_attack_has_its_parameters():
    assert list(ATTACKS) == list(ATTACK_PARAMS)


def test_registry_is_a_read_only_mapping():
    assert len(ATTACKS) == len(list(ATTACKS)) and "laplacian" in ATTACKS and "smooth" not in ATTACKS
    assert ATTACKS.get("smooth") is None
    with pytest.raises(KeyError):
        ATTACKS["smooth"]
    with pytest.raises(TypeError):
        ATTACKS["smooth"] = similarity  # type: ignore[index]


def _modules_after(code: str) -> list[str]:
    """The heavy libraries and attack modules loaded by ``code`` in a fresh interpreter."""
    watched = ("trimesh", "igl", "pymeshlab", "scipy", "PIL", "meshwm.attacks.")
    script = (
        f"import sys\n{code}\nprint(sorted(m for m in sys.modules if m.startswith({watched!r})))"
    )
    root = Path(__file__).parent.parent.parent
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        cwd=root,
        env=env,
        check=True,
    )
    return ast.literal_eval(out.stdout.strip())


def test_importing_the_registry_loads_no_attack_module():
    """Names and parameters (what ``meshwm --help`` shows) come without pymeshlab, SciPy, igl."""
    loaded = _modules_after(
        "import meshwm.attacks as a\nsorted(a.ATTACKS); a.ATTACK_PARAMS['laplacian']"
    )
    assert loaded == ["meshwm.attacks.params", "meshwm.attacks.registry"]


def test_a_lookup_imports_only_the_module_of_its_kind():
    loaded = _modules_after("from meshwm.attacks import ATTACKS\nATTACKS['similarity']")
    assert loaded == [
        "meshwm.attacks.params",
        "meshwm.attacks.registry",
        "meshwm.attacks.transforms",
    ]
