"""The results of many runs: a tidy table, failures, and summaries with confidence
intervals."""
import dataclasses
import math
import warnings

import numpy as np

from .._validate import real
from .metrics import _SUMMARIES


@dataclasses.dataclass(frozen=True)
class RunFailure:
    """A run that raised: its index, ``seed`` (a SeedSequence: ``run_trial(..., seed)``
    reproduces it), the error as ``'Type: message'``, and the traceback text.

    Parameters
    ----------
    run : int
        Index of the run, in [0, n_runs).
    seed : numpy.random.SeedSequence
        The run's seed.
    error : str
        ``'Type: message'`` of the exception.
    traceback : str
        The formatted traceback (empty if the run's worker was lost).
    """

    run: int
    seed: np.random.SeedSequence
    error: str
    traceback: str


@dataclasses.dataclass(frozen=True)
class MetricSummary:
    """A per-run statistic over the completed runs: ``mean`` and its confidence interval
    [``low``, ``high``], from ``runs`` runs where it is defined.

    Every statistic is non-negative, so the interval is the Student t interval of
    ``log(mean)`` (delta method), ``mean * exp(-h) .. mean * exp(h)`` with
    ``h = t * s / (mean * sqrt(runs))``: it never goes below zero, and for a small relative
    error ``s / mean`` it equals the usual ``mean +- t * s / sqrt(runs)``. NaN bounds from a
    single run.

    Parameters
    ----------
    metric : str
        Name of the per-run statistic: a column of :meth:`TrialResults.per_run`
        (e.g. 'rmse', 'anees', 'mean_gospa' or 'step_seconds').
    mean : float
        Mean over the runs.
    low, high : float
        Bounds of the confidence interval.
    runs : int
        Number of runs where the statistic is defined.
    """

    metric: str
    mean: float
    low: float
    high: float
    runs: int


class TrialResults:
    """The results of :func:`run_trials`.

    Parameters
    ----------
    table : numpy.ndarray
        The tidy table (see the attributes).
    failures : list of RunFailure
        The failed runs.
    seed : numpy.random.SeedSequence
        The root seed.
    n_runs : int
        Number of runs, completed or failed.

    Attributes
    ----------
    table : numpy.ndarray
        Tidy structured array, one row per (run, step), sorted: ``run``, ``step``, ``time``
        (seconds since the run's first detection), then one float64 column per metric:
        ``position_error`` (Euclidean distance of the posterior mean's position from the
        truth, in state units), ``nees`` and ``nis`` (normalised estimation error and
        innovation squared, Gaussian filters; a mixture's, e.g. an IMM's, NEES is its
        moment-matched Gaussian's and its NIS NaN), ``ess`` (effective sample size of the
        weights before resampling, particle filters), ``step_seconds`` (wall time of predict +
        update); for a multi-target tracker, per scan, ``gospa`` and its parts
        ``gospa_localisation``, ``gospa_missed`` and ``gospa_false`` (position units,
        p = 1), ``n_tracks``, ``cardinality_error`` (the distance of ``n_tracks`` from the
        number of targets) and ``step_seconds``. NaN where a metric does not apply.
        Failed runs have no rows.
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
        over steps of the position error; the others, ``anees``, ``anis``, ``mean_ess``,
        ``mean_gospa``, ``mean_localisation``, ``mean_missed``, ``mean_false``,
        ``mean_tracks``, ``mean_cardinality_error`` and ``step_seconds``, means over
        steps)."""
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

        Parameters
        ----------
        confidence : float
            Confidence level of the interval, in (0, 1).

        Returns
        -------
        list of MetricSummary
            One per statistic defined for at least one run.
        """
        from scipy import stats
        confidence = real(confidence, "confidence")
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
            if n == 1:
                low = high = np.nan
            elif mean == 0.0:
                low = high = 0.0
            else:
                relative = np.std(values, ddof=1) / (mean * math.sqrt(n))
                factor = math.exp(stats.t.ppf(0.5 + confidence / 2, n - 1) * relative)
                low, high = mean / factor, mean * factor
            out.append(MetricSummary(name, mean, low, high, n))
        return out

    def rmse_over_time(self):
        """Position RMSE over the completed runs at each step, (steps,)."""
        if "position_error" not in self.metrics:
            raise ValueError(f"rmse_over_time needs the metric 'position_error'; these results "
                             f"have {list(self.metrics)} (see mean_over_time)")
        steps = self.table["step"]
        squared = np.bincount(steps, self.table["position_error"] ** 2)
        return np.sqrt(squared / np.bincount(steps))

    def mean_over_time(self, metric):
        """The mean of a metric over the completed runs at each step.

        Parameters
        ----------
        metric : str
            A metric column of :attr:`table`, e.g. 'gospa'.

        Returns
        -------
        (steps,) float64 ndarray
            NaN where no run defines the metric.
        """
        if metric not in self.metrics:
            raise ValueError(f"metric must be one of {list(self.metrics)}, got {metric!r}")
        values, steps = self.table[metric], self.table["step"]
        defined = np.isfinite(values)
        with np.errstate(invalid="ignore", divide="ignore"):
            return (np.bincount(steps[defined], values[defined], minlength=steps.max() + 1)
                    / np.bincount(steps[defined], minlength=steps.max() + 1))

    def to_dataframe(self):
        """:attr:`table` as a pandas DataFrame (needs pandas)."""
        try:
            import pandas
        except ImportError:
            raise ImportError("to_dataframe needs pandas: pip install pandas") from None
        return pandas.DataFrame(self.table)

    def __str__(self):
        summaries = self.summary()
        width = max([len(s.metric) for s in summaries] + [12]) + 2
        lines = [f"{self.n_runs - len(self.failures)} of {self.n_runs} runs completed "
                 f"(seed entropy {self.seed.entropy})",
                 f"{'metric':<{width}}{'mean':>12}{'95% interval':>28}{'runs':>7}"]
        for s in summaries:
            lines.append(f"{s.metric:<{width}}{s.mean:>12.5g}   [{s.low:>11.5g}, "
                         f"{s.high:>11.5g}]{s.runs:>7}")
        lines += [f"run {f.run} failed: {f.error}" for f in self.failures]
        return "\n".join(lines)
