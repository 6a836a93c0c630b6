"""The kernels on log weights against their mirrors."""
import numpy as np
import pytest

from fasttrack._jit import weights

import reference.weights


def test_normalise_in_place_matches_mirror():
    log_w = np.random.default_rng(5).normal(size=50_000) * 30 + 500
    got, want = log_w.copy(), log_w.copy()
    assert weights.normalise_in_place(got, got.max()) == pytest.approx(
        reference.weights.normalise_in_place(want, want.max()), rel=1e-13)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
    assert np.exp(got).sum() == pytest.approx(1.0, rel=1e-12)
