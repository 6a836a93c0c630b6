"""Gaussian mixtures: the kernels against their mirrors, closed forms, and the
:class:`~fasttrack.types.GaussianMixture` face."""
import types

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fasttrack._jit import mixture as kernels
from fasttrack.core import mixture, mixture_numpy
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


_SEGMENTS_OUT_OF_RANGE = """
import numpy as np
import fasttrack._jit
from fasttrack.core import mixture
fasttrack._jit.kernels_from_now()
values = np.zeros(20_000)
for last, first in [(10**12, 0), (20_000, -7), (20_001, 0)]:
    starts = np.arange(20_001)
    starts[-1], starts[0] = last, first
    try:
        mixture.segment_logsumexp(values, starts)
    except ValueError as error:
        print("refused:", str(error).split(" within")[0])
try:
    mixture.segment_logsumexp(values, np.array([0, 5, 3, 9]))
except ValueError as error:
    print("refused:", str(error).split(" within")[0])
"""


def test_segments_out_of_range_are_refused_in_a_process_of_their_own():
    """The kernel never reads past the values: the process lives, each call refused."""
    import subprocess
    import sys
    done = subprocess.run([sys.executable, "-c", _SEGMENTS_OUT_OF_RANGE], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["refused: starts must be non-decreasing"] * 4
    with pytest.raises(ValueError, match="starts a non-empty 1-D integer array"):
        mixture.segment_logsumexp(np.zeros(3), np.array([0.0, 3.0]))


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


@pytest.mark.parametrize("j, d, m", [(0, 4, 2), (1, 4, 2), (7, 4, 2), (5, 6, 3), (3, 2, 1)])
def test_component_gains_match_their_mirror_and_the_numpy_twin(j, d, m):
    rng = np.random.default_rng(j + d)
    _, covars = _components(rng, j, d)
    h = rng.standard_normal((m, d))
    cross = covars @ h.T
    innovation = h @ covars @ h.T + np.eye(m)
    outputs = []
    for run in (kernels.component_gains, reference.mixture.component_gains,
                mixture_numpy.component_gains):
        gains, updated = np.empty((j, d, m)), np.empty((j, d, d))
        assert run(covars, cross, innovation, gains, updated) == -1
        outputs.append((gains, updated))
    for gains, updated in outputs[1:]:
        np.testing.assert_allclose(outputs[0][0], gains, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(outputs[0][1], updated, rtol=1e-10, atol=1e-12)
    assert (outputs[0][1] == outputs[0][1].transpose(0, 2, 1)).all()
    if j:  # K S K^T, the other form of what the update removes
        s_gain = np.einsum("kam,kmn,kbn->kab", outputs[0][0], innovation, outputs[0][0])
        np.testing.assert_allclose(outputs[0][1], covars - s_gain, rtol=1e-9, atol=1e-9)


def test_component_gains_name_an_innovation_covariance_that_is_not_positive_definite():
    rng = np.random.default_rng(1)
    _, covars = _components(rng, 3, 4)
    cross = covars[:, :, :2].copy()
    innovation = cross[:, :2, :] + np.eye(2)
    innovation[1] = [[1.0, 2.0], [2.0, 1.0]]
    for run in (kernels.component_gains, reference.mixture.component_gains,
                mixture_numpy.component_gains):
        assert run(covars, cross, innovation, np.empty((3, 4, 2)), np.empty((3, 4, 4))) == 1
    with pytest.raises(ValueError, match="innovation covariance of component 1 is not "
                                         "positive definite"):
        mixture.component_gains(covars, cross, innovation)


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


# -- Reduction: prune, merge, cap ---------------------------------------------------------

def _clustered(rng, j, d, spread=30.0, clusters=None, stretched=False):
    """``j`` components around ``clusters`` centres (default j // 3 + 1), with linear
    weights spanning 1e-12 to 1; ``stretched``: each covariance's axes scaled by factors
    from 0.03 to 30 (variances over six decades)."""
    centres = rng.uniform(-spread, spread, size=(clusters or j // 3 + 1, d))
    means = centres[rng.integers(0, centres.shape[0], size=j)] + rng.normal(size=(j, d))
    a = rng.standard_normal((j, d, d)) * 0.5
    covars = a @ a.transpose(0, 2, 1) + np.eye(d) * rng.uniform(0.2, 2.0, size=(j, 1, 1))
    if stretched:
        scale = 10.0 ** rng.uniform(-1.5, 1.5, size=(j, d))
        covars = covars * scale[:, :, None] * scale[:, None, :]
    return means, covars, 10.0 ** rng.uniform(-12, 0, size=j)


def _reduced(reduce, means, covars, weights, mode, prune, merging, threshold, cap):
    j, d = means.shape
    out = (np.empty((j, d)), np.empty((j, d, d)), np.empty(j), np.empty(j, dtype=np.int64),
           np.empty(j, dtype=np.int64))
    count = reduce(means, covars, weights, mixture.MODES[mode], prune, merging, threshold,
                   cap, mixture._grid_axes(means), *out)
    return count, [a[:count] for a in out[:4]] + [out[4]]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 160), st.integers(1, 4), st.sampled_from(["textbook", "stonesoup"]),
       st.sampled_from([-np.inf, 0.0, 1e-6, 1e-3]), st.booleans(),
       st.sampled_from([0.5, 4.0, 16.0, 200.0]), st.sampled_from([1, 5, 40, 2**40]),
       st.integers(0, 2**31), st.booleans(), st.sampled_from(["kernel", "numpy"]))
def test_reduce_matches_its_mirror(j, d, mode, prune, merging, threshold, cap, seed, stretched,
                                   implementation):
    """Above 64 components the kernel gates merges by a grid; the NumPy twin tests the live
    candidates at once; the mirror tests every pair in turn."""
    means, covars, weights = _clustered(np.random.default_rng(seed), j, d, stretched=stretched)
    reduce = kernels.reduce if implementation == "kernel" else mixture_numpy.reduce
    count, got = _reduced(reduce, means, covars, weights, mode, prune, merging, threshold, cap)
    want_count, want = _reduced(reference.mixture.reduce, means, covars, weights, mode, prune,
                                merging, threshold, cap)
    assert count == want_count
    for name, a, b in zip(["means", "covars", "weights"], got, want):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9, err_msg=name)
    np.testing.assert_array_equal(got[3], want[3])
    np.testing.assert_array_equal(got[4], want[4])


def test_reduce_follows_a_merged_mean_that_drifts_out_of_the_gate():
    """A chain of components 0.5 apart, lighter towards the heaviest at one end: with the
    merged weight capped at 1, Stone Soup's running mean walks along the chain, far past
    the gate drawn around its start."""
    n = 100
    means = np.zeros((n, 2))
    means[:, 0] = 0.5 * np.arange(n)
    covars = np.broadcast_to(np.eye(2), (n, 2, 2)).copy()
    weights = 0.5 + 0.001 * np.arange(n)
    weights[0] = 1.0
    for mode, reduce in [(mode, reduce) for mode in ("stonesoup", "textbook")
                         for reduce in (kernels.reduce, mixture_numpy.reduce)]:
        got = _reduced(reduce, means, covars, weights, mode, -np.inf, True, 4.0, 2**40)
        want = _reduced(reference.mixture.reduce, means, covars, weights, mode, -np.inf, True,
                        4.0, 2**40)
        assert got[0] == want[0]
        np.testing.assert_array_equal(got[1][4], want[1][4])
        np.testing.assert_allclose(got[1][0], want[1][0], rtol=1e-12)
        assert (got[1][4] == 0).sum() > (50 if mode == "stonesoup" else 1)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 120), st.integers(1, 4), st.integers(0, 2**31))
def test_textbook_merges_conserve_mass_within_the_threshold(j, d, seed):
    means, covars, weights = _clustered(np.random.default_rng(seed), j, d)
    out_means, out_covars, out_weights, source, member = mixture.reduce(
        means, covars, weights, prune_threshold=None, merge_threshold=9.0)
    assert out_weights.sum() == pytest.approx(weights.sum(), rel=1e-12)
    assert (member >= 0).all()
    for i in range(j):  # each component lies within the threshold of its group's heaviest
        best = source[member[i]]
        v = means[i] - means[best]
        assert v @ np.linalg.solve(covars[best], v) <= 9.0 * (1 + 1e-9)
        assert weights[i] <= weights[best]
    for o in range(out_weights.size):  # each group is the moment match of its members
        w = weights[member == o] / weights[member == o].sum()
        np.testing.assert_allclose(out_means[o], w @ means[member == o], rtol=1e-9, atol=1e-9)


def test_reduce_closed_forms():
    p = np.eye(2)
    means = np.array([[0.0, 0.0], [1.0, 0.0], [50.0, 0.0]])
    # textbook: the two near ones merge with the spread term, weights summed
    m, c, w, source, member = mixture.reduce(means, [p, p, p], [0.6, 0.2, 0.1])
    np.testing.assert_allclose(m, [[0.25, 0.0], [50.0, 0.0]])
    np.testing.assert_allclose(c[0], p + np.diag([0.75 * 0.25, 0.0]))
    np.testing.assert_allclose(w, [0.8, 0.1])
    np.testing.assert_array_equal(source, [0, 2])
    np.testing.assert_array_equal(member, [0, 0, 1])
    # Stone Soup: merged weight capped at 1; pruned mass spread evenly; cut mass likewise
    m, c, w, source, member = mixture.reduce(means, [p, p, p], [0.9, 0.5, 1e-10],
                                             mode="stonesoup", prune_threshold=1e-9)
    np.testing.assert_allclose(w, [1.0])
    np.testing.assert_array_equal(member, [0, 0, -1])
    m, c, w, source, member = mixture.reduce(means, [p, p, p], [0.5, 0.3, 0.2],
                                             mode="stonesoup", merge_threshold=0.5,
                                             max_components=2)
    np.testing.assert_allclose(w, [0.6, 0.4])
    np.testing.assert_array_equal(member, [0, 1, -1])
    m, c, w, source, member = mixture.reduce(means, [p, p, p], [0.5, 0.3, 0.2],
                                             merge_threshold=0.5, max_components=2)
    np.testing.assert_allclose(w, [0.625, 0.375])


def test_reduce_of_nothing_and_of_one():
    m, c, w, source, member = mixture.reduce(np.zeros((0, 3)), np.zeros((0, 3, 3)), [])
    assert m.shape == (0, 3) and c.shape == (0, 3, 3) and w.shape == (0,) and member.size == 0
    m, c, w, source, member = mixture.reduce([[1.0, 2.0]], [np.eye(2)], [1e-12])
    assert w.size == 0 and member[0] == -1


@pytest.mark.parametrize("change, message", [
    (dict(weights=[0.5, -0.1]), r"weights must be >= 0, got -0.1 at weights\[1\]"),
    (dict(weights=[0.5, np.nan]), "weights"),
    (dict(covars=[np.eye(2), -np.eye(2)]), r"covars\[1\] is not positive definite"),
    (dict(covars=[np.eye(2), [[1.0, 0.5], [0.0, 1.0]]]), r"covars\[1\] is not symmetric"),
    (dict(mode="vo"), "mode must be one of 'textbook', 'stonesoup'"),
    (dict(prune_threshold=-1.0), "prune_threshold must be finite and >= 0"),
    (dict(merge_threshold=np.nan), "merge_threshold must be >= 0"),
    (dict(max_components=0), "max_components must be >= 1"),
    (dict(means=[[0.0, np.inf], [0.0, 0.0]]), "means"),
])
def test_bad_reductions_are_refused_naming_the_argument(change, message):
    arguments = dict(means=[[0.0, 0.0], [1.0, 0.0]], covars=[np.eye(2), np.eye(2)],
                     weights=[0.5, 0.5])
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        mixture.reduce(**arguments)


@pytest.mark.parametrize("bad, code", [([[1.0, 0.5], [0.0, 1.0]], -(2 + 2 * 2)),
                                       (-np.eye(2), -(1 + 2 * 2)),
                                       (np.array([[1.0, 2.0], [2.0, 1.0]]), -(1 + 2 * 2))])
def test_the_numpy_twin_names_a_bad_covariance_as_the_kernel_does(bad, code):
    """Status codes: -(2 + 2 i) for input i not symmetric, -(1 + 2 i) not positive
    definite (a pruned component is not checked)."""
    covars = np.array([np.eye(2), np.eye(2), bad, np.eye(2)], dtype=np.float64)
    means = np.arange(8.0).reshape(4, 2)
    weights = np.array([0.5, 1e-12, 0.5, 0.5])
    for covar in (covars, np.where(np.arange(4)[:, None, None] == 1, bad, covars)):
        got = [_reduced(reduce, means, covar, weights, "stonesoup", 1e-6, True, 4.0, 8)[0]
               for reduce in (kernels.reduce, mixture_numpy.reduce)]
        assert got == [code, code]


def test_zero_weights_merged_without_pruning_are_an_error():
    with pytest.raises(ValueError, match="components of zero weight .* merged"):
        mixture.reduce([[0.0], [0.1]], [[[1.0]], [[1.0]]], [0.0, 0.0], prune_threshold=None)


@pytest.mark.parametrize("settings, error, message", [
    (dict(mode="vo"), ValueError, "mode must be one of 'textbook', 'stonesoup'"),
    (dict(max_number_components=0), ValueError, "max_number_components must be >= 1"),
    (dict(prune_threshold=np.nan), ValueError, "prune_threshold must be finite"),
    (dict(merge_threshold="4"), TypeError, "merge_threshold must be a real number"),
    (dict(merging=1), TypeError, "merging must be a bool"),
])
def test_bad_reducer_settings_are_refused_naming_them(settings, error, message):
    from fasttrack import GaussianMixtureReducer
    with pytest.raises(error, match=message):
        GaussianMixtureReducer(**settings)


def test_the_reducer_face_keeps_labels_and_names_new_ones():
    from fasttrack import GaussianMixtureReducer
    p = np.eye(2)
    mixture = GaussianMixture([[0.0, 0.0], [0.5, 0.0], [50.0, 0.0], [80.0, 0.0]], [p] * 4,
                              np.log([0.6, 0.3, 0.2, 0.1]), labels=[4, 7, 4, 9])
    reduced = GaussianMixtureReducer(merge_threshold=4.0).reduce(mixture, first_label=100)
    np.testing.assert_array_equal(reduced.labels, [4, 100, 9])  # label 4 left twice
    np.testing.assert_allclose(np.exp(reduced.log_weights), [0.9, 0.2, 0.1])
    with pytest.raises(TypeError, match="mixture must be a GaussianMixture"):
        GaussianMixtureReducer().reduce([0.0])
    with pytest.raises(TypeError, match="first_label must be an int"):
        GaussianMixtureReducer().reduce(mixture, first_label=1.5)


def test_reducer_settings_are_checked_when_assigned():
    """``pruning = "no"`` was taken as True, ``truncating = None`` turned the cap off and
    ``max_number_components = 0`` was named ``max_components`` at the next call."""
    from fasttrack.mixturereducer import GaussianMixtureReducer
    reducer = GaussianMixtureReducer()
    for name, value, error in (("pruning", "no", TypeError), ("truncating", None, TypeError),
                               ("max_number_components", 0, ValueError),
                               ("prune_threshold", -1.0, ValueError),
                               ("merge_threshold", np.nan, ValueError),
                               ("mode", "vo", ValueError)):
        with pytest.raises(error, match=name):
            setattr(reducer, name, value)
    reducer.max_number_components = None  # (no cap, as in the constructor)
    assert reducer.max_number_components >= 2**31


@pytest.mark.parametrize("covars, match", [(-np.eye(2), "positive semi-definite"),
                                           (np.array([[1.0, 5.0], [0.0, 1.0]]), "symmetric")])
def test_moment_match_checks_the_covariances(covars, match):
    """It returned a covariance of -I or an asymmetric one, where ``reduce`` refused."""
    means = np.array([[0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(ValueError, match=rf"covars\[0\] is not {match}"):
        mixture.moment_match(means, np.stack([covars, np.eye(2)]), [0.0, 0.0])
    with pytest.raises(ValueError, match=rf"covars\[0\] is not {match}"):
        GaussianMixture(means, np.stack([covars, np.eye(2)])).reduce()


def test_moments_beyond_float64_are_named():
    """Means of +-1e200 merged into an inf covariance silently (reduce, moment matching, a
    mixture's covariance, an IMM combination); weights of 1e308 summed to inf, blamed on
    zero weights."""
    import fasttrack as ft
    means, covars = np.array([[1e200], [-1e200]]), np.ones((2, 1, 1))
    match = "the merged mean or covariance is not finite"
    with pytest.raises(ValueError, match=match):
        mixture.reduce(means, covars, [0.5, 0.5], merge_threshold=np.inf)
    with pytest.raises(ValueError, match=match):
        mixture.moment_match(means, covars, [0.0, 0.0])
    with pytest.raises(ValueError, match=match):
        GaussianMixture(means, covars).covar
    with pytest.raises(ValueError, match=match):
        ft.BatchIMMFilter.combine(means[None], covars[None], [[0.5, 0.5]])
    with pytest.raises(ValueError, match="a merged weight overflows float64"):
        mixture.reduce(np.zeros((3, 1)), np.ones((3, 1, 1)), [1e308] * 3,
                       merge_threshold=np.inf)


@pytest.mark.parametrize("mode", ["textbook", "stonesoup"])
@pytest.mark.parametrize("numpy_first", [False, True])
def test_a_merge_of_weights_the_kernels_cannot_divide_by_is_refused_on_both_paths(
        mode, numpy_first, monkeypatch):
    """Two weights of 5e-324 (log weights of -745): the kernels' reciprocal of their total
    overflows and the merge is refused; the NumPy twin merged them."""
    import fasttrack._jit
    monkeypatch.setattr(fasttrack._jit, "numpy_first", lambda work=1: numpy_first)
    with pytest.raises(ValueError, match="components of zero weight"):
        mixture.reduce(np.zeros((2, 1)), np.ones((2, 1, 1)), [5e-324, 5e-324], mode,
                       prune_threshold=0.0)


def test_a_reduction_whose_numpy_twin_is_slow_takes_the_kernel(monkeypatch):
    """Merge tests cost d^2 each, and a component that many merge into meets up to J of
    them: 5,000 60-D components merging into one took 79 s in a process's NumPy first
    calls (1.6 s on the kernels). Such sizes take the kernel; the tutorial's take NumPy."""
    from fasttrack import _jit
    monkeypatch.setattr(_jit, "kernels_loaded", lambda: False)  # a new process
    twin, kernel = [], []
    monkeypatch.setattr(mixture_numpy, "reduce", lambda *args: twin.append(args) or 0)
    monkeypatch.setattr(mixture, "_mixture", types.SimpleNamespace(
        reduce=lambda *args: kernel.append(args) or 0))
    for j, d, numpy in ((5000, 60, False), (8000, 4, False), (30, 4, True), (4000, 4, True),
                        (2000, 8, True), (2100, 8, False)):
        monkeypatch.setattr(_jit, "_numpy_work", _jit.NUMPY_WORK)
        twin.clear(), kernel.clear()
        mixture.reduce(np.zeros((j, d)), np.tile(np.eye(d), (j, 1, 1)), np.ones(j),
                       "stonesoup", merge_threshold=np.inf)
        assert (len(twin), len(kernel)) == ((1, 0) if numpy else (0, 1)), (j, d)
