"""Monte Carlo evaluation: many independent runs of a filter on a simulated scenario, scored
against the truth, on the local machine's cores or on a Dask cluster.

Run ``i`` of ``run_trials(..., seed=s)`` is seeded by ``run_seed = numpy.random.SeedSequence(
s).spawn(n_runs)[i]`` alone: its scenario is drawn from ``run_seed.spawn(2)[0]`` and its filter
from a Generator on ``run_seed.spawn(2)[1]``. Its results therefore do not depend on how the
runs are spread over processes, workers or batches.

Modules, one job each: :mod:`~fasttrack.montecarlo.runner` (``run_trials``),
:mod:`~fasttrack.montecarlo.trial` (one run and its seeds), :mod:`~fasttrack.montecarlo.results`,
:mod:`~fasttrack.montecarlo.metrics` (what a step records) and
:mod:`~fasttrack.montecarlo.workers` (local processes and Dask); every public name is
importable from here.
"""
from .metrics import METRICS, MULTI_TARGET_METRICS
from .results import MetricSummary, RunFailure, TrialResults
from .runner import run_trials
from .trial import run_seeds, run_trial
from .workers import local_cluster

__all__ = ["METRICS", "MULTI_TARGET_METRICS", "MetricSummary", "RunFailure", "TrialResults", "local_cluster",
           "run_seeds", "run_trial", "run_trials"]
