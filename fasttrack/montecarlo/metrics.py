"""What a Monte Carlo run records at each step: position error, NEES, NIS, ESS and step
time, and the checks of the position mapping."""
import math
import numbers

import numpy as np

from ..types import GaussianMeasurementPrediction, GaussianState


#: The metrics a run can record per step.
METRICS = ("position_error", "nees", "nis", "ess", "step_seconds")
_SUMMARIES = {"position_error": "rmse", "nees": "anees", "nis": "anis", "ess": "mean_ess",
              "step_seconds": "step_seconds"}


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
