"""Simulation helpers: a ground-truth path from a transition model and detections of it,
and multi-target scenarios with births, deaths, missed detections and clutter."""
import dataclasses
import datetime
import numbers

import numpy as np

from . import _validate
from . import random as _random
from .models.base import check_model, check_same_states
from .models.measurement import MeasurementModel
from .models.transition import TransitionModel
from .types import Detection, GroundTruthPath, GroundTruthState, check_timestamp, seconds


def ground_truth(transition_model, initial_state, steps, time_interval=1.0, start_time=0.0,
                 rng=None):
    """A :class:`GroundTruthPath` of ``steps`` states, each drawn from the transition model
    (with process noise) over ``time_interval`` from the one before.

    Parameters
    ----------
    transition_model : TransitionModel
        A transition model of :mod:`fasttrack.models`.
    initial_state : (d,) or (d, 1) array_like, or State
        The first state, at ``start_time`` (a State gives its ``state_vector``); finite.
    steps : int
        Number of states, >= 1 (the first included).
    time_interval : datetime.timedelta or float seconds
        > 0.
    start_time : datetime.datetime or float seconds
        Timestamps are ``start_time + k * time_interval``, datetimes if it is one; the last
        must be representable (a datetime before year 10000, a finite number of seconds).
    rng : None, int or numpy.random.Generator

    Raises
    ------
    TypeError
        For a model that is not a fasttrack TransitionModel, or arguments of the wrong type.
    ValueError
        For a bad value, and if a state overflows float64 (the path is then not finite).
    """
    check_model(transition_model, TransitionModel, "transition_model")
    steps = _validate.count(steps, "steps")
    _validate.storable(steps, BYTES_PER_STATE, "steps")
    dt = _interval(time_interval)
    check_timestamp(start_time, "start_time")
    if start_time is None:
        raise ValueError("start_time is required")
    first = _vector(initial_state, "initial_state", transition_model.ndim_state,
                    "the transition model's ndim_state")
    rng = _random.generator(_random.check_rng(rng))
    path = GroundTruthPath([GroundTruthState(first, timestamp=start_time)])
    for k in range(1, steps):
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is raised below
            state = transition_model.function(path[-1], noise=True, time_interval=dt, rng=rng)
        if not np.isfinite(state).all():
            raise ValueError(f"the truth overflows float64 at step {k}: the transition model "
                             f"over time_interval={dt:g} s from initial_state "
                             f"{first.tolist()} gives a state that is not finite")
        path.append(GroundTruthState(state, timestamp=_timestamp(start_time, k, dt)))
    return path


def detections(truth, measurement_model, rng=None):
    """One :class:`Detection` (with measurement noise, carrying its measurement model) of
    each state of ``truth``, at the same timestamps.

    Parameters
    ----------
    truth : iterable of states
        E.g. a :class:`GroundTruthPath`; each state's ``state_vector`` is measured.
    measurement_model : MeasurementModel
        A measurement model of :mod:`fasttrack.models`.
    rng : None, int or numpy.random.Generator
        Source of the measurement noise (None: the package default generator).

    Returns
    -------
    list of Detection

    Raises
    ------
    TypeError
        If ``truth`` is not an iterable of states or the model is not a fasttrack
        MeasurementModel.
    ValueError
        If a measurement is not finite (the model overflows on a state of ``truth``).
    """
    check_model(measurement_model, MeasurementModel, "measurement_model")
    rng = _random.generator(_random.check_rng(rng))
    given = type(truth).__name__
    truth = list(truth) if hasattr(truth, "__iter__") and not isinstance(truth, (str, bytes)) \
        else truth
    if not isinstance(truth, list) or not all(hasattr(state, "state_vector")
                                               and hasattr(state, "timestamp")
                                               for state in truth):
        raise TypeError(f"truth must be an iterable of states (with state_vector and "
                        f"timestamp), such as a GroundTruthPath, got {given}")
    out = []
    for k, state in enumerate(truth):
        if np.shape(state.state_vector)[:1] != (measurement_model.ndim_state,):
            raise ValueError(f"measurement_model measures {measurement_model.ndim_state}-D "
                             f"states, got truth[{k}] of shape {np.shape(state.state_vector)}")
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is raised below
            measured = measurement_model.function(state, noise=True, rng=rng)
        if not np.isfinite(measured).all():
            raise ValueError(f"the measurement of truth[{k}] is not finite: measurement_model "
                             f"overflows float64 on its state")
        out.append(Detection(measured, timestamp=state.timestamp,
                             measurement_model=measurement_model))
    return out


def _interval(time_interval):
    """``time_interval`` (a timedelta or seconds) in seconds, > 0."""
    dt = seconds(time_interval)
    if not dt > 0:
        raise ValueError(f"time_interval must be > 0 seconds, got {dt}")
    return dt


#: The most clutter or births a scan may expect (more would not fit in memory).
MAX_RATE = 1e7

#: About the memory of a truth or detection object (its vector and timestamp), bytes.
BYTES_PER_STATE = 512


def check_storable(steps, per_scan, d, m, described):
    """ValueError, ``described`` saying what was asked for, when ``steps`` scans of
    ``per_scan`` expected measurements and target states (``d``-D states, ``m``-D
    measurements) need more memory than the machine has."""
    _validate.storable(int(steps * per_scan), 8 * (2 * m + d + 4), "steps",
                       f"{described}, about {steps * per_scan:.3g} measurements,")


def _rate(value, name):
    value = _validate.non_negative(value, name)
    if value > MAX_RATE:
        raise ValueError(f"{name} must be at most {MAX_RATE:g} a scan, got {value:g}")
    return value


def _vector(value, name, size, what):
    """A finite state ``value`` (or a State's ``state_vector``) as a (size,) float64 vector:
    a (size,) or (size, 1) array."""
    vector = _validate.finite_array(getattr(value, "state_vector", value), name)
    if not (vector.ndim == 1 or (vector.ndim == 2 and vector.shape[1] == 1)) \
            or vector.shape[0] != size:
        raise ValueError(f"{name} must have {size} components ({what}), as a ({size},) or "
                         f"({size}, 1) array, got shape {vector.shape}")
    return vector.reshape(-1)


def _timestamp(start, k, dt):
    """``start + k * dt``: a ValueError naming start_time and time_interval if it cannot be
    represented (a datetime past year 9999, seconds beyond float64)."""
    try:
        stamp = _advance(start, k * dt)
    except OverflowError:
        stamp = None
    if stamp is None or not (isinstance(stamp, datetime.datetime) or np.isfinite(stamp)):
        raise ValueError(f"the timestamps run out of range: start_time {start!r} plus "
                         f"{k} steps of time_interval={dt:g} s cannot be represented")
    return stamp


def _advance(start, offset):
    if isinstance(start, datetime.datetime):
        return start + datetime.timedelta(seconds=offset)
    assert isinstance(start, numbers.Real)
    return start + offset


@dataclasses.dataclass(frozen=True)
class MultiTargetScenario:
    """A simulated multi-target scenario, scan by scan (scan t at ``t * time_interval``
    seconds).

    Attributes
    ----------
    transition_model : TransitionModel
    measurement_model : MeasurementModel
    truths : list of (n_t, d) float64 ndarray
        The states of the targets alive at each scan.
    truth_ids : list of (n_t,) int64 ndarray
        Their identities (the order of birth, from 0).
    detections : list of (M_t, m) float64 ndarray
        Each scan's measurements: target detections and clutter, in random order.
    origins : list of (M_t,) int64 ndarray
        The target each measurement came from, -1 for clutter.
    time_interval : float
        Seconds between scans.
    region : (2, m) float64 ndarray
        Lower and upper corner of the measurement region where clutter falls.
    clutter_density : float
        Expected clutter measurements per unit volume of the region per scan.
    """

    transition_model: object
    measurement_model: object
    truths: list
    truth_ids: list
    detections: list
    origins: list
    time_interval: float
    region: np.ndarray
    clutter_density: float


def multi_target(transition_model, measurement_model, initial_states, steps, region,
                 time_interval=1.0, prob_detect=0.9, clutter_rate=0.0, birth_rate=0.0,
                 birth_mean=None, birth_covar=None, prob_survive=1.0, rng=None):
    """Simulate targets, their detections and clutter over ``steps`` scans.

    At each scan after the first, every target survives with ``prob_survive`` and moves
    through the transition model (with process noise), and Poisson(``birth_rate``) targets
    are born from N(``birth_mean``, ``birth_covar``). Each live target is detected with
    ``prob_detect`` (with measurement noise), and Poisson(``clutter_rate``) clutter
    measurements fall uniformly in ``region``.

    Parameters
    ----------
    transition_model : TransitionModel
        A transition model of :mod:`fasttrack.models`.
    measurement_model : MeasurementModel
        A measurement model of :mod:`fasttrack.models`.
    initial_states : (n, d) array_like
        The targets alive at the first scan (n may be 0).
    steps : int
        Number of scans, >= 1.
    region : (2, m) array_like
        Lower and upper corner of the clutter region, in measurement space; its volume must
        be a positive finite float64.
    time_interval : datetime.timedelta or float
        Seconds between scans, > 0.
    prob_detect : float
        Probability of detection P_D, in [0, 1].
    clutter_rate : float
        Expected clutter measurements per scan, in [0, 1e7].
    birth_rate : float
        Expected births per scan, in [0, 1e7].
    birth_mean : (d,) or (d, 1) array_like, optional
        Mean of a new target's state (required if ``birth_rate > 0``), finite.
    birth_covar : (d, d) array_like, optional
        Its covariance, symmetric positive semi-definite.
    prob_survive : float
        Probability that a target lives on to the next scan, in [0, 1].
    rng : None, int or numpy.random.Generator

    Returns
    -------
    MultiTargetScenario

    Raises
    ------
    TypeError
        For a model that is not a fasttrack model, or arguments of the wrong type.
    ValueError
        For a bad value, and if the targets' states or their measurements overflow float64
        during the simulation.
    """
    check_model(transition_model, TransitionModel, "transition_model")
    check_model(measurement_model, MeasurementModel, "measurement_model")
    steps = _validate.count(steps, "steps")
    check_same_states(transition_model, measurement_model)
    d, m = transition_model.ndim_state, measurement_model.ndim_meas
    states = _validate.finite_array(initial_states, "initial_states", 2)
    if states.shape[1:] != (d,):
        raise ValueError(f"initial_states must have shape (n, {d}), got {states.shape}")
    region = _validate.finite_array(region, "region", 2)
    if region.shape != (2, m) or np.any(region[1] <= region[0]):
        raise ValueError(f"region must be (2, {m}): a lower and a larger upper corner, "
                         f"got {region.tolist()}")
    for row in measurement_model.angle_components:
        if region[0, row] < -np.pi or region[1, row] > np.pi:
            raise ValueError(f"region's row {row} holds angles (radians): it must lie within "
                             f"[-pi, pi], got {region[:, row].tolist()}")
    with np.errstate(over="ignore", under="ignore"):
        volume = float(np.prod(region[1] - region[0]))
    if not np.isfinite(volume):
        raise ValueError(f"region's volume overflows float64, got {region.tolist()}")
    if not volume > 0:
        raise ValueError(f"region's volume underflows to 0 in float64, got {region.tolist()}")
    prob_detect = _validate.probability(prob_detect, "prob_detect")
    prob_survive = _validate.probability(prob_survive, "prob_survive")
    clutter_rate = _rate(clutter_rate, "clutter_rate")
    birth_rate = _rate(birth_rate, "birth_rate")
    with np.errstate(over="ignore"):
        clutter_density = clutter_rate / volume
    if not np.isfinite(clutter_density):
        raise ValueError(f"the clutter density (clutter_rate {clutter_rate:g} over region's "
                         f"volume {volume:.3g}) overflows float64")
    check_storable(steps, clutter_rate + states.shape[0] + birth_rate * (steps + 1) / 2, d, m,
                   f"steps={steps} of clutter_rate={clutter_rate:g}, birth_rate={birth_rate:g} "
                   f"and {states.shape[0]} initial_states")
    if birth_rate > 0 and (birth_mean is None or birth_covar is None):
        raise ValueError("birth_rate > 0 needs birth_mean and birth_covar")
    if birth_mean is not None:
        birth_mean = _vector(birth_mean, "birth_mean", d, "the transition model's ndim_state")
    if birth_covar is not None:
        birth_covar = _validate.psd_covariance(birth_covar, "birth_covar", d)
    dt = _interval(time_interval)
    rng = _random.generator(_random.check_rng(rng))
    ids = np.arange(states.shape[0])
    next_id = states.shape[0]
    out = {"truths": [], "truth_ids": [], "detections": [], "origins": []}
    for t in range(steps):
        if t > 0:
            alive = rng.random(ids.size) < prob_survive
            states, ids = states[alive], ids[alive]
            if states.shape[0]:
                with np.errstate(over="ignore", invalid="ignore"):  # raised below
                    states = np.ascontiguousarray(transition_model.function(
                        states.T, noise=True, time_interval=dt, rng=rng).T)
            born = rng.poisson(birth_rate) if birth_rate > 0 else 0
            if born:
                new = rng.multivariate_normal(birth_mean, birth_covar, born)
                states = np.concatenate((states, new))
                ids = np.concatenate((ids, np.arange(next_id, next_id + born)))
                next_id += born
            if not np.isfinite(states).all():
                raise ValueError(f"the targets' states overflow float64 at scan {t}: the "
                                 f"transition model over time_interval={dt:g} s (or a birth "
                                 f"from birth_covar) gives states that are not finite; "
                                 f"check initial_states, time_interval and birth_covar")
        _observe(out, t, states, ids, measurement_model, prob_detect, clutter_rate, region,
                 rng)
    return MultiTargetScenario(transition_model, measurement_model, time_interval=dt,
                               region=region,
                               clutter_density=clutter_density, **out)


def _observe(out, t, states, ids, measurement_model, prob_detect, clutter_rate, region, rng):
    """Scan ``t`` of the targets ``states`` (n, d) with identities ``ids``: each detected
    with ``prob_detect`` (with noise), Poisson(``clutter_rate``) clutter uniform in
    ``region``, shuffled; appended to the lists of ``out``."""
    m = measurement_model.ndim_meas
    seen = rng.random(ids.size) < prob_detect
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is raised below
        measured = (np.asarray(measurement_model.function(states[seen].T, noise=True,
                                                          rng=rng)).T.reshape(-1, m)
                    if seen.any() else np.empty((0, m)))
    if not np.isfinite(measured).all():
        raise ValueError(f"the measurements at scan {t} are not finite: measurement_model "
                         f"overflows float64 on the targets' states")
    clutter = rng.uniform(region[0], region[1], (rng.poisson(clutter_rate), m))
    shuffle = rng.permutation(measured.shape[0] + clutter.shape[0])
    out["truths"].append(states.copy())
    out["truth_ids"].append(ids.copy())
    out["detections"].append(np.ascontiguousarray(np.concatenate((measured, clutter))[shuffle]))
    out["origins"].append(np.concatenate((ids[seen], np.full(clutter.shape[0], -1)))[shuffle])
