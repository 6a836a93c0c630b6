"""Scores of tracks against the truth: the position error of one track, and the GOSPA and OSPA
distances between the sets of truths and estimates at each time step.

GOSPA (generalised optimal sub-pattern assignment) between n truths and m estimates, with
cut-off ``c``, order ``p`` and ``alpha`` (Rahmathullah, Garcia-Fernandez and Svensson, 2017),
for n <= m (symmetric otherwise)::

    d = ( min over injections pi of sum_i min(|x_i - y_pi(i)|, c)^p + c^p / alpha (m - n) )^(1/p)

With ``alpha = 2`` (the default, Stone Soup's only value) it splits as ``d^p = localisation +
missed + false``: assigned pairs closer than ``c`` add their distance to the power p, and each
missed truth and false estimate adds ``c^p / 2`` (a pair at the cut-off counts as one of
each). OSPA (Schuhmacher, Vo and Vo, 2008) is ``((min sum min(d, c)^p + c^p |m - n|) /
max(n, m))^(1/p)``, and for ``p = inf`` the smallest largest pair distance (``c`` if
n != m). Distances are Euclidean over the columns given (pick the position components
beforehand); the assignment is exact (the compiled solver of
:mod:`fasttrack.core.assign`).

These match Stone Soup 1.9.1's ``GOSPAMetric`` and ``OSPAMetric`` (``compute_over_time``,
default ``Euclidean`` measure, i.e. over whatever components the arrays hold) step for step,
with these differences: the steps are given explicitly, so a step with neither truths nor
estimates (which Stone Soup cannot represent) has distance 0; ``alpha`` may be any value in
``(0, 2]`` (Stone Soup fixes 2), and for ``alpha != 2`` a pair at the cut-off stays assigned
and its ``c^p`` counts as localisation; OSPA minimises ``sum min(d, c)^p`` (its definition),
whereas Stone Soup minimises ``sum min(d, c)`` and then sums powers, so the two differ for
p != 1 unless ``stonesoup_pairs=True``.
"""
import math
from typing import NamedTuple

import numpy as np

from .core import metric as _metric
from . import _validate
from ._validate import _describe, non_negative, positive, real

__all__ = ["GOSPAResult", "gospa", "gospa_over_time", "ospa", "ospa_over_time",
           "position_rmse"]


def position_rmse(track, truth, mapping=(0, 2), pair="order"):
    """Root-mean-square position error over the states of ``track`` and ``truth``:
    ``sqrt(mean over steps of |mean[mapping] - truth[mapping]|^2)``.

    Parameters
    ----------
    track, truth : sequences of states (with ``mean`` or ``state_vector``)
    mapping : sequence of int
        The position components (at least one, distinct rows of the states).
    pair : {'order', 'timestamp'}
        Pair the states in order (the sequences of the same length), or each track state
        with the truth state of its timestamp (a truth with states at other times too, e.g.
        a track that started late or missed steps).
    """
    track = list(_validate.iterator(track, "track"))
    truth = list(_validate.iterator(truth, "truth"))
    if pair == "timestamp":
        for name, states in (("track", track), ("truth", truth)):
            untimed = [k for k, state in enumerate(states) if state.timestamp is None]
            if untimed:
                raise ValueError(f"pair='timestamp' needs timestamps: {name}[{untimed[0]}] "
                                 f"has none")
        by_time = {state.timestamp: state for state in truth}
        missing = [s.timestamp for s in track if s.timestamp not in by_time]
        if missing:
            raise ValueError(f"truth has no state at the track's timestamps {missing[:3]}"
                             f"{' ...' if len(missing) > 3 else ''}")
        truth = [by_time[s.timestamp] for s in track]
    elif pair != "order":
        raise ValueError(f"pair must be 'order' or 'timestamp', got {pair!r}")
    if len(track) != len(truth) or len(track) == 0:
        raise ValueError(f"track and truth must be non-empty and of the same length, "
                         f"got {len(track)} and {len(truth)} (pair='timestamp' matches "
                         f"them by time)")
    estimated = _positions(track, "track", lambda s: getattr(s, "mean", s.state_vector))
    true = _positions(truth, "truth", lambda s: s.state_vector)
    if estimated.shape[1] != true.shape[1]:
        raise ValueError(f"track and truth states must have the same dimension, got "
                         f"{estimated.shape[1]} and {true.shape[1]}")
    index = list(_validate.indices(mapping, "mapping", estimated.shape[1], minimum=1))
    if len(set(index)) != len(index):
        raise ValueError(f"mapping must name distinct rows, got {tuple(index)}")
    errors = estimated[:, index] - true[:, index]
    scale = np.abs(errors).max()  # |errors| / scale <= 1: the squares cannot overflow
    if not np.isfinite(scale):
        raise ValueError("the position errors overflow float64")
    if scale == 0:
        return 0.0
    return float(scale * np.sqrt(np.mean(np.sum(np.square(errors / scale), axis=1))))


def _positions(states, name, vector):
    """(n, d) float64 of the ``vector`` of each of ``states``, naming a bad one."""
    rows = []
    for k, state in enumerate(states):
        if not hasattr(state, "state_vector"):
            raise TypeError(f"{name}[{k}] must be a state (with a state_vector), got "
                            f"{type(state).__name__}")
        rows.append(np.ravel(vector(state)))
    if len({row.size for row in rows}) > 1:
        raise ValueError(f"{name}'s states must all have one dimension")
    out = np.array(rows, dtype=np.float64)
    bad = ~np.isfinite(out).all(axis=1)
    if bad.any():
        raise ValueError(f"{name}[{np.argmax(bad)}] contains NaN or infinite values")
    return out


class GOSPAResult(NamedTuple):
    """The GOSPA distance and its parts: floats for one step, ``(T,)`` arrays over T steps.

    The parts are in the units of the points to the power p, and (without a switching
    penalty) add up to ``distance ** p``.

    Parameters
    ----------
    distance : float or (T,) ndarray
        The GOSPA distance (units of the points); with a switching penalty,
        ``(gospa ** alpha + switching ** alpha) ** (1 / alpha)`` as in Stone Soup.
    localisation : float or (T,) ndarray
        Sum of ``|x - y| ** p`` over the assigned pairs closer than ``c`` (with
        ``alpha != 2``, over all assigned pairs, a pair at the cut-off adding ``c ** p``).
    missed : float or (T,) ndarray
        ``c ** p / alpha`` times the number of truths left unassigned.
    false : float or (T,) ndarray
        ``c ** p / alpha`` times the number of estimates left unassigned.
    switching : float or (T,) ndarray
        ``switching_penalty * (number of switches) ** (1 / p)``, a switch counting 1 when a
        truth changes estimate, 1/2 when it gains or loses one (0 without a penalty).
    assignment : ndarray of int64, or list of them
        For each truth, the row of its estimate in the same step, -1 if it has none (with
        ``alpha = 2``, also if the pair is at the cut-off): ``(n,)`` for one step; over
        time, a list of ``(n_k,)`` arrays, or ``(T, n)`` (-1 past the counts) for padded
        inputs.
    """
    distance: object
    localisation: object
    missed: object
    false: object
    switching: object
    assignment: object


def _points(value, name):
    """One step's points as a 2-D float64 array ``(n, d)`` (any empty array is ``(0, 0)``);
    finiteness is checked by the caller."""
    if type(value) is np.ndarray:
        a = value
    else:
        if isinstance(value, (str, bytes)) or value is None:
            raise TypeError(f"{name} must be an (n, d) array of real numbers, "
                            f"got {_describe(value)}")
        try:
            a = np.asarray(value)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be an (n, d) array of real numbers, "
                            f"got {_describe(value)} that is not a rectangular array") from None
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold real numbers, got {_describe(a)}")
    if a.ndim == 2 and a.shape[0] and not a.shape[1]:
        raise ValueError(f"{name} must have at least one coordinate a point, got shape "
                         f"{a.shape}")
    if a.size == 0:
        return np.empty((0, a.shape[1] if a.ndim == 2 else 0))
    if a.ndim != 2:
        raise ValueError(f"{name} must be a 2-D (n, d) array of n points, got shape {a.shape}")
    return a


def _counts(value, name, steps, largest, points_name):
    counts = np.asarray(value)
    if counts.size and counts.dtype.kind not in "iu":
        raise TypeError(f"{name} must hold integers, got {_describe(counts)}")
    if counts.dtype.kind not in "iu" or counts.shape != (steps,):
        raise ValueError(f"{name} must be {steps} integers (one per step of {points_name}), "
                         f"got {_describe(value)} of shape {counts.shape}")
    if counts.size and (counts.min() < 0 or counts.max() > largest):
        raise ValueError(f"{name} must lie in [0, {largest}] (the rows of {points_name}), "
                         f"got values in [{counts.min()}, {counts.max()}]")
    return counts.astype(np.int64)


def _stack(points, counts, name, counts_name):
    """Per-step point sets as ``(flat (N, d) float64, offsets (T + 1,) int64, mask)``:
    ``points`` is a sequence of T ``(n_k, d)`` arrays, or a padded ``(T, n, d)`` array whose
    first ``counts[k]`` rows are step k's (all n if ``counts`` is None); ``mask`` is the
    ``(T, n)`` boolean mask of the valid rows of a padded array (None for a sequence)."""
    if isinstance(points, np.ndarray) and points.ndim == 3:
        if points.dtype.kind not in "fiu":
            raise TypeError(f"{name} must hold real numbers, got {_describe(points)}")
        steps, largest, d = points.shape
        if counts is None:
            flat = points.reshape(steps * largest, d)
            counts = np.full(steps, largest, dtype=np.int64)
            mask = np.ones((steps, largest), dtype=np.bool_)
        else:
            counts = _counts(counts, counts_name, steps, largest, name)
            mask = np.arange(largest) < counts[:, None]
            flat = points[mask]
    else:
        if counts is not None:
            raise ValueError(f"{counts_name} is only for a padded (T, n, d) array {name}, "
                             f"got {name} as {_describe(points)}")
        if (isinstance(points, (str, bytes)) or not hasattr(points, "__iter__")
                or isinstance(points, np.ndarray)):
            raise TypeError(f"{name} must be a sequence of (n_k, d) arrays (one per step) "
                            f"or a (T, n, d) array, got {_describe(points)}"
                            + (f" of shape {points.shape}" if hasattr(points, "shape") else ""))
        arrays, lengths, d, first = [], [], None, None
        for k, step in enumerate(points):
            a = _points(step, f"{name}[{k}]")
            lengths.append(a.shape[0])
            if a.shape[0]:
                if d is None:
                    d, first = a.shape[1], k
                elif a.shape[1] != d:
                    raise ValueError(f"{name}[{k}] has {a.shape[1]} columns but "
                                     f"{name}[{first}] has {d}: every point needs the same "
                                     f"components")
                arrays.append(a)
        flat = (np.concatenate(arrays, dtype=np.float64) if arrays
                else np.empty((0, 0)))
        counts = np.array(lengths, dtype=np.int64)
        mask = None
    flat = np.ascontiguousarray(flat, dtype=np.float64)
    if not np.isfinite(flat).all():
        bad = int(np.flatnonzero(~np.isfinite(flat).all(axis=1))[0])
        step = int(np.searchsorted(np.cumsum(counts), bad, side="right"))
        raise ValueError(f"{name} contains NaN or infinite values (step {step})")
    offsets = np.zeros(counts.size + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return flat, offsets, mask


def _one_step(value, name):
    """One step's points and their offsets ``[0, n]``, for the one-step functions."""
    a = np.ascontiguousarray(_points(value, name), dtype=np.float64)
    if not np.isfinite(a).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return a, np.array([0, a.shape[0]], dtype=np.int64)


def _same_components(truths, estimates):
    """The two stacks with the same number of columns (an empty side takes the other's)."""
    if truths.shape[0] and estimates.shape[0] and truths.shape[1] != estimates.shape[1]:
        raise ValueError(f"truths have {truths.shape[1]} components and estimates "
                         f"{estimates.shape[1]}: they must be the same")
    if not truths.shape[0]:
        truths = np.empty((0, estimates.shape[1]))
    if not estimates.shape[0]:
        estimates = np.empty((0, truths.shape[1]))
    return truths, estimates


#: The range of ``c ** p`` the OSPA and GOSPA sums hold (distances are summed to the power p).
POWER_RANGE = (1e-300, 1e300)

#: The largest finite order p: at p = 30, a distance of 1e-10 c has a power (d / c) ** p of
#: 1e-300, and a shorter one underflows to 0.
MAX_ORDER = 30.0


def _in_units_of_c(truths, estimates, c):
    """``(truths, estimates, c, e)``: the points and the cut-off divided by ``2 ** e``, the
    power of two that brings c into [0.5, 1) (exactly: the distances scale with them), so
    that the kernels' squared distances and ``c * c`` neither overflow nor underflow;
    ValueError for points too far out for the cut-off."""
    e = math.frexp(c)[1]
    with np.errstate(over="ignore"):  # (named below)
        truths, estimates = np.ldexp(truths, -e), np.ldexp(estimates, -e)
    for name, points in (("truths", truths), ("estimates", estimates)):
        if not np.isfinite(points).all():
            raise ValueError(f"{name} lie too far out for the cut-off c = {c:g}: |x| / c must "
                             f"stay below about 1e308")
    return truths, estimates, math.ldexp(c, -e), e


def _back_from_units_of_c(e, p, distances, powers=()):
    """The ``distances`` (units of c) in the points' units, and the ``powers`` (units of
    c ** p) in the points' units to the power p."""
    distances = np.ldexp(distances, e)
    if not len(powers):
        return distances, []
    scale = 2.0 ** (e * p / 2)  # (twice: 2 ** (e p) alone may overflow where the parts do not)
    return distances, [part * scale * scale for part in powers]


def _parameters(c, p, alpha=None, infinite_p=False):
    c = positive(c, "c")
    if infinite_p and _is_inf(p):
        p = np.inf
    else:
        p = real(p, "p")
        if not p >= 1:
            raise ValueError(f"p must be >= 1{' (or inf)' if infinite_p else ''}, got {p}")
        if p > MAX_ORDER:
            raise ValueError(f"p must be at most {MAX_ORDER:g}{' (or inf)' if infinite_p else ''}"
                             f", got {p:g}: beyond it, the powers d ** p of distances under "
                             f"1e-10 c underflow float64 to 0")
        with np.errstate(over="ignore", under="ignore"):
            cut = np.float64(c) ** p
        if not POWER_RANGE[0] <= cut <= POWER_RANGE[1]:
            raise ValueError(f"c ** p must lie in [1e-300, 1e300] (the distances are summed "
                             f"to the power p), got c = {c:g}, p = {p:g}: rescale the points "
                             f"so that c is nearer 1, or lower p")
    if alpha is not None:
        alpha = real(alpha, "alpha")
        if not 0 < alpha <= 2:
            raise ValueError(f"alpha must lie in (0, 2], got {alpha}")
        with np.errstate(over="ignore"):
            missed = np.float64(c) ** p / alpha
        if p != np.inf and not missed <= 1e300:
            raise ValueError(f"c ** p / alpha, the cost of a target missed, must be at most "
                             f"1e300, got c = {c:g}, p = {p:g}, alpha = {alpha:g}: raise alpha")
    return c, p, alpha


def _is_inf(value):
    return (isinstance(value, (float, np.floating)) and not isinstance(value, bool)
            and value == np.inf)


def _ids(ids, offsets, mask, name, points_name):
    """Flat int64 ids of the points, dense in ``[0, n_ids)``; default: the row in the step."""
    counts = np.diff(offsets)
    total = int(offsets[-1])
    steps = np.repeat(np.arange(counts.size), counts)
    if ids is None:
        return np.arange(total) - offsets[:-1][steps], int(counts.max(initial=0))
    if mask is not None:
        flat = np.asarray(ids)
        if flat.shape != mask.shape:
            raise ValueError(f"{name} must have shape {mask.shape} (as the rows of the padded "
                             f"{points_name}), got {_describe(ids)} of shape {flat.shape}")
        flat = flat[mask]
    else:
        if isinstance(ids, (str, bytes)) or not hasattr(ids, "__iter__"):
            raise TypeError(f"{name} must be a sequence of integer arrays (one per step), "
                            f"got {_describe(ids)}")
        parts = [np.asarray(step).reshape(-1) for step in ids]
        if len(parts) != counts.size or any(a.size != n for a, n in zip(parts, counts)):
            raise ValueError(f"{name} must hold one id per point of {points_name} at each "
                             f"of its {counts.size} steps")
        flat = np.concatenate(parts) if parts else np.empty(0, dtype=np.int64)
    if flat.size and flat.dtype.kind not in "iu":
        raise TypeError(f"{name} must hold integers, got {_describe(flat)}")
    unique, dense = np.unique(flat, return_inverse=True)
    if np.unique(steps * unique.size + dense).size != dense.size:
        raise ValueError(f"{name} repeats an id within a step")
    return dense.astype(np.int64).reshape(-1), unique.size


def gospa(truths, estimates, c, p=1, alpha=2):
    """GOSPA distance between one step's truths and estimates (Stone Soup's
    ``GOSPAMetric.compute_gospa_metric``).

    Parameters
    ----------
    truths : (n, d) array_like of float
        The true points (e.g. positions, in metres); an empty array for none.
    estimates : (m, d) array_like of float
        The estimated points, in the same components and units.
    c : float
        Cut-off distance, > 0 (same units).
    p : float
        Order, in [1, 30] (``c ** p`` in [1e-300, 1e300]).
    alpha : float
        ``0 < alpha <= 2``; 2 (Stone Soup's value) makes the parts missed and false sum to
        the cardinality errors.

    Returns
    -------
    GOSPAResult
        Floats ``distance``, ``localisation``, ``missed``, ``false`` (``switching`` 0) and the
        ``(n,)`` ``assignment`` of the truths to rows of ``estimates`` (-1 for none).

    Raises
    ------
    ValueError
        For points that are not 2-D with the same number of columns, NaN or infinite
        points, or parameters out of range (naming them).
    TypeError
        For non-numeric points or parameters.
    """
    c, p, alpha = _parameters(c, p, alpha)
    (t, t_offsets), (e, e_offsets) = _one_step(truths, "truths"), _one_step(estimates,
                                                                           "estimates")
    t, e = _same_components(t, e)
    distance, (localisation, missed, false), assignment = _gospa(t, t_offsets, e, e_offsets,
                                                                 c, p, alpha)
    return GOSPAResult(float(distance[0]), float(localisation[0]), float(missed[0]),
                       float(false[0]), 0.0, assignment)


def _gospa(t, t_offsets, e, e_offsets, c, p, alpha):
    """The kernel's GOSPA in units of c: (T,) distances, the three (T,) parts and the
    assignment."""
    t, e, unit_c, exponent = _in_units_of_c(t, e, c)
    out, assignment = _metric.gospa(t, t_offsets, e, e_offsets, unit_c, p, alpha)
    distance, parts = _back_from_units_of_c(exponent, p, out[:, 0], out[:, 1:].T)
    return distance, parts, assignment


def gospa_over_time(truths, estimates, c, p=1, alpha=2, switching_penalty=0.0, *,
                    truth_ids=None, estimate_ids=None, truth_counts=None,
                    estimate_counts=None):
    """GOSPA at every time step, all steps in one compiled call (Stone Soup's
    ``GOSPAMetric.compute_over_time``).

    Parameters
    ----------
    truths : sequence of T (n_k, d) array_like, or (T, n, d) array_like of float
        Each step's true points (empty arrays for none), or a padded array whose first
        ``truth_counts[k]`` rows are step k's (rows past the counts are ignored, NaN
        allowed).
    estimates : sequence of T (m_k, d) array_like, or (T, m, d) array_like of float
        Each step's estimated points, likewise (same components and units).
    c : float
        Cut-off distance, > 0.
    p : float
        Order, in [1, 30] (``c ** p`` in [1e-300, 1e300]).
    alpha : float
        ``0 < alpha <= 2``.
    switching_penalty : float
        Penalty per track switch, >= 0 (Stone Soup's ``switching_penalty``; 0 ignores ids).
    truth_ids, estimate_ids : sequence of T (n_k,) int arrays, or (T, n) int array, optional
        Which truth (track) each row is, to count switches; default: the row's position in
        its step (so row i of a padded array is object i throughout).
    truth_counts, estimate_counts : (T,) array_like of int, optional
        Valid rows per step of padded ``truths`` / ``estimates`` (default: all).

    Returns
    -------
    GOSPAResult
        ``(T,)`` arrays ``distance``, ``localisation``, ``missed``, ``false``, ``switching``,
        and the ``assignment`` of each step's truths to its estimates (a list of ``(n_k,)``
        arrays, or ``(T, n)`` padded with -1 for a padded ``truths``).

    Raises
    ------
    ValueError
        For steps of different counts or components, NaN or infinite points, ids that do
        not match the points or repeat within a step, or parameters out of range.
    TypeError
        For non-numeric points, ids or parameters.

    Notes
    -----
    As in Stone Soup, a truth's switches are counted against the estimate it had when last
    recorded; its first record is its first step with estimates, and a step without any
    estimates changes no record.
    """
    c, p, alpha = _parameters(c, p, alpha)
    switching_penalty = non_negative(switching_penalty, "switching_penalty")
    t, t_offsets, t_mask = _stack(truths, truth_counts, "truths", "truth_counts")
    e, e_offsets, e_mask = _stack(estimates, estimate_counts, "estimates", "estimate_counts")
    if t_offsets.size != e_offsets.size:
        raise ValueError(f"truths have {t_offsets.size - 1} steps and estimates "
                         f"{e_offsets.size - 1}: they must be the same")
    t, e = _same_components(t, e)
    distance, (localisation, missed, false), assignment = _gospa(t, t_offsets, e, e_offsets,
                                                                 c, p, alpha)
    switching = np.zeros(t_offsets.size - 1)
    if truth_ids is not None or estimate_ids is not None or switching_penalty > 0:
        t_ids, n_ids = _ids(truth_ids, t_offsets, t_mask, "truth_ids", "truths")
        e_ids, _ = _ids(estimate_ids, e_offsets, e_mask, "estimate_ids", "estimates")
        if switching_penalty > 0:
            assigned = np.full(assignment.size, -1, dtype=np.int64)
            found = assignment >= 0
            first = np.repeat(e_offsets[:-1], np.diff(t_offsets))
            assigned[found] = e_ids[first[found] + assignment[found]]
            switching = _metric.switching(t_ids, t_offsets, e_offsets, assigned, n_ids)
            switching = switching_penalty * switching ** (1.0 / p)
            distance = (distance ** alpha + switching ** alpha) ** (1.0 / alpha)
    if t_mask is not None:
        padded = np.full(t_mask.shape, -1, dtype=np.int64)
        padded[t_mask] = assignment
        assignment = padded
    else:
        bounds = t_offsets.tolist()
        assignment = [assignment[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    return GOSPAResult(distance, localisation, missed, false, switching, assignment)


def ospa(truths, estimates, c, p=1, stonesoup_pairs=False):
    """OSPA distance between one step's truths and estimates (Stone Soup's
    ``OSPAMetric.compute_OSPA_distance``).

    Parameters
    ----------
    truths : (n, d) array_like of float
        The true points; an empty array for none.
    estimates : (m, d) array_like of float
        The estimated points, in the same components and units.
    c : float
        Cut-off distance, > 0 (same units).
    p : float
        Order, in [1, 30] (``c ** p`` in [1e-300, 1e300]), or ``inf``.
    stonesoup_pairs : bool
        Choose the pairs as Stone Soup 1.9.1 does, minimising ``sum min(d, c)`` (and for
        ``p = inf`` taking the largest distance of those pairs) instead of
        ``sum min(d, c) ** p`` (the bottleneck for ``p = inf``); the same for p = 1.

    Returns
    -------
    float
        The OSPA distance (units of the points); 0 when both sets are empty.

    Raises
    ------
    ValueError, TypeError
        As :func:`gospa`.
    """
    c, p = _ospa_parameters(c, p, stonesoup_pairs)
    (t, t_offsets), (e, e_offsets) = _one_step(truths, "truths"), _one_step(estimates,
                                                                           "estimates")
    return float(_ospa(t, t_offsets, e, e_offsets, c, p, stonesoup_pairs)[0])


def _ospa_parameters(c, p, stonesoup_pairs):
    c, p, _ = _parameters(c, p, infinite_p=True)
    if not isinstance(stonesoup_pairs, (bool, np.bool_)):
        raise TypeError(f"stonesoup_pairs must be a bool, got {_describe(stonesoup_pairs)}")
    return c, p


def _ospa(t, t_offsets, e, e_offsets, c, p, stonesoup_pairs):
    if t_offsets.size != e_offsets.size:
        raise ValueError(f"truths have {t_offsets.size - 1} steps and estimates "
                         f"{e_offsets.size - 1}: they must be the same")
    t, e = _same_components(t, e)
    t, e, unit_c, exponent = _in_units_of_c(t, e, c)
    return _back_from_units_of_c(exponent, p, _metric.ospa(t, t_offsets, e, e_offsets, unit_c,
                                                           p, stonesoup_pairs))[0]


def ospa_over_time(truths, estimates, c, p=1, stonesoup_pairs=False, *, truth_counts=None,
                   estimate_counts=None):
    """OSPA at every time step, all steps in one compiled call (Stone Soup's
    ``OSPAMetric.compute_over_time``).

    Parameters
    ----------
    truths : sequence of T (n_k, d) array_like, or (T, n, d) array_like of float
        Each step's true points, or a padded array (as :func:`gospa_over_time`).
    estimates : sequence of T (m_k, d) array_like, or (T, m, d) array_like of float
        Each step's estimated points, likewise.
    c : float
        Cut-off distance, > 0.
    p : float
        Order, in [1, 30] (``c ** p`` in [1e-300, 1e300]), or ``inf``.
    stonesoup_pairs : bool
        Choose the pairs as Stone Soup 1.9.1 does (see :func:`ospa`).
    truth_counts, estimate_counts : (T,) array_like of int, optional
        Valid rows per step of padded ``truths`` / ``estimates`` (default: all).

    Returns
    -------
    (T,) ndarray of float
        The OSPA distance at each step (0 where both sets are empty).

    Raises
    ------
    ValueError, TypeError
        As :func:`gospa_over_time`.
    """
    c, p = _ospa_parameters(c, p, stonesoup_pairs)
    t, t_offsets, _ = _stack(truths, truth_counts, "truths", "truth_counts")
    e, e_offsets, _ = _stack(estimates, estimate_counts, "estimates", "estimate_counts")
    return _ospa(t, t_offsets, e, e_offsets, c, p, stonesoup_pairs)
