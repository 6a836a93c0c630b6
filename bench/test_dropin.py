"""The seed tutorials' filter loops through fasttrack.stonesoup (Stone Soup objects in and
out) against pure Stone Soup and against fasttrack's native API, in the same run: the particle
filter (21 steps) at N = 1000 and 100,000, the extended Kalman filter (21 steps), and the
AKKF (30 steps) at M = 30 and 3000; and, drop-in against Stone Soup, one unscented Kalman
step (predict and update) of the extended Kalman tutorial's bearing-range scenario and the
Kalman smoother over a 1000-step track. Stone Soup's AKKF is not run at M = 3000: its two SVD
pseudo-inverses of 3000 x 3000 matrices a step would take minutes per loop.

Stone Soup memoises ``predict`` (up to 128 predictions, with their particles and, for the
AKKF, M x M kernel covariances); each round starts with an empty memo so that rounds do not
pile up memory."""
import datetime

import numpy as np
import pytest

import fasttrack as ft

pytest.importorskip("stonesoup")
from stonesoup import kernel as ss_kernel  # noqa: E402
from stonesoup.models.measurement.nonlinear import (  # noqa: E402
    Cartesian2DToBearing, CartesianToBearingRange)
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kalman import (ExtendedKalmanPredictor,  # noqa: E402
                                       UnscentedKalmanPredictor)
from stonesoup.predictor.kernel import AdaptiveKernelKalmanPredictor  # noqa: E402
from stonesoup.predictor.particle import ParticlePredictor  # noqa: E402
from stonesoup.resampler.particle import SystematicResampler  # noqa: E402
from stonesoup.types.array import StateVectors  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.state import GaussianState, KernelParticleState, ParticleState  # noqa: E402
from stonesoup.smoother.kalman import KalmanSmoother  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.updater.kalman import ExtendedKalmanUpdater, UnscentedKalmanUpdater  # noqa
from stonesoup.updater.kernel import AdaptiveKernelKalmanUpdater  # noqa: E402
from stonesoup.updater.particle import ParticleUpdater  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402
from fasttrack.scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial,  # noqa: E402
                                 particle_filter_tutorial)

START = datetime.datetime(2026, 1, 1)


def _rounds(implementation, n):
    if implementation == "stonesoup":
        return 3 if n >= 10**5 else 7
    return 5 if n >= 10**5 else 15


def _loop(predictor, updater, prior, detections, hypothesis):
    cached = getattr(type(predictor).predict, "__wrapped__", None)
    if cached is not None:  # Stone Soup's memo would keep every round's states alive
        cached.cache_clear()
    for detection in detections:
        prior = updater.update(hypothesis(predictor.predict(prior, timestamp=detection.timestamp),
                                          detection))
    return prior


def _ss_detections(scenario, sensor):
    return [Detection(d.state_vector, timestamp=d.timestamp, measurement_model=sensor)
            for d in scenario.detections]


def _bearing_range(scenario):
    sensor = scenario.measurement_model
    return CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=sensor.noise_covar,
                                   translation_offset=np.array([[50], [0]]))


def _time(benchmark, implementation, n, run):
    benchmark.pedantic(run, rounds=_rounds(implementation, n), iterations=1, warmup_rounds=1)


@pytest.mark.parametrize("n", [1000, 100_000])
@pytest.mark.parametrize("implementation", ["dropin", "stonesoup", "fasttrack"])
def test_pf_loop(benchmark, implementation, n):
    benchmark.group = f"dropin-pf N={n}"
    scenario = particle_filter_tutorial(n)
    if implementation == "fasttrack":
        predictor = ft.ParticlePredictor(scenario.transition_model, rng=1)
        updater = ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=2))
        args = (scenario.prior, scenario.detections, ft.SingleHypothesis)
    else:
        classes = (fss.ParticlePredictor, fss.ParticleUpdater, fss.SystematicResampler) \
            if implementation == "dropin" else (ParticlePredictor, ParticleUpdater,
                                                SystematicResampler)
        transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
        sensor = _bearing_range(scenario)
        predictor, updater = classes[0](transition), classes[1](sensor, classes[2]())
        prior = ParticleState(StateVectors(scenario.prior.state_vector), weight=np.full(n, 1 / n),
                              timestamp=START)
        args = (prior, _ss_detections(scenario, sensor), SingleHypothesis)
    _time(benchmark, implementation, n, lambda: _loop(predictor, updater, *args))


@pytest.mark.parametrize("implementation", ["dropin", "stonesoup", "fasttrack"])
def test_ekf_loop(benchmark, implementation):
    benchmark.group = "dropin-ekf N=1"
    scenario = extended_kalman_tutorial()
    if implementation == "fasttrack":
        predictor = ft.ExtendedKalmanPredictor(scenario.transition_model)
        updater = ft.ExtendedKalmanUpdater(scenario.measurement_model, jacobian="forward")
        args = (scenario.prior, scenario.detections, ft.SingleHypothesis)
    else:
        classes = (fss.ExtendedKalmanPredictor, fss.ExtendedKalmanUpdater) \
            if implementation == "dropin" else (ExtendedKalmanPredictor, ExtendedKalmanUpdater)
        transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
        sensor = _bearing_range(scenario)
        predictor, updater = classes[0](transition), classes[1](sensor)
        prior = GaussianState(scenario.prior.state_vector, scenario.prior.covar, timestamp=START)
        args = (prior, _ss_detections(scenario, sensor), SingleHypothesis)
    _time(benchmark, implementation, 1, lambda: _loop(predictor, updater, *args))


@pytest.mark.parametrize("m", [30, 3000])
@pytest.mark.parametrize("implementation", ["dropin", "stonesoup", "fasttrack"])
def test_akkf_loop(benchmark, implementation, m):
    if implementation == "stonesoup" and m > 300:
        pytest.skip("Stone Soup's AKKF at M = 3000 takes minutes per loop")
    benchmark.group = f"dropin-akkf N={m}"
    scenario = adaptive_kernel_tutorial(m)
    if implementation == "fasttrack":
        kernel = ft.QuadraticKernel(c=1, ialpha=1)
        predictor = ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, kernel)
        updater = ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel, rng=1)
        args = (scenario.prior, scenario.detections, ft.SingleHypothesis)
    else:
        dropin = implementation == "dropin"
        kernel = (fss.QuadraticKernel if dropin else ss_kernel.QuadraticKernel)(c=1, ialpha=1)
        transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-4)] * 2)
        sensor = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                      noise_covar=np.array([[0.005 ** 2]]))
        predictor = (fss.AdaptiveKernelKalmanPredictor if dropin else
                     AdaptiveKernelKalmanPredictor)(transition_model=transition, kernel=kernel)
        updater = (fss.AdaptiveKernelKalmanUpdater if dropin else AdaptiveKernelKalmanUpdater)(
            measurement_model=sensor, kernel=kernel)
        prior = KernelParticleState(state_vector=StateVectors(scenario.prior.state_vector),
                                    weight=np.full(m, 1 / m), timestamp=START)
        args = (prior, _ss_detections(scenario, sensor), SingleHypothesis)
    _time(benchmark, implementation, m * 100, lambda: _loop(predictor, updater, *args))


@pytest.mark.parametrize("implementation", ["dropin", "stonesoup"])
def test_ukf_step(benchmark, implementation):
    benchmark.group = "dropin-ukf step"
    scenario = extended_kalman_tutorial()
    classes = (fss.UnscentedKalmanPredictor, fss.UnscentedKalmanUpdater) \
        if implementation == "dropin" else (UnscentedKalmanPredictor, UnscentedKalmanUpdater)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = _bearing_range(scenario)
    predictor, updater = classes[0](transition), classes[1](sensor)
    prior = GaussianState(scenario.prior.state_vector, scenario.prior.covar, timestamp=START)
    detection = _ss_detections(scenario, sensor)[1]
    memos = (type(predictor).predict.__wrapped__, type(updater).predict_measurement)

    def step():
        for memo in memos:  # a new prediction each round, as in a filter loop
            memo.cache_clear()
        prediction = predictor.predict(prior, timestamp=detection.timestamp)
        return updater.update(SingleHypothesis(prediction, detection))

    benchmark(step)


@pytest.fixture(scope="module")
def filtered_track():
    """1000 steps of the extended Kalman tutorial's scenario filtered by Stone Soup's EKF
    (every 50th detection missed: a prediction in the track)."""
    scenario = extended_kalman_tutorial()
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = _bearing_range(scenario)
    predictor, updater = ExtendedKalmanPredictor(transition), ExtendedKalmanUpdater(sensor)
    np.random.seed(3)
    truth = GaussianState(scenario.prior.state_vector, scenario.prior.covar, timestamp=START)
    track = Track([truth])
    state = truth
    for k in range(1, 1000):
        timestamp = START + datetime.timedelta(seconds=k)
        truth = GaussianState(transition.function(truth, noise=True,
                                                  time_interval=timestamp - truth.timestamp),
                              truth.covar, timestamp=timestamp)
        state = predictor.predict(state, timestamp=timestamp)
        if k % 50:
            detection = Detection(sensor.function(truth, noise=True), timestamp=timestamp,
                                  measurement_model=sensor)
            state = updater.update(SingleHypothesis(state, detection))
        track.append(state)
    return transition, track


@pytest.mark.parametrize("implementation", ["dropin", "stonesoup"])
def test_smooth_track(benchmark, implementation, filtered_track):
    benchmark.group = "dropin-smooth T=1000"
    transition, track = filtered_track
    smoother = (fss.KalmanSmoother if implementation == "dropin" else KalmanSmoother)(transition)
    _time(benchmark, implementation, 1, lambda: smoother.smooth(track))
