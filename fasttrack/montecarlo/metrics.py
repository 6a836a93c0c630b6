"""What a Monte Carlo run records at each step: position error, NEES, NIS, ESS and step
time of a filter; GOSPA and its parts, the track count and step time of a multi-target
tracker; and the checks of the position mapping."""
import collections.abc
import math

import numpy as np

from .._validate import indices, iterator
from ..types import GaussianMeasurementPrediction, GaussianMixture, GaussianState


#: The metrics a run of a filter can record per step.
METRICS = ("position_error", "nees", "nis", "ess", "step_seconds")
#: The metrics a run of a multi-target tracker can record per scan: the GOSPA distance
#: (p = 1, alpha = 2, cut-off ``gospa_cutoff``) between the true and the tracks' positions,
#: its localisation, missed-target and false-track parts (they add up to it), the number of
#: tracks (or estimates), its distance from the number of targets (the cardinality error),
#: and the wall time of the scan.
MULTI_TARGET_METRICS = ("gospa", "gospa_localisation", "gospa_missed", "gospa_false",
                        "n_tracks", "cardinality_error", "step_seconds")
_SUMMARIES = {"position_error": "rmse", "nees": "anees", "nis": "anis", "ess": "mean_ess",
              "step_seconds": "step_seconds", "gospa": "mean_gospa",
              "gospa_localisation": "mean_localisation", "gospa_missed": "mean_missed",
              "gospa_false": "mean_false", "n_tracks": "mean_tracks",
              "cardinality_error": "mean_cardinality_error"}


def _check_mapping(mapping):
    """``position_mapping`` (a sequence of distinct non-negative ints) as a list."""
    if isinstance(mapping, collections.abc.Mapping):
        raise TypeError(f"position_mapping must be a sequence of state indices, got "
                        f"{type(mapping).__name__}")
    index = indices(mapping, "position_mapping", np.iinfo(np.int64).max, minimum=1)
    if len(set(index)) != len(index):
        raise ValueError(f"position_mapping must be distinct state indices, got {index}")
    return list(index)


def _check_mapping_fits(world, mapping):
    """Raise if ``position_mapping`` indexes beyond the states of a run's scenario."""
    ndim = (world.transition_model.ndim_state if not hasattr(world, "prior")
            else getattr(world.prior, "ndim", None))
    if ndim is not None and max(mapping) >= ndim:
        raise ValueError(f"position_mapping {tuple(mapping)} is outside the scenario's "
                         f"{ndim}-dimensional states")


def _row_dtype(metrics):
    return np.dtype([("run", np.int64), ("step", np.int64), ("time", np.float64)]
                    + [(name, np.float64) for name in metrics])


def _check_metrics(metrics, multi_target=False):
    """``metrics`` as a tuple of distinct known names (None: all of the kind's)."""
    known = MULTI_TARGET_METRICS if multi_target else METRICS
    if metrics is None:
        return known
    metrics = tuple(iterator(metrics, "metrics"))
    unknown = [m for m in metrics if m not in known]
    if unknown or not metrics or len(set(metrics)) != len(metrics):
        kind = "a multi-target scenario's" if multi_target else "a filter's"
        raise ValueError(f"metrics must be distinct names among {kind} "
                         f"{', '.join(known)}; got {list(metrics)}")
    return metrics


def _quadratic_form(error, covar, metric):
    """``e^T C^-1 e`` by a Cholesky solve; ValueError naming the ``metric`` if C is not
    positive definite."""
    try:
        half = np.linalg.solve(np.linalg.cholesky(covar), error)
    except np.linalg.LinAlgError:
        covariance = "posterior" if metric == "nees" else "innovation"
        raise ValueError(f"metric {metric!r}: the {covariance} covariance is not positive "
                         f"definite, so it has no inverse to weigh the error by (leave "
                         f"{metric!r} out of metrics for this filter)") from None
    return float(half @ half)


def _score(metrics, posterior, truth, hypothesis, model, mapping, effective, seconds):
    """The ``metrics`` of one step (NaN where one does not apply to the filter)."""
    out = []
    for name in metrics:
        if name == "position_error":
            error = np.ravel(posterior.mean)[mapping] - np.ravel(truth.state_vector)[mapping]
            out.append(math.sqrt(error @ error))
        elif name == "nees":  # (of a mixture, e.g. an IMM's: its moment-matched Gaussian)
            out.append(_quadratic_form(np.ravel(posterior.mean) - np.ravel(truth.state_vector),
                                       posterior.covar, name)
                       if isinstance(posterior, (GaussianState, GaussianMixture)) else np.nan)
        elif name == "nis":
            predicted = hypothesis.measurement_prediction
            if isinstance(predicted, GaussianMeasurementPrediction):
                innovation = (np.ravel(hypothesis.measurement.state_vector)
                              - np.ravel(predicted.state_vector))[:, None]
                out.append(_quadratic_form(model.wrap(innovation)[:, 0], predicted.covar,
                                           name))
            else:
                out.append(np.nan)
        else:
            out.append(effective if name == "ess" else seconds)
    return out


def _score_scans(metrics, world, tracks, mapping, seconds, cutoff):
    """The ``metrics`` of every scan of a multi-target run, (T, len(metrics)): GOSPA between
    the truths' and the tracks' positions in one compiled call."""
    from ..metrics import gospa_over_time
    truths = [np.ascontiguousarray(x[:, mapping]) for x in world.truths]
    estimates = [np.ascontiguousarray(t.means[:, mapping]) for t in tracks]
    result = gospa_over_time(truths, estimates, cutoff)
    counts = np.array([len(t.means) for t in tracks], dtype=np.float64)
    columns = {"gospa": result.distance, "gospa_localisation": result.localisation,
               "gospa_missed": result.missed, "gospa_false": result.false,
               "n_tracks": counts,
               "cardinality_error": np.abs(counts - [len(x) for x in world.truths]),
               "step_seconds": np.asarray(seconds)}
    return np.column_stack([columns[name] for name in metrics])
