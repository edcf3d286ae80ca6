"""Tests for :mod:`meshwm.mesh.unsmooth`: MeshLab's Laplacian smoothing, and undoing it."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from meshwm.attacks import apply_attack
from meshwm.mesh.unsmooth import COTANGENT_STEPS, cotangent_smooth, cotangent_unsmoothed
from meshwm.metrics import bounding_box_diagonal


@pytest.mark.parametrize("fixture", ["spot_mesh", "plane_mesh"])
def test_the_forward_step_is_meshlabs(fixture, request):
    v, f = request.getfixturevalue(fixture)  # closed, and open with 27 boundary loops
    theirs, _ = apply_attack("meshlab_laplacian", v, f, iterations=3)
    ours = cotangent_smooth(v, f, iterations=3)
    moved = np.abs(theirs - v).max()
    assert np.abs(ours - theirs).max() < 1e-5 * moved  # VCG's angles are single precision


def test_undoing_the_steps_comes_back_towards_the_mesh(spot_mesh):
    v, f = spot_mesh
    rng = np.random.default_rng(0)
    diag = bounding_box_diagonal(v)
    marked = v + rng.normal(size=v.shape) * 1e-4 * diag
    smoothed = cotangent_smooth(marked, f, iterations=3)
    undone = {label: x for label, x in cotangent_unsmoothed(smoothed, f)}
    assert len(undone) == 2 * len(COTANGENT_STEPS)
    undone = {k: undone[f"cotangent {k}/10"] for k in COTANGENT_STEPS}

    def rms(x):
        return float(np.sqrt(np.mean(np.sum((x - marked) ** 2, axis=1))))

    assert rms(undone[3]) < 0.35 * rms(smoothed)
    assert rms(undone[3]) < rms(undone[1])
    assert_allclose(undone[3].mean(axis=0), marked.mean(axis=0), atol=1e-3 * diag)
