"""Parity with Stone Soup 1.9.1's resamplers on the resampler tutorial's examples."""
import numpy as np
import pytest
from scipy.stats import chi2_contingency

import fasttrack as ft

ss_particle = pytest.importorskip("stonesoup.types.particle")
ss_state = pytest.importorskip("stonesoup.types.state")
ss_resampler = pytest.importorskip("stonesoup.resampler.particle")
ss_array = pytest.importorskip("stonesoup.types.array")

TUTORIAL_WEIGHTS = np.array([1, 5, 1.5, 0.5, 2]) / 10

PAIRS = [
    (lambda: ss_resampler.MultinomialResampler(), lambda: ft.MultinomialResampler(rng=1)),
    (lambda: ss_resampler.SystematicResampler(), lambda: ft.SystematicResampler(rng=1)),
    (lambda: ss_resampler.StratifiedResampler(), lambda: ft.StratifiedResampler(rng=1)),
    (lambda: ss_resampler.ResidualResampler(
        residual_method=ss_resampler.ResidualMethod.SYSTEMATIC),
     lambda: ft.ResidualResampler("systematic", rng=1)),
    (lambda: ss_resampler.ResidualResampler(
        residual_method=ss_resampler.ResidualMethod.MULTINOMIAL),
     lambda: ft.ResidualResampler("multinomial", rng=1)),
    (lambda: ss_resampler.ResidualResampler(
        residual_method=ss_resampler.ResidualMethod.STRATIFIED),
     lambda: ft.ResidualResampler("stratified", rng=1)),
]


def _ss_state(weights, parent=None):
    n = len(weights)
    return ss_state.ParticleState(ss_array.StateVectors(np.arange(n, dtype=float)[None]),
                                  weight=np.asarray(weights, dtype=float), parent=parent)


def _ft_state(weights, parent=None):
    return ft.ParticleState(np.arange(len(weights), dtype=float)[None], weight=weights,
                            parent=parent)


def _counts(resampler, make_state, weights, nparts, reps, order=None):
    """Offspring counts of each particle over ``reps`` draws; with ``order``, the particles
    are handed to the resampler in that order."""
    order = np.arange(len(weights)) if order is None else order
    state = make_state(np.asarray(weights)[order])
    counts = np.empty((reps, len(weights)), dtype=int)
    for r in range(reps):
        out = resampler.resample(state, nparts)
        drawn = order[np.asarray(out.state_vector, dtype=float)[0].astype(int)]
        counts[r] = np.bincount(drawn, minlength=len(weights))
    return counts


def test_tutorial_example_same_kinds_of_output():
    ss_particles = [ss_particle.Particle(np.array([[i]]), weight=1 / 5) for i in range(5)]
    ft_particles = [ft.Particle(np.array([[i]]), weight=1 / 5) for i in range(5)]
    for nparts in (None, 10):
        ss_out = ss_resampler.MultinomialResampler().resample(ss_particles, nparts=nparts)
        ft_out = ft.MultinomialResampler().resample(ft_particles, nparts=nparts)
        assert np.shape(ss_out.state_vector) == ft_out.state_vector.shape
        np.testing.assert_allclose(np.asarray(ss_out.weight, dtype=float), ft_out.weight)
        assert set(np.asarray(ss_out.state_vector, float).ravel()) <= set(range(5))
        assert set(ft_out.state_vector.ravel()) <= set(range(5))


# Stone Soup's residual resampler only draws nparts = N
@pytest.mark.parametrize("pair,nparts", [(p, None) for p in range(len(PAIRS))]
                         + [(p, 10) for p in range(3)])
def test_count_distributions_match_stone_soup(pair, nparts):
    make_ss, make_ft = PAIRS[pair]
    reps = 3000
    np.random.seed(2)
    ss_counts = _counts(make_ss(), _ss_state, TUTORIAL_WEIGHTS, nparts, reps)
    # Stone Soup lays the cumulative weights out in ascending order of the weights it draws
    # from (the residuals, for residual resampling); stratified counts depend on that order,
    # so fasttrack gets the particles in the same order
    drawn_from = TUTORIAL_WEIGHTS
    if pair >= 3:
        drawn_from = TUTORIAL_WEIGHTS - np.floor(5 * TUTORIAL_WEIGHTS) / 5
    ft_counts = _counts(make_ft(), _ft_state, TUTORIAL_WEIGHTS, nparts, reps,
                        order=np.argsort(drawn_from, kind="stable"))
    n = nparts or len(TUTORIAL_WEIGHTS)
    for counts in (ss_counts, ft_counts):
        assert np.all(counts.sum(axis=1) == n)
        se = counts.std(axis=0) / np.sqrt(reps) + 1e-9
        assert np.all(np.abs(counts.mean(axis=0) - n * TUTORIAL_WEIGHTS) <= 5 * se)
    for i in range(len(TUTORIAL_WEIGHTS)):  # same distribution of each particle's count
        values = np.union1d(ss_counts[:, i], ft_counts[:, i])
        if values.size == 1:
            continue
        table = [[np.sum(c[:, i] == v) for v in values] for c in (ss_counts, ft_counts)]
        assert chi2_contingency(table).pvalue > 1e-4


def test_parent_link_matches_stone_soup():
    """With one surviving particle the draw is deterministic, so the outputs are equal."""
    weights = [0.0, 0.0, 1.0, 0.0]
    ss_prior = _ss_state([0.25] * 4)
    ft_prior = _ft_state([0.25] * 4)
    ss_prior.state_vector = ss_array.StateVectors(np.array([[10.0, 11, 12, 13]]))
    ft_prior.state_vector = np.array([[10.0, 11, 12, 13]])
    with np.errstate(divide="ignore"):
        ss_out = ss_resampler.SystematicResampler().resample(_ss_state(weights, ss_prior), 3)
    ft_out = ft.SystematicResampler().resample(_ft_state(weights, ft_prior), 3)
    np.testing.assert_array_equal(np.asarray(ss_out.state_vector, float), ft_out.state_vector)
    np.testing.assert_array_equal(np.asarray(ss_out.parent.state_vector, float),
                                  ft_out.parent.state_vector)
    np.testing.assert_allclose(ss_out.log_weight, ft_out.log_weight)


def test_ess_resampler_identity_like_stone_soup():
    ss_state_even = _ss_state([0.25] * 4)
    ft_state_even = _ft_state([0.25] * 4)
    assert ss_resampler.ESSResampler().resample(ss_state_even) is ss_state_even
    assert ft.ESSResampler().resample(ft_state_even) is ft_state_even
    skewed = [0.97, 0.01, 0.01, 0.01]
    assert ss_resampler.ESSResampler().resample(_ss_state(skewed)).log_weight.size == 4
    assert len(ft.ESSResampler().resample(_ft_state(skewed))) == 4


def test_stone_soup_defects_that_fasttrack_does_not_have():
    # the tutorial's own call: Stone Soup rejects the string, fasttrack takes it
    with pytest.raises(ValueError):
        ss_resampler.ResidualResampler(residual_method="systematic").resample(
            _ss_state(TUTORIAL_WEIGHTS))
    assert len(ft.ResidualResampler(residual_method="systematic").resample(
        _ft_state(TUTORIAL_WEIGHTS))) == 5
    # every N w_i < 1 (weights summing to 0.6): Stone Soup's residual resampler crashes
    flat = np.full(6, 0.1)
    with pytest.raises(IndexError):
        ss_resampler.ResidualResampler().resample(_ss_state(flat))
    assert len(ft.ResidualResampler().resample(_ft_state(flat))) == 6
    assert len(ft.ResidualResampler().resample(_ft_state(flat), nparts=5)) == 5
    # weights summing to 0.6: Stone Soup indexes out of range
    short = TUTORIAL_WEIGHTS * 0.6
    np.random.seed(0)
    with pytest.raises(IndexError):
        for _ in range(50):
            ss_resampler.MultinomialResampler().resample(_ss_state(short))
    for _ in range(50):
        assert len(ft.MultinomialResampler().resample(_ft_state(short))) == 5
    # Stone Soup stores the default ESS threshold of its first call
    ss_ess = ss_resampler.ESSResampler()
    ss_ess.resample(_ss_state([0.25] * 4))
    assert ss_ess.threshold == 2
    ft_ess = ft.ESSResampler()
    ft_ess.resample(_ft_state([0.25] * 4))
    assert ft_ess.threshold is None
