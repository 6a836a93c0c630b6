"""Compile (or load from the on-disk cache) the kernels of each filter family, by running a
tiny instance of it."""
import concurrent.futures
import multiprocessing
import time

import numpy as np


def _resamplers():
    import fasttrack as ft
    particles = ft.ParticleState(np.zeros((2, 16)), log_weight=np.linspace(-3.0, 0.0, 16))
    for resampler in (ft.SystematicResampler(0), ft.StratifiedResampler(0),
                      ft.MultinomialResampler(0), ft.ResidualResampler(rng=0)):
        resampler.resample(particles)
    ft.ess(particles.log_weight)
    ft.normalise(particles.log_weight)
    _ = particles.mean


def _step(predictor, updater, scenario):
    import fasttrack as ft
    detection = scenario.detections[1]
    prediction = predictor.predict(scenario.prior, detection.timestamp)
    return updater.update(ft.SingleHypothesis(prediction, detection))


def _particle_filter():
    import fasttrack as ft
    from fasttrack.scenarios import particle_filter_tutorial
    scenario = particle_filter_tutorial(64, steps=2)
    _step(ft.ParticlePredictor(scenario.transition_model, rng=0),
          ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=0)), scenario)


def _kalman():
    import fasttrack as ft
    from fasttrack.scenarios import extended_kalman_tutorial
    scenario = extended_kalman_tutorial(steps=2)
    _step(ft.ExtendedKalmanPredictor(scenario.transition_model),
          ft.ExtendedKalmanUpdater(scenario.measurement_model), scenario)


def _unscented():
    import fasttrack as ft
    from fasttrack.scenarios import extended_kalman_tutorial
    scenario = extended_kalman_tutorial(steps=2)
    _step(ft.UnscentedKalmanPredictor(scenario.transition_model),
          ft.UnscentedKalmanUpdater(scenario.measurement_model), scenario)


def _batch():
    import fasttrack as ft
    from fasttrack.scenarios import extended_kalman_tutorial
    scenario = extended_kalman_tutorial(steps=2)
    means = np.tile([0.0, 1.0, 0.0, 1.0], (4, 1))
    covars = np.broadcast_to(np.eye(4), (4, 4, 4)).copy()
    measurements = np.tile([0.0, 49.0], (4, 1))
    ft.BatchExtendedKalmanFilter(scenario.transition_model, scenario.measurement_model).step(
        means, covars, measurements, 1.0)
    unscented = ft.BatchUnscentedKalmanFilter(scenario.transition_model,
                                              scenario.measurement_model)
    unscented.step(means, covars, measurements, 1.0)
    predicted = unscented.predict(means, covars, 1.0)
    unscented.update(predicted[0], predicted[1], measurements)


def _smoothers():
    import fasttrack as ft
    from fasttrack.scenarios import extended_kalman_tutorial, particle_filter_tutorial
    scenario = extended_kalman_tutorial(steps=3)
    track = ft.run_filter(ft.ExtendedKalmanPredictor(scenario.transition_model),
                          ft.ExtendedKalmanUpdater(scenario.measurement_model), scenario.prior,
                          scenario.detections[1:])
    smoother = ft.KalmanSmoother(scenario.transition_model)
    smoother.smooth(track)
    smoother.smooth_arrays(np.zeros((3, 4)), np.broadcast_to(np.eye(4), (3, 4, 4)), 1.0)
    scenario = particle_filter_tutorial(64, steps=3)
    track = ft.run_filter(ft.ParticlePredictor(scenario.transition_model, rng=0),
                          ft.ParticleUpdater(scenario.measurement_model,
                                             ft.SystematicResampler(rng=0)),
                          scenario.prior, scenario.detections[1:])
    ft.ffbs(track, scenario.transition_model, 4, rng=0)


def _adaptive_kernel():
    import fasttrack as ft
    from fasttrack.scenarios import adaptive_kernel_tutorial
    scenario = adaptive_kernel_tutorial(8, steps=2)
    for kernel in (ft.QuadraticKernel(), ft.GaussianKernel()):
        _step(ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, kernel),
              ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, kernel, rng=0),
              scenario)
        kernel(scenario.prior)


def _multi_target():
    import fasttrack as ft
    from fasttrack import association
    from fasttrack.metrics import gospa_over_time
    from fasttrack.scenarios import grid_targets
    scenario = grid_targets(n_targets=4, steps=4, clutter_rate=4.0, seed=0)
    tracker = ft.MultiTargetTracker(scenario.transition_model, scenario.measurement_model,
                                    np.zeros(4), np.eye(4), association="nn")
    tracks = tracker.run(scenario.detections)
    tracker = ft.MultiTargetTracker(scenario.transition_model, scenario.measurement_model,
                                    np.zeros(4), np.eye(4))
    tracks = tracker.run(scenario.detections)
    gospa_over_time([x[:, [0, 2]] for x in scenario.truths],
                    [t.means[:, [0, 2]] for t in tracks], 10.0)
    weights = association.pda_weights(np.zeros((2, 2)), np.broadcast_to(np.eye(2), (2, 2, 2)),
                                      np.array([[0.1, 0.0], [0.0, 0.2]]),
                                      clutter_spatial_density=1e-3)
    association.jpda_marginals(weights)
    association.jpda_marginals([weights, weights])


#: Families, slowest to compile first (so that a pool balances them).
FAMILIES = {"batch": _batch, "kalman": _kalman, "unscented": _unscented,
            "adaptive_kernel": _adaptive_kernel,
            "multi_target": _multi_target, "smoothers": _smoothers, "resamplers": _resamplers,
            "particle_filter": _particle_filter}


def _run(name):
    """Compile (or load) one family; returns its name and the seconds it took."""
    start = time.perf_counter()
    FAMILIES[name]()
    return name, time.perf_counter() - start


def warmup(families=None, processes=1, report=None, load=True):
    """Compile (or load from the on-disk cache) the kernels of ``families`` now rather than
    on first use.

    Parameters
    ----------
    families : iterable of str, optional
        Some of 'resamplers', 'particle_filter', 'kalman', 'unscented', 'batch',
        'adaptive_kernel', 'multi_target', 'smoothers' (default: all).
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
    from ._validate import count
    processes = count(processes, "processes")
    names = list(FAMILIES) if families is None else list(families)
    unknown = sorted(set(names) - set(FAMILIES))
    if unknown:
        raise ValueError(f"unknown families {unknown}; valid: {', '.join(FAMILIES)}")
    start = time.perf_counter()
    if names and (not load or (processes > 1 and len(names) > 1)):
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(min(processes, len(names)),
                                                    mp_context=context) as pool:
            for done in concurrent.futures.as_completed([pool.submit(_run, n) for n in names]):
                if report is not None:
                    report(*done.result())
    if load:
        for name in names:
            name, seconds = _run(name)
            if report is not None and processes == 1:
                report(name, seconds)
    return time.perf_counter() - start
