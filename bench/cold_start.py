"""Cold-start costs, each measured in a new Python process.

Usage: python bench/cold_start.py [--repeats 3] [--json bench/results/cold_start.json]
[--families NAME ...]

- ``import fasttrack``;
- the first call of each kernel family in a new process with an empty compile cache,
  import included (what a new user waits for), and the same with the cache filled;
- ``fasttrack.warmup(processes=2)`` of every family from an empty cache;
- the first particle-filter step of a new process with a warm cache, import included.

The cold runs use a temporary ``FASTTRACK_CACHE_DIR``, so the user's cache is left alone.
``python bench/report.py ... --cold bench/results/cold_start.json`` prints the table with
the targets.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

IMPORT = "import time; t = time.perf_counter(); import fasttrack; print(time.perf_counter() - t)"

#: The first call of each family, timed from interpreter start (import included).
FAMILY = """
import sys, time
start = time.perf_counter()
import numpy as np
import fasttrack as ft
from fasttrack.scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial,
                                 particle_filter_tutorial)
def step(predictor, updater, scenario):
    d = scenario.detections[1]
    return updater.update(ft.SingleHypothesis(predictor.predict(scenario.prior, d.timestamp), d))
family = sys.argv[1]
if family == "resample":
    ft.SystematicResampler(rng=0).resample(particle_filter_tutorial(1000).prior)
elif family == "particle filter":
    s = particle_filter_tutorial(1000)
    step(ft.ParticlePredictor(s.transition_model, rng=1),
         ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=2)), s)
elif family == "extended Kalman filter":
    s = extended_kalman_tutorial()
    step(ft.ExtendedKalmanPredictor(s.transition_model),
         ft.ExtendedKalmanUpdater(s.measurement_model), s)
elif family == "AKKF":
    s = adaptive_kernel_tutorial(30)
    step(ft.AdaptiveKernelKalmanPredictor(s.transition_model),
         ft.AdaptiveKernelKalmanUpdater(s.measurement_model, rng=1), s)
elif family == "EKF batch":
    s = extended_kalman_tutorial()
    ft.BatchExtendedKalmanFilter(s.transition_model, s.measurement_model).step(
        np.zeros((4, 4)) + [0, 1, 0, 1], np.broadcast_to(np.eye(4), (4, 4, 4)).copy(),
        np.array([[0.0, 49.0]] * 4), 1.0)
elif family == "unscented Kalman filter":
    s = extended_kalman_tutorial()
    step(ft.UnscentedKalmanPredictor(s.transition_model),
         ft.UnscentedKalmanUpdater(s.measurement_model), s)
elif family == "UKF batch":
    s = extended_kalman_tutorial()
    ft.BatchUnscentedKalmanFilter(s.transition_model, s.measurement_model).step(
        np.zeros((4, 4)) + [0, 1, 0, 1], np.broadcast_to(np.eye(4), (4, 4, 4)).copy(),
        np.array([[0.0, 49.0]] * 4), 1.0)
elif family == "Kalman smoother":
    s = extended_kalman_tutorial()
    track = ft.run_filter(ft.KalmanPredictor(s.transition_model),
                          ft.KalmanUpdater(ft.LinearGaussian(4, (0, 2), np.eye(2))), s.prior,
                          [ft.Detection([k, k], timestamp=d.timestamp)
                           for k, d in enumerate(s.detections[1:])])
    ft.KalmanSmoother(s.transition_model).smooth(track)
elif family == "warmup":
    ft.warmup(processes=2)
print(time.perf_counter() - start)
"""

FAMILIES = ["resample", "particle filter", "extended Kalman filter", "AKKF", "EKF batch",
            "unscented Kalman filter", "UKF batch", "Kalman smoother"]
#: Seconds from an empty cache, import included (the targets of a first result).
TARGETS = {"resample": 2.0, "particle filter": 4.0, "extended Kalman filter": 4.0,
           "AKKF": 6.0, "warmup": 25.0}

FIRST_STEP = """
import time; t = time.perf_counter()
import fasttrack as ft
from fasttrack.scenarios import particle_filter_tutorial
s = particle_filter_tutorial(1000)
d = s.detections[1]
ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=2)).update(
    ft.SingleHypothesis(ft.ParticlePredictor(s.transition_model, rng=1).predict(s.prior,
                                                                              d.timestamp), d))
print(time.perf_counter() - t)
"""


def _python(code, *args, cache=None):
    env = dict(os.environ)
    if cache is not None:
        env["FASTTRACK_CACHE_DIR"] = cache
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          check=True, env=env)
    return float(done.stdout.strip().splitlines()[-1])


def _runs(values):
    return f"median {statistics.median(values):.2f} s ({', '.join(f'{v:.2f}' for v in values)})"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="also write the measurements here")
    parser.add_argument("--families", nargs="+", choices=FAMILIES + ["warmup"],
                        default=FAMILIES + ["warmup"], help="the families to time (all)")
    args = parser.parse_args(argv)
    results = {"import": [_python(IMPORT) for _ in range(args.repeats)], "cold": {}, "warm": {}}
    print(f"import fasttrack: {_runs(results['import'])}; target 0.5 s")
    print("\nfirst call per family, new process, import included: empty cache | cache filled")
    for family in args.families:
        cold, warm = [], []
        for _ in range(args.repeats if family != "warmup" else 1):
            with tempfile.TemporaryDirectory() as cache:
                cold.append(_python(FAMILY, family, cache=cache))
                warm.append(_python(FAMILY, family, cache=cache))
        results["cold"][family], results["warm"][family] = cold, warm
        target = f" (target {TARGETS[family]:.0f} s)" if family in TARGETS else ""
        print(f"  {family:<24} {_runs(cold)}{target} | {_runs(warm)}")
    _python(FIRST_STEP)  # fill the user cache if needed
    results["first_step"] = [_python(FIRST_STEP) for _ in range(args.repeats)]
    print(f"\nfirst particle-filter step in a new process, warm cache, import included: "
          f"{_runs(results['first_step'])}; target 1.5 s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
