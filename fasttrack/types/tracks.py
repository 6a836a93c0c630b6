"""Sequences of states in time order (tracks, ground truth paths) and hypotheses."""
import datetime
import numbers
import uuid
import weakref

from .base import Link

__all__ = ["StateSequence", "Track", "GroundTruthPath", "SingleHypothesis"]


class StateSequence:
    """States kept in time order: indexing is by position, iteration in time order, and
    attributes not found here (``state_vector``, ``mean``, ``covar``, ...) are the last
    state's."""

    def __init__(self, states=None):
        self.states = []
        for state in states or ():
            self.append(state)

    def append(self, state):
        """Add a state, keeping time order (after any states with the same timestamp).

        Parameters
        ----------
        state : state object
            Anything with a ``timestamp`` (None, a datetime or seconds; a state without a
            timestamp goes at the end, and the timestamps must not mix datetimes and
            numbers).
        """
        if not hasattr(state, "timestamp"):
            raise TypeError(f"a {type(self).__name__} holds states, got {type(state).__name__}")
        if state.timestamp is None or not self.states or self.states[-1].timestamp is None \
                or _time_order(self.states[-1].timestamp, state.timestamp) <= 0:
            self.states.append(state)
            return
        position = len(self.states)
        while position > 0 and _time_order(self.states[position - 1].timestamp,
                                           state.timestamp) > 0:
            position -= 1
        self.states.insert(position, state)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return type(self)(self.states[index])
        return self.states[index]

    def __iter__(self):
        return iter(self.states)

    def __len__(self):
        return len(self.states)

    @property
    def state(self):
        """The last state."""
        return self.states[-1]

    @property
    def timestamps(self):
        return [state.timestamp for state in self.states]

    def __getattr__(self, name):
        if name.startswith("_") or name == "states":
            raise AttributeError(name)
        if not self.__dict__.get("states"):
            raise AttributeError(f"{type(self).__name__} is empty: no {name!r}")
        return getattr(self.states[-1], name)


def _time_order(a, b):
    """-1, 0 or 1 as timestamp a is before, at or after b (same kind required)."""
    if a is None or b is None:
        raise TypeError(f"cannot order timestamps {a!r} and {b!r}: a state without a "
                        f"timestamp")
    both_real = isinstance(a, numbers.Real) and isinstance(b, numbers.Real)
    if type(a) is not type(b) and not both_real:
        raise TypeError(f"cannot order timestamps {a!r} and {b!r}: mix of datetimes and numbers")
    if isinstance(a, datetime.datetime) and (a.utcoffset() is None) != (b.utcoffset() is None):
        raise TypeError(f"cannot order timestamps {a!r} and {b!r}: one has a time zone, the "
                        f"other none")
    return int(a > b) - int(a < b)  # (NumPy scalars' bools do not subtract)


class Track(StateSequence):
    """A track: estimated states in time order, with an ``id``.

    Parameters
    ----------
    states : iterable of states, optional
        Added with :meth:`append`, so kept in time order.
    id : str, optional
        Default: a new random UUID, as a string.
    """

    def __init__(self, states=None, id=None):
        super().__init__(states)
        self.id = str(uuid.uuid4()) if id is None else id


class GroundTruthPath(StateSequence):
    """A true path: :class:`GroundTruthState` objects in time order, with an ``id``.

    Parameters
    ----------
    states : iterable of GroundTruthState, optional
        Added with :meth:`append`, so kept in time order.
    id : str, optional
        Default: a new random UUID, as a string.
    """

    def __init__(self, states=None, id=None):
        super().__init__(states)
        self.id = str(uuid.uuid4()) if id is None else id


class SingleHypothesis:
    """A prediction paired with a measurement (a :class:`Detection`, or None for a missed
    detection); updaters store their ``measurement_prediction`` on it.

    The hypothesis holds its ``prediction`` until an updater has used it; from then on the
    link is weak (see the module's notes): an update, kept in a :class:`Track`, does not
    keep its prediction's particle cloud alive unless the program holds the prediction.

    Parameters
    ----------
    prediction : state
        The predicted state (a prediction from a predictor).
    measurement : Detection or None
        None for a missed detection.
    measurement_prediction : state, optional
        A predicted measurement. The Kalman and adaptive kernel updaters store theirs here;
        the adaptive kernel updater uses one given instead of computing it.
    """

    prediction = Link()

    def __init__(self, prediction, measurement, measurement_prediction=None):
        self.prediction = prediction
        self.measurement = measurement
        self.measurement_prediction = measurement_prediction

    def _used(self):
        """Turn the link to the prediction weak (an updater has used it)."""
        value = self.__dict__.get("_prediction")
        if value is not None and type(value) is not weakref.ref:
            self.__dict__["_prediction"] = weakref.ref(value)

    def __bool__(self):
        return self.measurement is not None

    def __repr__(self):
        return (f"SingleHypothesis(prediction={self.prediction!r}, "
                f"measurement={self.measurement!r})")
