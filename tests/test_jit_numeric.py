"""The scalar building blocks (exp, log, atan2, sin/cos, angle wrapping), the random stream
and the fixed chunking of reductions, against their mirrors."""
import numpy as np
from scipy import stats

from fasttrack._jit import numeric, weights

import reference.numeric


def test_fast_exp_within_one_ulp_over_the_whole_range():
    rng = np.random.default_rng(0)
    x = np.concatenate([np.linspace(-760, 720, 200_001), rng.normal(0, 30, 100_000),
                        [0.0, -0.0, 709.78, -708.4, -745.13, -745.14, np.inf, -np.inf, np.nan]])
    got = np.array([numeric.fast_exp(v) for v in x[:2000]] +
                   list(_vector_exp(x[2000:])))
    with np.errstate(over="ignore"):
        want = reference.numeric.fast_exp(x)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    assert np.array_equal(got[np.isinf(want)], want[np.isinf(want)])
    assert np.all(got[want == 0] == 0)
    finite = np.isfinite(want) & (want > 0)
    ulps = np.abs(got[finite] - want[finite]) / np.spacing(want[finite])
    assert ulps.max() <= 1.0


def _vector_exp(x):
    out = np.empty_like(x)
    weights.relative_weights(x, 0.0, out)
    return out


def test_fast_log_within_three_ulp_on_positive_normals():
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.random(50_000), np.exp(rng.uniform(-700, 700, 50_000)),
                        [1.0, 2.0, 0.5, 2.2250738585072014e-308, 1.7976931348623157e308,
                         1 - 2**-53, 1 + 2**-52]])
    got = np.array([numeric.fast_log(v) for v in x])
    want = reference.numeric.fast_log(x)
    assert got[-7] == 0.0
    nonzero = want != 0
    ulps = np.abs(got - want)[nonzero] / np.spacing(np.abs(want[nonzero]))
    assert ulps.max() <= 3.0


def test_uniform_stream_matches_its_mirror_and_is_uniform():
    key = 0x1234_5678_9ABC_DEF
    counters = np.arange(100_000)
    got = np.array([numeric.uniform(key, int(c)) for c in counters[:1000]])
    want = reference.numeric.uniform(key, counters)
    assert np.array_equal(got, want[:1000])
    assert want.min() >= 0.0 and want.max() < 1.0
    # chi-square over 100 equal bins: 99 dof, reject far above the 99.99th percentile (~150)
    counts = np.bincount((want * 100).astype(int), minlength=100)
    chi2 = ((counts - 1000) ** 2 / 1000).sum()
    assert chi2 < 160
    # neighbouring counters are uncorrelated
    assert abs(np.corrcoef(want[:-1], want[1:])[0, 1]) < 0.02


def test_cumulate_integer_is_exact_and_float_close():
    rng = np.random.default_rng(3)
    ints = rng.integers(0, 5, 100_003)
    got = ints.copy()
    numeric.cumulate(got)
    want = ints.copy()
    reference.numeric.cumulate(want)
    assert np.array_equal(got, want)
    floats = rng.random(100_003)
    got = floats.copy()
    numeric.cumulate(got)
    want = floats.copy()
    reference.numeric.cumulate(want)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert np.all(np.diff(got) >= 0)


def test_stable_argsort_is_numpys_stable_argsort():
    rng = np.random.default_rng(8)
    for n in (0, 1, 2, 15, 16, 17, 33, 100, 1000, 4099):
        for values in (rng.integers(0, 7, n).astype(np.float64), rng.normal(size=n),
                       np.r_[rng.normal(size=n), np.inf, -np.inf, 0.0, -0.0][:n]):
            want = reference.numeric.stable_argsort(values)
            assert np.array_equal(numeric.stable_argsort(values), want), n
        ints = rng.integers(-3, 3, n)
        assert np.array_equal(numeric.stable_argsort(ints),
                              reference.numeric.stable_argsort(ints)), n


def test_chunking_mirrors():
    for n in (0, 1, 8191, 8192, 10**6, 10**9):
        k = numeric.n_chunks(n)
        assert k == reference.numeric.n_chunks(n) and 1 <= k <= 4096
        bounds = [numeric.chunk_bounds(c, k, n) for c in range(k)]
        assert bounds == [reference.numeric.chunk_bounds(c, k, n) for c in range(k)]
        assert bounds[0][0] == 0 and bounds[-1][1] == n
        assert all(a[1] == b[0] for a, b in zip(bounds, bounds[1:]))


def test_fast_atan2_and_sin_cos_turns_and_wrap():
    rng = np.random.default_rng(6)
    y = rng.normal(size=20_000) * 10.0 ** rng.uniform(-6, 6, 20_000)
    x = rng.normal(size=20_000) * 10.0 ** rng.uniform(-6, 6, 20_000)
    y = np.r_[y, 0.0, 0.0, 1.0, -1.0, 2.0, -3.0]
    x = np.r_[x, 0.0, 1.0, 0.0, 0.0, -2.0, -3.0]
    got = np.array([numeric.fast_atan2(a, b) for a, b in zip(y, x)])
    np.testing.assert_allclose(got, reference.numeric.fast_atan2(y, x), rtol=4e-16, atol=1e-300)
    u = np.r_[rng.random(20_000), 0.0, 0.125, 0.25, 0.5, 0.75, 1 - 2**-53]
    sin_cos = np.array([numeric.sin_cos_turns(v) for v in u])
    want_sin, want_cos = reference.numeric.sin_cos_turns(u)
    np.testing.assert_allclose(sin_cos[:, 0], want_sin, atol=1e-15)
    np.testing.assert_allclose(sin_cos[:, 1], want_cos, atol=1e-15)
    a = np.r_[rng.uniform(-50, 50, 20_000), -np.pi, np.pi, 3 * np.pi, 0.0]
    wrapped = np.array([numeric.wrap_angle(v) for v in a])
    assert wrapped.min() >= -np.pi and wrapped.max() < np.pi
    np.testing.assert_allclose(np.cos(wrapped), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(wrapped, reference.numeric.wrap_angle(a), atol=1e-12)


def test_fill_normals_matches_mirror_and_is_standard_normal():
    out, want = np.empty(200_000), np.empty(200_000)
    numeric.fill_normals(99, 12345, out)
    reference.numeric.fill_normals(99, 12345, want)
    np.testing.assert_allclose(out, want, rtol=1e-12, atol=1e-12)
    assert stats.kstest(out, "norm").pvalue > 1e-4
    assert abs(out.mean()) < 0.01 and abs(out.var() - 1) < 0.01
    half = out.size // 2
    assert abs(np.corrcoef(out[:half], out[half:])[0, 1]) < 0.01  # cos and sin partners


def test_cholesky_matches_mirror_and_refuses_what_is_not_positive_definite():
    rng = np.random.default_rng(4)
    root = rng.normal(size=(5, 5))
    a = root @ root.T + 0.1 * np.eye(5)
    got, want = np.full((5, 5), 7.0), np.empty((5, 5))
    assert numeric.cholesky(a, got) and reference.numeric.cholesky(a, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-14)
    assert not numeric.cholesky(-a, got) and not reference.numeric.cholesky(-a, want)
