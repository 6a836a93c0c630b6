"""The seed tutorials' scenarios, built with fasttrack: models, a simulated truth, its
detections and the filter's prior; and a multi-target scenario on a grid."""
import datetime
from dataclasses import dataclass

import numpy as np

from . import _validate
from . import random as _random
from .models import (Cartesian2DToBearing, CartesianToBearingRange,
                     CombinedLinearGaussianTransitionModel, ConstantVelocity, LinearGaussian,
                     LinearGaussianTransitionModel)
from .simulate import (MAX_RATE, MultiTargetScenario, _observe, _rate, check_storable,
                       detections, ground_truth, multi_target)
from .types import GaussianMixture, GaussianState, KernelParticleState, ParticleState

START = datetime.datetime(2026, 1, 1)


@dataclass
class Scenario:
    """A tracking scenario: ``truth`` observed by ``detections`` (which carry the
    measurement model), and the ``prior`` a filter starts from."""

    transition_model: object
    measurement_model: object
    truth: object
    detections: list
    prior: object


#: The most targets :func:`grid_targets` places (as many as the clutter a scan may expect).
MAX_TARGETS = int(MAX_RATE)


def _generator(seed):
    """The generator a scenario's ``seed`` stands for: None, an int >= 0, a
    ``numpy.random.SeedSequence``, a ``numpy.random.Generator`` (used as it is) or a
    ``RandomState``; a TypeError or ValueError naming ``seed`` for anything else."""
    if not isinstance(seed, np.random.SeedSequence):
        _random.check_rng(seed, "seed")
    return np.random.default_rng(seed)


def _particles(n_particles):
    """``n_particles``, an int >= 1 whose (4, N) prior and its draws fit in memory."""
    n_particles = _validate.count(n_particles, "n_particles")
    _validate.storable(n_particles, 3 * 4 * 8, "n_particles")
    return n_particles


def _diagonal_gaussian(rng, mean, std, n):
    """(d, n) draws of N(mean, diag(std)^2), elementwise: a matrix product here would wake
    NumPy's OpenBLAS threads, which then spin for about 0.1 s on the cores the filter's
    parallel kernels need."""
    noise = rng.standard_normal((len(mean), n))
    return np.asarray(mean)[:, None] + np.asarray(std)[:, None] * noise


def _bearing_range_scenario(rng, steps):
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = CartesianToBearingRange(4, (0, 2), np.diag([np.radians(0.2), 1.0]),
                                     translation_offset=[50.0, 0.0])
    truth = ground_truth(transition, [0.0, 1.0, 0.0, 1.0], steps, start_time=START, rng=rng)
    return transition, sensor, truth, detections(truth, sensor, rng=rng)


def particle_filter_tutorial(n_particles=1000, seed=1991, steps=21):
    """The particle-filter tutorial: a nearly-constant-velocity target (q = 0.05) in 2-D,
    state (x, vx, y, vy), seen by a bearing-range sensor at (50, 0) with noise
    diag(0.2 deg in rad, 1 m^2) once a second; the prior is ``n_particles`` samples of
    N((0, 1, 0, 1), diag(1.5, 0.5, 1.5, 0.5)) at the first detection's time.

    Parameters
    ----------
    n_particles : int
        Particles of the prior, >= 1.
    seed : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Fixes the truth, the detections and the prior samples (an int seed is >= 0).
    steps : int
        States of the truth and detections, >= 1.

    Returns
    -------
    Scenario
    """
    n_particles = _particles(n_particles)
    steps = _validate.count(steps, "steps")
    rng = _generator(seed)
    transition, sensor, truth, measured = _bearing_range_scenario(rng, steps)
    samples = _diagonal_gaussian(rng, [0.0, 1.0, 0.0, 1.0], np.sqrt([1.5, 0.5, 1.5, 0.5]),
                                 n_particles)
    prior = ParticleState(samples, timestamp=START)
    return Scenario(transition, sensor, truth, measured, prior)


def extended_kalman_tutorial(seed=1991, steps=21):
    """The extended-Kalman-filter tutorial: the target and sensor of
    :func:`particle_filter_tutorial`, and the prior N((0, 1, 0, 1), diag(1.5, 0.5, 1.5, 0.5))
    as a :class:`~fasttrack.GaussianState`.

    Parameters
    ----------
    seed : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Fixes the truth and the detections (an int seed is >= 0).
    steps : int
        States of the truth and detections, >= 1.

    Returns
    -------
    Scenario
    """
    steps = _validate.count(steps, "steps")
    rng = _generator(seed)
    transition, sensor, truth, measured = _bearing_range_scenario(rng, steps)
    prior = GaussianState([0.0, 1.0, 0.0, 1.0], np.diag([1.5, 0.5, 1.5, 0.5]), timestamp=START)
    return Scenario(transition, sensor, truth, measured, prior)


def adaptive_kernel_tutorial(n_particles=30, seed=50, steps=30):
    """The adaptive-kernel-Kalman-filter tutorial: a nearly-constant-velocity target
    (q = 1e-4) from (-0.3, 0.001, 0.7, -0.055), seen once a second by a bearing-only sensor
    at the origin with noise 0.005 rad (the first detection at the start time); the prior is
    ``n_particles`` samples of N(truth[0], diag(0.1, 0.005, 0.1, 0.01)^2) with weights 1/M
    and kernel covariance I/M.

    Parameters
    ----------
    n_particles : int
        Particles of the prior, >= 1.
    seed : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Fixes the truth, the detections and the prior samples (an int seed is >= 0).
    steps : int
        States of the truth and detections, >= 1.

    Returns
    -------
    Scenario
    """
    n_particles = _particles(n_particles)
    steps = _validate.count(steps, "steps")
    rng = _generator(seed)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-4)] * 2)
    sensor = Cartesian2DToBearing(4, (0, 2), np.array([[0.005 ** 2]]))
    start = [-0.3, 0.001, 0.7, -0.055]
    truth = ground_truth(transition, start, steps, start_time=START, rng=rng)
    measured = detections(truth, sensor, rng=rng)
    samples = _diagonal_gaussian(rng, start, [0.1, 0.005, 0.1, 0.01], n_particles)
    prior = KernelParticleState(samples, timestamp=START)
    return Scenario(transition, sensor, truth, measured, prior)


def grid_targets(n_targets=20, steps=50, spacing=20.0, clutter_rate=20.0, prob_detect=0.9,
                 seed=None):
    """A multi-target scenario: ``n_targets`` nearly-constant-velocity targets (q = 0.05)
    starting on a jittered square grid of ``spacing`` metres with N(0, 1) m/s velocities,
    seen once a second by a position sensor (R = I m^2) with ``prob_detect``, and
    Poisson(``clutter_rate``) clutter per scan over the grid plus a 50 m margin.

    Parameters
    ----------
    n_targets : int
        Targets, in [1, 1e7] (the grid, and with it the clutter region, needs a target).
    steps : int
        Scans, >= 1.
    spacing : float
        Grid spacing, metres, >= 0 and finite; the grid's area must be a finite float64.
    clutter_rate : float
        Expected clutter measurements per scan, in [0, 1e7].
    prob_detect : float
        Probability of detection, in [0, 1].
    seed : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Fixes the targets, detections and clutter (an int seed is >= 0).

    Returns
    -------
    fasttrack.simulate.MultiTargetScenario
    """
    n_targets = _validate.count(n_targets, "n_targets", maximum=MAX_TARGETS)
    spacing = _validate.non_negative(spacing, "spacing")
    rng = _generator(seed)
    side = int(np.ceil(np.sqrt(n_targets)))
    width = (side - 1) * spacing + 100.0
    if not np.isfinite(width * width):  # Python floats: overflow gives inf
        raise ValueError(f"spacing {spacing:g} is too large for {n_targets} targets: the "
                         f"clutter region over the grid ({side - 1} spacings plus a 100 m "
                         f"margin a side) has an area beyond float64")
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)
    positions = grid[:n_targets] * spacing + rng.normal(0, 1, (n_targets, 2))
    velocities = rng.normal(0, 1, (n_targets, 2))
    initial = np.c_[positions[:, 0], velocities[:, 0], positions[:, 1], velocities[:, 1]]
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    sensor = LinearGaussian(4, (0, 2), np.eye(2))
    edge = (side - 1) * spacing
    return multi_target(transition, sensor, initial, steps, [[-50, -50], [edge + 50] * 2],
                        prob_detect=prob_detect, clutter_rate=clutter_rate, rng=rng)


#: Vo and Ma's linear scenario: each target's first state, and the scans (from 1) of its
#: birth and of its last state.
_VO_STARTS = np.array([[0.0, 0.0, 0.0, -10.0], [400.0, -10.0, -600.0, 5.0],
                       [-800.0, 20.0, -200.0, -5.0], [400.0, -7.0, -600.0, -4.0],
                       [400.0, -2.5, -600.0, 10.0], [0.0, 7.5, 0.0, -5.0],
                       [-800.0, 12.0, -200.0, 7.0], [-200.0, 15.0, 800.0, -10.0],
                       [-800.0, 3.0, -200.0, 15.0], [-200.0, -3.0, 800.0, -15.0],
                       [0.0, -20.0, 0.0, -15.0], [-200.0, 15.0, 800.0, -5.0]])
_VO_BIRTHS = np.array([1, 1, 1, 20, 20, 20, 40, 40, 60, 60, 80, 80])
_VO_DEATHS = np.array([70, 100, 70, 100, 100, 100, 100, 100, 100, 100, 100, 100])


def vo_linear(clutter_rate=60.0, seed=None):
    """Vo and Ma's linear Gaussian scenario (the GM-PHD paper's, as their MATLAB toolbox
    generates it): 100 scans a second apart, 12 targets in all, at most 10 at once (born at
    scans 1, 1, 1, 20, 20, 20, 40, 40, 60, 60, 80, 80 at or near four places; two die after
    scan 70), moving at constant velocity without process noise; a position sensor with
    R = 100 I m^2 and P_D = 0.98; Poisson(``clutter_rate``) clutter uniform over
    [-1000, 1000]^2 m. The transition model is the toolbox's (F of constant velocity,
    Q = 25 B B^T, B = [[1/2, 0], [1, 0], [0, 1/2], [0, 1]]). :func:`vo_linear_birth` is its
    birth intensity.

    Parameters
    ----------
    clutter_rate : float
        Expected clutter measurements a scan, in [0, 1e7] (the toolbox's PHD demo: 60, its
        GLMB demo: 30).
    seed : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Fixes the detections and clutter.

    Returns
    -------
    fasttrack.simulate.MultiTargetScenario
    """
    clutter_rate = _rate(clutter_rate, "clutter_rate")
    check_storable(100, clutter_rate + 10, 4, 2, f"100 scans of clutter_rate={clutter_rate:g}")
    rng = _generator(seed)
    f = np.kron(np.eye(2), [[1.0, 1.0], [0.0, 1.0]])
    b = np.kron(np.eye(2), [[0.5], [1.0]])
    transition = LinearGaussianTransitionModel(f, 25.0 * b @ b.T)
    sensor = LinearGaussian(4, (0, 2), 100.0 * np.eye(2))
    region = np.array([[-1000.0, -1000.0], [1000.0, 1000.0]])
    out = {"truths": [], "truth_ids": [], "detections": [], "origins": []}
    for scan in range(1, 101):
        ids = np.flatnonzero((_VO_BIRTHS <= scan) & (scan <= _VO_DEATHS))
        steps = scan - _VO_BIRTHS[ids] + 1  # the toolbox records F x0 at the birth scan
        states = _VO_STARTS[ids].copy()
        states[:, 0] += steps * states[:, 1]
        states[:, 2] += steps * states[:, 3]
        _observe(out, scan - 1, states, ids, sensor, 0.98, clutter_rate, region, rng)
    return MultiTargetScenario(transition, sensor, time_interval=1.0, region=region,
                               clutter_density=clutter_rate / 4e6, **out)


def vo_linear_birth():
    """The birth intensity of :func:`vo_linear`: four components of weight 0.03 at
    (0, 0), (400, -600), (-800, -200) and (-200, 800) m, at rest, covariance
    diag(10, 10, 10, 10)^2.

    Returns
    -------
    fasttrack.types.GaussianMixture
    """
    means = np.array([[0.0, 0, 0, 0], [400.0, 0, -600, 0], [-800.0, 0, -200, 0],
                      [-200.0, 0, 800, 0]])
    return GaussianMixture(means, np.broadcast_to(np.eye(4) * 100.0, (4, 4, 4)),
                           np.log(np.full(4, 0.03)))


#: The manoeuvres of :func:`manoeuvring_target`: (steps, turn rate in rad/s; 0 for straight).
MANOEUVRES = ((150, 0.0), (200, -0.01634), (40, 0.0), (165, 0.0232), (45, 0.0))


@dataclass
class ManoeuvringScenario:
    """One target that flies straight and turns, seen by a position sensor every second.

    Attributes
    ----------
    truths : (T, 4) float64 ndarray
        The states (x, vx, y, vy) at each scan, m and m/s.
    measurements : (T, 2) float64 ndarray
        The positions measured, m.
    turn_rates : (T,) float64 ndarray
        The turn rate flown into each scan, rad/s (0: straight).
    measurement_model : LinearGaussian
    time_interval : float
        Seconds between scans.
    """

    truths: np.ndarray
    measurements: np.ndarray
    turn_rates: np.ndarray
    measurement_model: object
    time_interval: float = 1.0


def manoeuvring_target(seed=None):
    """The multiple-model scenario of Stone Soup's multiple-model tutorial (its pull
    request 1257): 600 scans a second apart of one target starting at (3700, -30, 1700,
    -30), straight for 150 s, turning at -0.01634 rad/s for 200 s, straight for 40 s, at
    +0.0232 rad/s for 165 s and straight for 45 s (:data:`MANOEUVRES`), with a process
    noise of q = 0.01 m^2/s^3 per axis; positions measured with R = diag(0.725, 0.7025) m^2.

    Parameters
    ----------
    seed : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Fixes the process and measurement noise.

    Returns
    -------
    ManoeuvringScenario
    """
    from .models import KnownTurnRate
    rng = _generator(seed)
    sensor = LinearGaussian(4, (0, 2), np.diag([0.725, 0.7025]))
    state = np.array([3700.0, -30.0, 1700.0, -30.0])
    truths, rates = [], []
    for steps, rate in MANOEUVRES:
        model = KnownTurnRate([0.01, 0.01], rate)
        f, q = model.matrix(1.0), model.covar(1.0)
        noise = np.linalg.cholesky(q)
        for _ in range(steps):
            state = f @ state + noise @ rng.standard_normal(4)
            truths.append(state)
            rates.append(rate)
    truths = np.array(truths)
    measurements = truths[:, [0, 2]] + rng.standard_normal((len(truths), 2)) \
        * np.sqrt([0.725, 0.7025])
    return ManoeuvringScenario(truths, measurements, np.array(rates), sensor)
