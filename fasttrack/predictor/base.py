"""What the predictors share: the transition model, the prior's checks and the prediction
interval."""
import numpy as np

from ..models.base import check_model
from ..models.transition import TransitionModel
from ..types import check_timestamp, time_interval

__all__ = ["Predictor"]


class Predictor:
    """Base class: ``predictor.predict(prior, timestamp)`` through ``transition_model``.

    Parameters
    ----------
    transition_model : TransitionModel
    """

    def __init__(self, transition_model):
        check_model(transition_model, TransitionModel, "transition_model")
        self.transition_model = transition_model

    @staticmethod
    def _interval(prior, timestamp):
        """Seconds from the prior's timestamp to ``timestamp``, with clear errors."""
        check_timestamp(timestamp)
        if timestamp is None:
            raise ValueError("predict needs a timestamp")
        if prior.timestamp is None:
            raise ValueError("the prior has no timestamp, so the prediction interval is "
                             "unknown")
        return time_interval(timestamp, prior.timestamp)

    @staticmethod
    def _check_prior(prior, kind, ndim):
        """A TypeError unless ``prior`` is a ``kind``, a ValueError unless it has ``ndim``
        state dimensions (the transition model's)."""
        if not isinstance(prior, kind):
            raise TypeError(f"prior must be a {kind.__name__}, got {type(prior).__name__}")
        if prior.ndim != ndim:
            raise ValueError(f"prior has {prior.ndim} state dimensions, the transition model "
                             f"{ndim}")

    @staticmethod
    def _check_finite(state, name):
        """A ValueError if NaN or inf was written into ``state.state_vector`` after it was
        built (a Gaussian mean, or a kernel filter's few particles; a Gaussian covariance's
        values are checked by the kernels), or a Gaussian covariance of another shape or
        type than (d, d) float64 was assigned."""
        if not np.isfinite(state.state_vector).all():
            raise ValueError(f"{name}.state_vector contains NaN or infinite values")
        check_covariance_kind(state, name)


def check_covariance_kind(state, name):
    """A ValueError unless a Gaussian ``state``'s ``covar`` (if it has one) is still a
    (d, d) float64 array (an attribute assigned after construction is not checked there)."""
    covar = state.__dict__.get("covar")
    if covar is None:
        return
    d = state.state_vector.shape[0]
    if type(covar) is not np.ndarray or covar.shape != (d, d) or covar.dtype != np.float64:
        raise ValueError(f"{name}.covar must be a ({d}, {d}) float64 array (as the state was "
                         f"built), got {type(covar).__name__} of shape {np.shape(covar)}")
