"""Monte Carlo evaluation: many independent runs of a filter on a simulated scenario, scored
against the truth, on the local machine's cores or on a Dask cluster.

Run ``i`` of ``run_trials(..., seed=s)`` is seeded by ``run_seed = numpy.random.SeedSequence(
s).spawn(n_runs)[i]`` alone: its scenario is drawn from ``run_seed.spawn(2)[0]`` and its filter
from a Generator on ``run_seed.spawn(2)[1]``. Its results therefore do not depend on how the
runs are spread over processes, workers or batches.
"""
import collections
import contextlib
import dataclasses
import math
import multiprocessing
import multiprocessing.connection
import numbers
import os
import pickle
import sys
import time
import traceback
import warnings

import numpy as np

from ._validate import count
from .types import (GaussianMeasurementPrediction, GaussianState, SingleHypothesis,
                    time_interval)

#: The metrics a run can record per step.
METRICS = ("position_error", "nees", "nis", "ess", "step_seconds")
_SUMMARIES = {"position_error": "rmse", "nees": "anees", "nis": "anis", "ess": "mean_ess",
              "step_seconds": "step_seconds"}
_INSTALL = "pip install 'fasttrack[distributed]'"


def run_seeds(seed, n_runs):
    """The per-run seeds of ``run_trials(..., n_runs, seed=seed)``:
    ``numpy.random.SeedSequence(seed).spawn(n_runs)``."""
    return _children(_root_seed(seed), count(n_runs, "n_runs"))


def _root_seed(seed):
    if seed is None or isinstance(seed, np.random.SeedSequence):
        return np.random.SeedSequence(seed) if seed is None else seed
    if not isinstance(seed, numbers.Integral) or isinstance(seed, bool):
        raise TypeError(f"seed must be None, an int or a numpy.random.SeedSequence, "
                        f"got {type(seed).__name__}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    return np.random.SeedSequence(int(seed))


def _check_mapping(mapping):
    """``position_mapping`` as a list of distinct non-negative ints."""
    index = list(mapping) if isinstance(mapping, (list, tuple, np.ndarray)) else None
    if (not index or len(set(index)) != len(index)
            or not all(isinstance(i, numbers.Integral) and i >= 0 for i in index)):
        raise ValueError(f"position_mapping must be distinct non-negative state indices, "
                         f"got {mapping!r}")
    return [int(i) for i in index]


def _check_mapping_fits(world, mapping):
    """Raise if ``position_mapping`` indexes beyond the states of a run's scenario."""
    ndim = getattr(world.prior, "ndim", None)
    if ndim is not None and max(mapping) >= ndim:
        raise ValueError(f"position_mapping {tuple(mapping)} is outside the scenario's "
                         f"{ndim}-dimensional states")


def _children(seed, n):
    """What ``seed.spawn(n)`` gives on a fresh ``seed``, whatever it has spawned already."""
    return [np.random.SeedSequence(seed.entropy, spawn_key=seed.spawn_key + (k,),
                                   pool_size=seed.pool_size) for k in range(n)]


def _row_dtype(metrics):
    return np.dtype([("run", np.int64), ("step", np.int64), ("time", np.float64)]
                    + [(name, np.float64) for name in metrics])


def _check_metrics(metrics):
    metrics = tuple(metrics)
    unknown = [m for m in metrics if m not in METRICS]
    if unknown or not metrics or len(set(metrics)) != len(metrics):
        raise ValueError(f"metrics must be distinct names among {', '.join(METRICS)}; "
                         f"got {list(metrics)}")
    return metrics


def _quadratic_form(error, covar):
    """``e^T C^-1 e`` by a Cholesky solve."""
    half = np.linalg.solve(np.linalg.cholesky(covar), error)
    return float(half @ half)


def _score(metrics, posterior, truth, hypothesis, model, mapping, effective, seconds):
    """The ``metrics`` of one step (NaN where one does not apply to the filter)."""
    out = []
    for name in metrics:
        if name == "position_error":
            error = np.ravel(posterior.mean)[mapping] - np.ravel(truth.state_vector)[mapping]
            out.append(math.sqrt(error @ error))
        elif name == "nees":
            out.append(_quadratic_form(np.ravel(posterior.mean) - np.ravel(truth.state_vector),
                                       posterior.covar)
                       if isinstance(posterior, GaussianState) else np.nan)
        elif name == "nis":
            predicted = hypothesis.measurement_prediction
            if isinstance(predicted, GaussianMeasurementPrediction):
                innovation = (np.ravel(hypothesis.measurement.state_vector)
                              - np.ravel(predicted.state_vector))[:, None]
                out.append(_quadratic_form(model.wrap(innovation)[:, 0], predicted.covar))
            else:
                out.append(np.nan)
        else:
            out.append(effective if name == "ess" else seconds)
    return out


def run_trial(scenario, make_filter, run_seed, metrics=METRICS, position_mapping=(0, 2)):
    """Track one run and score every step: what :func:`run_trials` does for each run.

    Parameters
    ----------
    scenario, make_filter, metrics, position_mapping
        As for :func:`run_trials`.
    run_seed : numpy.random.SeedSequence
        The run's seed, e.g. ``run_seeds(seed, n_runs)[i]`` or a failure's ``seed``.

    Returns
    -------
    numpy.ndarray
        The run's rows of the table of :class:`TrialResults` (``run`` = -1).

    Raises
    ------
    Exception
        Whatever the scenario, the filter or the scoring raises.
    """
    metrics = _check_metrics(metrics)
    mapping = _check_mapping(position_mapping)
    if not isinstance(run_seed, np.random.SeedSequence):
        raise TypeError(f"run_seed must be a numpy.random.SeedSequence (see run_seeds), "
                        f"got {type(run_seed).__name__}")
    scenario_seed, filter_seed = _children(run_seed, 2)
    world = scenario(seed=scenario_seed)
    _check_mapping_fits(world, mapping)
    predictor, updater = make_filter(world, np.random.default_rng(filter_seed))
    truth = {state.timestamp: state for state in world.truth}
    rows = np.zeros(len(world.detections), _row_dtype(metrics))
    rows["run"] = -1
    state, start = world.prior, None
    for step, detection in enumerate(world.detections):
        if detection.timestamp not in truth:
            raise ValueError(f"the scenario has no true state at detection {step}'s time "
                             f"{detection.timestamp}")
        start = detection.timestamp if start is None else start
        tic = time.perf_counter()
        hypothesis = SingleHypothesis(predictor.predict(state, timestamp=detection.timestamp),
                                      detection)
        state = updater.update(hypothesis)
        effective = getattr(state, "ess", None)  # a particle filter's, before resampling
        effective = np.nan if effective is None else effective
        seconds = time.perf_counter() - tic
        elapsed = time_interval(detection.timestamp, start, "detection.timestamp")
        model = detection.measurement_model or getattr(updater, "measurement_model", None)
        rows[step] = (-1, step, elapsed,
                      *_score(metrics, state, truth[detection.timestamp], hypothesis, model,
                              mapping, effective, seconds))
    return rows


@dataclasses.dataclass(frozen=True)
class RunFailure:
    """A run that raised: its index, ``seed`` (a SeedSequence: ``run_trial(..., seed)``
    reproduces it), the error as ``'Type: message'``, and the traceback text."""

    run: int
    seed: np.random.SeedSequence
    error: str
    traceback: str


@dataclasses.dataclass(frozen=True)
class MetricSummary:
    """A per-run statistic over the completed runs: ``mean`` and its confidence interval
    [``low``, ``high``] (Student t), from ``runs`` runs where it is defined."""

    metric: str
    mean: float
    low: float
    high: float
    runs: int


class TrialResults:
    """The results of :func:`run_trials`.

    Attributes
    ----------
    table : numpy.ndarray
        Tidy structured array, one row per (run, step), sorted: ``run``, ``step``, ``time``
        (seconds since the run's first detection), then one float64 column per metric:
        ``position_error`` (Euclidean distance of the posterior mean's position from the
        truth, in state units), ``nees`` and ``nis`` (normalised estimation error and
        innovation squared, Gaussian filters), ``ess`` (effective sample size of the weights
        before resampling, particle filters), ``step_seconds`` (wall time of predict +
        update). NaN where a metric does not apply. Failed runs have no rows.
    failures : list of RunFailure
    seed : numpy.random.SeedSequence
        The root seed; ``seed.entropy`` reproduces the whole evaluation.
    n_runs : int
    """

    def __init__(self, table, failures, seed, n_runs):
        self.table = table
        self.failures = failures
        self.seed = seed
        self.n_runs = n_runs

    @property
    def metrics(self):
        """The metric columns of :attr:`table`."""
        return self.table.dtype.names[3:]

    def per_run(self):
        """One row per completed run: ``run`` and each metric's per-run statistic (``rmse``
        over steps of the position error, ``anees``, ``anis``, ``mean_ess`` and
        ``step_seconds`` as means over steps)."""
        runs, starts = np.unique(self.table["run"], return_index=True)
        out = np.zeros(len(runs), [("run", np.int64)]
                       + [(_SUMMARIES[m], np.float64) for m in self.metrics])
        out["run"] = runs
        for metric in self.metrics:
            values = self.table[metric]
            if metric == "position_error":
                values = values ** 2
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                column = np.array([np.nanmean(chunk) if np.isfinite(chunk).any() else np.nan
                                   for chunk in np.split(values, starts[1:])])
            out[_SUMMARIES[metric]] = np.sqrt(column) if metric == "position_error" else column
        return out

    def summary(self, confidence=0.95):
        """The mean over runs of each per-run statistic (see :meth:`per_run`), with a
        ``confidence`` interval.

        Returns
        -------
        list of MetricSummary
            One per statistic defined for at least one run.
        """
        from scipy import stats
        if not 0 < confidence < 1:
            raise ValueError(f"confidence must be in (0, 1), got {confidence}")
        per_run = self.per_run()
        out = []
        for name in per_run.dtype.names[1:]:
            values = per_run[name][np.isfinite(per_run[name])]
            n = len(values)
            if n == 0:
                continue
            mean = float(np.mean(values))
            half = (stats.t.ppf(0.5 + confidence / 2, n - 1) * np.std(values, ddof=1)
                    / math.sqrt(n)) if n > 1 else np.nan
            out.append(MetricSummary(name, mean, mean - half, mean + half, n))
        return out

    def rmse_over_time(self):
        """Position RMSE over the completed runs at each step, (steps,)."""
        steps = self.table["step"]
        squared = np.bincount(steps, self.table["position_error"] ** 2)
        return np.sqrt(squared / np.bincount(steps))

    def to_dataframe(self):
        """:attr:`table` as a pandas DataFrame (needs pandas)."""
        try:
            import pandas
        except ImportError:
            raise ImportError("to_dataframe needs pandas: pip install pandas") from None
        return pandas.DataFrame(self.table)

    def __str__(self):
        lines = [f"{self.n_runs - len(self.failures)} of {self.n_runs} runs completed "
                 f"(seed entropy {self.seed.entropy})",
                 f"{'metric':<14}{'mean':>12}{'95% interval':>28}{'runs':>7}"]
        for s in self.summary():
            lines.append(f"{s.metric:<14}{s.mean:>12.5g}   [{s.low:>11.5g}, {s.high:>11.5g}]"
                         f"{s.runs:>7}")
        lines += [f"run {f.run} failed: {f.error}" for f in self.failures]
        return "\n".join(lines)


def _run_batch(payload, runs):
    """Run ``runs`` (index, seed) pairs in this process: the task of a worker.

    ``payload`` is the pickled (scenario, make_filter, metrics, position_mapping, threads).
    Returns the rows of the completed runs and the failures."""
    scenario, make_filter, metrics, mapping, threads = pickle.loads(payload)
    if threads is not None:
        import numba
        from .threads import set_threads
        set_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    tables, failures = [], []
    for run, run_seed in runs:
        try:
            rows = run_trial(scenario, make_filter, run_seed, metrics, mapping)
        except Exception as error:  # a failing run is reported, the others go on
            failures.append(RunFailure(run, run_seed, f"{type(error).__name__}: {error}",
                                       traceback.format_exc()))
            continue
        rows["run"] = run
        tables.append(rows)
    return tables, failures


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


def _serialise(scenario, make_filter, metrics, mapping, threads):
    """The pickled payload of the tasks (cloudpickle when installed, so that lambdas and
    functions defined in ``__main__`` travel too)."""
    try:
        import cloudpickle as pickler
    except ImportError:
        pickler = pickle
    try:
        return pickler.dumps((scenario, make_filter, metrics, mapping, threads))
    except Exception as error:
        raise TypeError(f"scenario and make_filter must be picklable to run in other "
                        f"processes (define them at module level, install cloudpickle, or "
                        f"pass processes=1): {error}") from error


def _local_cores():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class _Worker:
    """One spawned worker process and the pipe it takes tasks from."""

    def __init__(self, context):
        self.connection, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child,), daemon=True)
        self.process.start()
        child.close()

    def stop(self):
        self.connection.close()
        if self.process.is_alive():
            self.process.terminate()
        self.process.join()


def _serve(connection):
    """A worker's loop: run each ``(payload, batch)`` task received, send back
    ``("ok", result)`` or, if the batch could not run at all, ``("error", message)``."""
    while True:
        try:
            payload, batch = connection.recv()
        except (EOFError, OSError):
            return
        try:
            reply = ("ok", _run_batch(payload, batch))
        except Exception as error:
            reply = ("error", f"{type(error).__name__}: {error}\n{traceback.format_exc()}")
        connection.send(reply)


class _Pool:
    """``processes`` spawned worker processes, each running one batch at a time, kept
    between calls so that their kernels stay compiled (they end with the interpreter).

    Each batch is sent to one worker, so a worker that dies costs only the batch it was
    running: that batch is charged one attempt and queued again, a new worker takes the
    dead one's place, and the other workers go on.
    """

    def __init__(self, processes):
        self.context = multiprocessing.get_context("spawn")
        self.workers = [_Worker(self.context) for _ in range(processes)]

    def run(self, payload, batches, max_retries):
        """Yield each batch's result; a batch whose worker died more than ``max_retries``
        times has all its runs failed."""
        queue = collections.deque(range(len(batches)))
        attempts = [0] * len(batches)
        running = {}  # worker -> batch index
        try:
            while queue or running:
                for worker in list(self.workers):
                    if queue and worker not in running:
                        i = queue.popleft()
                        running[self._send(worker, payload, batches[i])] = i
                waiting = {w.connection: w for w in running}
                waiting.update({w.process.sentinel: w for w in running})
                done = {waiting[ready] for ready in multiprocessing.connection.wait(waiting)}
                for worker in done:
                    i = running.pop(worker)
                    reply = self._reply(worker)
                    if reply is not None:
                        yield batches[i], _result(batches[i], reply)
                        continue
                    attempts[i] += 1
                    if attempts[i] > max_retries:
                        yield batches[i], _lost(batches[i], f"the worker process died "
                                                            f"{attempts[i]} times")
                    else:
                        queue.appendleft(i)
        finally:  # an interrupted call leaves no work behind: its workers are replaced
            for worker in running:
                self._replace(worker)

    def _send(self, worker, payload, batch):
        """Send the task to ``worker``, or to its replacement if it has died while idle;
        returns the worker that took it."""
        try:
            worker.connection.send((payload, batch))
            return worker
        except (BrokenPipeError, OSError):
            worker = self._replace(worker)
            worker.connection.send((payload, batch))
            return worker

    def _reply(self, worker):
        """The worker's reply, or None if it died (it is then replaced)."""
        try:
            if worker.connection.poll():
                return worker.connection.recv()
        except (EOFError, OSError):
            pass
        self._replace(worker)
        return None

    def _replace(self, worker):
        """Stop ``worker`` and start a new one in its place; returns the new one."""
        worker.stop()
        new = _Worker(self.context)
        self.workers[self.workers.index(worker)] = new
        return new

    def shutdown(self):
        for worker in self.workers:
            worker.stop()
        self.workers = []


def _result(batch, reply):
    """A batch's result from a worker's reply: an error fails every run of the batch."""
    status, value = reply
    if status == "ok":
        return value
    message, _, details = value.partition("\n")
    return [], [RunFailure(run, seed, message, details) for run, seed in batch]


_pool = {}


def _local_pool(processes):
    """The :class:`_Pool` of ``processes`` workers (a pool of another size is shut down)."""
    if processes not in _pool:
        for old in _pool.values():
            old.shutdown()
        _pool.clear()
        _pool[processes] = _Pool(processes)
    return _pool[processes]


def _run_local(payload, batches, processes, max_retries):
    """Yield each batch's result, in this process or in the pool of worker processes."""
    if processes == 1:
        for batch in batches:
            yield batch, _run_batch(payload, batch)
        return
    yield from _local_pool(processes).run(payload, batches, max_retries)


def _lost(batch, reason):
    """The result of a batch that could not be run: every run failed with ``reason``."""
    return [], [RunFailure(run, seed, f"WorkerLost: {reason}", "") for run, seed in batch]


def _run_dask(client, payload, batches):
    """Yield each batch's result from ``client``'s cluster."""
    try:
        from distributed import as_completed
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise ImportError(f"run_trials with a client needs Dask: {_INSTALL}") from None
    futures = {client.submit(_run_batch, payload, batch, pure=False): batch
               for batch in batches}
    try:
        for future in as_completed(futures):
            batch = futures[future]
            try:
                result = future.result()
            except KilledWorker as error:
                result = _lost(batch, f"Dask gave up on the task: {error}")
            yield batch, result
    finally:  # an interrupted call leaves no queued work behind
        client.cancel(list(futures))


@contextlib.contextmanager
def local_cluster(n_workers=None):
    """A ``distributed.Client`` on a new Dask ``LocalCluster`` of ``n_workers`` worker
    processes (default: the usable cores) with one thread each, closed on exit::

        with local_cluster(2) as client:
            results = run_trials(scenario, make_filter, 1000, client=client)
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ImportError(f"a Dask cluster needs Dask: {_INSTALL}") from None
    n_workers = count(n_workers, "n_workers", default=_local_cores())
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        yield client


@contextlib.contextmanager
def _client(client):
    """The ``distributed.Client`` given, or one connected to the scheduler address given
    (closed on exit)."""
    if not isinstance(client, str):
        yield client
        return
    try:
        from distributed import Client
    except ImportError:
        raise ImportError(f"connecting to a Dask scheduler needs Dask: {_INSTALL}") from None
    with Client(client) as connected:
        yield connected


def run_trials(scenario, make_filter, n_runs, seed=None, metrics=METRICS, client=None,
               batch_size=None, processes=None, position_mapping=(0, 2), progress=True,
               max_retries=2):
    """Track ``n_runs`` independent runs of a scenario and score them.

    Parameters
    ----------
    scenario : callable
        ``scenario(seed=seed_sequence)`` returns a run's
        :class:`~fasttrack.scenarios.Scenario` (``truth``, time-ordered ``detections``, one
        per step at times of the truth, and the filter's ``prior``), drawing everything from
        the seed, e.g. ``functools.partial(particle_filter_tutorial, n_particles=1000)``.
    make_filter : callable
        ``make_filter(scenario, rng)`` returns ``(predictor, updater)`` for one run (any of
        fasttrack's particle, Kalman, extended Kalman or adaptive kernel filters), drawing
        its randomness from the Generator ``rng``.
    n_runs : int
        Number of runs, >= 1.
    seed : None, int or numpy.random.SeedSequence
        Root seed (None: fresh entropy, kept in ``results.seed``).
    metrics : sequence of str
        Among ``METRICS``: 'position_error', 'nees', 'nis', 'ess', 'step_seconds'.
    client : distributed.Client or str, optional
        Run on this Dask cluster (or the scheduler at this address) instead of locally.
    batch_size : int, optional
        Runs per task (default: about four tasks per worker, at most 100 runs each). Larger
        batches cost less scheduling; each worker process keeps its compiled kernels across
        batches.
    processes : int, optional
        Local worker processes (default: the usable cores). With 1, runs in this process at
        its Numba thread count; otherwise each worker runs one run at a time on one thread,
        and the workers are kept for the next call (their kernels stay compiled).
        Not with a client (Dask workers also run each task on one Numba thread).
    position_mapping : sequence of int
        State components of the position.
    progress : bool
        Show a progress bar on stderr when the work takes over a second.
    max_retries : int
        Times a batch whose local worker process died is rerun (Dask retries tasks of lost
        workers by its own ``allowed-failures`` setting).

    Returns
    -------
    TrialResults
        Failed runs are in ``results.failures`` with their seed and error (and a warning
        says how many); the other runs complete.
    """
    n_runs = count(n_runs, "n_runs")
    metrics = _check_metrics(metrics)
    max_retries = count(max_retries, "max_retries", minimum=0)
    if client is not None and processes is not None:
        raise ValueError("processes is for local runs; with a client, the cluster's "
                         "workers run the tasks")
    root = _root_seed(seed)
    mapping = _check_mapping(position_mapping)
    if client is None:
        _check_mapping_fits(scenario(seed=_children(_children(root, 1)[0], 2)[0]), mapping)
        processes = _local_cores() if processes is None else count(processes, "processes")
        batches = _batches(root, n_runs, batch_size, processes)
        payload = _serialise(scenario, make_filter, metrics, mapping,
                             None if processes == 1 else 1)
        return _collect(_run_local(payload, batches, processes, max_retries), root, n_runs,
                        metrics, progress)
    with _client(client) as connected:
        batches = _batches(root, n_runs, batch_size, sum(connected.nthreads().values()))
        payload = _serialise(scenario, make_filter, metrics, mapping, 1)
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
    if failures:
        warnings.warn(f"{len(failures)} of {n_runs} runs failed (first: run {failures[0].run}, "
                      f"{failures[0].error}); see results.failures", RuntimeWarning,
                      stacklevel=3)
    return TrialResults(table, failures, root, n_runs)
