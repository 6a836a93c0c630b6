"""fasttrack.stonesoup: every call that runs Stone Soup's own code says why (a debug record)
and is counted by ``fallbacks``; calls on the fast path leave no trace."""
import datetime
import logging

import numpy as np
import pytest

pytest.importorskip("stonesoup")
from stonesoup.hypothesiser.distance import DistanceHypothesiser as SSDistance  # noqa: E402
from stonesoup.measures import Mahalanobis as SSMahalanobis  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity, RandomWalk)
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402

START = datetime.datetime(2026, 1, 1)
LATER = START + datetime.timedelta(seconds=1)


@pytest.fixture(autouse=True)
def counting(caplog):
    fss.fallbacks(clear=True)
    caplog.set_level(logging.DEBUG, logger="fasttrack.stonesoup")
    yield caplog
    fss.fallbacks(clear=True)


def _prior():
    return GaussianState([[0.0], [1.0], [0.0], [1.0]], np.eye(4), timestamp=START)


def _records(caplog):
    return [r.getMessage() for r in caplog.records if r.name == "fasttrack.stonesoup"]


def test_the_fast_path_records_nothing(counting):
    predictor = fss.KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.1)] * 2))
    updater = fss.KalmanUpdater(LinearGaussian(4, [0, 2], np.eye(2)))
    prediction = predictor.predict(_prior(), timestamp=LATER)
    updater.update(SingleHypothesis(prediction, Detection([[1.0], [1.0]], timestamp=LATER)))
    assert fss.fallbacks() == {} and _records(counting) == []


def test_a_model_fasttrack_does_not_compute_is_named(counting):
    model = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.1), RandomWalk(0.1),
                                                  ConstantVelocity(0.1)])
    prior = GaussianState(np.zeros((5, 1)), np.eye(5), timestamp=START)
    for seconds in (1, 2):
        fss.KalmanPredictor(model).predict(prior, timestamp=START
                                           + datetime.timedelta(seconds=seconds))
    reason = "RandomWalk is not a model fasttrack computes"
    assert fss.fallbacks() == {("KalmanPredictor", "predict", reason): 2}
    assert _records(counting) == [f"KalmanPredictor.predict runs Stone Soup's code: {reason}"] * 2
    assert fss.fallbacks(clear=True) and fss.fallbacks() == {}


def test_particles_of_another_dimension_or_none_get_stone_soups_update(counting):
    from stonesoup.types.array import StateVectors
    from stonesoup.types.prediction import ParticleStatePrediction
    sensor = LinearGaussian(4, [0, 2], np.eye(2))
    prediction = ParticleStatePrediction(StateVectors(np.ones((6, 20))),
                                         log_weight=np.full(20, -np.log(20)), timestamp=LATER)
    hypothesis = SingleHypothesis(prediction, Detection([[1.0], [1.0]], timestamp=LATER))
    for call in (lambda u: u.update(hypothesis), lambda u: u.predict_measurement(prediction)):
        with pytest.raises(ValueError, match="matmul: Input operand 1 has a mismatch"):
            call(fss.ParticleUpdater(sensor))
    reason = "particles of other than the model's 4 dimensions"
    assert fss.fallbacks() == {("ParticleUpdater", "update", reason): 1,
                               ("ParticleUpdater", "predict_measurement", reason): 1}
    none = ParticleStatePrediction(StateVectors(np.ones((4, 0))), log_weight=np.zeros(0),
                                   timestamp=LATER)  # (Stone Soup returns an empty update)
    empty = fss.ParticleUpdater(sensor).update(SingleHypothesis(none, hypothesis.measurement))
    assert empty.state_vector.shape == (4, 0)
    assert fss.fallbacks()[("ParticleUpdater", "update", "no particles")] == 1


def test_keywords_a_mapping_and_a_hypothesiser_setting_are_reasons(counting):
    updater = fss.KalmanUpdater(LinearGaussian(4, [0, 2], np.eye(2)))
    prediction = fss.KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.1)] * 2)).predict(_prior(), timestamp=LATER)
    updater.predict_measurement(prediction, noise=False)
    fss.Mahalanobis(mapping=[0])(updater.predict_measurement(prediction),
                                 Detection([[1.0], [0.0]], timestamp=LATER))
    hypothesiser = fss.DistanceHypothesiser(
        fss.KalmanPredictor(CombinedLinearGaussianTransitionModel([ConstantVelocity(0.1)] * 2)),
        updater, fss.Mahalanobis(), predict_with_measurements=True)
    track = Track([_prior()])
    ours = hypothesiser.hypothesise(track, {Detection([[1.0], [1.0]], timestamp=LATER)}, LATER)
    theirs = SSDistance(hypothesiser.predictor, updater, SSMahalanobis(),
                        predict_with_measurements=True).hypothesise(
        track, {Detection([[1.0], [1.0]], timestamp=LATER)}, LATER)
    assert len(ours) == len(theirs)
    assert fss.fallbacks() == {
        ("KalmanUpdater", "predict_measurement", "keyword arguments noise"): 1,
        ("Mahalanobis", "__call__", "a mapping"): 1,
        ("DistanceHypothesiser", "hypothesise", "predict_with_measurements"): 1}


def test_keywords_the_models_ignore_take_the_fast_path(counting):
    """Stone Soup's built-in models accept and ignore keywords other than ``time_interval``
    and ``noise`` (a ``DistanceHypothesiser`` passes ``measurement`` to its predictor)."""
    from stonesoup.predictor.kalman import KalmanPredictor as SSKalmanPredictor
    model = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.1)] * 2)
    detection = Detection([[1.0], [1.0]], timestamp=LATER)
    ours = fss.KalmanPredictor(model).predict(_prior(), timestamp=LATER, measurement=detection)
    theirs = SSKalmanPredictor(model).predict(_prior(), timestamp=LATER, measurement=detection)
    np.testing.assert_allclose(ours.state_vector, theirs.state_vector, rtol=1e-12)
    np.testing.assert_allclose(ours.covar, theirs.covar, rtol=1e-12)
    assert fss.fallbacks() == {}


def test_a_subclass_gets_its_keywords_through_stone_soups_code(counting):
    """A subclass's own methods may read a keyword (Stone Soup's recursive updaters pass
    ``scale_factor`` to their ``_innovation_covariance``): its calls run Stone Soup's code."""
    class ScaledNoise(fss.KalmanUpdater):
        def _innovation_covariance(self, m_cross_cov, meas_mat, meas_mod, measurement_noise,
                                   scale=1, **kwargs):
            return scale * super()._innovation_covariance(m_cross_cov, meas_mat, meas_mod,
                                                          measurement_noise, **kwargs)

    sensor = LinearGaussian(4, [0, 2], np.eye(2))
    prediction = fss.KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.1)] * 2)).predict(_prior(), timestamp=LATER)
    plain = fss.KalmanUpdater(sensor).predict_measurement(prediction)
    scaled = ScaledNoise(sensor).predict_measurement(prediction, scale=4)
    np.testing.assert_allclose(scaled.covar, 4 * plain.covar, rtol=1e-12)
    assert fss.fallbacks() == {("ScaledNoise", "predict_measurement",
                                "a subclass's own _innovation_covariance"): 1}

    class Keyed(fss.KalmanUpdater):
        """A subclass whose own code might read a keyword."""

    Keyed(sensor).predict_measurement(prediction, scale=4)
    assert fss.fallbacks()[("Keyed", "predict_measurement", "keyword arguments scale")] == 1


def test_the_counts_stay_bounded(monkeypatch, counting):
    from fasttrack.stonesoup import _fallback
    monkeypatch.setattr(_fallback, "MAX_REASONS", 3)
    for k in range(10):
        _fallback.fall_back(object(), "method", f"reason {k}")
    found = fss.fallbacks()
    assert len(found) == 4 and sum(found.values()) == 10
    assert found[("(any)", "(any)", "other reasons, beyond the first 3")] == 7
    assert len(_records(counting)) == 10  # every call is logged


def test_a_subclass_overriding_stone_soups_hooks_runs_stone_soups_code(counting):
    """The fast paths compute Stone Soup's hooks themselves: a subclass that overrides one
    (as Stone Soup's own iterated and recursive updaters and k-d tree associators do) gets
    its own code."""
    class Inflated(fss.KalmanUpdater):
        def _innovation_covariance(self, *args, **kwargs):
            return 2 * super()._innovation_covariance(*args, **kwargs)

    class Ordered(fss.GNNWith2DAssignment):
        def generate_hypotheses(self, tracks, detections, timestamp, **kwargs):
            return super().generate_hypotheses(tracks, detections, timestamp, **kwargs)

    sensor = LinearGaussian(4, [0, 2], np.eye(2))
    predictor = fss.KalmanPredictor(CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(0.1)] * 2))
    prediction = predictor.predict(_prior(), timestamp=LATER)
    plain = fss.KalmanUpdater(sensor).predict_measurement(prediction)
    inflated = Inflated(sensor).predict_measurement(prediction)
    np.testing.assert_allclose(inflated.covar, 2 * plain.covar, rtol=1e-12)
    hypothesiser = fss.DistanceHypothesiser(predictor, fss.KalmanUpdater(sensor),
                                            fss.Mahalanobis(), missed_distance=3)
    Ordered(hypothesiser).associate({Track([_prior()])},
                                    {Detection([[1.0], [1.0]], timestamp=LATER)}, LATER)
    found = fss.fallbacks()
    assert found[("Inflated", "predict_measurement",
                  "a subclass's own _innovation_covariance")] == 1
    assert found[("Ordered", "associate", "a subclass's own generate_hypotheses")] == 1


def test_clear_must_be_a_bool():
    with pytest.raises(TypeError, match="clear must be a bool, got str"):
        fss.fallbacks(clear="yes")
