"""The null hypothesis of verify: on an unmarked mesh every extracted bit is a fair coin.

verify's p-value is the binomial tail of the agreement between the extracted and the expected
bits; it is only a false-positive probability if, without a mark, the agreement really is
Binomial(n, 1/2).  Checked empirically on an unmarked geometry image with 2000 random keys.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from meshwm.detect import detection_p_value, is_detected
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.mesh.io import read_mesh
from meshwm.message.mark import default_mark
from meshwm.message.scramble import arnold_scramble
from meshwm.profiles.robust.decode import GAINS, extract_gim_robust

ASSETS = Path(__file__).resolve().parent.parent / "assets"
TRIALS = 2000


@pytest.mark.slow
def test_agreement_on_unmarked_meshes_is_binomial():
    v, f = read_mesh(ASSETS / "kitten.ply")
    gim = mesh_to_geometry_image(v, f, size=128).gim
    mark = default_mark(16)
    expected = arnold_scramble(mark, iterations=5).ravel()
    agree = np.empty(TRIALS, dtype=np.int64)
    pvals = np.empty(TRIALS)
    for t in range(TRIALS):
        bits = extract_gim_robust(gim, 256, key=f"random key {t}").bits
        agree[t] = int(np.sum(bits == expected))
        pvals[t] = detection_p_value(int(agree[t]), 256)
    # The agreement counts follow Binomial(256, 1/2): a chi-square goodness of fit on bins.
    edges = np.array([0, 112, 118, 122, 126, 130, 134, 138, 144, 257])
    observed = np.histogram(agree, bins=edges)[0]
    cdf = stats.binom.cdf(edges[1:] - 1, 256, 0.5) - stats.binom.cdf(edges[:-1] - 1, 256, 0.5)
    assert stats.chisquare(observed, cdf * TRIALS).pvalue > 1e-3
    assert abs(agree.mean() - 128) < 4 * 8 / np.sqrt(TRIALS)
    # And never a detection, even without the Bonferroni factor.
    assert not any(is_detected(p, fpr=1e-6) for p in pvals)
    assert len(GAINS) > 100  # the search the Bonferroni factor accounts for is really there
