"""GOSPA over time and the 2-D assignment solver: fasttrack, the NumPy reference (SciPy's
linear_sum_assignment step by step, tests/reference/assign.py) and Stone Soup 1.9.1 in the same
run.

Workloads: the GOSPA of /work/shared/stonesoup_mtt_baseline.py (``ss_gospa``: truths 20 m
apart moving diagonally, tracks at unit noise in all four state components, c = 10, p = 1),
50 tracks x 100 steps (all three; Stone Soup takes seconds) and 40 tracks x 30,000 steps
(fasttrack and the reference: Stone Soup would take about half an hour); linear sum
assignment of uniform random and of gated tracking matrices at 100 x 100 and 1000 x 1000,
and 2,000 problems of 20 x 20 in one batch, against SciPy.
"""
import datetime

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from fasttrack.core.assign import assign2d, assign2d_batch
from fasttrack.metrics import gospa_over_time

import reference.assign

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
GOSPA_SIZES = [(50, 100), (40, 30_000)]


def gospa_workload(n_tracks, steps, seed=0):
    """``(steps, n, 4)`` truths and estimates of the baseline's ``ss_gospa``."""
    rng = np.random.default_rng(seed)
    k = np.arange(steps, dtype=float)[:, None]
    i = np.arange(n_tracks, dtype=float)[None, :]
    ones = np.ones((steps, n_tracks))
    truths = np.stack([i * 20.0 + k, ones, k * ones, ones], axis=-1)
    return truths, truths + rng.normal(0, 1, truths.shape)


def _rounds(benchmark, function, rounds, warmup=1):
    return benchmark.pedantic(function, rounds=rounds, iterations=1, warmup_rounds=warmup)


@pytest.mark.parametrize("n_tracks, steps", GOSPA_SIZES)
def test_fasttrack_gospa(benchmark, n_tracks, steps):
    """Per-step arrays in lists, as a tracker would collect them."""
    benchmark.group = f"gospa-{n_tracks}-tracks N={steps}"
    truths, estimates = gospa_workload(n_tracks, steps)
    truths, estimates = list(truths), list(estimates)
    result = _rounds(benchmark, lambda: gospa_over_time(truths, estimates, 10, 1),
                     50 if steps <= 1000 else 11)
    assert result.distance.shape == (steps,)


@pytest.mark.parametrize("n_tracks, steps", GOSPA_SIZES)
def test_fasttrack_gospa_padded(benchmark, n_tracks, steps):
    """The same steps as one (steps, n, 4) array."""
    benchmark.group = f"gospa-padded-{n_tracks}-tracks N={steps}"
    truths, estimates = gospa_workload(n_tracks, steps)
    result = _rounds(benchmark, lambda: gospa_over_time(truths, estimates, 10, 1),
                     50 if steps <= 1000 else 11)
    assert result.distance.shape == (steps,)


@pytest.mark.parametrize("n_tracks, steps", GOSPA_SIZES)
def test_numpy_reference_gospa(benchmark, n_tracks, steps):
    benchmark.group = f"gospa-{n_tracks}-tracks N={steps}"
    truths, estimates = gospa_workload(n_tracks, steps)
    t, e = truths.reshape(-1, 4), estimates.reshape(-1, 4)
    offsets = np.arange(steps + 1, dtype=np.int64) * n_tracks
    assignment = np.empty(len(t), dtype=np.int64)
    out = np.empty((steps, 4))
    _rounds(benchmark, lambda: reference.assign.gospa_steps(t, offsets, e, offsets, 10.0, 1.0, 2.0,
                                                            assignment, out),
            11 if steps <= 1000 else 3, warmup=0)


@pytest.mark.parametrize("n_tracks, steps", GOSPA_SIZES[:1])
def test_stonesoup_gospa(benchmark, n_tracks, steps):
    pytest.importorskip("stonesoup")
    from stonesoup.metricgenerator.ospametric import GOSPAMetric
    from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
    benchmark.group = f"gospa-{n_tracks}-tracks N={steps}"
    truths, estimates = gospa_workload(n_tracks, steps)
    paths, tracks = set(), set()
    for i in range(n_tracks):
        path, track = GroundTruthPath(), Track()
        for k in range(steps):
            path.append(GroundTruthState(truths[k, i].reshape(4, 1), timestamp=T0 + k * DT))
            track.append(GaussianState(estimates[k, i].reshape(4, 1), np.eye(4),
                                       timestamp=T0 + k * DT))
        paths.add(path)
        tracks.add(track)
    metric = GOSPAMetric(c=10, p=1)

    def run():
        return metric.compute_over_time(*metric.extract_states(tracks, True),
                                        *metric.extract_states(paths, True))

    result = _rounds(benchmark, run, 3, warmup=0)
    assert len(result.value) == steps


def assignment_workload(kind, n, seed=0):
    """A uniform random ``(n, n)`` matrix, or the baseline's gated GNN matrix (targets on a
    20 m grid, squared distances / 3, 1e6 beyond the gate of 25)."""
    rng = np.random.default_rng(seed)
    if kind == "uniform":
        return rng.random((n, n))
    side = int(np.ceil(np.sqrt(n)))
    gx, gy = np.meshgrid(np.arange(side), np.arange(side))
    grid = np.c_[gx.ravel(), gy.ravel()][:n] * 20.0
    z = grid + rng.normal(0, 1, (n, 2))
    cost = ((z[None, :, :] - grid[:, None, :]) ** 2).sum(-1) / 3.0
    cost[cost > 25.0] = 1e6
    return cost


ASSIGN = [(kind, n) for kind in ("uniform", "gated") for n in (100, 1000)]


@pytest.mark.parametrize("kind, n", ASSIGN)
def test_fasttrack_assign2d(benchmark, kind, n):
    benchmark.group = f"assign2d-{kind} N={n}"
    cost = assignment_workload(kind, n)
    rows, cols = _rounds(benchmark, lambda: assign2d(cost), 50 if n <= 100 else 11)
    assert np.array_equal(cols, linear_sum_assignment(cost)[1])


@pytest.mark.parametrize("kind, n", ASSIGN)
def test_numpy_reference_assign2d(benchmark, kind, n):
    """SciPy's linear_sum_assignment."""
    benchmark.group = f"assign2d-{kind} N={n}"
    cost = assignment_workload(kind, n)
    _rounds(benchmark, lambda: linear_sum_assignment(cost), 50 if n <= 100 else 11)


BATCH = 2000


def _batch():
    rng = np.random.default_rng(1)
    return [rng.random((20, 20)) for _ in range(BATCH)]


def test_fasttrack_assign2d_batch(benchmark):
    benchmark.group = f"assign2d-batch-20x20 N={BATCH}"
    problems = _batch()
    out = _rounds(benchmark, lambda: assign2d_batch(problems), 50)
    assert len(out) == BATCH


def test_numpy_reference_assign2d_batch(benchmark):
    """SciPy, one call per problem."""
    benchmark.group = f"assign2d-batch-20x20 N={BATCH}"
    problems = _batch()
    _rounds(benchmark, lambda: [linear_sum_assignment(c) for c in problems], 21)
