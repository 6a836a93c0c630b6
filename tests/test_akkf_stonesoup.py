"""The adaptive kernel Kalman filter against Stone Soup 1.9.1: the same numbers on the same
inputs and proposals, and a position RMSE no worse on the tutorial scenario."""
import datetime

import numpy as np
import pytest
from scipy import stats

import fasttrack as ft
from fasttrack.metrics import position_rmse

pytest.importorskip("stonesoup")
from scipy.stats import multivariate_normal  # noqa: E402
from stonesoup import kernel as ss_kernel  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kernel import AdaptiveKernelKalmanPredictor  # noqa: E402
from stonesoup.types.array import StateVectors  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.state import KernelParticleState  # noqa: E402
from stonesoup.updater.kernel import AdaptiveKernelKalmanUpdater  # noqa: E402

START = datetime.datetime(2026, 1, 1)
KERNELS = {  # Stone Soup's and fasttrack's kernel of each name
    "quadratic": (lambda: ss_kernel.QuadraticKernel(c=1, ialpha=1),
                  ft.QuadraticKernel(c=1, ialpha=1)),
    "quartic": (lambda: ss_kernel.QuarticKernel(c=1, ialpha=1), ft.QuarticKernel(c=1, ialpha=1)),
    "gaussian": (lambda: ss_kernel.GaussianKernel(), ft.GaussianKernel(variance=10.0)),
}


def _scenario(seed, m, steps=30):
    """The tutorial as Stone Soup builds it: truth, bearing detections, prior samples."""
    np.random.seed(seed)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-4)] * 2)
    truth = GroundTruthPath([GroundTruthState([-0.3, 0.001, 0.7, -0.055], timestamp=START)])
    for k in range(1, steps):
        truth.append(GroundTruthState(
            transition.function(truth[k - 1], noise=True,
                                time_interval=datetime.timedelta(seconds=1)),
            timestamp=START + datetime.timedelta(seconds=k)))
    sensor = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                  noise_covar=np.array([[0.005 ** 2]]))
    detections = [Detection(sensor.function(s, noise=True), timestamp=s.timestamp,
                            measurement_model=sensor) for s in truth]
    samples = multivariate_normal.rvs(np.squeeze(truth[0].state_vector),
                                      np.diag([0.1, 0.005, 0.1, 0.01]) ** 2, size=m)
    return transition, sensor, truth, detections, np.array(samples.T)


def _ft_models():
    return (ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(1e-4)] * 2),
            ft.Cartesian2DToBearing(4, (0, 2), np.array([[0.005 ** 2]])))


def _ft_detection(detection, model=None):
    return ft.Detection(np.asarray(detection.state_vector, dtype=float),
                        timestamp=detection.timestamp, measurement_model=model)


def _assert_close(actual, expected, rtol=1e-6):
    expected = np.asarray(expected, dtype=float)
    np.testing.assert_allclose(actual, expected, atol=rtol * np.abs(expected).max())


@pytest.mark.parametrize("name", ["quadratic", "quartic"])
def test_same_numbers_as_stone_soup_over_five_cycles(name):
    """Each predict and update from the same prior and Stone Soup's own proposals."""
    ss_make, kernel = KERNELS[name]
    transition, sensor, truth, detections, samples = _scenario(50, 30)
    predictor = AdaptiveKernelKalmanPredictor(transition_model=transition, kernel=ss_make())
    updater = AdaptiveKernelKalmanUpdater(measurement_model=sensor, kernel=ss_make())
    ft_transition, ft_sensor = _ft_models()
    ft_predictor = ft.AdaptiveKernelKalmanPredictor(ft_transition, kernel)
    ft_updater = ft.AdaptiveKernelKalmanUpdater(ft_sensor, kernel, rng=0)
    prior = KernelParticleState(state_vector=StateVectors(samples), weight=np.full(30, 1 / 30),
                                timestamp=START)
    ft_prior = ft.KernelParticleState(samples, timestamp=START)
    for k, detection in enumerate(detections[:5]):
        prediction = predictor.predict(prior, timestamp=detection.timestamp)
        proposal = None if k == 0 else np.asarray(prior.proposal, dtype=float)
        ft_prediction = ft_predictor.predict(ft_prior, detection.timestamp, proposal=proposal)
        _assert_close(ft_prediction.state_vector, prediction.state_vector, 1e-14)
        _assert_close(ft_prediction.weight, prediction.weight)
        _assert_close(ft_prediction.kernel_covar, prediction.kernel_covar)
        prior = updater.update(SingleHypothesis(prediction, detection))
        ft_prior = ft_updater.update(ft.SingleHypothesis(ft_prediction,
                                                         _ft_detection(detection)))
        _assert_close(ft_prior.weight, prior.weight)
        _assert_close(ft_prior.kernel_covar, prior.kernel_covar)
        _assert_close(ft_prior.mean, prior.mean)
        assert ft_prior.timestamp == prior.timestamp


def test_gaussian_kernel_same_numbers_as_stone_soup_with_a_linear_sensor():
    """Stone Soup's Gaussian kernel fails on bearings; with a position sensor it runs."""
    ss_make, kernel = KERNELS["gaussian"]
    transition, _, _, _, samples = _scenario(51, 40)
    noise = np.diag([1e-4, 1e-4])
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=noise)
    prior = KernelParticleState(state_vector=StateVectors(samples), weight=np.full(40, 1 / 40),
                                timestamp=START)
    when = START + datetime.timedelta(seconds=1)
    prediction = AdaptiveKernelKalmanPredictor(transition_model=transition,
                                               kernel=ss_make()).predict(prior, timestamp=when)
    update = AdaptiveKernelKalmanUpdater(measurement_model=sensor, kernel=ss_make()).update(
        SingleHypothesis(prediction, Detection(np.array([[-0.28], [0.64]]), timestamp=when)))
    ft_transition, _ = _ft_models()
    ft_prediction = ft.AdaptiveKernelKalmanPredictor(ft_transition, kernel).predict(
        ft.KernelParticleState(samples, timestamp=START), when)
    ft_update = ft.AdaptiveKernelKalmanUpdater(ft.LinearGaussian(4, (0, 2), noise), kernel,
                                               rng=0).update(
        ft.SingleHypothesis(ft_prediction, ft.Detection([-0.28, 0.64], timestamp=when)))
    _assert_close(ft_prediction.weight, prediction.weight)
    _assert_close(ft_prediction.kernel_covar, prediction.kernel_covar)
    _assert_close(ft_update.weight, update.weight)
    _assert_close(ft_update.kernel_covar, update.kernel_covar)


def _rmse_pair(name, seed, m):
    """Position RMSE of Stone Soup (None if it fails) and fasttrack on the same data."""
    ss_make, kernel = KERNELS[name]
    transition, sensor, truth, detections, samples = _scenario(seed, m)
    predictor = AdaptiveKernelKalmanPredictor(transition_model=transition, kernel=ss_make())
    updater = AdaptiveKernelKalmanUpdater(measurement_model=sensor, kernel=ss_make())
    prior = KernelParticleState(state_vector=StateVectors(samples), weight=np.full(m, 1 / m),
                                timestamp=START)
    track = []
    try:
        for detection in detections:
            prior = updater.update(SingleHypothesis(
                predictor.predict(prior, timestamp=detection.timestamp), detection))
            track.append(prior)
        theirs = position_rmse(track, truth)
    except ValueError:  # Stone Soup's "not positive semidefinite" failure
        theirs = None
    ft_transition, ft_sensor = _ft_models()
    ft_predictor = ft.AdaptiveKernelKalmanPredictor(ft_transition, kernel)
    ft_updater = ft.AdaptiveKernelKalmanUpdater(ft_sensor, kernel, rng=seed)
    prior = ft.KernelParticleState(samples, timestamp=START)
    track = []
    for detection in detections:
        prior = ft_updater.update(ft.SingleHypothesis(
            ft_predictor.predict(prior, detection.timestamp), _ft_detection(detection)))
        track.append(prior)
    return theirs, position_rmse(track, truth)


@pytest.mark.slow
@pytest.mark.parametrize("m", [30, 300])
@pytest.mark.parametrize("name", ["quadratic", "quartic"])
def test_tutorial_rmse_not_worse_than_stone_soup(name, m):
    """Over 10 seeds, paired on the same truth, detections and prior: the mean RMSE
    difference is not significantly positive (one-sided paired t-test at 1%)."""
    pairs = [_rmse_pair(name, seed, m) for seed in range(10)]
    differences = np.array([ours - theirs for theirs, ours in pairs if theirs is not None])
    assert differences.size >= 5
    t = differences.mean() / (differences.std(ddof=1) / np.sqrt(differences.size))
    assert t < stats.t.ppf(0.99, differences.size - 1)
