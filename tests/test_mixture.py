"""Gaussian mixtures: the kernels against their mirrors, closed forms, and the
:class:`~fasttrack.types.GaussianMixture` face."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fasttrack._jit import mixture as kernels
from fasttrack.core import mixture
from fasttrack.types import GaussianMixture

import reference.mixture


def _components(rng, k, d):
    a = rng.standard_normal((k, d, d))
    return rng.standard_normal((k, d)) * 3.0, a @ a.transpose(0, 2, 1) + 0.1 * np.eye(d)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=1, max_size=6), st.integers(0, 2**31))
def test_segment_logsumexp_matches_its_mirror(sizes, seed):
    rng = np.random.default_rng(seed)
    starts = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    values = rng.normal(scale=300.0, size=starts[-1])
    values[rng.random(values.size) < 0.2] = -np.inf
    got, want = np.empty(len(sizes)), np.empty(len(sizes))
    kernels.segment_logsumexp(values, starts, got)
    reference.mixture.segment_logsumexp(values, starts, want)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_segment_logsumexp_of_empty_zero_infinite_and_nan_segments():
    values = np.array([-np.inf, -np.inf, np.inf, 0.0, np.nan, 1e300, 1e300])
    got = mixture.segment_logsumexp(values, np.array([0, 0, 2, 4, 5, 7]))
    assert got[0] == got[1] == -np.inf and got[2] == np.inf and np.isnan(got[3])
    assert got[4] == pytest.approx(1e300 + np.log(2.0))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(1, 4), min_size=1, max_size=5), st.integers(1, 4),
       st.integers(0, 2**31))
def test_moment_match_matches_its_mirror(sizes, d, seed):
    rng = np.random.default_rng(seed)
    starts = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    means, covars = _components(rng, starts[-1], d)
    log_weights = rng.normal(scale=50.0, size=starts[-1])
    outs = [(np.empty((len(sizes), d)), np.empty((len(sizes), d, d)), np.empty(len(sizes)))
            for _ in range(2)]
    assert kernels.moment_match(means, covars, log_weights, starts, *outs[0]) == -1
    assert reference.mixture.moment_match(means, covars, log_weights, starts, *outs[1]) == -1
    for got, want in zip(*outs):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_two_equal_components_merge_to_the_closed_form():
    """Two equal weights at -a and +a with covariance P: mean 0, covariance P + a a^T."""
    a, p = np.array([1.0, -2.0]), np.array([[2.0, 0.3], [0.3, 1.0]])
    merged = GaussianMixture([-a, a], [p, p], np.log([0.25, 0.25])).reduce()
    np.testing.assert_allclose(merged.means, [[0.0, 0.0]], atol=1e-15)
    np.testing.assert_allclose(merged.covars[0], p + np.outer(a, a), rtol=1e-14)
    assert merged.log_weights[0] == pytest.approx(np.log(0.5))


def test_labels_merge_separately_and_a_single_component_is_itself():
    rng = np.random.default_rng(3)
    means, covars = _components(rng, 4, 3)
    mixture_ = GaussianMixture(means, covars, [0.0, -1.0, -np.inf, 2.0], labels=[7, 2, 2, 5])
    merged = mixture_.reduce()
    np.testing.assert_array_equal(merged.labels, [2, 5, 7])
    np.testing.assert_allclose(merged.means[1], means[3], rtol=1e-15)
    np.testing.assert_allclose(merged.covars[2], covars[0], rtol=1e-15)
    np.testing.assert_allclose(merged.means[0], means[1], rtol=1e-15)  # the -inf adds nothing
    np.testing.assert_allclose(merged.log_weights, [-1.0, 2.0, 0.0])


def test_a_group_without_weight_is_an_error_naming_its_label():
    means, covars = _components(np.random.default_rng(0), 2, 2)
    with pytest.raises(ValueError, match="labelled 4 have no positive finite total weight"):
        GaussianMixture(means, covars, [0.0, -np.inf], labels=[1, 4]).reduce()


@pytest.mark.parametrize("arguments, message", [
    ((np.zeros((2, 2)), np.zeros((2, 3, 3))), "covars must have shape"),
    ((np.zeros((2, 2)), np.zeros((2, 2, 2)), [0.0]), "log_weights must have shape"),
    ((np.zeros((2, 2)), np.zeros((2, 2, 2)), [0.0, np.nan]), "log_weights must not be NaN"),
    ((np.zeros((2, 2)), np.zeros((2, 2, 2)), None, [0.5, 1.0]), "labels must be 2 integers"),
    ((np.full((1, 2), np.nan), np.zeros((1, 2, 2))), "means"),
])
def test_bad_mixtures_are_refused_naming_the_argument(arguments, message):
    with pytest.raises(ValueError, match=message):
        GaussianMixture(*arguments)
