"""Propagation and likelihood kernels against their mirrors; the numeric helpers they use."""
import numpy as np
import pytest
from scipy import stats

from fasttrack._jit import likelihood, numeric, propagate, sensor, weights

import reference
from user_models import bearing_range_from_50_0, coordinated_turn


def _noise_root():
    q = np.array([[1.0, 0.5, 0, 0], [0.5, 1.0, 0, 0], [0, 0, 2.0, 0.1], [0, 0, 0.1, 0.5]])
    values, vectors = np.linalg.eigh(q)
    return np.ascontiguousarray(vectors * np.sqrt(values))


@pytest.mark.parametrize("n", [1, 1023, 1025, 20_000])
def test_propagate_linear_matches_mirror(n):
    x = np.random.default_rng(0).normal(size=(4, n))
    f = np.array([[1, 2.0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 2.0], [0, 0, 0, 1]])
    got, want = np.empty_like(x), np.empty_like(x)
    propagate.propagate_linear(x, f, _noise_root(), 42, got)
    reference.propagate_linear(x, f, _noise_root(), 42, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    quiet = np.empty_like(x)
    propagate.propagate_linear(x, f, np.zeros((4, 4)), 42, quiet)
    np.testing.assert_allclose(quiet, f @ x, rtol=1e-14)


def test_propagate_odd_dimension_and_user_function():
    x = np.random.default_rng(1).normal(size=(3, 3000))
    root = np.diag([1.0, 0.0, 2.0])
    got, want = np.empty_like(x), np.empty_like(x)
    propagate.propagate_linear(x, np.eye(3), root, 7, got)
    reference.propagate_linear(x, np.eye(3), root, 7, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    x4 = np.random.default_rng(2).normal(size=(4, 5000))
    got, want = np.empty_like(x4), np.empty_like(x4)
    propagate.propagate_function(coordinated_turn, 2.0, x4, _noise_root(), 9, got)
    reference.propagate_function(coordinated_turn, 2.0, x4, _noise_root(), 9, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_process_noise_has_the_covariance():
    n = 400_000
    x = np.zeros((4, n))
    out = np.empty_like(x)
    root = _noise_root()
    propagate.propagate_linear(x, np.eye(4), root, 3, out)
    np.testing.assert_allclose(np.cov(out), root @ root.T, atol=0.01)
    assert abs(out.mean()) < 0.01


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
    reference.measure(kind, x, mapping, offset, rotation, want)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    covar = np.array([[0.3, 0.1], [0.1, 2.0]])[:m, :m]
    whiten = np.linalg.inv(np.linalg.cholesky(covar))
    log_norm = -0.5 * (m * np.log(2 * np.pi) + np.log(np.linalg.det(covar)))
    z = np.array([3.1, 10.0])[:m]  # a bearing near pi: innovations wrap
    log_w = rng.normal(size=n)
    got_w, want_w = np.empty(n), np.empty(n)
    top = likelihood.log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten, log_norm,
                                    log_w, got_w)
    top_ref = reference.log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten,
                                       log_norm, log_w, want_w)
    np.testing.assert_allclose(got_w, want_w, rtol=1e-10)
    assert top == pytest.approx(top_ref, rel=1e-12)


def test_user_measurement_kernels_match_mirrors():
    x = np.random.default_rng(4).normal(0, 10, size=(4, 2500))
    angles = np.array([True, False])
    got, want = np.empty((2, 2500)), np.empty((2, 2500))
    likelihood.measure_function(bearing_range_from_50_0, x, angles, got)
    reference.measure_function(bearing_range_from_50_0, x, angles, want)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    whiten = np.diag([1.0, 10.0])
    log_w = np.zeros(2500)
    got_w, want_w = np.empty(2500), np.empty(2500)
    z = np.array([-3.1, 9.0])
    assert likelihood.log_likelihood_function(bearing_range_from_50_0, z, x, angles, whiten, -1.0, log_w,
                                              got_w) == pytest.approx(
        reference.log_likelihood_function(bearing_range_from_50_0, z, x, angles, whiten, -1.0, log_w,
                                          want_w), rel=1e-12)
    np.testing.assert_allclose(got_w, want_w, rtol=1e-10)


def test_normalise_in_place_matches_mirror():
    log_w = np.random.default_rng(5).normal(size=50_000) * 30 + 500
    got, want = log_w.copy(), log_w.copy()
    assert weights.normalise_in_place(got, got.max()) == pytest.approx(
        reference.normalise_in_place(want, want.max()), rel=1e-13)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
    assert np.exp(got).sum() == pytest.approx(1.0, rel=1e-12)


def test_fast_atan2_and_sin_cos_turns_and_wrap():
    rng = np.random.default_rng(6)
    y = rng.normal(size=20_000) * 10.0 ** rng.uniform(-6, 6, 20_000)
    x = rng.normal(size=20_000) * 10.0 ** rng.uniform(-6, 6, 20_000)
    y = np.r_[y, 0.0, 0.0, 1.0, -1.0, 2.0, -3.0]
    x = np.r_[x, 0.0, 1.0, 0.0, 0.0, -2.0, -3.0]
    got = np.array([numeric.fast_atan2(a, b) for a, b in zip(y, x)])
    np.testing.assert_allclose(got, reference.fast_atan2(y, x), rtol=4e-16, atol=1e-300)
    u = np.r_[rng.random(20_000), 0.0, 0.125, 0.25, 0.5, 0.75, 1 - 2**-53]
    sin_cos = np.array([numeric.sin_cos_turns(v) for v in u])
    want_sin, want_cos = reference.sin_cos_turns(u)
    np.testing.assert_allclose(sin_cos[:, 0], want_sin, atol=1e-15)
    np.testing.assert_allclose(sin_cos[:, 1], want_cos, atol=1e-15)
    a = np.r_[rng.uniform(-50, 50, 20_000), -np.pi, np.pi, 3 * np.pi, 0.0]
    wrapped = np.array([numeric.wrap_angle(v) for v in a])
    assert wrapped.min() >= -np.pi and wrapped.max() < np.pi
    np.testing.assert_allclose(np.cos(wrapped), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(wrapped, reference.wrap_angle(a), atol=1e-12)


def test_fill_normals_matches_mirror_and_is_standard_normal():
    out, want = np.empty(200_000), np.empty(200_000)
    numeric.fill_normals(99, 12345, out)
    reference.fill_normals(99, 12345, want)
    np.testing.assert_allclose(out, want, rtol=1e-12, atol=1e-12)
    assert stats.kstest(out, "norm").pvalue > 1e-4
    assert abs(out.mean()) < 0.01 and abs(out.var() - 1) < 0.01
    half = out.size // 2
    assert abs(np.corrcoef(out[:half], out[half:])[0, 1]) < 0.01  # cos and sin partners
