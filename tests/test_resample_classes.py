"""The resampler classes."""
import numpy as np
import pytest

import fasttrack as ft
from fasttrack import (ESSResampler, MultinomialResampler, Particle, ParticleState,
                       ResidualMethod, ResidualResampler, StratifiedResampler,
                       SystematicResampler)

RESAMPLERS = [SystematicResampler, StratifiedResampler, MultinomialResampler,
              ResidualResampler]


class Update(ParticleState):
    """A subclass with an extra attribute, like Stone Soup's ParticleStateUpdate."""


def _tutorial_particles():
    return [Particle(np.array([[i]]), weight=1 / 5) for i in range(5)]


@pytest.mark.parametrize("cls", RESAMPLERS)
@pytest.mark.parametrize("nparts", [None, 10, 2])
def test_resample_returns_equal_weights_and_keeps_type(cls, nparts):
    prior = ParticleState(np.arange(6.0)[None] * 10)
    state = Update(np.arange(12.0).reshape(2, 6), log_weight=np.log([1, 5, 1.5, 0.5, 2, 1]),
                   parent=prior, timestamp=3.0)
    state.hypothesis = "h"
    out = cls(rng=1).resample(state, nparts)
    n = nparts or 6
    assert type(out) is Update and out.hypothesis == "h" and out.timestamp == 3.0
    assert len(out) == n and out.ndim == 2
    np.testing.assert_allclose(out.weight, 1 / n)
    ancestors = out.state_vector[0].astype(int)
    assert np.all(np.diff(ancestors) >= 0)
    np.testing.assert_array_equal(out.state_vector[1], ancestors + 6)
    # parent: the input's parent indexed by the same ancestors, its own parent dropped
    np.testing.assert_array_equal(out.parent.state_vector[0], ancestors * 10)
    assert out.parent.parent is None
    assert state.state_vector.shape == (2, 6)  # input untouched


@pytest.mark.parametrize("cls", RESAMPLERS)
def test_resample_accepts_a_list_of_particles(cls):
    out = cls(rng=2).resample(_tutorial_particles(), nparts=10)
    assert isinstance(out, ParticleState) and len(out) == 10 and out.parent is None
    assert set(out.state_vector[0]) <= set(range(5))


def test_without_parent_the_output_has_none():
    out = SystematicResampler(rng=0).resample(ParticleState(np.zeros((1, 4))))
    assert out.parent is None


@pytest.mark.parametrize("method", ["multinomial", "systematic", "stratified",
                                    ResidualMethod.SYSTEMATIC])
def test_residual_method_by_name_or_member(method):
    resampler = ResidualResampler(residual_method=method, rng=3)
    assert resampler.residual_method is ResidualMethod(method)
    assert len(resampler.resample(_tutorial_particles())) == 5


def test_residual_method_invalid_lists_valid_names():
    with pytest.raises(ValueError, match="'multinomial', 'systematic', 'stratified'"):
        ResidualResampler(residual_method="metropolis")


def test_settings_assigned_later_are_checked():
    """A threshold of NaN never resampled, a scheme 'x' resampled with some scheme: refused
    where they are assigned, the resampler unchanged."""
    residual = ResidualResampler(rng=3)
    with pytest.raises(ValueError, match="residual_method must be one of"):
        residual.residual_method = "x"
    assert residual.residual_method is ResidualMethod.MULTINOMIAL
    residual.residual_method = "systematic"
    assert residual.residual_method is ResidualMethod.SYSTEMATIC
    ess = ESSResampler(threshold=3.0)
    for value, error, match in [(np.nan, ValueError, "threshold must be finite"),
                                ("x", TypeError, "threshold must be a number or None"),
                                (0.0, ValueError, "threshold must be finite and > 0")]:
        with pytest.raises(error, match=match):
            ess.threshold = value
        assert ess.threshold == 3.0
    with pytest.raises(TypeError, match="resampler must be a resampler"):
        ess.resampler = SystematicResampler
    ess.threshold = None  # (half the particles of each call)


def test_same_seed_same_draws_and_generator_advances():
    state = ParticleState(np.arange(100.0)[None], log_weight=np.random.default_rng(0).normal(size=100))
    a = MultinomialResampler(rng=7)
    b = MultinomialResampler(rng=7)
    first = a.resample(state).state_vector
    assert np.array_equal(first, b.resample(state).state_vector)
    assert not np.array_equal(first, a.resample(state).state_vector)


def test_ess_resampler_threshold_follows_n():
    resampler = ESSResampler()
    skewed = ParticleState(np.zeros((1, 4)), weight=[0.97, 0.01, 0.01, 0.01])
    even = ParticleState(np.zeros((1, 4)))
    assert resampler.resample(even) is even
    assert resampler.resample(skewed) is not skewed
    # the default threshold is N/2 of each call, never stored
    big = ParticleState(np.zeros((1, 100)), weight=np.r_[np.ones(30), np.full(70, 1e-9)])
    assert resampler.threshold is None
    assert resampler.resample(big) is not big  # ESS ~ 30 < 50
    small = ParticleState(np.zeros((1, 4)), weight=[1, 1, 1, 0.2])
    assert resampler.resample(small) is small  # ESS ~ 3.4 >= 2
    assert resampler.threshold is None


def test_ess_resampler_uses_its_resampler_and_threshold():
    inner = ResidualResampler("systematic", rng=1)
    resampler = ESSResampler(threshold=5, resampler=inner)
    state = ParticleState(np.arange(4.0)[None])
    out = resampler.resample(state, nparts=4)
    assert out is not state and len(out) == 4  # ESS 4 < 5
    assert ESSResampler(threshold=4).resample(state) is state  # not strictly below


def test_ess_resampler_with_the_tutorial_calls():
    resampler = ESSResampler(resampler=ResidualResampler(residual_method="systematic"))
    out = resampler.resample(_tutorial_particles())
    assert isinstance(out, ParticleState) and len(out) == 5


@pytest.mark.parametrize("cls", RESAMPLERS)
def test_bad_input(cls):
    resampler = cls()
    with pytest.raises(TypeError, match="particles must be a ParticleState or a list"):
        resampler.resample(np.zeros((1, 3)))
    with pytest.raises(ValueError, match="nparts must be >= 1"):
        resampler.resample(ParticleState(np.zeros((1, 3))), nparts=0)
    with pytest.raises(ValueError, match=r"nparts=1099511627776 needs .* GiB of arrays, more "
                                         r"than this machine's"):
        resampler.resample(ParticleState(np.zeros((1, 3))), nparts=2**40)
    state = ParticleState(np.zeros((1, 3)))
    state._log_weight = np.array([0.0, np.nan, 0.0])  # corrupted after construction
    with pytest.raises(ValueError, match="particles.log_weight contains NaN"):
        resampler.resample(state)
    with pytest.raises(ValueError, match="particles.parent has 2 particles"):
        resampler.resample(ParticleState(np.zeros((1, 3)), parent=ParticleState(np.zeros((1, 2)))))
    with pytest.raises(TypeError, match="rng must be"):
        cls(rng=1.5)


def test_ess_resampler_bad_arguments():
    with pytest.raises(TypeError, match="threshold must be a number"):
        ESSResampler(threshold="half")
    with pytest.raises(ValueError, match="threshold must be finite"):
        ESSResampler(threshold=np.nan)
    for resampler in (object(), SystematicResampler):  # (the class, not one)
        with pytest.raises(TypeError, match="resampler must be a resampler"):
            ESSResampler(resampler=resampler)


def test_default_rng_follows_seed():
    state = ParticleState(np.arange(50.0)[None], log_weight=np.random.default_rng(1).normal(size=50))
    resampler = StratifiedResampler()
    ft.seed(3)
    a = resampler.resample(state).state_vector
    ft.seed(3)
    assert np.array_equal(a, resampler.resample(state).state_vector)


def test_resampled_states_share_one_read_only_uniform_log_weight():
    state = ParticleState(np.arange(12.0).reshape(2, 6), log_weight=np.log([1, 5, 1.5, 0.5, 2, 1]))
    first, second = SystematicResampler(rng=1).resample(state), MultinomialResampler(rng=2).resample(state)
    assert first.log_weight is second.log_weight  # one array per size, not one per state
    np.testing.assert_array_equal(first.log_weight, np.full(6, -np.log(6)))
    with pytest.raises(ValueError, match="read-only"):
        first.log_weight[0] = 0.0  # an in-place edit would change every resampled state
    first.log_weight = np.log([2, 1, 1, 1, 1, 1])  # assigning gives the state its own
    assert first.log_weight.flags.writeable and second.log_weight[0] == -np.log(6)
    assert SystematicResampler(rng=1).resample(state, 4).log_weight.size == 4


def test_mean_of_a_resampled_state_is_the_plain_mean():
    rng = np.random.default_rng(3)
    state = ParticleState(rng.normal(size=(3, 500)) * [[1.0], [10.0], [1e3]],
                          log_weight=rng.normal(size=500))
    out = SystematicResampler(rng=4).resample(state)
    np.testing.assert_allclose(out.mean[:, 0], out.state_vector.mean(axis=1), rtol=1e-14)
    weighted = ParticleState(out.state_vector, log_weight=np.full(500, -np.log(500)))
    np.testing.assert_allclose(out.mean, weighted.mean, rtol=1e-12)  # the weighted path
    huge = ParticleState(np.full((1, 4), 1e308), log_weight=np.zeros(4))
    with pytest.raises(ValueError, match="beyond float64's range"):
        SystematicResampler(rng=1).resample(huge).mean
