"""Stone Soup's GOSPAMetric through fasttrack.stonesoup (Stone Soup objects in, Stone Soup's
metric objects out) against Stone Soup 1.9.1's own and against fasttrack's native
``gospa_over_time`` on the same points, in the same run.

Workload: the GOSPA of /work/shared/stonesoup_mtt_baseline.py (``ss_gospa``): 50 truths 20 m
apart moving diagonally, 50 tracks at unit noise in all four state components, 100 steps,
c = 10, p = 1. Two entry points: ``compute_over_time(*extract_states(tracks, True),
*extract_states(truths, True))`` (the baseline's call) and ``compute_metric(manager)`` (a
MultiManager holding both sets). The native figure takes the per-step arrays as given.
"""
import datetime

import numpy as np
import pytest

from fasttrack.metrics import gospa_over_time

pytest.importorskip("stonesoup")
from stonesoup.metricgenerator.manager import MultiManager  # noqa: E402
from stonesoup.metricgenerator.ospametric import GOSPAMetric  # noqa: E402
from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402

import fasttrack.stonesoup as fss  # noqa: E402

T0 = datetime.datetime(2025, 1, 1)
DT = datetime.timedelta(seconds=1)
N_TRACKS, STEPS = 50, 100


def _workload(n_tracks=N_TRACKS, steps=STEPS, seed=0):
    """``(steps, n, 4)`` truths and estimates, and the same as Stone Soup paths and tracks."""
    rng = np.random.default_rng(seed)
    k = np.arange(steps, dtype=float)[:, None]
    i = np.arange(n_tracks, dtype=float)[None, :]
    ones = np.ones((steps, n_tracks))
    truths = np.stack([i * 20.0 + k, ones, k * ones, ones], axis=-1)
    estimates = truths + rng.normal(0, 1, truths.shape)
    paths, tracks = set(), set()
    for j in range(n_tracks):
        path, track = GroundTruthPath(), Track()
        for step in range(steps):
            path.append(GroundTruthState(truths[step, j].reshape(4, 1),
                                         timestamp=T0 + step * DT))
            track.append(GaussianState(estimates[step, j].reshape(4, 1), np.eye(4),
                                       timestamp=T0 + step * DT))
        paths.add(path)
        tracks.add(track)
    return truths, estimates, paths, tracks


def _native(truths, estimates):
    truths, estimates = list(truths), list(estimates)
    return lambda: gospa_over_time(truths, estimates, 10, 1)


def _time(benchmark, implementation, run):
    result = benchmark.pedantic(run, rounds=3 if implementation == "stonesoup" else 30,
                                iterations=1,
                                warmup_rounds=0 if implementation == "stonesoup" else 1)
    distances = result.distance if implementation == "fasttrack" else [
        step.value["distance"] for step in result.value]
    assert len(distances) == STEPS


@pytest.mark.parametrize("implementation", ["dropin", "stonesoup", "fasttrack"])
def test_gospa_over_time(benchmark, implementation):
    """The baseline's call: ``compute_over_time(*extract_states(...), *extract_states(...))``."""
    benchmark.group = f"dropin-gospa-{N_TRACKS}-tracks N={STEPS}"
    truths, estimates, paths, tracks = _workload()
    if implementation == "fasttrack":
        run = _native(truths, estimates)
    else:
        metric = (fss.GOSPAMetric if implementation == "dropin" else GOSPAMetric)(c=10, p=1)

        def run():
            return metric.compute_over_time(*metric.extract_states(tracks, True),
                                            *metric.extract_states(paths, True))
    _time(benchmark, implementation, run)


@pytest.mark.parametrize("implementation", ["dropin", "stonesoup", "fasttrack"])
def test_gospa_compute_metric(benchmark, implementation):
    """``compute_metric`` of a MultiManager holding the tracks and the truths."""
    benchmark.group = f"dropin-gospa-manager-{N_TRACKS}-tracks N={STEPS}"
    truths, estimates, paths, tracks = _workload()
    if implementation == "fasttrack":
        run = _native(truths, estimates)
    else:
        metric = (fss.GOSPAMetric if implementation == "dropin" else GOSPAMetric)(c=10, p=1)
        manager = MultiManager([metric])
        manager.add_data({"groundtruth_paths": paths, "tracks": tracks})

        def run():
            return metric.compute_metric(manager)
    _time(benchmark, implementation, run)


def test_dropin_gospa_equals_stonesoup():
    """The benchmarked drop-in gives Stone Soup's values (smoke-run check)."""
    _, _, paths, tracks = _workload(10, 20)
    ours, theirs = fss.GOSPAMetric(c=10, p=1), GOSPAMetric(c=10, p=1)
    mine = ours.compute_over_time(*ours.extract_states(tracks, True),
                                  *ours.extract_states(paths, True))
    reference = theirs.compute_over_time(*theirs.extract_states(tracks, True),
                                         *theirs.extract_states(paths, True))
    for a, b in zip(mine.value, reference.value):
        assert a.timestamp == b.timestamp
        assert a.value == pytest.approx(b.value, rel=1e-9, abs=1e-9)
