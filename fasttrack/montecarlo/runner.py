"""``run_trials``: batches of runs spread over the local cores or a Dask cluster, collected
as they finish, with a progress bar."""
import math
import sys
import time
import warnings

import numpy as np

from .._validate import count, flag, storable
from ..simulate import BYTES_PER_STATE, MultiTargetScenario
from .metrics import _check_mapping, _check_mapping_fits, _check_metrics, _row_dtype
from .workers import _client, _local_cores, _run_dask, _run_local, _serialise, check_main_guard
from .trial import _check_run, _children, _root_seed, _world
from .results import TrialResults


#: The most local worker processes a call starts (each holds its own compiled kernels).
MAX_PROCESSES = 1024


class _Progress:
    """A progress bar on stderr, shown once the work has taken a second; on a terminal it
    redraws in place, elsewhere it prints a line every tenth of the work."""

    def __init__(self, total, enabled):
        self.total, self.enabled = total, enabled
        self.done, self.start, self.shown = 0, time.perf_counter(), False
        self.tty = sys.stderr.isatty()
        self.next_line = 0.1

    def advance(self, n):
        self.done += n
        elapsed = time.perf_counter() - self.start
        if not self.enabled or elapsed < 1.0:
            return
        fraction = self.done / self.total
        if not self.tty and fraction < self.next_line and self.done < self.total:
            return
        self.next_line = math.floor(fraction * 10 + 1) / 10
        rate = self.done / elapsed
        eta = (self.total - self.done) / rate if rate else math.inf
        bar = "#" * int(30 * fraction)
        line = (f"[{bar:<30}] {self.done}/{self.total} runs, {rate:.1f} runs/s, "
                f"{eta:.0f} s left")
        print(f"\r{line}" if self.tty else line, end="" if self.tty else "\n",
              file=sys.stderr, flush=True)
        self.shown = True

    def close(self):
        if self.shown and self.tty:
            print(file=sys.stderr, flush=True)


def run_trials(scenario, make_filter, n_runs, seed=None, metrics=None, client=None,
               batch_size=None, processes=None, position_mapping=(0, 2), progress=True,
               max_retries=2, gospa_cutoff=10.0):
    """Track ``n_runs`` independent runs of a scenario and score them.

    Parameters
    ----------
    scenario : callable
        ``scenario(seed=seed_sequence)`` returns a run's
        :class:`~fasttrack.scenarios.Scenario` (``truth``, time-ordered ``detections``, one
        per step at times of the truth, and the filter's ``prior``), drawing everything from
        the seed, e.g. ``functools.partial(particle_filter_tutorial, n_particles=1000)``;
        or a multi-target :class:`~fasttrack.simulate.MultiTargetScenario` (e.g.
        :func:`~fasttrack.scenarios.grid_targets`).
    make_filter : callable
        ``make_filter(scenario, rng)`` returns ``(predictor, updater)`` for one run (any of
        fasttrack's particle, Kalman, extended Kalman or adaptive kernel filters), drawing
        its randomness from the Generator ``rng``; for a multi-target scenario, a tracker
        whose ``step(detections, time)`` returns the tracks (with ``means`` (K, d)), such as
        :class:`~fasttrack.tracker.MultiTargetTracker`, or the estimates of
        :class:`~fasttrack.phd.PHDTracker` and :class:`~fasttrack.phd.CPHDTracker`.
    n_runs : int
        Number of runs, >= 1.
    seed : None, int or numpy.random.SeedSequence
        Root seed (None: fresh entropy, kept in ``results.seed``).
    metrics : sequence of str, optional
        Among ``METRICS`` ('position_error', 'nees', 'nis', 'ess', 'step_seconds') for a
        filter, or ``MULTI_TARGET_METRICS`` ('gospa', 'gospa_localisation', 'gospa_missed',
        'gospa_false', 'n_tracks', 'cardinality_error', 'step_seconds') for a multi-target
        tracker (default: all of the kind).
    client : distributed.Client or str, optional
        Run on this Dask cluster (or the scheduler at this address) instead of locally.
    batch_size : int, optional
        Runs per task (default: about four tasks per worker, at most 100 runs each). Larger
        batches cost less scheduling; each worker process keeps its compiled kernels across
        batches.
    processes : int, optional
        Local worker processes, at most 1024 (default: the usable cores). With 1, runs in
        this process at its Numba thread count; otherwise each worker runs one run at a time
        on one thread, and the workers are kept for the next call (their kernels stay
        compiled).
        Not with a client (Dask workers also run each task on one Numba thread).
    position_mapping : sequence of int
        State components of the position.
    progress : bool
        Show a progress bar on stderr when the work takes over a second.
    max_retries : int
        Times a batch whose local worker process died is rerun (Dask retries tasks of lost
        workers by its own ``allowed-failures`` setting).
    gospa_cutoff : float
        The GOSPA cut-off c of a multi-target scenario, in position units, in
        [1e-300, 1e300].

    Returns
    -------
    TrialResults
        Failed runs are in ``results.failures`` with their seed and error (and a warning
        says how many); the other runs complete.

    Raises
    ------
    RuntimeError
        If every run failed (with the first failure's error; the exception's ``results``
        holds them all), or if worker processes would
        re-run the calling script: a script that calls ``run_trials`` with worker processes
        must do so under ``if __name__ == "__main__":``.
    """
    n_runs = count(n_runs, "n_runs")
    storable(n_runs, BYTES_PER_STATE, "n_runs")  # (a seed and a table row a run, at least)
    max_retries = count(max_retries, "max_retries", minimum=0)
    if client is not None and processes is not None:
        raise ValueError("processes is for local runs; with a client, the cluster's "
                         "workers run the tasks")
    if client is not None and not isinstance(client, str) \
            and not all(callable(getattr(client, name, None)) for name in ("submit", "nthreads")):
        raise TypeError(f"client must be a distributed.Client or a scheduler's address (a "
                        f"str), got {type(client).__name__}")
    cutoff = _check_run(scenario, make_filter, gospa_cutoff)
    progress = flag(progress, "progress")
    root = _root_seed(seed)
    mapping = _check_mapping(position_mapping)
    first = _world(scenario, _children(_children(root, 1)[0], 2)[0])
    metrics = _check_metrics(metrics, isinstance(first, MultiTargetScenario))
    _check_mapping_fits(first, mapping)
    if client is None:
        processes = _local_cores() if processes is None \
            else count(processes, "processes", maximum=MAX_PROCESSES)
        batches = _batches(root, n_runs, batch_size, processes)
        if processes == 1:  # in this process: nothing to pickle
            payload = (scenario, make_filter, metrics, mapping, cutoff, None)
        else:
            check_main_guard()
            payload = _serialise(scenario, make_filter, metrics, mapping, cutoff, 1)
        return _collect(_run_local(payload, batches, processes, max_retries), root, n_runs,
                        metrics, progress)
    with _client(client) as connected:
        batches = _batches(root, n_runs, batch_size, sum(connected.nthreads().values()))
        payload = _serialise(scenario, make_filter, metrics, mapping, cutoff, 1)
        return _collect(_run_dask(connected, payload, batches), root, n_runs, metrics,
                        progress)


def _batches(root, n_runs, batch_size, workers):
    """The (index, seed) pairs of the runs in batches of ``batch_size`` (default: about
    four batches per worker, at most 100 runs each)."""
    if batch_size is None:
        batch_size = max(1, min(100, math.ceil(n_runs / (4 * max(1, workers)))))
    batch_size = count(batch_size, "batch_size")
    runs = list(enumerate(_children(root, n_runs)))
    return [runs[i:i + batch_size] for i in range(0, n_runs, batch_size)]


def _collect(results, root, n_runs, metrics, progress):
    """The :class:`TrialResults` of the batches' ``results``, as they come in, with the
    progress bar; warns if runs failed."""
    bar = _Progress(n_runs, progress)
    tables, failures = [], []
    try:
        for batch, (batch_tables, batch_failures) in results:
            tables += batch_tables
            failures += batch_failures
            bar.advance(len(batch))
    finally:
        bar.close()
    table = np.concatenate(tables) if tables else np.zeros(0, _row_dtype(metrics))
    table = table[np.lexsort((table["step"], table["run"]))]
    failures.sort(key=lambda f: f.run)
    results = TrialResults(table, failures, root, n_runs)
    if failures and len(failures) == n_runs:
        first = failures[0]
        error = RuntimeError(f"all {n_runs} runs failed (see the error's results.failures); "
                             f"the first, run {first.run}: {first.error}\n{first.traceback}")
        error.results = results
        raise error
    if failures:
        warnings.warn(f"{len(failures)} of {n_runs} runs failed (first: run {failures[0].run}, "
                      f"{failures[0].error}); see results.failures", RuntimeWarning,
                      stacklevel=3)
    return results
