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
        values are checked by the kernels)."""
        check_gaussian(state, name)


def check_gaussian(state, name):
    """A ValueError if NaN or inf was written into ``state.state_vector`` after it was
    built (a covariance assigned later is checked when assigned, its values written in
    place by the kernels)."""
    if not np.isfinite(state.state_vector).all():
        raise ValueError(f"{name}.state_vector contains NaN or infinite values")
