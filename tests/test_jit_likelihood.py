"""The measurement and likelihood kernels (built-in sensors and user functions) against
their mirrors."""
import numpy as np
import pytest

from fasttrack._jit import likelihood, sensor

import reference.likelihood
from user_models import bearing_range_from_50_0


KINDS = [(sensor.SELECT, [0, 2]), (sensor.BEARING_RANGE, [0, 2]), (sensor.BEARING, [0, 2])]


@pytest.mark.parametrize("kind,mapping", KINDS)
@pytest.mark.parametrize("n", [1, 1500])
def test_measure_and_log_likelihood_match_mirrors(kind, mapping, n):
    rng = np.random.default_rng(3)
    x = rng.normal(0, 20, size=(4, n))
    m = 1 if kind == sensor.BEARING else 2
    mapping = np.array(mapping)
    offset = np.array([5.0, -3.0])
    c, s = np.cos(0.4), np.sin(0.4)
    rotation = np.array([[c, s], [-s, c]])
    angles = np.array([kind != sensor.SELECT] + [False] * (m - 1))
    got, want = np.empty((m, n)), np.empty((m, n))
    likelihood.measure(kind, x, mapping, offset, rotation, got)
    reference.likelihood.measure(kind, x, mapping, offset, rotation, want)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    covar = np.array([[0.3, 0.1], [0.1, 2.0]])[:m, :m]
    whiten = np.linalg.inv(np.linalg.cholesky(covar))
    log_norm = -0.5 * (m * np.log(2 * np.pi) + np.log(np.linalg.det(covar)))
    z = np.array([3.1, 10.0])[:m]  # a bearing near pi: innovations wrap
    log_w = rng.normal(size=n)
    got_w, want_w = np.empty(n), np.empty(n)
    top = likelihood.log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten, log_norm,
                                    log_w, got_w)
    top_ref = reference.likelihood.log_likelihood(kind, z, x, mapping, offset, rotation, angles,
                                                  whiten, log_norm, log_w, want_w)
    np.testing.assert_allclose(got_w, want_w, rtol=1e-10)
    assert top == pytest.approx(top_ref, rel=1e-12)


def test_user_measurement_kernels_match_mirrors():
    x = np.random.default_rng(4).normal(0, 10, size=(4, 2500))
    angles = np.array([True, False])
    got, want = np.empty((2, 2500)), np.empty((2, 2500))
    likelihood.measure_function(bearing_range_from_50_0, x, angles, got)
    reference.likelihood.measure_function(bearing_range_from_50_0, x, angles, want)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    whiten = np.diag([1.0, 10.0])
    log_w = np.zeros(2500)
    got_w, want_w = np.empty(2500), np.empty(2500)
    z = np.array([-3.1, 9.0])
    assert likelihood.log_likelihood_function(bearing_range_from_50_0, z, x, angles, whiten, -1.0, log_w,
                                              got_w) == pytest.approx(
        reference.likelihood.log_likelihood_function(bearing_range_from_50_0, z, x, angles,
                                                     whiten, -1.0, log_w, want_w), rel=1e-12)
    np.testing.assert_allclose(got_w, want_w, rtol=1e-10)
