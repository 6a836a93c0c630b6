"""Gaussian states, their predictions and updates, ground truth states and detections."""
from .. import _validate
from .base import Link, check_timestamp

__all__ = [
    "State", "GaussianState", "WeightedGaussianState", "GaussianStatePrediction",
    "GaussianMeasurementPrediction", "GaussianStateUpdate", "GroundTruthState", "Detection",
]


def column_vector(value, name="state_vector"):
    """A finite (d, 1) float64 column from a (d,) or (d, 1) array_like (d >= 1)."""
    v = _validate.finite_array(value, name)
    if v.ndim == 0 or v.ndim > 2 or (v.ndim == 2 and v.shape[1] != 1) or v.size == 0:
        raise ValueError(f"{name} must have shape (d,) or (d, 1), got {v.shape}")
    return v.reshape(-1, 1)


class State:
    """A point state: a (d, 1) ``state_vector`` at a ``timestamp``.

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
        Finite; stored as a (d, 1) float64 column.
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    """

    def __init__(self, state_vector, timestamp=None):
        self.state_vector = state_vector
        self.timestamp = timestamp

    #: Checked when assigned (here or later): None, a datetime or finite seconds.
    timestamp = _validate.Setting(check_timestamp)
    #: Checked when assigned (here or later): (d, 1), finite.
    state_vector = _validate.Setting("_checked_vector")

    def _checked_vector(self, value, name):
        return column_vector(value, name)

    @property
    def ndim(self):
        """Number of state dimensions d."""
        return self.state_vector.shape[0]

    def __repr__(self):
        return (f"{type(self).__name__}(state_vector={self.state_vector.ravel()}, "
                f"timestamp={self.timestamp!r})")


class GaussianState(State):
    """A Gaussian state: mean ``state_vector`` (d, 1) and covariance ``covar`` (d, d).

    The covariance must be finite and symmetric (to 1e-9 relative); positive definiteness is
    checked where a filter needs it.

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
        Finite; stored as a (d, 1) float64 column.
    covar : (d, d) array_like
        Finite and symmetric.
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    """

    def __init__(self, state_vector, covar, timestamp=None):
        super().__init__(state_vector, timestamp)
        self.covar = covar

    #: Checked when assigned (here or later): (d, d), finite and symmetric.
    covar = _validate.Setting("_checked_covar")

    def _checked_covar(self, value, name):
        return _validate.covariance(value, name, self.ndim)

    def _checked_vector(self, value, name):
        """A mean of the covariance's dimension, once there is one."""
        vector = column_vector(value, name)
        covar = self.__dict__.get("covar")
        if covar is not None and covar.shape[0] != vector.shape[0]:
            raise ValueError(f"{name} must have {covar.shape[0]} components (the covariance's "
                             f"dimension), got {vector.shape[0]}")
        return vector

    @property
    def mean(self):
        """The mean, ``state_vector``."""
        return self.state_vector

    @classmethod
    def _trusted(cls, state_vector, covar, timestamp, attributes):
        """Build from arrays that a kernel produced (no validation, no copies).
        ``attributes``, a new dict of the other attributes (a :class:`Link` under its slot
        name, ``_prior``), becomes the state's ``__dict__``."""
        state = object.__new__(cls)
        attributes["state_vector"] = state_vector
        attributes["covar"] = covar
        attributes["timestamp"] = timestamp
        state.__dict__ = attributes
        return state


class WeightedGaussianState(GaussianState):
    """A Gaussian state with a weight, a component of a
    :class:`~fasttrack.types.GaussianMixture`.

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
    covar : (d, d) array_like
    weight : float
        Finite, >= 0 (e.g. a mode probability).
    timestamp : datetime.datetime or float, optional
    """

    def __init__(self, state_vector, covar, weight=1.0, timestamp=None):
        super().__init__(state_vector, covar, timestamp)
        self.weight = weight

    #: Checked when assigned (here or later): finite, >= 0.
    weight = _validate.Setting(_validate.non_negative)


class GaussianStatePrediction(GaussianState):
    """A predicted Gaussian state, with the ``transition_model`` that produced it and the
    ``prior`` it came from (a weak link when a predictor made it, see the module's
    notes).

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
        Finite; stored as a (d, 1) float64 column.
    covar : (d, d) array_like
        Finite and symmetric (to 1e-9 relative).
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    transition_model : TransitionModel, optional
    prior : state, optional
        The state predicted from; held strongly (see :mod:`fasttrack.types`).
    """

    prior = Link()

    def __init__(self, state_vector, covar, timestamp=None, transition_model=None, prior=None):
        super().__init__(state_vector, covar, timestamp)
        self.transition_model = transition_model
        self.prior = prior


class GaussianMeasurementPrediction(GaussianState):
    """A predicted measurement: mean ``state_vector`` (m, 1), innovation covariance
    ``covar`` (m, m) and ``cross_covar`` (d, m) between state and measurement.

    Parameters
    ----------
    state_vector : (m,) or (m, 1) array_like
        Predicted measurement mean; finite, stored as an (m, 1) float64 column.
    covar : (m, m) array_like
        Innovation covariance; finite and symmetric (to 1e-9 relative).
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    cross_covar : (d, m) array_like, optional
        Cross covariance of state and measurement (stored as given).
    """

    def __init__(self, state_vector, covar, timestamp=None, cross_covar=None):
        super().__init__(state_vector, covar, timestamp)
        self.cross_covar = cross_covar


class GaussianStateUpdate(GaussianState):
    """An updated Gaussian state, with the ``hypothesis`` it was updated from.

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
        Finite; stored as a (d, 1) float64 column.
    covar : (d, d) array_like
        Finite and symmetric (to 1e-9 relative).
    hypothesis : SingleHypothesis, optional
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    """

    def __init__(self, state_vector, covar, hypothesis=None, timestamp=None):
        super().__init__(state_vector, covar, timestamp)
        self.hypothesis = hypothesis


class GroundTruthState(State):
    """A true state, with optional ``metadata``.

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
        Finite; stored as a (d, 1) float64 column.
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    metadata : mapping, optional
        Copied into a new dict (default empty).
    """

    def __init__(self, state_vector, timestamp=None, metadata=None):
        super().__init__(state_vector, timestamp)
        self.metadata = _metadata(metadata)


class Detection(State):
    """A measurement ``state_vector`` (m, 1) at a ``timestamp``; its ``measurement_model``, if
    set, is used by updaters instead of their own.

    Parameters
    ----------
    state_vector : (m,) or (m, 1) array_like
        The measurement; finite, stored as an (m, 1) float64 column.
    timestamp : datetime.datetime or float, optional
        Time of the measurement (a datetime, or seconds).
    measurement_model : MeasurementModel, optional
    metadata : mapping, optional
        Copied into a new dict (default empty).
    """

    def __init__(self, state_vector, timestamp=None, measurement_model=None, metadata=None):
        super().__init__(state_vector, timestamp)
        self.measurement_model = measurement_model
        self.metadata = _metadata(metadata)


def _metadata(value):
    """``metadata`` as a new dict (None: empty), a TypeError unless ``dict`` takes it (a
    mapping, or key-value pairs)."""
    if value is None:
        return {}
    try:
        return dict(value)
    except (TypeError, ValueError):
        raise TypeError(f"metadata must be a mapping (e.g. a dict) or key-value pairs, got "
                        f"{value!r}") from None
