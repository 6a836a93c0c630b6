"""fasttrack.stonesoup's IMM pair on Stone Soup's types: equal to fasttrack's batch IMM on the
multiple-model tutorial's flight through one kernel call a step and through each model's
own Stone Soup predictor and updater, deterministic, and bad input."""
import datetime

import numpy as np
import pytest

pytest.importorskip("stonesoup")

from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity, KnownTurnRate)
from stonesoup.predictor.kalman import (ExtendedKalmanPredictor,  # noqa: E402
                                        KalmanPredictor)
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.mixture import GaussianMixture  # noqa: E402
from stonesoup.types.state import WeightedGaussianState  # noqa: E402
from stonesoup.updater.kalman import ExtendedKalmanUpdater, KalmanUpdater  # noqa: E402

import fasttrack as ft  # noqa: E402
from fasttrack import stonesoup as drop  # noqa: E402
from fasttrack.scenarios import manoeuvring_target  # noqa: E402

RATES = (0.02, 0.0, -0.02)
MATRIX = np.full((3, 3), 0.05) + 0.85 * np.eye(3)
START = datetime.datetime(2025, 1, 1)


def _run(predictor_class, updater_class, steps=80, pair=drop):
    """The pair's posteriors on the tutorial's flight, and fasttrack's batch filter's."""
    scenario = manoeuvring_target(seed=1)
    sensor = LinearGaussian(4, [0, 2], np.diag([0.725, 0.7025]))
    models = [KnownTurnRate(turn_noise_diff_coeffs=np.array([1e-3, 1e-3]), turn_rate=w)
              if w else CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-3)] * 2)
              for w in RATES]  # (Stone Soup's KnownTurnRate divides by a rate of 0)
    predictor = pair.IMMPredictor([predictor_class(m) for m in models], MATRIX)
    updater = pair.IMMUpdater([updater_class(sensor) for _ in models], MATRIX)
    x, y = scenario.measurements[0]
    state = GaussianMixture([WeightedGaussianState([[x], [-30.0], [y], [-30.0]],
                                                   np.diag([1.0, 25.0, 1.0, 25.0]),
                                                   timestamp=START, weight=1 / 3)] * 3)
    batch = ft.BatchIMMFilter([ft.KnownTurnRate([1e-3, 1e-3], w) for w in RATES],
                              ft.LinearGaussian(4, (0, 2), np.diag([0.725, 0.7025])), MATRIX)
    means = np.tile([x, -30.0, y, -30.0], (1, 3, 1))
    covars = np.tile(np.diag([1.0, 25.0, 1.0, 25.0]), (1, 3, 1, 1))
    probs = np.full((1, 3), 1 / 3)
    for t, z in enumerate(scenario.measurements[1:steps + 1], start=1):
        when = START + datetime.timedelta(seconds=t)
        prediction = predictor.predict(state, timestamp=when)
        state = updater.update(SingleHypothesis(prediction, Detection(
            z.reshape(2, 1), timestamp=when, measurement_model=sensor)))
        means, covars, probs = batch.step(means, covars, probs, z[None], 1.0)
    return state, (means[0], covars[0], probs[0])


@pytest.mark.parametrize("predictor_class,updater_class", [
    (KalmanPredictor, KalmanUpdater),  # one kernel call a step
    (drop.KalmanPredictor, drop.KalmanUpdater),  # the same
    (ExtendedKalmanPredictor, ExtendedKalmanUpdater),  # each model's Stone Soup code
])
def test_the_pair_is_the_batch_filter_on_the_tutorial_flight(predictor_class, updater_class):
    drop.fallbacks(clear=True)
    state, (means, covars, probs) = _run(predictor_class, updater_class)
    imm_fallbacks = {key: n for key, n in drop.fallbacks().items() if "IMM" in key[0]}
    if predictor_class is ExtendedKalmanPredictor:
        assert imm_fallbacks[("IMMPredictor", "predict", "a predictor that is not a "
                              "KalmanPredictor without control")] == 80
    else:  # the kernels, once the process runs them (a few NumPy-first steps at most)
        assert sum(imm_fallbacks.values()) <= 2 * 10, imm_fallbacks
        assert all("NumPy-first" in key[2] for key in imm_fallbacks), imm_fallbacks
    assert all(type(c).__name__ == "WeightedGaussianStateUpdate" for c in state.components)
    np.testing.assert_allclose([float(c.weight) for c in state.components], probs, rtol=1e-8,
                               atol=1e-12)
    for j, component in enumerate(state.components):
        np.testing.assert_allclose(np.asarray(component.state_vector, float).ravel(),
                                   means[j], rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(np.asarray(component.covar, float), covars[j], rtol=1e-8,
                                   atol=1e-8)
    assert probs[1] > 0.5  # the flight is straight at step 80


def test_the_pair_is_deterministic():
    first, _ = _run(KalmanPredictor, KalmanUpdater, steps=20)
    second, _ = _run(KalmanPredictor, KalmanUpdater, steps=20)
    for a, b in zip(first.components, second.components):
        assert float(a.weight) == float(b.weight)
        np.testing.assert_array_equal(a.state_vector, b.state_vector)


def test_bad_input_is_refused_naming_the_argument():
    sensor = LinearGaussian(4, [0, 2], np.eye(2))
    model = KnownTurnRate(turn_noise_diff_coeffs=np.array([1e-3, 1e-3]), turn_rate=0.1)
    with pytest.raises(ValueError, match="row 0 sums to 1.2"):
        drop.IMMPredictor([KalmanPredictor(model)] * 2, [[0.6, 0.6], [0.5, 0.5]])
    predictor = drop.IMMPredictor([KalmanPredictor(model)] * 2, [[0.9, 0.1], [0.1, 0.9]])
    component = WeightedGaussianState([[0.0]] * 4, np.eye(4), timestamp=START, weight=0.7)
    with pytest.raises(ValueError, match="prior's weights must sum to 1; they sum to 1.4"):
        predictor.predict(GaussianMixture([component, component]), START)
    with pytest.raises(ValueError, match=r"prior must have 2 components \(one a model\)"):
        predictor.predict(GaussianMixture([component]), START)
    with pytest.raises(TypeError, match="prior must be a Stone Soup GaussianMixture"):
        predictor.predict(component, START)
    updater = drop.IMMUpdater([KalmanUpdater(sensor)] * 2, [[0.9, 0.1], [0.1, 0.9]])
    half = WeightedGaussianState([[0.0]] * 4, np.eye(4), timestamp=START, weight=0.5)
    prediction = predictor.predict(GaussianMixture([half, half]), START)
    with pytest.raises(ValueError, match="hypothesis.measurement is None"):
        updater.update(SingleHypothesis(prediction, None))
    for z in ([[1.0]], [[1.0], [2.0], [3.0]]):  # (the kernel read past a short one)
        with pytest.raises(ValueError, match="hypothesis.measurement must have 2 components"):
            updater.update(SingleHypothesis(prediction, Detection(z, timestamp=START)))


@pytest.mark.parametrize("pair", [drop, ft])
def test_a_switching_matrix_assigned_later_is_checked(pair):
    """Rows summing to 3 gave mode probabilities summing to 3; a NaN, NaN ones; a nested
    list, Numba's typing error."""
    if pair is drop:
        predictor = KalmanPredictor(
            CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-3)] * 2))
    else:
        predictor = ft.KalmanPredictor(
            ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1e-3)] * 2))
    predictor = pair.IMMPredictor([predictor] * 2, [[0.9, 0.1], [0.1, 0.9]])
    for matrix, match in (([[3.0, 0.0], [0.0, 3.0]], "row 0 sums to 3.0"),
                          ([[np.nan, 0.0], [0.0, 1.0]], "transition_matrix contains NaN"),
                          ([[0.5, 0.5]], r"transition_matrix must have shape \(2, 2\)")):
        with pytest.raises(ValueError, match=match):
            predictor.transition_matrix = matrix
    assert predictor.transition_matrix.tolist() == [[0.9, 0.1], [0.1, 0.9]]


@pytest.mark.parametrize("numpy_first", [False, True])
def test_a_prior_that_is_not_finite_or_mixes_beyond_float64_is_refused(numpy_first,
                                                                       monkeypatch):
    """A NaN prior mean gave NaN predictions on the kernels (and 'the prediction
    overflowed' in NumPy); means of +-1e200, whose mixing overflows, inf covariances."""
    from fasttrack import _jit
    monkeypatch.setattr(_jit, "numpy_first", lambda work=1: numpy_first)
    model = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-3)] * 2)
    predictor = drop.IMMPredictor([KalmanPredictor(model)] * 2, [[0.9, 0.1], [0.1, 0.9]])
    for first, second, match in ((np.nan, 0.0, "prior's component 0 is not finite"),
                                 (1e200, -1e200, "merged mean or covariance is not finite")):
        prior = GaussianMixture([
            WeightedGaussianState([[x], [0.0], [0.0], [0.0]], np.eye(4), timestamp=START,
                                  weight=0.5) for x in (first, second)])
        with pytest.raises(ValueError, match=match):
            predictor.predict(prior, START + datetime.timedelta(seconds=1))
    skew = np.eye(4)
    skew[0, 1] = 0.5  # (the kernel's mixing read one triangle: symmetrised it silently)
    prior = GaussianMixture([WeightedGaussianState([[0.0]] * 4, covar, timestamp=START,
                                                   weight=0.5) for covar in (np.eye(4), skew)])
    with pytest.raises(ValueError, match=r"prior's covariances\[1\] is not symmetric"):
        predictor.predict(prior, START + datetime.timedelta(seconds=1))
