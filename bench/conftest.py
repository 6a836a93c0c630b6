"""Benchmark setup: fasttrack, the NumPy reference (tests/reference/) and Stone Soup run the
same workloads in the same session; ``python bench/report.py`` turns the saved JSON into
speed-up ratios.

Run:  python -m pytest bench --benchmark-json=bench/results/latest.json
Smoke (no timing, as in CI):  python -m pytest bench --benchmark-disable

The process runs as a user's would: glibc's default allocator (set
FASTTRACK_BENCH_TUNED_ALLOCATOR=1 for ``fasttrack.tune_allocator()``), fasttrack's default
threads, NumPy's BLAS threads as fasttrack leaves them (timed rounds follow set-ups and other
benchmarks without a pause).
"""
import os
import pathlib
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))

import fasttrack  # noqa: E402
import fasttrack._jit  # noqa: E402

fasttrack._jit.kernels_from_now()  # the benchmarks time the kernels, from the first round

SIZES = [10**3, 10**4, 10**5, 10**6]


def rounds_for(n, slow=False):
    """Repeats per measurement: fewer at large N, fewest for the slow implementations."""
    if slow:
        return 5 if n >= 10**5 else 15
    return 21 if n >= 10**5 else 50




@pytest.fixture(scope="session", autouse=True)
def _compiled():
    fasttrack.warmup()


def pytest_configure(config):
    """Every implementation runs with glibc's default malloc, what a user gets, unless
    FASTTRACK_BENCH_TUNED_ALLOCATOR=1 (fasttrack.tune_allocator, for comparison)."""
    if os.environ.get("FASTTRACK_BENCH_TUNED_ALLOCATOR") == "1":
        fasttrack.tune_allocator()


def run(benchmark, function, n, slow=False):
    """Time ``function()`` with pytest-benchmark's pedantic mode (one call per round)."""
    return benchmark.pedantic(function, rounds=rounds_for(n, slow), iterations=1,
                              warmup_rounds=0 if slow else 1)


def workload(n, d=4, seed=0):
    """Random unnormalised log weights (N,) and a (d, N) state."""
    rng = np.random.default_rng(seed)
    return np.log(rng.random(n)), rng.standard_normal((d, n))
