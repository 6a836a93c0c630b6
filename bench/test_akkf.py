"""The adaptive kernel Kalman filter of the AKKF tutorial (CV 4-D, bearing-only): one
predict + update step from the same mid-track state, fasttrack against Stone Soup 1.9.1 and
the dense NumPy reference (the contract's formulas with solves) in the same run, at
M = 30, 300, 1000 with each of the tutorial's kernels."""
import numpy as np
import pytest

import fasttrack as ft
import reference.akkf
from fasttrack.scenarios import adaptive_kernel_tutorial

SIZES = [30, 300, 1000]
KERNELS = {"quadratic": (2, {"c": 1, "ialpha": 1}), "quartic": (4, {"c": 1, "ialpha": 1}),
           "gaussian": (None, {})}
WARM_STEPS = 5  # the timed step starts from the update after this many detections


def _rounds(m, slow):
    if slow:
        return 1 if m >= 1000 else (5 if m >= 300 else 30)
    return 20 if m >= 1000 else 200


def _ft_kernel(name):
    power, options = KERNELS[name]
    return ft.GaussianKernel(**options) if power is None else ft.PolynomialKernel(power,
                                                                                 **options)


def _fasttrack_setup(name, m):
    scenario = adaptive_kernel_tutorial(m, seed=50)
    kernel = _ft_kernel(name)
    predictor = ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, kernel)
    updater = ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel, rng=1)
    prior = scenario.prior
    for detection in scenario.detections[:WARM_STEPS]:
        prior = updater.update(ft.SingleHypothesis(
            predictor.predict(prior, detection.timestamp), detection))
    return scenario, predictor, updater, prior, scenario.detections[WARM_STEPS]


@pytest.mark.parametrize("m", SIZES)
@pytest.mark.parametrize("name", KERNELS)
def test_fasttrack_akkf(benchmark, name, m):
    benchmark.group = f"akkf-{name} N={m}"
    _, predictor, updater, prior, detection = _fasttrack_setup(name, m)

    def step():
        return updater.update(ft.SingleHypothesis(predictor.predict(prior, detection.timestamp),
                                                  detection))

    benchmark.pedantic(step, rounds=_rounds(m, False), iterations=1, warmup_rounds=2)


@pytest.mark.parametrize("m", SIZES)
@pytest.mark.parametrize("name", KERNELS)
def test_numpy_reference_akkf(benchmark, name, m):
    benchmark.group = f"akkf-{name} N={m}"
    scenario, _, updater, prior, detection = _fasttrack_setup(name, m)
    kernel = _ft_kernel(name)
    kind, params = kernel._kind, kernel._parameters()
    sensor = scenario.measurement_model
    angles_x, angles_z = ft.Kernel.angle_mask(4), sensor.spec.angles
    s = prior.kernel_covar
    z = detection.state_vector

    def step():
        x = scenario.transition_model.function(prior.proposal, time_interval=1.0)
        w, s_pred = reference.akkf.predict_dense(kind, params, angles_x, prior.proposal,
                                                 prior.state_vector, prior.weight, s, 1e-3)
        y = sensor.function(x)
        w, s_post = reference.akkf.update_dense(kind, params, angles_z, y, z, w, s_pred, 1e-3)
        out = np.empty_like(x)
        reference.akkf.proposal_dense(x, w, s_post, 0, out)
        return out

    benchmark.pedantic(step, rounds=_rounds(m, True), iterations=1, warmup_rounds=0)


@pytest.mark.parametrize("m", SIZES)
@pytest.mark.parametrize("name", KERNELS)
def test_stonesoup_akkf(benchmark, name, m):
    pytest.importorskip("stonesoup")
    if name == "gaussian":
        pytest.skip("Stone Soup's GaussianKernel fails on bearing measurements (TypeError)")
    from stonesoup import kernel as ss_kernel
    from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing
    from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                    ConstantVelocity)
    from stonesoup.predictor.kernel import AdaptiveKernelKalmanPredictor
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import KernelParticleState
    from stonesoup.updater.kernel import AdaptiveKernelKalmanUpdater

    benchmark.group = f"akkf-{name} N={m}"
    scenario = adaptive_kernel_tutorial(m, seed=50)
    power, options = KERNELS[name]
    kernel = ss_kernel.QuadraticKernel(**options) if power == 2 else \
        ss_kernel.QuarticKernel(**options)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-4)] * 2)
    sensor = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                  noise_covar=np.array([[0.005 ** 2]]))
    detections = [Detection(d.state_vector, timestamp=d.timestamp, measurement_model=sensor)
                  for d in scenario.detections[:WARM_STEPS + 1]]
    predictor = AdaptiveKernelKalmanPredictor(transition_model=transition, kernel=kernel)
    updater = AdaptiveKernelKalmanUpdater(measurement_model=sensor, kernel=kernel)
    prior = KernelParticleState(state_vector=StateVectors(scenario.prior.state_vector),
                                weight=np.full(m, 1 / m), timestamp=scenario.prior.timestamp)
    np.random.seed(1)
    for detection in detections[:WARM_STEPS]:
        prior = updater.update(SingleHypothesis(
            predictor.predict(prior, timestamp=detection.timestamp), detection))
    detection = detections[WARM_STEPS]

    def step():
        AdaptiveKernelKalmanPredictor.predict.__wrapped__.cache_clear()  # time the work
        return updater.update(SingleHypothesis(
            predictor.predict(prior, timestamp=detection.timestamp), detection))

    benchmark.pedantic(step, rounds=_rounds(m, True), iterations=1,
                       warmup_rounds=0 if m >= 1000 else 1)
