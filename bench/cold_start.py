"""Cold-start costs, each measured in a new Python process.

Usage: python bench/cold_start.py [--repeats 3]

- ``import fasttrack``;
- the first call of each kernel family, with an empty compile cache (compilation) and with
  the cache filled (loading compiled code);
- the first particle-filter step of a new process with a warm cache, import included.

Targets: import <= 0.5 s; first PF step with a warm cache <= 1.5 s. The cold runs use a
temporary ``NUMBA_CACHE_DIR``, so the package's own cache is left alone.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

IMPORT = "import time; t = time.perf_counter(); import fasttrack; print(time.perf_counter() - t)"

SETUP = """
import time, json
import numpy as np
import fasttrack as ft
from fasttrack.scenarios import (particle_filter_tutorial, extended_kalman_tutorial,
                                 adaptive_kernel_tutorial)
pf = particle_filter_tutorial(1000)
ekf = extended_kalman_tutorial()
akkf = adaptive_kernel_tutorial(30)
def step(predictor, updater, scenario):
    d = scenario.detections[1]
    return updater.update(ft.SingleHypothesis(predictor.predict(scenario.prior, d.timestamp), d))
FAMILIES = {
    "resamplers": lambda: [r.resample(pf.prior) for r in (
        ft.SystematicResampler(rng=0), ft.StratifiedResampler(rng=0),
        ft.MultinomialResampler(rng=0), ft.ResidualResampler(rng=0))],
    "particle filter": lambda: step(ft.ParticlePredictor(pf.transition_model, rng=1),
                                    ft.ParticleUpdater(pf.measurement_model), pf),
    "extended Kalman filter": lambda: step(ft.ExtendedKalmanPredictor(ekf.transition_model),
                                           ft.ExtendedKalmanUpdater(ekf.measurement_model), ekf),
    "EKF batch": lambda: ft.BatchExtendedKalmanFilter(ekf.transition_model,
                                                      ekf.measurement_model).step(
        np.zeros((4, 4)) + [0, 1, 0, 1], np.broadcast_to(np.eye(4), (4, 4, 4)).copy(),
        np.array([[0.0, 49.0]] * 4), 1.0),
    "AKKF": lambda: step(ft.AdaptiveKernelKalmanPredictor(akkf.transition_model),
                         ft.AdaptiveKernelKalmanUpdater(akkf.measurement_model, rng=1), akkf),
}
out = {}
for name, call in FAMILIES.items():
    t = time.perf_counter(); call(); out[name] = time.perf_counter() - t
print(json.dumps(out))
"""

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


def _python(code, env=None):
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env={**os.environ, **(env or {})})
    return done.stdout.strip().splitlines()[-1]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    imports = [float(_python(IMPORT)) for _ in range(args.repeats)]
    print(f"import fasttrack: median {statistics.median(imports):.3f} s "
          f"(runs: {', '.join(f'{t:.3f}' for t in imports)}; target 0.5 s)")
    with tempfile.TemporaryDirectory() as cache:
        cold = json.loads(_python(SETUP, {"NUMBA_CACHE_DIR": cache}))
        warm = json.loads(_python(SETUP, {"NUMBA_CACHE_DIR": cache}))
    print("\nfirst call per kernel family  compile (empty cache)  load (warm cache)")
    for name in cold:
        print(f"  {name:<28}{cold[name]:>10.2f} s{warm[name]:>18.3f} s")
    print(f"  {'total':<28}{sum(cold.values()):>10.2f} s{sum(warm.values()):>18.3f} s")
    _python(FIRST_STEP)  # fill the package cache if needed
    firsts = [float(_python(FIRST_STEP)) for _ in range(args.repeats)]
    print(f"\nfirst particle-filter step in a new process, warm cache, import included: median "
          f"{statistics.median(firsts):.3f} s (runs: {', '.join(f'{t:.3f}' for t in firsts)}; "
          f"target 1.5 s)")


if __name__ == "__main__":
    sys.exit(main())
