"""The unscented Kalman filter of the EKF tutorial (CV 4-D, bearing-range): one predict +
update step through the class API, fasttrack against Stone Soup 1.9.1 in the same run."""
import datetime

import numpy as np
import pytest

import fasttrack as ft

START = datetime.datetime(2026, 1, 1)
STEP = datetime.timedelta(seconds=1)
NOISE = np.diag([np.radians(0.2), 1.0])
PRIOR_MEAN = np.array([0.0, 1.0, 0.0, 1.0])
PRIOR_COVAR = np.diag([1.5, 0.5, 1.5, 0.5])
MEASUREMENT = np.array([[3.12], [49.0]])  # near bearing pi: the sigma points straddle the wrap


def test_ukf_step_fasttrack(benchmark):
    benchmark.group = "ukf-step N=1"
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    predictor = ft.UnscentedKalmanPredictor(transition)
    updater = ft.UnscentedKalmanUpdater(sensor)
    prior = ft.GaussianState(PRIOR_MEAN, PRIOR_COVAR, timestamp=START)
    detection = ft.Detection(MEASUREMENT, timestamp=START + STEP)

    def step():
        return updater.update(ft.SingleHypothesis(predictor.predict(prior, detection.timestamp),
                                                  detection))

    benchmark.pedantic(step, rounds=2000, iterations=10, warmup_rounds=10)


def test_ukf_step_stonesoup(benchmark):
    pytest.importorskip("stonesoup")
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kalman import UnscentedKalmanPredictor
    from stonesoup.types.angle import Bearing
    from stonesoup.types.array import StateVector
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import UnscentedKalmanUpdater

    benchmark.group = "ukf-step N=1"
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05),
                                                        ConstantVelocity(0.05)])
    sensor = CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=NOISE,
                                     translation_offset=np.array([[50], [0]]))
    predictor, updater = UnscentedKalmanPredictor(transition), UnscentedKalmanUpdater(sensor)
    prior = GaussianState(PRIOR_MEAN.reshape(-1, 1), PRIOR_COVAR, timestamp=START)
    detection = Detection(StateVector([Bearing(MEASUREMENT[0, 0]), MEASUREMENT[1, 0]]),
                          timestamp=START + STEP, measurement_model=sensor)

    def step():
        UnscentedKalmanPredictor.predict.__wrapped__.cache_clear()  # time the work, not the memo
        prediction = predictor.predict(prior, timestamp=detection.timestamp)
        return updater.update(SingleHypothesis(prediction, detection))

    benchmark.pedantic(step, rounds=200, iterations=5, warmup_rounds=2)


@pytest.mark.parametrize("k", [10**4])
def test_ukf_batch_fasttrack(benchmark, k):
    """10^4 unscented filters, each with its own interval and measurement, one predict +
    update (the EKF batch's workload)."""
    benchmark.group = f"ukf-batch N={k}"
    transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
    sensor = ft.CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    batch = ft.BatchUnscentedKalmanFilter(transition, sensor)
    rng = np.random.default_rng(0)
    means = PRIOR_MEAN + rng.normal(0, 1, (k, 4))
    covars = np.broadcast_to(PRIOR_COVAR, (k, 4, 4)).copy()
    measurements = np.column_stack([rng.normal(0.0, 0.1, k), rng.normal(49.0, 1.0, k)])
    intervals = rng.uniform(0.5, 1.5, k)
    benchmark.extra_info["filters"] = k
    benchmark.pedantic(lambda: batch.step(means, covars, measurements, intervals), rounds=50,
                       iterations=1, warmup_rounds=1)
