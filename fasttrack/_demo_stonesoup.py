"""The Stone Soup side of the demo: the same scenarios and data through Stone Soup 1.9.
Importing this module fails without Stone Soup (the demo then skips the comparison)."""
import time

import numpy as np
from stonesoup import kernel as ss_kernel
from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing, CartesianToBearingRange
from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                ConstantVelocity)
from stonesoup.predictor.kalman import ExtendedKalmanPredictor
from stonesoup.predictor.kernel import AdaptiveKernelKalmanPredictor
from stonesoup.predictor.particle import ParticlePredictor
from stonesoup.resampler import particle as ss_resampler
from stonesoup.types.array import StateVectors
from stonesoup.types.detection import Detection
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.state import GaussianState, KernelParticleState, ParticleState
from stonesoup.updater.kalman import ExtendedKalmanUpdater
from stonesoup.updater.kernel import AdaptiveKernelKalmanUpdater
from stonesoup.updater.particle import ParticleUpdater

RESAMPLERS = {
    "systematic": ss_resampler.SystematicResampler,
    "stratified": ss_resampler.StratifiedResampler,
    "multinomial": ss_resampler.MultinomialResampler,
    "residual": lambda: ss_resampler.ResidualResampler(
        residual_method=ss_resampler.ResidualMethod.SYSTEMATIC),
}
KERNELS = {"quadratic": lambda: ss_kernel.QuadraticKernel(c=1, ialpha=1),
           "quartic": lambda: ss_kernel.QuarticKernel(c=1, ialpha=1),
           "gaussian": lambda: ss_kernel.GaussianKernel()}


def _per_step(predictor, updater, prior, detections):
    np.random.seed(0)
    start = time.perf_counter()
    for detection in detections:
        prior = updater.update(SingleHypothesis(
            predictor.predict(prior, timestamp=detection.timestamp), detection))
    return (time.perf_counter() - start) / len(detections)


def _detections(scenario, sensor):
    return [Detection(d.state_vector, timestamp=d.timestamp, measurement_model=sensor)
            for d in scenario.detections]


def _bearing_range(scenario):
    sensor = scenario.measurement_model
    return CartesianToBearingRange(ndim_state=4, mapping=sensor.mapping,
                                   noise_covar=sensor.noise_covar,
                                   translation_offset=sensor.translation_offset)


def _constant_velocity(q):
    return CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])


def resample_time(name, state, repeats):
    """Median seconds of Stone Soup's resampler on the same (normalised) particles."""
    log_w = state.log_weight - np.logaddexp.reduce(state.log_weight)
    particles = ParticleState(StateVectors(state.state_vector), log_weight=log_w)
    resampler = RESAMPLERS[name]()
    np.random.seed(0)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        resampler.resample(particles)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def particle_filter_time(scenario):
    """Seconds per step of Stone Soup's particle filter on the scenario's detections."""
    sensor = _bearing_range(scenario)
    n = len(scenario.prior)
    prior = ParticleState(StateVectors(scenario.prior.state_vector), weight=np.full(n, 1 / n),
                          timestamp=scenario.prior.timestamp)
    return _per_step(ParticlePredictor(_constant_velocity(0.05)),
                     ParticleUpdater(sensor, ss_resampler.SystematicResampler()), prior,
                     _detections(scenario, sensor))


def extended_kalman_time(scenario):
    """Seconds per step of Stone Soup's EKF (median of 5 runs)."""
    sensor = _bearing_range(scenario)
    prior = GaussianState(scenario.prior.state_vector, scenario.prior.covar,
                          timestamp=scenario.prior.timestamp)
    detections = _detections(scenario, sensor)
    return float(np.median([_per_step(ExtendedKalmanPredictor(_constant_velocity(0.05)),
                                      ExtendedKalmanUpdater(sensor), prior, detections)
                            for _ in range(5)]))


def akkf_time(scenario, kernel_name):
    """Seconds per step of Stone Soup's AKKF, or the exception it fails with."""
    sensor = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                  noise_covar=scenario.measurement_model.noise_covar)
    m = len(scenario.prior)
    prior = KernelParticleState(state_vector=StateVectors(scenario.prior.state_vector),
                                weight=np.full(m, 1 / m), timestamp=scenario.prior.timestamp)
    kernel = KERNELS[kernel_name]()
    try:
        return _per_step(AdaptiveKernelKalmanPredictor(transition_model=_constant_velocity(1e-4),
                                                       kernel=kernel),
                         AdaptiveKernelKalmanUpdater(measurement_model=sensor, kernel=kernel),
                         prior, _detections(scenario, sensor))
    except Exception as error:  # noqa: BLE001 - shown in the table as a failure
        return error


def tracker_time(scenario, missed_distance, min_points, delete_after_misses,
                 tentative_misses):
    """Seconds per scan of Stone Soup's MultiTargetTracker (GNN with a Mahalanobis
    DistanceHypothesiser, MultiMeasurementInitiator, UpdateTimeStepsDeleter) on the scans of
    a multi-target scenario, with the settings of fasttrack's tracker."""
    import datetime
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetTracker
    from stonesoup.updater.kalman import KalmanUpdater

    start, step = datetime.datetime(2026, 1, 1), datetime.timedelta(
        seconds=scenario.time_interval)
    sensor = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2))
    predictor = KalmanPredictor(_constant_velocity(0.05))
    updater = KalmanUpdater(sensor)
    associator = GNNWith2DAssignment(DistanceHypothesiser(predictor, updater, Mahalanobis(),
                                                          missed_distance=missed_distance))
    initiator = MultiMeasurementInitiator(
        GaussianState(np.zeros((4, 1)), np.diag([0.0, 1.0, 0.0, 1.0])),
        UpdateTimeStepsDeleter(tentative_misses), associator, updater,
        measurement_model=sensor, min_points=min_points)
    scans = [(start + t * step, {Detection(z.reshape(2, 1), timestamp=start + t * step,
                                           measurement_model=sensor) for z in detections})
             for t, detections in enumerate(scenario.detections)]
    tracker = MultiTargetTracker(initiator, UpdateTimeStepsDeleter(delete_after_misses),
                                 iter(scans), associator, updater)
    began = time.perf_counter()
    for _ in tracker:
        pass
    return (time.perf_counter() - began) / len(scans)
