"""The demo behind ``python -m fasttrack demo``: the tutorial scenarios tracked with fasttrack,
timed against the NumPy reference (from a source checkout) and Stone Soup (when installed) in
the same run."""
import importlib.util
import pathlib
import time

import numpy as np

import fasttrack as ft
from fasttrack.metrics import position_rmse
from fasttrack.scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial,
                                 particle_filter_tutorial)

TUTORIAL_WEIGHTS = np.array([1, 5, 1.5, 0.5, 2]) / 10


def _median_time(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _reference_module():
    """tests/reference.py of the source checkout, if this is one (else None)."""
    for root in (pathlib.Path.cwd(), pathlib.Path(__file__).resolve().parents[1]):
        path = root / "tests" / "reference.py"
        if path.is_file():
            spec = importlib.util.spec_from_file_location("fasttrack_reference", path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            return module
    return None


def _stonesoup_resamplers():
    try:
        from stonesoup.resampler import particle as ss
    except ImportError:
        return None
    return {
        "systematic": ss.SystematicResampler(),
        "stratified": ss.StratifiedResampler(),
        "multinomial": ss.MultinomialResampler(),
        "residual": ss.ResidualResampler(residual_method=ss.ResidualMethod.SYSTEMATIC),
    }


def _resamplers():
    return {
        "systematic": (ft.SystematicResampler(rng=1), "systematic", False),
        "stratified": (ft.StratifiedResampler(rng=1), "stratified", False),
        "multinomial": (ft.MultinomialResampler(rng=1), "multinomial", False),
        "residual": (ft.ResidualResampler("systematic", rng=1), "systematic", True),
    }


def _counts(values):
    return " ".join(f"{v:5.3g}" for v in values)


def tutorial_examples(draws):
    """Offspring counts of each resampler on the tutorial's five weights."""
    print("Resampler tutorial: weights", TUTORIAL_WEIGHTS.tolist(), "N = 5")
    print(f"{'resampler':<14}{'one draw':<31}{f'mean of {draws} draws':<31}")
    particles = ft.ParticleState(np.arange(5.0)[None], weight=TUTORIAL_WEIGHTS)
    for name, (resampler, _, _) in _resamplers().items():
        counts = np.zeros(5)
        for i in range(draws):
            drawn = resampler.resample(particles).state_vector[0].astype(int)
            counts += np.bincount(drawn, minlength=5)
            if i == 0:
                first = np.bincount(drawn, minlength=5)
        print(f"{name:<14}{_counts(first):<31}{_counts(counts / draws):<31}")
    print(f"{'expected N w':<45}{_counts(5 * TUTORIAL_WEIGHTS)}")
    ess = ft.ess(particles.log_weight)
    kept = ft.ESSResampler().resample(particles) is particles
    print(f"ESSResampler: ESS = {ess:.2f} against N/2 = 2.5, so the particles are "
          f"{'kept as they are' if kept else 'resampled'}")


def timing(n, repeats):
    """Median time of each resampler at N particles (4-D) for each implementation."""
    reference = _reference_module()
    stonesoup = _stonesoup_resamplers()
    rng = np.random.default_rng(0)
    log_w = np.log(rng.random(n))
    x = rng.standard_normal((4, n))
    state = ft.ParticleState(x, log_weight=log_w)
    if stonesoup:
        from stonesoup.types.array import StateVectors
        from stonesoup.types.state import ParticleState
        ss_state = ParticleState(StateVectors(x), log_weight=log_w - np.logaddexp.reduce(log_w))
    out = np.empty_like(x)
    floor = _median_time(lambda: np.copyto(out, x), repeats)
    print(f"\nResampling N = {n:,} particles (4-D), median of {repeats}; "
          f"floor (np.copyto of the state): {floor * 1e3:.2f} ms")
    print(f"{'resampler':<14}{'fasttrack':>12}{'NumPy ref':>12}{'Stone Soup':>12}"
          f"{'vs NumPy':>10}{'vs Stone Soup':>15}")
    for name, (resampler, method, residual) in _resamplers().items():
        ours = _median_time(lambda: resampler.resample(state), repeats)
        row = f"{name:<14}{ours * 1e3:>9.2f} ms"
        if reference:
            numpy_time = _median_time(
                lambda: x[:, reference.draw(log_w, n, method, residual, 1)], repeats)
            row += f"{numpy_time * 1e3:>9.1f} ms"
        else:
            numpy_time = None
            row += f"{'n/a':>12}"
        if stonesoup:
            print(f"{row}   (timing Stone Soup...)", end="\r", flush=True)
            np.random.seed(0)
            ss_time = _median_time(lambda: stonesoup[name].resample(ss_state),
                                   max(1, repeats // 2))
            row += f"{ss_time * 1e3:>9.1f} ms"
        else:
            ss_time = None
            row += f"{'n/a':>12}"
        row += f"{numpy_time / ours:>9.1f}x" if numpy_time else f"{'':>10}"
        row += f"{ss_time / ours:>14.1f}x" if ss_time else ""
        print(row + " " * 10)
    if reference is None:
        print("(NumPy reference: run from a source checkout, where tests/reference.py is)")
    if stonesoup is None:
        print("(Stone Soup: pip install 'fasttrack[stonesoup]' to compare)")


def _run_filter(predictor, updater, prior, detections, hypothesis):
    track = []
    for detection in detections:
        prior = updater.update(hypothesis(predictor.predict(prior, timestamp=detection.timestamp),
                                          detection))
        track.append(prior)
    return track


def _stonesoup_scenario(scenario):
    """Stone Soup's bearing-range tutorial models and the scenario's detections, or None if
    Stone Soup is not installed."""
    try:
        from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
        from stonesoup.models.transition.linear import (CombinedLinearGaussianTransitionModel,
                                                        ConstantVelocity)
        from stonesoup.types.detection import Detection
    except ImportError:
        return None
    sensor = scenario.measurement_model
    ss_sensor = CartesianToBearingRange(ndim_state=4, mapping=sensor.mapping,
                                        noise_covar=sensor.noise_covar,
                                        translation_offset=sensor.translation_offset)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 2)
    detections = [Detection(d.state_vector, timestamp=d.timestamp, measurement_model=ss_sensor)
                  for d in scenario.detections]
    return transition, ss_sensor, detections


def _stonesoup_particle_filter(scenario):
    """Stone Soup's particle filter on the same detections, or None if not installed."""
    models = _stonesoup_scenario(scenario)
    if models is None:
        return None
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import SystematicResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater
    transition, sensor, detections = models
    n = len(scenario.prior)
    prior = ParticleState(StateVectors(scenario.prior.state_vector), weight=np.full(n, 1 / n),
                          timestamp=scenario.prior.timestamp)
    predictor = ParticlePredictor(transition)
    updater = ParticleUpdater(sensor, SystematicResampler())
    np.random.seed(0)
    start = time.perf_counter()
    track = _run_filter(predictor, updater, prior, detections, SingleHypothesis)
    return track, (time.perf_counter() - start) / len(detections)


def particle_filter(sizes):
    """The particle-filter tutorial at each size: RMSE and time per step, against Stone Soup."""
    print("\nParticle filter tutorial (bearing-range sensor, 21 steps, systematic resampling "
          "every step)")
    print(f"{'filter':<18}{'N':>10}{'RMSE':>9}{'fasttrack':>14}{'Stone Soup':>14}"
          f"{'speed-up':>10}")
    for n in sizes:
        scenario = particle_filter_tutorial(n_particles=n)
        predictor = ft.ParticlePredictor(scenario.transition_model, rng=1)
        updater = ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=2))

        def track():
            return _run_filter(predictor, updater, scenario.prior, scenario.detections,
                               ft.SingleHypothesis)

        rmse = position_rmse(track(), scenario.truth)
        ours = _median_time(track, 3) / len(scenario.detections)
        row = f"{'particle filter':<18}{n:>10,}{rmse:>8.2f}m{ours * 1e3:>11.2f} ms"
        if n >= 10**4:
            print(f"{row}   (running Stone Soup...)", end="\r", flush=True)
        theirs = _stonesoup_particle_filter(scenario)
        if theirs is None:
            print(row + f"{'n/a':>14}")
            continue
        print(row + f"{theirs[1] * 1e3:>11.2f} ms{theirs[1] / ours:>9.1f}x"
              f"   (Stone Soup RMSE {position_rmse(theirs[0], scenario.truth):.2f} m)")


def _stonesoup_ekf(scenario):
    """Stone Soup's extended Kalman filter on the same detections (time per step), or None."""
    models = _stonesoup_scenario(scenario)
    if models is None:
        return None
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater
    transition, sensor, detections = models
    prior = GaussianState(scenario.prior.state_vector, scenario.prior.covar,
                          timestamp=scenario.prior.timestamp)
    predictor, updater = ExtendedKalmanPredictor(transition), ExtendedKalmanUpdater(sensor)
    return _median_time(lambda: _run_filter(predictor, updater, prior, detections,
                                            SingleHypothesis), 5) / len(detections)


def extended_kalman_filter(repeats):
    """The EKF tutorial: RMSE and time per step against Stone Soup, and the batch API."""
    scenario = extended_kalman_tutorial()
    predictor = ft.ExtendedKalmanPredictor(scenario.transition_model)
    updater = ft.ExtendedKalmanUpdater(scenario.measurement_model)

    def run():
        return _run_filter(predictor, updater, scenario.prior, scenario.detections,
                           ft.SingleHypothesis)

    rmse = position_rmse(run(), scenario.truth)
    ours = _median_time(run, repeats) / len(scenario.detections)
    theirs = _stonesoup_ekf(scenario)
    row = f"{'extended Kalman':<18}{1:>10}{rmse:>8.2f}m{ours * 1e6:>11.1f} us"
    print(row + (f"{theirs * 1e6:>11.1f} us{theirs / ours:>9.1f}x" if theirs else f"{'n/a':>14}"))
    k = 10_000
    batch = ft.BatchExtendedKalmanFilter(scenario.transition_model, scenario.measurement_model)
    rng = np.random.default_rng(0)
    means = np.array([0.0, 1.0, 0.0, 1.0]) + rng.normal(0, 1, (k, 4))
    covars = np.broadcast_to(scenario.prior.covar, (k, 4, 4)).copy()
    measurements = np.column_stack([rng.normal(0, 0.1, k), rng.normal(49, 1, k)])
    batch.step(means, covars, measurements, 1.0)
    per_filter = _median_time(lambda: batch.step(means, covars, measurements, 1.0), repeats) / k
    print(f"{'EKF batch':<18}{k:>10,}{'':>9}{per_filter * 1e6:>11.2f} us   per filter-step, "
          f"{k:,} filters in one call")


AKKF_KERNELS = {"quadratic": lambda: ft.QuadraticKernel(c=1, ialpha=1),
                "quartic": lambda: ft.QuarticKernel(c=1, ialpha=1),
                "gaussian": lambda: ft.GaussianKernel()}


def _stonesoup_akkf(scenario, kernel_name):
    """Stone Soup's AKKF on the same detections and prior: (track, time per step), the
    exception it fails with, or None if it is not installed."""
    try:
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
    except ImportError:
        return None
    kernel = {"quadratic": lambda: ss_kernel.QuadraticKernel(c=1, ialpha=1),
              "quartic": lambda: ss_kernel.QuarticKernel(c=1, ialpha=1),
              "gaussian": lambda: ss_kernel.GaussianKernel()}[kernel_name]()
    sensor = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                  noise_covar=scenario.measurement_model.noise_covar)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(1e-4)] * 2)
    detections = [Detection(d.state_vector, timestamp=d.timestamp, measurement_model=sensor)
                  for d in scenario.detections]
    m = len(scenario.prior)
    prior = KernelParticleState(state_vector=StateVectors(scenario.prior.state_vector),
                                weight=np.full(m, 1 / m), timestamp=scenario.prior.timestamp)
    predictor = AdaptiveKernelKalmanPredictor(transition_model=transition, kernel=kernel)
    updater = AdaptiveKernelKalmanUpdater(measurement_model=sensor, kernel=kernel)
    np.random.seed(0)
    start = time.perf_counter()
    try:
        track = _run_filter(predictor, updater, prior, detections, SingleHypothesis)
    except Exception as error:  # noqa: BLE001 - reported, not hidden
        return error
    return track, (time.perf_counter() - start) / len(detections)


def adaptive_kernel_filter(sizes, stonesoup_sizes, repeats):
    """The AKKF tutorial with each kernel at each size: RMSE and time per step, against
    Stone Soup at ``stonesoup_sizes``."""
    print("\nAdaptive kernel Kalman filter tutorial (bearing-only sensor, 30 steps)")
    for m in sizes:
        scenario = adaptive_kernel_tutorial(n_particles=m)
        for name, make in AKKF_KERNELS.items():
            predictor = ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, make())
            updater = ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, make(), rng=1)

            def track():
                return _run_filter(predictor, updater, scenario.prior, scenario.detections,
                                   ft.SingleHypothesis)

            rmse = position_rmse(track(), scenario.truth)
            ours = _median_time(track, repeats) / len(scenario.detections)
            row = f"{'AKKF ' + name:<18}{m:>10,}{rmse:>9.3f}{ours * 1e3:>11.3f} ms"
            theirs = None
            if m in stonesoup_sizes:
                print(f"{row}   (running Stone Soup...)", end="\r", flush=True)
                theirs = _stonesoup_akkf(scenario, name)
            if theirs is None:
                print(row + f"{'n/a':>14}" + " " * 20)
            elif isinstance(theirs, Exception):
                print(row + f"{'fails':>14}   (Stone Soup: {type(theirs).__name__})")
            else:
                print(row + f"{theirs[1] * 1e3:>11.3f} ms{theirs[1] / ours:>9.1f}x"
                      f"   (Stone Soup RMSE {position_rmse(theirs[0], scenario.truth):.3f})")


def run(quick=False):
    """Run the demo; ``quick`` uses smaller sizes and fewer repeats (well under a minute)."""
    start = time.perf_counter()
    ft.tune_allocator()
    print(f"fasttrack {ft.__version__}: compiling kernels (cached after the first run)...")
    print(f"  ready in {ft.warmup():.1f} s (malloc keeps freed memory: "
          f"fasttrack.tune_allocator())\n")
    tutorial_examples(draws=2000 if quick else 10000)
    timing(10**5 if quick else 10**6, repeats=5 if quick else 9)
    particle_filter([1000, 10**4] if quick else [1000, 10**5])
    extended_kalman_filter(repeats=5 if quick else 21)
    adaptive_kernel_filter([30, 300] if quick else [30, 300, 1000], stonesoup_sizes=[30, 300],
                           repeats=3 if quick else 9)
    print(f"\nDemo finished in {time.perf_counter() - start:.1f} s")
