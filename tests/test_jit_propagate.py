"""The propagation kernels against their mirrors, and the process noise they draw."""
import numpy as np
import pytest

from fasttrack._jit import propagate

import reference.propagate
from user_models import coordinated_turn


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
    reference.propagate.propagate_linear(x, f, _noise_root(), 42, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    quiet = np.empty_like(x)
    propagate.propagate_linear(x, f, np.zeros((4, 4)), 42, quiet)
    np.testing.assert_allclose(quiet, f @ x, rtol=1e-14)


def test_propagate_odd_dimension_and_user_function():
    x = np.random.default_rng(1).normal(size=(3, 3000))
    root = np.diag([1.0, 0.0, 2.0])
    got, want = np.empty_like(x), np.empty_like(x)
    propagate.propagate_linear(x, np.eye(3), root, 7, got)
    reference.propagate.propagate_linear(x, np.eye(3), root, 7, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    x4 = np.random.default_rng(2).normal(size=(4, 5000))
    got, want = np.empty_like(x4), np.empty_like(x4)
    propagate.propagate_function(coordinated_turn, 2.0, x4, _noise_root(), 9, got)
    reference.propagate.propagate_function(coordinated_turn, 2.0, x4, _noise_root(), 9, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_process_noise_has_the_covariance():
    n = 400_000
    x = np.zeros((4, n))
    out = np.empty_like(x)
    root = _noise_root()
    propagate.propagate_linear(x, np.eye(4), root, 3, out)
    np.testing.assert_allclose(np.cov(out), root @ root.T, atol=0.01)
    assert abs(out.mean()) < 0.01
