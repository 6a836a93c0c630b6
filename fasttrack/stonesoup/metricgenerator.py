"""Stone Soup's ``stonesoup.metricgenerator``: the ``GOSPAMetric`` and ``OSPAMetric``
generators, computed by fasttrack's compiled GOSPA and OSPA (:mod:`fasttrack.metrics`).

The states are read once into arrays (the position components the measure picks), grouped by
timestamp, and every time step is scored in one compiled call; the results are Stone Soup's
own ``SingleTimeMetric`` and ``TimeRangeMetric`` objects, with Stone Soup's titles, values,
timestamps and generator. The fast path covers the default ``Euclidean`` measure (with or
without a mapping) on real-valued state vectors; another measure, angle-typed or ragged state
vectors, ``alpha`` other than 2, or anything Stone Soup itself would fail on, goes through
Stone Soup's own code (correct, not faster).
"""
import operator
from itertools import islice

import numpy as np
from stonesoup.base import Base, Property
from stonesoup.measures import Euclidean
from stonesoup.metricgenerator import ospametric as ss_ospametric
from stonesoup.types.metric import SingleTimeMetric, TimeRangeMetric
from stonesoup.types.state import GaussianState, SqrtGaussianState, State, StateMutableSequence
from stonesoup.types.time import TimeRange

from ..metrics import MAX_ORDER, POWER_RANGE, gospa, gospa_over_time, ospa_over_time
from ._fallback import fall_back
from ._objects import builder

__all__ = ["GOSPAMetric", "OSPAMetric"]


class _NotFast(Exception):
    """The inputs need Stone Soup's own code; its text is the reason."""


# -- Stone Soup objects to arrays -------------------------------------------------------------

_SEQUENCE_METHODS = ("__iter__", "__getitem__", "last_timestamp_generator")
_PLAIN_SEQUENCES = {}


def _plain_sequence(cls):
    """Whether iterating a ``cls`` sequence is iterating its ``states`` and its
    ``last_timestamp_generator`` is Stone Soup's."""
    plain = _PLAIN_SEQUENCES.get(cls)
    if plain is None:
        plain = _PLAIN_SEQUENCES[cls] = all(
            getattr(cls, name, None) is getattr(StateMutableSequence, name)
            for name in _SEQUENCE_METHODS)
    return plain


def _last_per_timestamp(element):
    """``list(element.last_timestamp_generator())`` and those states' timestamps: a state is
    kept when the next one is later (and the last one always), comparing as Stone Soup's
    generator does."""
    states = element.states
    if not _plain_sequence(type(element)) or not isinstance(states, (list, tuple)) \
            or not states:
        kept = list(element.last_timestamp_generator())  # Stone Soup's errors for empty ones
        return kept, _timestamps(kept)
    stamps = _timestamps(states)
    if all(map(operator.gt, islice(stamps, 1, None), stamps)):
        return states, stamps
    keep = [j for j in range(len(stamps) - 1) if stamps[j + 1] > stamps[j]]
    keep.append(len(stamps) - 1)
    return [states[j] for j in keep], [stamps[j] for j in keep]


def _extract(objects):
    """Stone Soup's ``extract_states(objects, True)`` as lists ``(states, ids, timestamps)``."""
    states, ids, stamps = [], [], []
    for i, element in enumerate(list(objects)):
        if isinstance(element, StateMutableSequence) and not isinstance(element, State):
            kept, kept_stamps = _last_per_timestamp(element)
            states.extend(kept)
            stamps.extend(kept_stamps)
            ids.extend([i] * len(kept))
        elif isinstance(element, State):
            states.append(element)
            ids.append(i)
            stamps.append(element.timestamp)
        else:
            raise ValueError("{!r} has no state extraction method".format(element))
    return states, ids, stamps


def _as_list(states):
    """The states of a list, a Stone Soup sequence or any iterable, as a list."""
    if type(states) is list:
        return states
    if type(states) is StateMutableSequence and isinstance(states.states, list):
        return states.states
    return list(states)


#: ``mean`` attributes that are the state vector itself (the Euclidean measure reads
#: ``mean`` where a state has one).
_MEAN_IS_VECTOR = {GaussianState.mean, SqrtGaussianState.mean}
_READS_VECTOR = {}
_PLAIN_STATES = {}
_PLAIN_TIMESTAMPS = {}
_TIMESTAMP = operator.itemgetter("_property_timestamp")
_STATE_VECTOR = operator.itemgetter("_property_state_vector")


def _reads_vector(cls):
    """Whether the Euclidean measure reads a ``cls`` state's ``state_vector`` (not another
    ``mean``)."""
    reads = _READS_VECTOR.get(cls)
    if reads is None:
        mean = getattr(cls, "mean", None)
        reads = _READS_VECTOR[cls] = mean is None or mean in _MEAN_IS_VECTOR
    return reads


def _plain_property(cls, name):
    prop = getattr(cls, name, None)
    return (isinstance(prop, Property) and prop._getter is None
            and prop._property_name == f"_property_{name}")


def _plain_timestamp(cls):
    """Whether a ``cls`` state's ``timestamp`` is a stored property."""
    plain = _PLAIN_TIMESTAMPS.get(cls)
    if plain is None:
        plain = _PLAIN_TIMESTAMPS[cls] = (issubclass(cls, Base)
                                          and _plain_property(cls, "timestamp"))
    return plain


def _plain_state(cls):
    """Whether a ``cls`` state's ``timestamp`` and ``state_vector`` are stored properties
    (read from its ``__dict__`` as the properties read them) and its measured vector is its
    ``state_vector``."""
    plain = _PLAIN_STATES.get(cls)
    if plain is None:
        plain = _PLAIN_STATES[cls] = (_plain_timestamp(cls) and _reads_vector(cls)
                                      and _plain_property(cls, "state_vector"))
    return plain


def _timestamps(states):
    """``[state.timestamp for state in states]``."""
    if all(map(_plain_timestamp, set(map(type, states)))):
        try:
            return list(map(_TIMESTAMP, map(vars, states)))
        except (KeyError, TypeError):
            pass
    return [state.timestamp for state in states]


def _points(states, mapping):
    """The ``(n, k)`` float64 points the Euclidean measure compares: column 0 of each state's
    ``mean`` (else ``state_vector``), rows ``mapping`` (all if None); None for no states."""
    vectors = None
    kinds = set(map(type, states))
    if all(map(_plain_state, kinds)):
        try:
            vectors = list(map(_STATE_VECTOR, map(vars, states)))
        except (KeyError, TypeError):
            pass
    if vectors is None:
        if all(map(_reads_vector, kinds)):
            vectors = [state.state_vector for state in states]
        else:
            vectors = [state.state_vector if _reads_vector(type(state)) else state.mean
                       for state in states]
    if not vectors:
        return None
    try:
        stacked = np.array(vectors)
    except (ValueError, TypeError):  # ragged state vectors
        raise _NotFast("ragged state vectors") from None
    if stacked.ndim != 3 or stacked.dtype.kind not in "fiu" or stacked.shape[2] == 0:
        raise _NotFast("state vectors that are not numbers")
    try:
        points = stacked[:, :, 0] if mapping is None else stacked[:, mapping, 0]
    except IndexError:
        raise _NotFast("a mapping outside the state vectors") from None
    if points.ndim != 2:
        raise _NotFast("a mapping outside the state vectors")
    return np.ascontiguousarray(points, dtype=np.float64)


class _Side:
    """One side's points grouped by time step: ``points[offsets[k]:offsets[k + 1]]`` are
    step k's, ``order`` maps them to the positions of the states given."""

    def __init__(self, points, steps, n_steps, width):
        if points is None:
            points = np.empty((0, width))
            steps = np.empty(0, dtype=np.int64)
        self.order = np.argsort(steps, kind="stable")
        self.steps = steps[self.order]
        self.points = np.ascontiguousarray(points[self.order])
        self.offsets = np.zeros(n_steps + 1, dtype=np.int64)
        np.cumsum(np.bincount(steps, minlength=n_steps), out=self.offsets[1:])
        self.counts = np.diff(self.offsets)


def _timesteps(estimate_stamps, truth_stamps):
    """The sorted distinct timestamps and each state's step index."""
    stamps = set(estimate_stamps)
    stamps.update(truth_stamps)
    if None in stamps:  # Stone Soup cannot sort them (or groups them its own way)
        raise _NotFast("states without timestamps")
    try:
        unique = sorted(stamps)
    except TypeError:
        raise _NotFast("timestamps that do not sort") from None
    index = {stamp: k for k, stamp in enumerate(unique)}

    def steps(side):
        return np.fromiter(map(index.__getitem__, side), dtype=np.int64, count=len(side))
    return unique, steps(estimate_stamps), steps(truth_stamps)


def _mappings(measure):
    """The components the measure compares for tracks and for truths, or _NotFast."""
    if type(measure) is not Euclidean:
        raise _NotFast(f"measure {type(measure).__name__}")
    return measure.mapping, measure.mapping2


def _sides(generator, estimates, estimate_stamps, truths, truth_stamps):
    """Both sides as :class:`_Side` and the distinct timestamps."""
    mapping, mapping2 = _mappings(generator.measure)
    unique, estimate_steps, truth_steps = _timesteps(estimate_stamps, truth_stamps)
    e, t = _points(estimates, mapping), _points(truths, mapping2)
    if e is not None and t is not None and e.shape[1] != t.shape[1]:
        raise _NotFast("tracks and truths of different dimensions")
    width = (e if e is not None else t).shape[1] if (e is not None or t is not None) else 0
    return (_Side(e, estimate_steps, len(unique), width),
            _Side(t, truth_steps, len(unique), width), unique)


def _cut_off(generator):
    """``(c, p)`` as floats if the compiled code computes Stone Soup's formulas for them."""
    try:
        c, p = float(generator.c), float(generator.p)
    except (TypeError, ValueError):
        raise _NotFast("c or p not a number") from None
    if not (0 < c < np.inf and p > 0):
        raise _NotFast("c or p outside (0, inf)")
    with np.errstate(over="ignore", under="ignore"):
        power = np.float64(c) ** p
    if p != np.inf and not (1 <= p <= MAX_ORDER and POWER_RANGE[0] <= power <= POWER_RANGE[1]):
        raise _NotFast(f"p outside [1, {MAX_ORDER:g}] or c ** p outside [1e-300, 1e300]")
    return c, p


# -- Stone Soup metric objects ---------------------------------------------------------------

_single_time_metric = builder(SingleTimeMetric)


def _over_time(generator, title, metrics, unique):
    """Stone Soup's result: the step's metric for one step, else a ``TimeRangeMetric``."""
    if len(metrics) == 1:
        return metrics[0]
    return TimeRangeMetric(title=title, value=metrics,
                           time_range=TimeRange(start=unique[0], end=unique[-1]),
                           generator=generator)


def _fast(function):
    function._fasttrack = True
    return function


# -- the generators ----------------------------------------------------------------------------

class _Metric:
    """``extract_states`` and ``compute_metric`` reading every state once."""

    @staticmethod
    @_fast
    def extract_states(object_with_states, return_ids=False):
        states, ids, _ = _extract(object_with_states)
        sequence = StateMutableSequence(states)
        if return_ids:
            return sequence, ids
        return sequence

    def compute_metric(self, manager):
        cls = type(self)
        if not (getattr(cls.extract_states, "_fasttrack", False)
                and getattr(cls.compute_over_time, "_fasttrack", False)):
            fall_back(self, "compute_metric", "a subclass's own extract_states or "
                                              "compute_over_time")
            return super().compute_metric(manager)
        estimates = _extract(manager.states_sets[self.tracks_key])
        truths = _extract(manager.states_sets[self.truths_key])
        return self._compute(estimates, truths)

    def _compute(self, estimates, truths):
        """Stone Soup's ``compute_over_time`` of the extracted ``(states, ids, timestamps)``."""
        try:
            return self._fast_over_time(estimates, truths)
        except _NotFast as refusal:
            fall_back(self, "compute_metric", str(refusal))
            return self._stonesoup.compute_over_time(
                self, StateMutableSequence(estimates[0]), estimates[1],
                StateMutableSequence(truths[0]), truths[1])

    @_fast
    def compute_over_time(self, measured_states, measured_state_ids, truth_states,
                          truth_state_ids):
        estimates, truths = _as_list(measured_states), _as_list(truth_states)
        try:
            return self._fast_over_time(
                (estimates, measured_state_ids, _timestamps(estimates)),
                (truths, truth_state_ids, _timestamps(truths)))
        except _NotFast as refusal:
            fall_back(self, "compute_over_time", str(refusal))
            return self._stonesoup.compute_over_time(
                self, measured_states, measured_state_ids, truth_states, truth_state_ids)


def _steps(flat, offsets):
    """Per-step views of rows ``offsets[k]:offsets[k + 1]`` of ``flat``."""
    return np.split(flat, offsets[1:-1])


def _dense_ids(ids, count):
    """Ids as int64 in ``[0, n)`` (equal ids equal) and n."""
    if ids is None or isinstance(ids, (str, bytes)):
        raise _NotFast("ids that are not a sequence")
    try:
        array = np.asarray(ids)
        if count == 0 and array.size == 0:
            return np.empty(0, dtype=np.int64), 0
        if array.shape != (count,) or array.dtype.kind not in "iuUS":
            raise _NotFast("ids that are not integers or strings")
        unique, dense = np.unique(array, return_inverse=True)
    except (TypeError, ValueError):
        raise _NotFast("ids that are not integers or strings") from None
    return dense.astype(np.int64).reshape(-1), unique.size


class GOSPAMetric(_Metric, ss_ospametric.GOSPAMetric):
    """Stone Soup's ``GOSPAMetric``, computed by fasttrack's compiled GOSPA
    (:func:`fasttrack.metrics.gospa_over_time`), switching penalty included."""

    _stonesoup = ss_ospametric.GOSPAMetric

    def _parameters(self):
        if self.alpha != 2:  # Stone Soup splits the parts only for alpha = 2
            raise _NotFast("alpha other than 2")
        c, p = _cut_off(self)
        if p == np.inf:
            raise _NotFast("p = inf")
        return c, p

    def _fast_over_time(self, estimates, truths):
        c, p = self._parameters()
        (e_states, e_ids, e_stamps), (t_states, t_ids, t_stamps) = estimates, truths
        if not e_stamps and not t_stamps:
            raise _NotFast("no states (Stone Soup's error)")  # Stone Soup's error
        e, t, unique = _sides(self, e_states, e_stamps, t_states, t_stamps)
        ids = self._step_ids(e, e_ids, t, t_ids)
        result = gospa_over_time(_steps(t.points, t.offsets), _steps(e.points, e.offsets), c,
                                 p, 2.0, self._penalty(), **ids)
        title = "GOSPA Metric"
        metrics = [
            _single_time_metric(title=title, value={
                "distance": d, "localisation": loc, "missed": missed, "false": false,
                "switching": switch}, generator=self, timestamp=stamp)
            for d, loc, missed, false, switch, stamp in zip(
                result.distance.tolist(), result.localisation.tolist(),
                result.missed.tolist(), result.false.tolist(), result.switching.tolist(),
                unique)]
        return _over_time(self, "GOSPA Metrics", metrics, unique)

    def _penalty(self):
        try:
            return float(self.switching_penalty)
        except (TypeError, ValueError):
            raise _NotFast("a switching penalty that is not a number") from None

    def _step_ids(self, e, e_ids, t, t_ids):
        """Stone Soup's track and truth identities as per-step int arrays (for the
        switching term; none without a penalty)."""
        if self._penalty() == 0:
            return {}
        e_dense, _ = _dense_ids(e_ids, e.order.size)
        t_dense, n_ids = _dense_ids(t_ids, t.order.size)
        e_dense, t_dense = e_dense[e.order], t_dense[t.order]
        if np.unique(t.steps * max(n_ids, 1) + t_dense).size != t_dense.size:
            raise _NotFast("a truth twice in one time step")
        return {"truth_ids": _steps(t_dense, t.offsets),
                "estimate_ids": _steps(e_dense, e.offsets)}

    def compute_gospa_metric(self, measured_states, truth_states):
        estimates, truths = _as_list(measured_states), _as_list(truth_states)
        stamps = set(_timestamps(estimates))
        stamps.update(_timestamps(truths))
        if len(stamps) != 1:
            raise ValueError('All states must be from the same time to compute GOSPA')
        try:
            c, p = self._parameters()
            mapping, mapping2 = _mappings(self.measure)
            e, t = _points(estimates, mapping), _points(truths, mapping2)
            if e is not None and t is not None and e.shape[1] != t.shape[1]:
                raise _NotFast("tracks and truths of different dimensions")
        except _NotFast as refusal:
            fall_back(self, "compute_gospa_metric", str(refusal))
            return super().compute_gospa_metric(measured_states, truth_states)
        width = (e if e is not None else t).shape[1]
        e = np.empty((0, width)) if e is None else e
        t = np.empty((0, width)) if t is None else t
        result = gospa(t, e, c, p, 2.0)
        assignment = result.assignment
        distance, localisation, missed, false = (result.distance, result.localisation,
                                                 result.missed, result.false)
        metric = _single_time_metric(
            title='GOSPA Metric', generator=self, timestamp=stamps.pop(),
            value={"distance": distance, "localisation": localisation, "missed": missed,
                   "false": false})
        return metric, (assignment if e.shape[0] and t.shape[0] else [])


class OSPAMetric(_Metric, ss_ospametric.OSPAMetric):
    """Stone Soup's ``OSPAMetric``, computed by fasttrack's compiled OSPA
    (:func:`fasttrack.metrics.ospa_over_time` with ``stonesoup_pairs=True``: the pairs
    minimising ``sum min(d, c)``, as Stone Soup chooses them)."""

    _stonesoup = ss_ospametric.OSPAMetric

    def _distances(self, e, t):
        c, p = _cut_off(self)
        values = ospa_over_time(_steps(t.points, t.offsets), _steps(e.points, e.offsets), c, p,
                                stonesoup_pairs=True).tolist()
        if p == np.inf:  # Stone Soup gives its c itself where the counts differ
            for k in np.flatnonzero(e.counts != t.counts).tolist():
                values[k] = self.c
        return values

    def _fast_over_time(self, estimates, truths):
        (e_states, _, e_stamps), (t_states, _, t_stamps) = estimates, truths
        if not e_stamps and not t_stamps:
            raise _NotFast("no states (Stone Soup's error)")  # Stone Soup's error
        _cut_off(self)
        e, t, unique = _sides(self, e_states, e_stamps, t_states, t_stamps)
        title = 'OSPA distance'
        metrics = [_single_time_metric(title=title, value=value, generator=self,
                                       timestamp=stamp)
                   for value, stamp in zip(self._distances(e, t), unique)]
        return _over_time(self, 'OSPA distances', metrics, unique)

    def compute_OSPA_distance(self, track_states, truth_states):
        estimates, truths = _as_list(track_states), _as_list(truth_states)
        e_stamps, t_stamps = _timestamps(estimates), _timestamps(truths)
        stamps = set(e_stamps).union(t_stamps)
        if len(stamps) > 1:
            raise ValueError('All states must be from the same time to perform OSPA')
        try:
            if not stamps:
                raise _NotFast("no states (Stone Soup's error)")  # Stone Soup's error
            e, t, unique = _sides(self, estimates, e_stamps, truths, t_stamps)
            value = self._distances(e, t)[0]
        except _NotFast as refusal:
            fall_back(self, "compute_OSPA_distance", str(refusal))
            return super().compute_OSPA_distance(track_states, truth_states)
        return _single_time_metric(title='OSPA distance', value=value, generator=self,
                                   timestamp=unique[0])
