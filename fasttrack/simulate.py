"""Simulation helpers: a ground-truth path from a transition model and detections of it."""
import datetime
import numbers

from . import _validate
from . import random as _random
from .types import Detection, GroundTruthPath, GroundTruthState, check_timestamp, seconds


def ground_truth(transition_model, initial_state, steps, time_interval=1.0, start_time=0.0,
                 rng=None):
    """A :class:`GroundTruthPath` of ``steps`` states, each drawn from the transition model
    (with process noise) over ``time_interval`` from the one before.

    Parameters
    ----------
    transition_model : TransitionModel
    initial_state : (d,) array_like
        The first state, at ``start_time``.
    steps : int
        Number of states, >= 1 (the first included).
    time_interval : datetime.timedelta or float seconds
    start_time : datetime.datetime or float seconds
        Timestamps are ``start_time + k * time_interval``, datetimes if it is one.
    rng : None, int or numpy.random.Generator
    """
    steps = _validate.count(steps, "steps")
    dt = seconds(time_interval)
    check_timestamp(start_time, "start_time")
    if start_time is None:
        raise ValueError("start_time is required")
    rng = _random.generator(_random.check_rng(rng))
    path = GroundTruthPath([GroundTruthState(initial_state, timestamp=start_time)])
    for k in range(1, steps):
        state = transition_model.function(path[-1], noise=True, time_interval=dt, rng=rng)
        path.append(GroundTruthState(state, timestamp=_advance(start_time, k * dt)))
    return path


def detections(truth, measurement_model, rng=None):
    """One :class:`Detection` (with measurement noise, carrying its measurement model) of
    each state of ``truth``, at the same timestamps.

    Parameters
    ----------
    truth : iterable of states
        E.g. a :class:`GroundTruthPath`; each state's ``state_vector`` is measured.
    measurement_model : MeasurementModel
    rng : None, int or numpy.random.Generator
        Source of the measurement noise (None: the package default generator).

    Returns
    -------
    list of Detection
    """
    rng = _random.generator(_random.check_rng(rng))
    return [Detection(measurement_model.function(state, noise=True, rng=rng),
                      timestamp=state.timestamp, measurement_model=measurement_model)
            for state in truth]


def _advance(start, offset):
    if isinstance(start, datetime.datetime):
        return start + datetime.timedelta(seconds=offset)
    assert isinstance(start, numbers.Real)
    return start + offset
