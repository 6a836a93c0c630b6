"""Threads under load: a particle-filter step with fasttrack's default threads against one
thread (``NUMBA_NUM_THREADS=1``), in the same conditions:

- ``alone``: one process at N = 1e5 on the idle machine (the default should be faster);
- ``pair``: two processes at N = 1e5 stepping at once on the 2 cores (the default must not be
  much slower than one thread each: spin-waiting threads once made it 40x slower);
- ``small``: one process at N = 1000 (the default must never be slower);
- ``beside-numpy``: the tutorial's whole loop at N = 1e5, its prior drawn by NumPy, by
  default against one BLAS thread (``OPENBLAS_NUM_THREADS=1``): NumPy's BLAS workers must
  not take the cores from the kernels.

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

#: The particle-filter tutorial's loop as a user writes it (docs/examples/particle_filter.py):
#: the prior drawn by ``multivariate_normal`` (a threaded BLAS product at this N), then 21
#: steps; the median seconds of whole loops, each after a short pause.
LOOPER = """
import sys, time
import numpy as np
import fasttrack as ft
import fasttrack._jit
from fasttrack.scenarios import particle_filter_tutorial
fasttrack._jit.kernels_from_now()
n, seconds = int(sys.argv[1]), float(sys.argv[2])
s = particle_filter_tutorial(10, steps=21)
rng = np.random.default_rng(1)
predictor = ft.ParticlePredictor(s.transition_model, rng=rng)
updater = ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=rng))

def loop():
    samples = rng.multivariate_normal([0, 1, 0, 1], np.diag([1.5, 0.5, 1.5, 0.5]), size=n)
    prior = ft.ParticleState(samples.T, timestamp=s.prior.timestamp)
    track = ft.Track()
    for measurement in s.detections:
        prediction = predictor.predict(prior, timestamp=measurement.timestamp)
        track.append(updater.update(ft.SingleHypothesis(prediction, measurement)))
        prior = track[-1]

loop()
times, end = [], time.perf_counter() + seconds
while time.perf_counter() < end:
    time.sleep(0.05)  # the user's other work, during which BLAS workers may spin
    start = time.perf_counter(); loop(); times.append(time.perf_counter() - start)
print(np.median(times))
"""


def _steps(n, processes, threads, seconds, script=STEPPER, one="NUMBA_NUM_THREADS"):
    """Median step seconds of ``processes`` processes running ``script`` at once (their
    mean); ``threads`` 1 sets the variable ``one`` to 1."""
    env = dict(os.environ)
    if threads == 1:
        env[one] = "1"
    running = [subprocess.Popen([sys.executable, "-c", script, str(n), str(seconds)],
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


def test_loop_beside_numpy(benchmark):
    """The tutorial loop at N = 1e5 with its prior drawn by NumPy each time, by default and
    with one BLAS thread (``OPENBLAS_NUM_THREADS=1``), alternately three times each: NumPy's
    BLAS workers must not slow fasttrack's kernels (see :mod:`fasttrack.threads`)."""
    benchmark.group = "load-beside-numpy"
    seconds, rounds, n = (0.2, 1, 1000) if benchmark.disabled else (4.0, 3, 100_000)
    found = {"default": [], "one": []}

    def run():
        for _ in range(rounds):
            for threads in found:
                found[threads].append(_steps(n, 1, 1 if threads == "one" else None, seconds,
                                             LOOPER, "OPENBLAS_NUM_THREADS"))

    benchmark.pedantic(run, rounds=1, iterations=1)
    benchmark.extra_info.update(n=n, **{f"{threads}_step_seconds": sorted(times)[len(times) // 2]
                                        for threads, times in found.items()})
