"""The demo behind ``python -m fasttrack demo``: the four tutorial scenarios, a multi-target
scenario and Vo and Ma's PHD scenario tracked with fasttrack, in one table of accuracy and
time per step against Stone Soup (when installed), with PNG plots."""
import pathlib
import sys
import time

import numpy as np

import fasttrack as ft
from fasttrack._jit import cache
from fasttrack.metrics import gospa_over_time, position_rmse
from fasttrack.scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial,
                                 grid_targets, manoeuvring_target, particle_filter_tutorial,
                                 vo_linear, vo_linear_birth)

TUTORIAL_WEIGHTS = np.array([1, 5, 1.5, 0.5, 2]) / 10
AKKF_KERNELS = {"quadratic": lambda: ft.QuadraticKernel(c=1, ialpha=1),
                "quartic": lambda: ft.QuarticKernel(c=1, ialpha=1),
                "gaussian": lambda: ft.GaussianKernel()}
TRACKER = {"missed_distance": 3.0, "min_points": 3, "delete_after_misses": 3,
           "tentative_misses": 2}


def _median_time(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _progress(message):
    """Say what is running (overwritten by the next line)."""
    if sys.stdout.isatty():
        print(f"  ... {message:<70}", end="\r", flush=True)
    else:
        print(f"  ... {message}", flush=True)


class Table:
    """The demo's one table: filter, size, RMSE and time per step against Stone Soup."""

    def __init__(self):
        self.rows = []

    def add(self, name, size, rmse, ours, theirs=None):
        """``theirs``: Stone Soup's seconds per step, None if not run, or the exception it
        failed with."""
        self.rows.append((name, size, rmse, ours, theirs))

    @staticmethod
    def _time(seconds):
        return f"{seconds * 1e3:.3f} ms" if seconds >= 1e-4 else f"{seconds * 1e6:.1f} us"

    def render(self):
        lines = [f"{'filter':<26}{'size':>10}{'RMSE':>9}{'fasttrack':>13}{'Stone Soup':>13}"
                 f"{'speed-up':>10}"]
        for name, size, rmse, ours, theirs in self.rows:
            line = f"{name:<26}{size:>10,}{'' if rmse is None else f'{rmse:.3f}':>9}" \
                   f"{self._time(ours):>13}"
            if theirs is None:
                line += f"{'n/a':>13}"
            elif isinstance(theirs, Exception):
                line += f"{'fails':>13}   ({type(theirs).__name__})"
            else:
                line += f"{self._time(theirs):>13}{theirs / ours:>9.1f}x"
            lines.append(line)
        return "\n".join(lines)


def _stonesoup():
    """The Stone Soup side of the demo, or None if Stone Soup is not installed."""
    try:
        from fasttrack import _demo_stonesoup
    except ImportError:
        return None
    return _demo_stonesoup


def _timed_track(make_run, repeats, steps):
    """The track of one run and the median time per step over ``repeats`` runs."""
    track = make_run()
    return track, _median_time(make_run, repeats) / steps


def resamplers(table, plots, n, repeats):
    """The resampler tutorial's five weights (offspring counts and CDF plots) and the four
    schemes timed at N particles."""
    print("Resampler tutorial: weights", TUTORIAL_WEIGHTS.tolist())
    particles = ft.ParticleState(np.arange(5.0)[None], weight=TUTORIAL_WEIGHTS)
    schemes = {"systematic": ft.SystematicResampler(rng=1),
               "stratified": ft.StratifiedResampler(rng=1),
               "multinomial": ft.MultinomialResampler(rng=1),
               "residual": ft.ResidualResampler("systematic", rng=1)}
    for name, resampler in schemes.items():
        drawn = resampler.resample(particles).state_vector[0].astype(int)
        print(f"  {name:<12} offspring {np.bincount(drawn, minlength=5)}")
        if plots:  # the points the scheme drew (the same seed), or residual's copies
            ax = (plots.resampling(TUTORIAL_WEIGHTS, offspring=np.bincount(drawn, minlength=5))
                  if name == "residual" else
                  plots.resampling(TUTORIAL_WEIGHTS, ft.resampling_points(5, name, rng=1)))
            plots.save(ax, f"resampler-{name}.png", f"{name} resampling of the tutorial weights")
    print(f"  {'expected':<12} N w = {5 * TUTORIAL_WEIGHTS}")
    kept = ft.ESSResampler().resample(particles) is particles
    print(f"  ESSResampler: ESS = {ft.ess(particles.log_weight):.2f} against N/2 = 2.5: "
          f"{'kept' if kept else 'resampled'}\n")
    rng = np.random.default_rng(0)
    state = ft.ParticleState(rng.standard_normal((4, n)), log_weight=np.log(rng.random(n)))
    stonesoup = _stonesoup()
    for name, resampler in schemes.items():
        _progress(f"{name} resampling of {n:,} particles")
        ours = _median_time(lambda: resampler.resample(state), repeats)
        theirs = stonesoup.resample_time(name, state, max(1, repeats // 2)) if stonesoup \
            else None
        table.add(f"resample {name}", n, None, ours, theirs)


def particle_filter(table, plots, sizes, repeats):
    """The particle-filter tutorial at each size."""
    stonesoup = _stonesoup()
    for n in sizes:
        _progress(f"particle filter, {n:,} particles")
        scenario = particle_filter_tutorial(n_particles=n)
        predictor = ft.ParticlePredictor(scenario.transition_model, rng=1)
        updater = ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=2))
        track, ours = _timed_track(lambda: ft.run_filter(predictor, updater, scenario.prior,
                                                       scenario.detections),
                                   repeats, len(scenario.detections))
        theirs = None
        if stonesoup:
            _progress(f"Stone Soup particle filter, {n:,} particles")
            theirs = stonesoup.particle_filter_time(scenario)
        table.add("particle filter", n, position_rmse(track, scenario.truth), ours, theirs)
        if plots and n <= 10**4:
            ax = plots.scenario(scenario)
            plots.track(track, ax, particles=True)
            plots.save(ax, f"particle-filter-{n}.png", f"Particle filter, N = {n:,}")


def extended_kalman_filter(table, plots, repeats, batch=True):
    """The EKF tutorial, and (with ``batch``) 10,000 filters advanced together by the batch
    API."""
    _progress("extended Kalman filter")
    scenario = extended_kalman_tutorial()
    predictor = ft.ExtendedKalmanPredictor(scenario.transition_model)
    updater = ft.ExtendedKalmanUpdater(scenario.measurement_model)
    track, ours = _timed_track(lambda: ft.run_filter(predictor, updater, scenario.prior,
                                                   scenario.detections),
                               repeats, len(scenario.detections))
    stonesoup = _stonesoup()
    theirs = stonesoup.extended_kalman_time(scenario) if stonesoup else None
    table.add("extended Kalman filter", 1, position_rmse(track, scenario.truth), ours, theirs)
    if plots:
        ax = plots.scenario(scenario)
        plots.track(track, ax, uncertainty=True)
        plots.save(ax, "extended-kalman-filter.png", "Extended Kalman filter")
    if not batch:
        return
    k = 10_000
    batch = ft.BatchExtendedKalmanFilter(scenario.transition_model, scenario.measurement_model)
    rng = np.random.default_rng(0)
    means = np.array([0.0, 1.0, 0.0, 1.0]) + rng.normal(0, 1, (k, 4))
    covars = np.broadcast_to(scenario.prior.covar, (k, 4, 4)).copy()
    measurements = np.column_stack([rng.normal(0, 0.1, k), rng.normal(49, 1, k)])
    batch.step(means, covars, measurements, 1.0)
    per_step = _median_time(lambda: batch.step(means, covars, measurements, 1.0), repeats)
    table.add("EKF batch (all filters)", k, None, per_step)


def adaptive_kernel_filter(table, plots, sizes, stonesoup_sizes, repeats):
    """The AKKF tutorial with each kernel at each size."""
    stonesoup = _stonesoup()
    for m in sizes:
        scenario = adaptive_kernel_tutorial(n_particles=m)
        for name, make in AKKF_KERNELS.items():
            _progress(f"AKKF, {name} kernel, {m} particles")
            predictor = ft.AdaptiveKernelKalmanPredictor(scenario.transition_model, make())
            updater = ft.AdaptiveKernelKalmanUpdater(scenario.measurement_model, make(), rng=1)
            track, ours = _timed_track(lambda: ft.run_filter(predictor, updater, scenario.prior,
                                                           scenario.detections),
                                       repeats, len(scenario.detections))
            theirs = None
            if stonesoup and m in stonesoup_sizes:
                _progress(f"Stone Soup AKKF, {name} kernel, {m} particles")
                theirs = stonesoup.akkf_time(scenario, name)
            table.add(f"AKKF {name}", m, position_rmse(track, scenario.truth), ours, theirs)
            if plots and name == "quadratic" and m == sizes[0]:
                ax = plots.scenario(scenario)
                plots.track(track, ax, particles=True)
                plots.save(ax, f"akkf-{m}.png", f"Adaptive kernel Kalman filter, M = {m}")


def _matched_rmse(scenario, tracks):
    """Position RMSE of the tracks the GOSPA assignment (c = 10 m, p = 2) pairs with a
    target, over all scans."""
    truths = [x[:, [0, 2]] for x in scenario.truths]
    result = gospa_over_time(truths, [t.means[:, [0, 2]] for t in tracks], 10.0, p=2)
    pairs = sum(int((a >= 0).sum()) for a in result.assignment)
    return float(np.sqrt(result.localisation.sum() / max(pairs, 1)))


def multi_target(table, plots, sizes, stonesoup_sizes, steps):
    """The GNN multi-target tracker on ``n`` targets on a 20 m grid with ``n`` clutter
    detections per scan and P_D = 0.9, for each n in ``sizes``."""
    stonesoup = _stonesoup()
    for n in sizes:
        _progress(f"multi-target tracker, {n:,} targets")
        scenario = grid_targets(n_targets=n, steps=steps, clutter_rate=float(n), seed=1)

        def run():
            tracker = ft.MultiTargetTracker(scenario.transition_model,
                                            scenario.measurement_model, np.zeros(4),
                                            np.diag([0.0, 1.0, 0.0, 1.0]), **TRACKER)
            return tracker.run(scenario.detections, scenario.time_interval)

        tracks, ours = _timed_track(run, 1, steps)
        theirs = None
        if stonesoup and n in stonesoup_sizes:
            _progress(f"Stone Soup multi-target tracker, {n:,} targets")
            theirs = stonesoup.tracker_time(scenario, **TRACKER)
        table.add("multi-target GNN tracker", n, _matched_rmse(scenario, tracks), ours, theirs)
        if plots and n == sizes[0]:
            ax = plots.plotting.plot_multi_target(scenario, tracks)
            plots.save(ax, f"multi-target-{n}.png",
                       f"GNN tracker: {n} targets, {n} clutter per scan, P_D = 0.9")


def random_finite_sets(table, plots, clutter_rates, repeats):
    """The GM-PHD and GM-CPHD trackers on Vo and Ma's linear scenario (100 scans, up to 10
    targets, P_D = 0.98, P_S = 0.99, gate chi2(0.999, 2) = 13.8), for each clutter rate
    (clutter detections a scan)."""
    for rate in clutter_rates:
        scenario = vo_linear(clutter_rate=float(rate), seed=1)
        common = (scenario.transition_model, scenario.measurement_model, vo_linear_birth(),
                  0.98, 0.99, scenario.clutter_density)
        trackers = {"GM-PHD": lambda: ft.PHDTracker(*common, gate_threshold=13.8),
                    "GM-CPHD": lambda: ft.CPHDTracker(*common, float(rate), max_targets=30,
                                                      gate_threshold=13.8)}
        counts = {}
        for name, make in trackers.items():
            _progress(f"{name} tracker, clutter {rate} a scan")
            estimates, seconds = _timed_track(lambda: make().run(scenario.detections),
                                              repeats, len(scenario.detections))
            table.add(f"{name}, clutter a scan", rate, _matched_rmse(scenario, estimates),
                      seconds)
            counts[f"{name}: number of estimates"] = [len(e) for e in estimates]
        if plots and rate == clutter_rates[0]:
            ax = plots.plotting.plot_multi_target(scenario, estimates)
            plots.save(ax, f"cphd-vo-linear-{rate}.png",
                       f"GM-CPHD estimates (a colour a label): Vo and Ma's scenario, "
                       f"clutter {rate} a scan")
            ax = plots.plotting.plot_target_count(scenario, counts)
            plots.save(ax, f"target-count-{rate}.png",
                       f"Number of targets, GM-PHD and GM-CPHD: clutter {rate} a scan")


#: The IMM's models in the manoeuvring scenario: turns at +0.02 and -0.02 rad/s and
#: straight flight, and its switching matrix.
IMM_TURN_RATES = {"turn +0.02 rad/s": 0.02, "straight": 0.0, "turn -0.02 rad/s": -0.02}
IMM_MATRIX = np.full((3, 3), 0.05) + 0.85 * np.eye(3)


def multiple_models(table, plots):
    """An IMM filter of three turn models (:data:`IMM_TURN_RATES`, the flight's own process
    noise) on the manoeuvring target of Stone Soup's multiple-model tutorial (600 scans),
    and the IMM smoother over the whole flight."""
    _progress("IMM filter and smoother, manoeuvring target")
    scenario = manoeuvring_target(seed=1)
    models = [ft.KnownTurnRate([1e-2, 1e-2], rate) for rate in IMM_TURN_RATES.values()]
    imm = ft.BatchIMMFilter(models, scenario.measurement_model, IMM_MATRIX)
    first = scenario.measurements[0]
    start = (np.tile([first[0], -30.0, first[1], -30.0], (1, 3, 1)),
             np.tile(np.diag([1.0, 25.0, 1.0, 25.0]), (1, 3, 1, 1)), np.full((1, 3), 1 / 3))
    steps = len(scenario.measurements) - 1

    def run():
        state, history = start, []
        for z in scenario.measurements[1:]:
            state = imm.step(*state, z[None], 1.0)
            history.append([a[0] for a in state])
        return [np.array(a) for a in zip(*history)]  # (T, M, d), (T, M, d, d), (T, M)

    filtered, seconds = _timed_track(run, 3, steps)
    smoothed, smoothing = _timed_track(lambda: imm.smooth(*filtered, 1.0), 3, steps)
    truths = scenario.truths[1:, [0, 2]]
    estimates = {}
    for name, arrays, per_step in (("IMM, 3 turn models", filtered, seconds),
                                   ("IMM smoother", smoothed, smoothing)):
        estimates[name] = ft.BatchIMMFilter.combine(*arrays)[0][:, [0, 2]]
        table.add(name, 1, float(np.sqrt(((estimates[name] - truths) ** 2).sum(axis=1)
                                         .mean())), per_step)
    if plots:
        for probs, label in ((filtered[2], "filtered"), (smoothed[2], "smoothed")):
            ax = plots.plotting.plot_mode_probabilities(probs, list(IMM_TURN_RATES),
                                                        scenario.turn_rates[1:])
            plots.save(ax, f"imm-mode-probabilities-{label}.png",
                       f"IMM mode probabilities over a manoeuvring flight, {label}")
        ax = plots.plotting.plot_paths({"ground truth": scenario.truths[:, [0, 2]],
                                        "IMM estimate": estimates["IMM, 3 turn models"],
                                        "IMM smoothed": estimates["IMM smoother"]})
        plots.save(ax, "imm-track.png", "IMM track of the manoeuvring target")


class Plots:
    """PNG plots of the demo, written to ``out``."""

    def __init__(self, out):
        from fasttrack import plotting
        self.plotting = plotting
        self.out = pathlib.Path(out)
        self.out.mkdir(parents=True, exist_ok=True)
        self.written = []

    def scenario(self, scenario):
        ax = self.plotting.plot_ground_truth(scenario.truth)
        return self.plotting.plot_detections(scenario.detections, ax=ax)

    def track(self, track, ax, **options):
        return self.plotting.plot_track(track, ax=ax, color="tab:red", **options)

    def resampling(self, weights, points=None, offspring=None):
        return self.plotting.plot_resampling(weights, points, offspring)

    def save(self, ax, name, title):
        self.written.append(self.plotting.save(ax, self.out / name, title=title))


def run(quick=False, out="fasttrack-demo"):
    """Run the demo. ``quick`` uses smaller sizes and fewer repeats (under a minute on 2
    cores, compilation included); ``out`` is the folder of the PNG plots (None: no plots,
    as without matplotlib)."""
    start = time.perf_counter()
    shipped = cache.shipped()[0] is not None
    print(f"fasttrack {ft.__version__}: " + ("loading the kernels compiled at install..."
                                            if shipped else
                                            "compiling kernels (cached after the first run)..."),
          flush=True)
    families = ["kalman", "akkf", "gating", "assign", "jpda", "mixture", "imm", "resample",
                "particle"]
    if not quick:
        families.append("unscented")

    def ready(family, seconds):
        print(f"  {family:<16} ready after {time.perf_counter() - start:5.1f} s", flush=True)

    seconds = ft.warmup(families, processes=1 if shipped else 2, report=ready)
    print(f"  all ready in {seconds:.1f} s\n")
    plots = None
    if out is not None:
        try:
            plots = Plots(out)
        except ImportError:
            print("(plots: pip install 'fasttrack[plot]' for matplotlib)")
    if _stonesoup() is None:
        print("(Stone Soup: pip install 'fasttrack[stonesoup]' to compare)")
    table = Table()
    resamplers(table, plots, 10**5 if quick else 10**6, repeats=3 if quick else 9)
    particle_filter(table, plots, [1000, 10**4] if quick else [1000, 10**5],
                    repeats=2 if quick else 5)
    extended_kalman_filter(table, plots, repeats=3 if quick else 21, batch=not quick)
    adaptive_kernel_filter(table, plots, [30] if quick else [30, 300],
                           stonesoup_sizes=[30] if quick else [30, 300],
                           repeats=2 if quick else 5)
    multi_target(table, plots, [50] if quick else [50, 1000], stonesoup_sizes=[50],
                 steps=10 if quick else 100)
    random_finite_sets(table, plots, [30] if quick else [10, 30, 60], repeats=1 if quick else 3)
    multiple_models(table, plots)
    print(" " * 80, end="\r")
    print("\nTime per step (resamplers: per call; tracker: per scan), medians; RMSE: position "
          "error against the truth (tracker: of the tracks matched to targets)\n")
    print(table.render())
    if plots:
        print(f"\nPlots: {len(plots.written)} PNG files in {plots.out}/")
    print(f"\nDemo finished in {time.perf_counter() - start:.1f} s")
