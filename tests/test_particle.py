"""The particle predictor and updater, the tutorial scenario against Stone Soup, user models."""
import datetime

import numpy as np
import pytest
from numba import njit
from scipy import stats

import fasttrack as ft

from conftest import stonesoup_tutorial
from user_models import bearing_range_from_50_0, coordinated_turn

START = datetime.datetime(2026, 1, 1)
NOISE = np.diag([np.radians(0.2), 1.0])


def _models():
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    return transition, sensor


def _prior(n, seed=1, timestamp=START):
    rng = np.random.default_rng(seed)
    samples = rng.multivariate_normal([0, 1, 0, 1], np.diag([1.5, 0.5, 1.5, 0.5]), size=n)
    return ft.ParticleState(samples.T, timestamp=timestamp)


def test_prediction_links_and_noise():
    transition, _ = _models()
    prior = _prior(200_000)
    prediction = ft.ParticlePredictor(transition, rng=3).predict(prior, START + datetime.timedelta(seconds=2))
    assert type(prediction) is ft.ParticleStatePrediction
    assert prediction.parent is prior and prediction.prior is prior
    assert prediction.log_weight is prior.log_weight
    assert prediction.transition_model is transition
    assert prediction.timestamp == START + datetime.timedelta(seconds=2)
    f, q = transition.matrix(2.0), transition.covar(2.0)
    np.testing.assert_allclose(prediction.mean, f @ prior.mean, atol=0.02)
    np.testing.assert_allclose(prediction.covar, f @ prior.covar @ f.T + q, rtol=0.02, atol=0.01)
    again = ft.ParticlePredictor(transition, rng=3).predict(prior, START + datetime.timedelta(seconds=2))
    assert np.array_equal(again.state_vector, prediction.state_vector)


def test_predict_with_float_timestamps_and_errors():
    transition, _ = _models()
    predictor = ft.ParticlePredictor(transition, rng=1)
    prior = _prior(10, timestamp=3.0)
    assert predictor.predict(prior, 4.5).timestamp == 4.5
    with pytest.raises(ValueError, match="the prior has no timestamp"):
        predictor.predict(_prior(10, timestamp=None), 1.0)
    with pytest.raises(TypeError, match="must both be datetimes or both numbers"):
        predictor.predict(prior, START)
    with pytest.raises(TypeError, match="timestamp must be None, a datetime or a number"):
        predictor.predict(prior, "tomorrow")
    with pytest.raises(ValueError, match="predict needs a timestamp"):
        predictor.predict(prior, None)
    with pytest.raises(ValueError, match="prior has 2 state dimensions"):
        predictor.predict(ft.ParticleState(np.zeros((2, 5)), timestamp=0.0), 1.0)
    with pytest.raises(TypeError, match="prior must be a ParticleState"):
        predictor.predict(np.zeros((4, 5)), 1.0)
    with pytest.raises(TypeError, match="transition_model must be a TransitionModel"):
        ft.ParticlePredictor("cv")


def test_update_weights_and_links():
    transition, sensor = _models()
    prior = _prior(5000)
    prediction = ft.ParticlePredictor(transition, rng=1).predict(prior, START + datetime.timedelta(seconds=1))
    detection = ft.Detection(sensor.function([1, 1, 1, 1]), timestamp=prediction.timestamp)
    hypothesis = ft.SingleHypothesis(prediction, detection)
    update = ft.ParticleUpdater(sensor).update(hypothesis)
    assert type(update) is ft.ParticleStateUpdate and update.hypothesis is hypothesis
    assert update.state_vector is prediction.state_vector and update.parent is prior
    assert update.timestamp == prediction.timestamp
    expected = prediction.log_weight + sensor.logpdf(detection, prediction.state_vector)
    expected -= np.logaddexp.reduce(expected)
    np.testing.assert_allclose(update.log_weight, expected, rtol=1e-10, atol=1e-10)
    assert np.exp(update.log_weight).sum() == pytest.approx(1.0, rel=1e-12)


def test_detection_model_wins_and_resampling():
    transition, sensor = _models()
    other = ft.CartesianToBearingRange(4, (0, 2), NOISE * 100, translation_offset=[50, 0])
    prior = _prior(3000)  # held: the prediction's links to it are weak
    prediction = ft.ParticlePredictor(transition, rng=1).predict(prior, START + datetime.timedelta(seconds=1))
    z = sensor.function([1, 1, 1, 1])
    with_model = ft.ParticleUpdater(other).update(ft.SingleHypothesis(
        prediction, ft.Detection(z, timestamp=prediction.timestamp, measurement_model=sensor)))
    plain = ft.ParticleUpdater(sensor).update(ft.SingleHypothesis(
        prediction, ft.Detection(z, timestamp=prediction.timestamp)))
    np.testing.assert_allclose(with_model.log_weight, plain.log_weight)
    resampled = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=2)).update(
        ft.SingleHypothesis(prediction, ft.Detection(z, timestamp=prediction.timestamp)))
    assert type(resampled) is ft.ParticleStateUpdate
    np.testing.assert_allclose(resampled.weight, 1 / 3000)
    # the parent is the prior, indexed by the same ancestors
    ancestors_x = resampled.parent.state_vector
    assert ancestors_x.shape == (4, 3000)
    ess = ft.ParticleUpdater(sensor, ft.ESSResampler())
    flat = ft.Detection(z, timestamp=prediction.timestamp,
                        measurement_model=ft.CartesianToBearingRange(4, (0, 2), NOISE * 1e8))
    kept = ess.update(ft.SingleHypothesis(prediction, flat))
    assert kept.state_vector is prediction.state_vector  # ESS high: not resampled
    sharp = ft.Detection(z, timestamp=prediction.timestamp,
                         measurement_model=ft.CartesianToBearingRange(4, (0, 2), NOISE / 100,
                                                                      translation_offset=[50, 0]))
    drawn = ess.update(ft.SingleHypothesis(prediction, sharp))
    assert drawn.state_vector is not prediction.state_vector  # ESS low: resampled


@njit(cache=False)
def _infinite(states):
    return np.full((1, states.shape[1]), np.inf)


@njit(cache=False)
def _half_nan(states):
    out = np.zeros((2, states.shape[1]))
    out[0, ::2] = np.nan
    return out


def test_update_errors():
    transition, sensor = _models()
    prediction = ft.ParticlePredictor(transition, rng=1).predict(_prior(100), START + datetime.timedelta(seconds=1))
    updater = ft.ParticleUpdater(sensor)
    with pytest.raises(ValueError, match="must have 2 components"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([1.0], timestamp=prediction.timestamp)))
    with pytest.raises(ValueError, match="state_vector contains NaN"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([np.nan, 1.0])))
    far = ft.Detection([0.0, 1e9], timestamp=prediction.timestamp)
    lost = updater.update(ft.SingleHypothesis(prediction, far))  # log space: no underflow
    assert np.isfinite(lost.log_weight).any() and not np.isnan(lost.log_weight).any()
    assert np.exp(lost.log_weight).sum() == pytest.approx(1.0)
    broken = ft.NonlinearGaussianMeasurement(_infinite, 4, [[1.0]])
    with pytest.raises(ValueError, match="'_infinite' returned NaN or infinite values"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.0], measurement_model=broken)))
    nan_model = ft.NonlinearGaussianMeasurement(_half_nan, 4, NOISE)
    with pytest.raises(ValueError, match="NaN"):
        updater.update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 1.0], measurement_model=nan_model)))
    written = ft.ParticleState(prediction.state_vector.copy(), log_weight=prediction.log_weight,
                               timestamp=prediction.timestamp)
    written.state_vector[0, 7] = np.nan  # after construction: named where it is found
    with pytest.raises(ValueError, match=r"particles are not finite \(1 particles, the first "
                                         r"at index 7\)"):
        updater.update(ft.SingleHypothesis(written, ft.Detection([0.0, 1.0])))
    with pytest.raises(ValueError, match="no measurement model"):
        ft.ParticleUpdater().update(ft.SingleHypothesis(prediction, ft.Detection([0.0, 1.0])))
    with pytest.raises(ValueError, match="hypothesis.measurement is None"):
        updater.update(ft.SingleHypothesis(prediction, None))
    with pytest.raises(TypeError, match="hypothesis must be a SingleHypothesis"):
        updater.update(prediction)
    with pytest.raises(TypeError, match="resampler must be a Resampler"):
        ft.ParticleUpdater(sensor, resampler="systematic")
    with pytest.raises(ValueError, match="expects 4 state dimensions"):
        updater.update(ft.SingleHypothesis(ft.ParticleState(np.zeros((3, 5))), ft.Detection([0.0, 1.0])))


def _fasttrack_rmse(seed, n=1000):
    transition, sensor = _models()
    truth = ft.ground_truth(transition, [0, 1, 0, 1], 21, start_time=START, rng=seed)
    measurements = ft.detections(truth, sensor, rng=seed + 1)
    predictor = ft.ParticlePredictor(transition, rng=seed + 2)
    updater = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=seed + 3))
    prior = _prior(n, seed=seed + 4)
    track = ft.Track()
    for measurement in measurements:
        prior = updater.update(ft.SingleHypothesis(predictor.predict(prior, measurement.timestamp),
                                                   measurement))
        track.append(prior)
    return _rmse(track, truth)


def _rmse(track, truth):
    errors = [np.ravel(s.mean)[[0, 2]] - np.ravel(t.state_vector)[[0, 2]] for s, t in zip(track, truth)]
    return float(np.sqrt(np.mean(np.sum(np.square(errors), axis=1))))


def _stonesoup_rmse(seed, n=1000):
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.types.track import Track
    from stonesoup.updater.particle import ParticleUpdater

    transition, sensor, truth, measurements = stonesoup_tutorial(seed)
    samples = np.random.multivariate_normal([0, 1, 0, 1], np.diag([1.5, 0.5, 1.5, 0.5]), size=n)
    prior = ParticleState(StateVectors(samples.T), weight=np.full(n, 1 / n), timestamp=START)
    predictor = ParticlePredictor(transition)
    updater = ParticleUpdater(sensor, SystematicResampler())
    track = Track()
    for measurement in measurements:
        prior = updater.update(SingleHypothesis(predictor.predict(prior, timestamp=measurement.timestamp),
                                                measurement))
        track.append(prior)
    return _rmse(track, truth)


def test_tutorial_rmse_is_statistically_equal_to_stone_soup():
    pytest.importorskip("stonesoup")
    ours = [_fasttrack_rmse(seed) for seed in range(20)]
    theirs = [_stonesoup_rmse(1000 + seed) for seed in range(20)]
    # the same distribution of position RMSE: no detectable difference in mean or spread
    assert stats.mannwhitneyu(ours, theirs).pvalue > 0.01
    assert stats.ks_2samp(ours, theirs).pvalue > 0.01
    assert abs(np.mean(ours) - np.mean(theirs)) < 0.5 * np.std(theirs) + 0.1


def test_user_njit_models_run_through_the_filter():
    transition = ft.NonlinearGaussianTransitionModel(coordinated_turn, np.diag([0.01, 0.01, 0.01, 0.01]), 4)
    sensor = ft.NonlinearGaussianMeasurement(bearing_range_from_50_0, 4, NOISE, angle_components=(0,))
    built_in = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    x = np.random.default_rng(0).normal(0, 10, size=(4, 50))
    np.testing.assert_allclose(sensor.function(x), built_in.function(x), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sensor.logpdf([0.5, 40.0], x), built_in.logpdf([0.5, 40.0], x), rtol=1e-10)
    truth = ft.ground_truth(transition, [0, 1, 0, 1], 15, start_time=0.0, rng=1)
    measurements = ft.detections(truth, sensor, rng=2)
    predictor = ft.ParticlePredictor(transition, rng=3)
    updater = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=4))
    prior = ft.ParticleState(_prior(2000).state_vector, timestamp=0.0)
    track = ft.Track()
    for measurement in measurements:
        prior = updater.update(ft.SingleHypothesis(predictor.predict(prior, measurement.timestamp),
                                                   measurement))
        track.append(prior)
    assert len(track) == 15 and _rmse(track, truth) < 3.0


def test_an_outlying_measurement_leaves_weights_that_sum_to_one():
    transition, sensor = _models()
    prior = _prior(2000)
    prediction = ft.ParticlePredictor(transition, rng=1).predict(prior, START + datetime.timedelta(seconds=1))
    for outlier in (1e6, 1e150):
        update = ft.ParticleUpdater(sensor).update(ft.SingleHypothesis(
            prediction, ft.Detection([0.3, outlier], timestamp=prediction.timestamp)))
        assert np.exp(update.log_weight).sum() == pytest.approx(1.0, rel=1e-12, abs=0)
    with pytest.raises(ValueError, match="every particle has zero likelihood"):
        ft.ParticleUpdater(sensor).update(ft.SingleHypothesis(  # the squares overflow
            prediction, ft.Detection([0.3, 1e200], timestamp=prediction.timestamp)))


def test_the_update_records_the_ess_that_decided_resampling():
    rng = np.random.default_rng(8)
    sensor = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]), translation_offset=[50, 0])
    prediction = ft.ParticleStatePrediction(rng.standard_normal((4, 4000)) + [[0], [1], [0], [1]],
                                            timestamp=1.0)
    hypothesis = ft.SingleHypothesis(prediction, ft.Detection([0.3, 49.5], timestamp=1.0))
    weighed = ft.ParticleUpdater(sensor).update(hypothesis)
    assert weighed.ess == pytest.approx(ft.ess(weighed.log_weight), rel=1e-12)
    assert not weighed.resampled and weighed.ess < 4000
    always = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=1)).update(hypothesis)
    assert always.resampled and always.ess == pytest.approx(weighed.ess, rel=1e-12)
    assert ft.ess(always.log_weight) == pytest.approx(4000)
    never = ft.ParticleUpdater(sensor, ft.ESSResampler(threshold=0.5)).update(hypothesis)
    assert not never.resampled and never.ess == pytest.approx(weighed.ess, rel=1e-12)
    below = ft.ParticleUpdater(sensor, ft.ESSResampler(threshold=weighed.ess * 1.01)).update(
        hypothesis)
    assert below.resampled
