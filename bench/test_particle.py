"""The particle-filter tutorial (CV 4-D, bearing-range, systematic resampling every step) at
N = 1e4 ... 1e6: fasttrack, the NumPy reference and Stone Soup 1.9.1.

- ``pf-loop`` (the benchmark of record): the tutorial's own loop, as a user writes it: the
  prior drawn by ``multivariate_normal``, a new detection each step, every posterior kept in
  a Track, its mean read each step (21 steps; 5 at N = 1e6), fasttrack against Stone Soup's
  same loop;
- ``pf-step``: one step (predict, update, resample) repeated from the same prior, against
  the NumPy reference and Stone Soup, and the floor of drawing the step's 4N standard
  normals with NumPy's Generator.
"""
import datetime

import numpy as np
import pytest

import fasttrack as ft
from fasttrack.models import (CartesianToBearingRange, CombinedLinearGaussianTransitionModel,
                              ConstantVelocity)

import reference.likelihood
import reference.resample
import reference.weights
from .conftest import run

SIZES = [10**4, 10**5, 10**6]
START = datetime.datetime(2026, 1, 1)
STEP = datetime.timedelta(seconds=1)
NOISE = np.diag([np.radians(0.2), 1.0])
MEASUREMENT = np.array([0.8, 49.0])  # (bearing, range) of a target near the prior


def _prior_samples(n):
    """(4, n) prior samples, drawn as the tutorial draws them (``multivariate_normal``: a
    threaded BLAS product at large N, so the loop meets NumPy's BLAS workers as a user's
    does)."""
    rng = np.random.default_rng(1)
    return rng.multivariate_normal([0.0, 1.0, 0.0, 1.0], np.diag([1.5, 0.5, 1.5, 0.5]), n).T


def _loop_steps(n):
    return 5 if n >= 10**6 else 21


def _truth_and_measurements(steps):
    """The tutorial's truth (CV from (0, 1, 0, 1), q = 0.05) and its bearing-range
    measurements from (50, 0), one a second, drawn once for both libraries."""
    rng = np.random.default_rng(1991)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    truth = ft.ground_truth(transition, [0.0, 1.0, 0.0, 1.0], steps + 1, start_time=START,
                            rng=rng)
    return [d.state_vector for d in ft.detections(truth, sensor, rng=rng)][1:]


@pytest.mark.parametrize("n", SIZES)
def test_fasttrack_loop(benchmark, n):
    benchmark.group = f"pf-loop N={n}"
    steps = _loop_steps(n)
    benchmark.extra_info["steps"] = steps
    measurements = _truth_and_measurements(steps)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    predictor = ft.ParticlePredictor(transition, rng=1)
    updater = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=2))

    def loop():
        prior, track = ft.ParticleState(_prior_samples(n), timestamp=START), ft.Track()
        for k, z in enumerate(measurements, 1):
            detection = ft.Detection(z, timestamp=START + k * STEP, measurement_model=sensor)
            prediction = predictor.predict(prior, timestamp=detection.timestamp)
            post = updater.update(ft.SingleHypothesis(prediction, detection))
            track.append(post)
            prior = track[-1]
            post.mean
        return track

    assert len(benchmark.pedantic(loop, rounds=3 if n >= 10**6 else 7, iterations=1,
                                  warmup_rounds=1)) == steps


@pytest.mark.parametrize("n", SIZES)
def test_stonesoup_loop(benchmark, n):
    pytest.importorskip("stonesoup")
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange as SSBearingRange
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel as SSCombined, ConstantVelocity as SSConstantVelocity)
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.types.track import Track
    from stonesoup.updater.particle import ParticleUpdater

    benchmark.group = f"pf-loop N={n}"
    steps = _loop_steps(n)
    measurements = _truth_and_measurements(steps)
    transition = SSCombined([SSConstantVelocity(0.05), SSConstantVelocity(0.05)])
    sensor = SSBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=NOISE,
                            translation_offset=np.array([[50], [0]]))
    predictor = ParticlePredictor(transition)
    updater = ParticleUpdater(sensor, SystematicResampler())
    np.random.seed(4)

    def loop():
        ParticlePredictor.predict.__wrapped__.cache_clear()  # the memo would pin old rounds
        prior = ParticleState(StateVectors(_prior_samples(n)), weight=np.full(n, 1 / n),
                              timestamp=START)
        track = Track()
        for k, z in enumerate(measurements, 1):
            detection = Detection(z, timestamp=START + k * STEP, measurement_model=sensor)
            prediction = predictor.predict(prior, timestamp=detection.timestamp)
            post = updater.update(SingleHypothesis(prediction, detection))
            track.append(post)
            prior = track[-1]
            post.mean
        return track

    assert len(benchmark.pedantic(loop, rounds=1 if n >= 10**6 else 3, iterations=1)) == steps


@pytest.mark.parametrize("n", SIZES)
def test_fasttrack(benchmark, n):
    benchmark.group = f"pf-step N={n}"
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    predictor = ft.ParticlePredictor(transition, rng=1)
    updater = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=2))
    prior = ft.ParticleState(_prior_samples(n), timestamp=START)
    detection = ft.Detection(MEASUREMENT, timestamp=START + STEP)

    def step():
        prediction = predictor.predict(prior, detection.timestamp)
        return updater.update(ft.SingleHypothesis(prediction, detection))

    assert len(run(benchmark, step, n)) == n


@pytest.mark.parametrize("n", SIZES)
def test_numpy_reference(benchmark, n):
    benchmark.group = f"pf-step N={n}"
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = CartesianToBearingRange(4, (0, 2), NOISE, translation_offset=[50, 0])
    matrix = transition.matrix(1.0)
    noise_root = transition._noise(1.0).root
    whiten, log_norm = sensor._noise.whitening()
    x = _prior_samples(n)
    log_w = np.full(n, -np.log(n))
    rng = np.random.default_rng(3)

    def step():
        predicted = matrix @ x + noise_root @ rng.standard_normal((4, n))
        posterior = np.empty(n)
        reference.likelihood.log_likelihood(1, MEASUREMENT, predicted, np.array([0, 2]),
                                            np.array([50.0, 0]), np.eye(2),
                                            np.array([True, False]), whiten, log_norm, log_w,
                                            posterior)
        posterior -= reference.weights.log_sum_exp(posterior, posterior.max())
        idx = reference.resample.draw(posterior, n, "systematic", False, 7)
        return predicted[:, idx], x[:, idx]

    assert run(benchmark, step, n)[0].shape == (4, n)


@pytest.mark.parametrize("n", SIZES)
def test_stonesoup(benchmark, n):
    pytest.importorskip("stonesoup")
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange as SSBearingRange
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel as SSCombined, ConstantVelocity as SSConstantVelocity)
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater

    benchmark.group = f"pf-step N={n}"
    transition = SSCombined([SSConstantVelocity(0.05), SSConstantVelocity(0.05)])
    sensor = SSBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=NOISE,
                            translation_offset=np.array([[50], [0]]))
    predictor = ParticlePredictor(transition)
    updater = ParticleUpdater(sensor, SystematicResampler())
    prior = ParticleState(StateVectors(_prior_samples(n)), weight=np.full(n, 1 / n),
                          timestamp=START)
    detection = Detection(MEASUREMENT.reshape(2, 1), timestamp=START + STEP,
                          measurement_model=sensor)
    np.random.seed(4)

    def step():
        ParticlePredictor.predict.__wrapped__.cache_clear()  # time the work, not the memo
        prediction = predictor.predict(prior, timestamp=detection.timestamp)
        return updater.update(SingleHypothesis(prediction, detection))

    assert len(run(benchmark, step, n, slow=True)) == n


@pytest.mark.parametrize("n", SIZES)
def test_normals_floor(benchmark, n):
    """The floor: NumPy's Generator drawing the step's 4N standard normals."""
    benchmark.group = "pf-floor"
    benchmark.extra_info["n"] = n
    rng = np.random.default_rng(5)
    run(benchmark, lambda: rng.standard_normal((4, n)), n)
