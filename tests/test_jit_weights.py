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


@pytest.mark.parametrize("changed", [None, 0, 5000, 49_999])
def test_equal_weights_and_one_that_differs(changed):
    """Equal log weights (as after resampling) give plain moments and an ESS of N; a single
    different weight anywhere, even in the last block, is noticed."""
    rng = np.random.default_rng(6)
    x = rng.normal(size=(3, 50_000))
    log_w = np.full(50_000, -np.log(50_000))
    if changed is not None:
        log_w[changed] -= 3.0
    top = log_w.max()
    mean, covar = np.empty(3), np.empty((3, 3))
    want_mean, want_covar = np.empty(3), np.empty((3, 3))
    weights.weighted_mean_covar(x, log_w, top, mean, covar)
    reference.weights.weighted_mean_covar(x, log_w, top, want_mean, want_covar)
    np.testing.assert_allclose(mean, want_mean, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(covar, want_covar, rtol=1e-12)
    assert weights.ess(log_w, top) == pytest.approx(reference.weights.ess(log_w, top),
                                                   rel=1e-13)
    if changed is None:
        np.testing.assert_allclose(mean, x.mean(axis=1), rtol=1e-12, atol=1e-15)
        assert weights.ess(log_w, top) == pytest.approx(50_000, rel=1e-13)
