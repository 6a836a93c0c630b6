"""Compile (or load from the on-disk cache) the kernels of each filter family, by running tiny
instances of it: once with every kernel's serial build (small work), once with its parallel
build (large work). ``pip install .`` runs every family while it builds the wheel
(:func:`ship`), so that nothing a user calls afterwards compiles."""
import concurrent.futures
import contextlib
import multiprocessing
import os
import pathlib
import shutil
import tempfile
import time

import numpy as np

from . import association
from . import metrics
from .batch import BatchExtendedKalmanFilter, BatchUnscentedKalmanFilter
from .core import kalman
from .core.mixture import segment_logsumexp
from .core.particle import gather
from .core.resample import (ess, multinomial, normalise, resampling_points, residual, stratified,
                            systematic)
from .filtering import run_filter
from .imm import BatchIMMFilter, IMMPredictor, IMMUpdater
from .kernel import GaussianKernel, QuadraticKernel
from .mixturereducer import GaussianMixtureReducer
from .models.measurement import LinearGaussian
from .models.kinematic import ConstantTurn, ConstantVelocity
from .models.transition import (CombinedLinearGaussianTransitionModel,
                                LinearGaussianTransitionModel)
from .phd import CPHDTracker, PHDTracker
from .predictor import (AdaptiveKernelKalmanPredictor, ExtendedKalmanPredictor, KalmanPredictor,
                        ParticlePredictor, UnscentedKalmanPredictor)
from .resampler import (ESSResampler, MultinomialResampler, ResidualResampler, StratifiedResampler,
                        SystematicResampler)
from .scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial, grid_targets,
                        particle_filter_tutorial)
from .simulate import detections, ground_truth
from .smoother import ExtendedKalmanSmoother, KalmanSmoother, UnscentedKalmanSmoother, ffbs
from .tracker import MultiTargetTracker
from .types.gaussian import Detection, GaussianState, WeightedGaussianState
from .types.kernel import KernelParticleState
from .types.mixture import GaussianMixture
from .types.particle import ParticleState
from .types.tracks import SingleHypothesis
from .updater import (AdaptiveKernelKalmanUpdater, ExtendedKalmanUpdater, KalmanUpdater,
                      ParticleUpdater, UnscentedKalmanUpdater)


def _resample():
    particles = ParticleState(np.zeros((2, 16)), log_weight=np.linspace(-3.0, 0.0, 16),
                              parent=ParticleState(np.ones((2, 16))))
    for resampler in (SystematicResampler(0), StratifiedResampler(0),
                      MultinomialResampler(0), ResidualResampler(rng=0),
                      ResidualResampler(residual_method="systematic", rng=0), ESSResampler()):
        for nparts in (None, 8, 32):
            resampled = resampler.resample(particles, nparts)
            _ = resampled.state_vector, resampled.parent.state_vector
    for method in ("systematic", "stratified", "multinomial"):
        resampling_points(8, method, rng=0)
    for draw in (systematic, stratified, multinomial, residual):  # int64 indices
        for nparts in (None, 8, 32):
            draw(particles.log_weight, nparts, rng=0)
    residual(particles.log_weight, rng=0, method="systematic")
    gather(particles.state_vector, np.arange(4))  # the drop-in resamplers' int64 indices
    ess(particles.log_weight)
    normalise(particles.log_weight)
    _ = particles.mean, particles.covar


def _step(predictor, updater, scenario):
    detection = scenario.detections[1]
    prediction = predictor.predict(scenario.prior, detection.timestamp)
    return updater.update(SingleHypothesis(prediction, detection))


def _particle():
    scenario = particle_filter_tutorial(64, steps=2)
    posterior = _step(ParticlePredictor(scenario.transition_model, rng=0),
                      ParticleUpdater(scenario.measurement_model, SystematicResampler(rng=0)),
                      scenario)
    _ = posterior.mean, posterior.covar
    truth = ground_truth(scenario.transition_model, [0, 1, 0, 1], 2, rng=0)
    detections(truth, scenario.measurement_model, rng=0)
    metrics.position_rmse([posterior], truth[1:])


def _kalman():
    scenario = extended_kalman_tutorial(steps=2)
    for jacobian in ("analytic", "forward", "central"):
        _step(ExtendedKalmanPredictor(scenario.transition_model),
              ExtendedKalmanUpdater(scenario.measurement_model, jacobian=jacobian), scenario)
    detection = Detection([0.0, 1.0], timestamp=scenario.detections[1].timestamp,
                          measurement_model=LinearGaussian(4, (0, 2), np.eye(2)))
    prediction = KalmanPredictor(scenario.transition_model).predict(scenario.prior,
                                                                    detection.timestamp)
    KalmanUpdater(detection.measurement_model).update(
        SingleHypothesis(prediction, detection))
    _stack(BatchExtendedKalmanFilter(scenario.transition_model, scenario.measurement_model))
    turn = ConstantTurn([0.1, 0.1], 1e-4)  # the kernels that call a model's function
    ExtendedKalmanPredictor(turn).predict(GaussianState(np.zeros(5), np.eye(5), timestamp=0.0),
                                          1.0)
    means, covars = np.zeros((2, 5)), np.broadcast_to(np.eye(5), (2, 5, 5)).copy()
    kalman.stack_predict(turn, LinearGaussian(5, (0, 2), np.eye(2)), np.ones(2), means, covars)
    kalman.linearise(turn, 1.0, means)


def _unscented():
    scenario = extended_kalman_tutorial(steps=2)
    _step(UnscentedKalmanPredictor(scenario.transition_model),
          UnscentedKalmanUpdater(scenario.measurement_model), scenario)
    _stack(BatchUnscentedKalmanFilter(scenario.transition_model, scenario.measurement_model))


def _stack(batch):
    """A step, a prediction and an update of a stack of 4 filters."""
    means = np.tile([0.0, 1.0, 0.0, 1.0], (4, 1))
    covars = np.broadcast_to(np.eye(4), (4, 4, 4)).copy()
    measurements = np.tile([0.0, 49.0], (4, 1))
    batch.step(means, covars, measurements, 1.0)
    predicted = batch.predict(means, covars, 1.0)
    batch.update(predicted[0], predicted[1], measurements)


def _smooth():
    scenario = extended_kalman_tutorial(steps=3)
    for predictor, updater, smoother in (
            (ExtendedKalmanPredictor, ExtendedKalmanUpdater, ExtendedKalmanSmoother),
            (UnscentedKalmanPredictor, UnscentedKalmanUpdater,
             UnscentedKalmanSmoother)):
        track = run_filter(predictor(scenario.transition_model),
                           updater(scenario.measurement_model), scenario.prior,
                           scenario.detections[1:])
        smoother(scenario.transition_model).smooth(track)
    cv = ConstantVelocity(0.05)
    for model in (cv, LinearGaussianTransitionModel(np.eye(3), np.eye(3)),
                  CombinedLinearGaussianTransitionModel([cv] * 2),
                  CombinedLinearGaussianTransitionModel([cv] * 3)):
        d = model.ndim_state
        KalmanSmoother(model).smooth_arrays(np.zeros((3, d)),
                                            np.broadcast_to(np.eye(d), (3, d, d)), 1.0)
    scenario = particle_filter_tutorial(64, steps=3)
    track = run_filter(ParticlePredictor(scenario.transition_model, rng=0),
                       ParticleUpdater(scenario.measurement_model, SystematicResampler(rng=0)),
                       scenario.prior, scenario.detections[1:])
    for method in ("rejection", "exact"):
        ffbs(track, scenario.transition_model, 4, rng=0, method=method)


def _akkf():
    scenario = adaptive_kernel_tutorial(8, steps=2)
    for kernel in (QuadraticKernel(), GaussianKernel(), GaussianKernel(variance=1.0)):
        posterior = _step(AdaptiveKernelKalmanPredictor(scenario.transition_model, kernel),
                          AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel,
                                                      rng=0), scenario)
        kernel(scenario.prior)
        _ = posterior.mean, posterior.covar
    KernelParticleState(scenario.prior.state_vector, kernel_covar=np.eye(8))


def _gating():
    scenario = grid_targets(n_targets=4, steps=4, clutter_rate=4.0, seed=0)
    for method in ("nn", "gnn"):
        tracker = MultiTargetTracker(scenario.transition_model, scenario.measurement_model,
                                     np.zeros(4), np.eye(4), association=method)
        tracker.run(scenario.detections)


def _assign():
    rng = np.random.default_rng(0)
    truths = [rng.normal(size=(n, 2)) for n in (4, 3, 4)]
    estimates = [rng.normal(size=(n, 2)) for n in (3, 4, 0)]
    metrics.gospa(truths[0], estimates[0], 10.0)
    metrics.gospa_over_time(truths, estimates, 10.0, switching_penalty=1.0,
                            truth_ids=[np.arange(len(x)) for x in truths],
                            estimate_ids=[np.arange(len(x)) for x in estimates])
    metrics.ospa(truths[0], estimates[0], 10.0)
    metrics.ospa_over_time(truths, estimates, 10.0)
    costs = np.arange(6.0).reshape(2, 3)
    association.assign2d(costs)
    association.assign2d_batch([costs, costs.T])
    association.gnn_assign(costs, np.ones(2))


def _mixture():
    mixture = GaussianMixture(np.zeros((3, 2)), np.broadcast_to(np.eye(2), (3, 2, 2)),
                              np.log([0.2, 0.3, 0.5]), [0, 1, 0])
    mixture.reduce()
    segment_logsumexp(mixture.log_weights, np.array([0, 2, 3]))
    for mode in ("textbook", "stonesoup"):
        GaussianMixtureReducer(mode=mode).reduce(mixture)
    scenario = grid_targets(n_targets=2, steps=2, clutter_rate=2.0, seed=0)
    birth = GaussianMixture(scenario.truths[0], np.broadcast_to(np.eye(4), (2, 4, 4)))
    for gate in (None, 9.0):
        PHDTracker(scenario.transition_model, scenario.measurement_model, birth, 0.9, 0.99,
                   scenario.clutter_density, gate).run(scenario.detections)
        CPHDTracker(scenario.transition_model, scenario.measurement_model, birth, 0.9, 0.99,
                    scenario.clutter_density, 2.0, 8, gate).run(scenario.detections)


def _imm():
    models = [CombinedLinearGaussianTransitionModel([ConstantVelocity(q)] * 2)
              for q in (0.1, 1.0)]
    sensor, matrix = LinearGaussian(4, (0, 2), np.eye(2)), [[0.9, 0.1], [0.1, 0.9]]
    imm = BatchIMMFilter(models, sensor, matrix)
    means = np.zeros((2, 2, 4))
    covars = np.broadcast_to(np.eye(4), (2, 2, 4, 4)).copy()
    means, covars, probs = imm.step(means, covars, np.full((2, 2), 0.5), np.zeros((2, 2)), 1.0)
    imm.smooth(np.stack([means] * 2, axis=1), np.stack([covars] * 2, axis=1),
               np.stack([probs] * 2, axis=1), 1.0)
    axis = BatchIMMFilter([ConstantVelocity(0.1), ConstantVelocity(1.0)],
                          LinearGaussian(2, (0,), np.eye(1)), matrix)  # the smoother for any d
    axis.smooth(np.zeros((3, 2, 2)), np.broadcast_to(np.eye(2), (3, 2, 2, 2)),
                np.full((3, 2), 0.5), 1.0)
    prior = GaussianMixture([WeightedGaussianState(np.zeros(4), np.eye(4), weight=0.5,
                                                   timestamp=0.0)] * 2)
    prediction = IMMPredictor([KalmanPredictor(m) for m in models], matrix).predict(prior, 1.0)
    IMMUpdater([KalmanUpdater(sensor)] * 2, matrix).update(
        SingleHypothesis(prediction, Detection(np.zeros(2), timestamp=1.0,
                                               measurement_model=sensor)))


def _jpda():
    weights = association.pda_weights(np.zeros((2, 2)), np.broadcast_to(np.eye(2), (2, 2, 2)),
                                      np.array([[0.1, 0.0], [0.0, 0.2]]),
                                      clutter_spatial_density=1e-3)
    association.jpda_marginals(weights)
    association.jpda_marginals([weights, weights])


#: Families, slowest to compile first (so that a pool balances them).
FAMILIES = {"kalman": _kalman, "unscented": _unscented, "imm": _imm, "resample": _resample,
            "smooth": _smooth, "akkf": _akkf, "mixture": _mixture, "gating": _gating,
            "jpda": _jpda, "assign": _assign, "particle": _particle}

#: Families compiled one after the other in the same worker process: they share kernels
#: called only from other kernels, which have no cache entries of their own (their code is
#: linked into each caller's), so another process would compile them again.
TOGETHER = (("kalman", "unscented"), ("mixture", "gating"))


@contextlib.contextmanager
def _parallel_builds():
    """Every kernel that chooses between its serial and parallel builds runs the parallel one
    meanwhile, whatever the work."""
    from . import _jit
    threaded = [k for k in _jit.kernels() if isinstance(k, _jit.ThreadedKernel)]
    limits = [k.serial_below for k in threaded]
    for kernel in threaded:
        kernel.serial_below = 0
    try:
        yield
    finally:
        for kernel, limit in zip(threaded, limits):
            kernel.serial_below = limit


def _run(name):
    """Compile (or load) one family's serial and parallel builds; returns its name and the
    seconds it took."""
    from . import _jit
    _jit.kernels_from_now()
    start = time.perf_counter()
    FAMILIES[name]()
    with _parallel_builds():
        FAMILIES[name]()
    return name, time.perf_counter() - start


def _run_each(names):
    """:func:`_run` for each of ``names`` in turn: a list of (name, seconds)."""
    return [_run(name) for name in names]


def _tasks(names):
    """``names`` as the worker processes' tasks (lists of names), a group of
    :data:`TOGETHER` in one task."""
    tasks = {}
    for name in names:
        group = next((g for g in TOGETHER if name in g), (name,))
        tasks.setdefault(next(g for g in group if g in names), []).append(name)
    return list(tasks.values())


def warmup(families=None, processes=1, report=None, load=True):
    """Compile (or load from the on-disk cache) the kernels of ``families`` now rather than
    on first use.

    After ``pip install .`` they are compiled already (see the README); this is for an
    editable install, a changed numba or NumPy, or a container image.

    Parameters
    ----------
    families : iterable of str, optional
        Some of the family words of :data:`FAMILIES`: 'kalman', 'unscented', 'akkf',
        'smooth', 'gating', 'assign', 'jpda', 'mixture', 'imm', 'resample', 'particle'
        (default: all).
    processes : int
        With more than one, compile in that many worker processes at once, which fill the
        shared cache, then load from it: on a first run, up to ``processes`` times faster.
    report : callable, optional
        Called as ``report(family, seconds)`` as each family is ready (in the workers'
        order of completion, or, with one process, as this process compiles it).
    load : bool
        Whether this process loads the families too. False only fills the cache, in at
        least one worker process (e.g. the cache their ``FASTTRACK_CACHE_DIR`` names).

    Returns
    -------
    float
        Seconds taken.
    """
    from ._validate import count, flag
    processes = count(processes, "processes")
    load = flag(load, "load")
    if report is not None and not callable(report):
        raise TypeError(f"report must be callable (report(family, seconds)) or None, got "
                        f"{type(report).__name__}")
    if isinstance(families, str):
        raise TypeError(f"families must be an iterable of family names, not one string "
                        f"({families!r}: give [{families!r}])")
    names = list(FAMILIES) if families is None else list(families)
    unknown = sorted(set(names) - set(FAMILIES))
    if unknown:
        raise ValueError(f"unknown families {unknown}; valid: {', '.join(FAMILIES)}")
    start = time.perf_counter()
    tasks = _tasks(names)
    if tasks and (not load or (processes > 1 and len(tasks) > 1)):
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(min(processes, len(tasks)),
                                                    mp_context=context) as pool:
            for done in concurrent.futures.as_completed([pool.submit(_run_each, task)
                                                         for task in tasks]):
                for name, seconds in done.result():
                    if report is not None:
                        report(name, seconds)
    if load:
        for name in names:
            name, seconds = _run(name)
            if report is not None and processes == 1:
                report(name, seconds)
    return time.perf_counter() - start


def ship(destination, processes=None, report=None):
    """Compile every family, from nothing, in ``processes`` worker processes (default: one a
    core) into ``destination/<tag>`` with its manifest: the kernels a wheel carries
    (``fasttrack._jit.cache``). Run by the build backend in a process that imports the
    package being built.

    Returns
    -------
    pathlib.Path
        The folder written.
    """
    from ._jit import cache
    if cache.shipped_enabled():
        raise RuntimeError(f"ship must run with {cache.SHIPPED_ENVIRONMENT}=0, so that it "
                           f"compiles every kernel instead of loading shipped ones")
    folder = pathlib.Path(destination) / cache.tag()
    with tempfile.TemporaryDirectory() as scratch:
        os.environ[cache.ENVIRONMENT] = scratch  # the workers' per-user cache
        warmup(processes=processes or os.cpu_count() or 1, report=report, load=False)
        compiled, = pathlib.Path(scratch).iterdir()
        folder.parent.mkdir(parents=True, exist_ok=True)
        shutil.copytree(compiled, folder, ignore=shutil.ignore_patterns(".lock"))
    cache.compress(folder)
    cache.write_manifest(folder)
    return folder
