"""Threads under load: a particle-filter step with fasttrack's default threads against one
thread (``NUMBA_NUM_THREADS=1``), in the same conditions:

- ``alone``: one process at N = 1e5 on the idle machine (the default should be faster);
- ``pair``: two processes at N = 1e5 stepping at once on the 2 cores (the default must not be
  much slower than one thread each: spin-waiting threads once made it 40x slower);
- ``small``: one process at N = 1000 (the default must never be slower).

Each configuration runs in new processes (the step's median over a few seconds, kernels from
the cache); ``python bench/report.py`` shows the ratios and checks them.
"""
import os
import subprocess
import sys

import pytest

STEPPER = """
import sys, time
import numpy as np
import fasttrack as ft
import fasttrack._jit
from fasttrack.scenarios import particle_filter_tutorial
fasttrack._jit.kernels_from_now()  # the kernels' step, from the first
n, seconds = int(sys.argv[1]), float(sys.argv[2])
s = particle_filter_tutorial(n, steps=3)
predictor = ft.ParticlePredictor(s.transition_model, rng=1)
updater = ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=2))
d = s.detections[1]
step = lambda: updater.update(ft.SingleHypothesis(predictor.predict(s.prior, d.timestamp), d))
step(); step()
times, end = [], time.perf_counter() + seconds
while time.perf_counter() < end:
    start = time.perf_counter(); step(); times.append(time.perf_counter() - start)
print(np.median(times))
"""

CONFIGS = {"alone": (100_000, 1), "pair": (100_000, 2), "small": (1000, 1)}


def _steps(n, processes, threads, seconds):
    """Median step seconds of ``processes`` processes stepping at once (their mean)."""
    env = dict(os.environ)
    if threads == 1:
        env["NUMBA_NUM_THREADS"] = "1"
    running = [subprocess.Popen([sys.executable, "-c", STEPPER, str(n), str(seconds)],
                                env=env, stdout=subprocess.PIPE, text=True)
               for _ in range(processes)]
    medians = [float(p.communicate()[0]) for p in running]
    assert all(p.returncode == 0 for p in running)
    return sum(medians) / len(medians)


@pytest.mark.parametrize("config", list(CONFIGS))
def test_step_under_load(benchmark, config):
    """Default threads and one thread, alternately, three times each (these machines are
    noisy): the medians of the three."""
    n, processes = CONFIGS[config]
    benchmark.group = f"load-{config}"
    seconds, rounds = (0.2, 1) if benchmark.disabled else (3.0, 3)
    found = {"default": [], "one": []}

    def run():
        for _ in range(rounds):
            for threads in found:
                found[threads].append(_steps(n, processes, 1 if threads == "one" else None,
                                             seconds))

    benchmark.pedantic(run, rounds=1, iterations=1)
    benchmark.extra_info.update(n=n, processes=processes, **{
        f"{threads}_step_seconds": sorted(times)[len(times) // 2]
        for threads, times in found.items()})
