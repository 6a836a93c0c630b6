"""The multi-target metrics on stacked points: GOSPA (with Stone Soup's switching count)
and OSPA at every step, one optimal assignment per step.

Step k's truths are ``truths[truth_offsets[k]:truth_offsets[k + 1]]`` of (N, d) stacked
truths, its estimates likewise; :mod:`fasttrack.metrics` validates and wraps. The kernels
work in units of :func:`unit` (a power of two near the cut-off, see
:mod:`fasttrack._jit.metric`), so no ``c ** p`` or ``d ** p`` overflows or underflows
inside them.
"""
import math

import numpy as np

from .. import _jit

_assign = _jit.lazy("assign")
_kernels = _jit.lazy("metric")


def unit(c):
    """The power of two ``u`` with ``1 <= c / u < 2``, for a positive finite ``c``: the
    kernels' unit of distance (dividing by it is exact)."""
    _, exponent = math.frexp(c)  # c = f * 2**exponent, 0.5 <= f < 1
    return math.ldexp(1.0, exponent - 1)


def gospa(truths, truth_offsets, estimates, estimate_offsets, c, p, alpha):
    """``(parts, assignment)``: (steps, 4) distance, localisation, missed and false parts
    of GOSPA at each step, and (N,) int64 each truth's estimate (its row within the step,
    -1 if unassigned).

    The distance is exact to rounding for any finite positive ``c``; the parts are in the
    units of the points to the power p, so a nonzero part is ``inf`` where it exceeds
    float64 (``c ** p`` beyond about 1.8e308) and underflows towards 0 below 2.2e-308."""
    u = unit(c)
    assignment = np.empty(truths.shape[0], dtype=np.int64)
    parts = np.empty((truth_offsets.size - 1, 4))
    _kernels.gospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, u, p, alpha,
                         assignment, parts)
    if u != 1.0:  # back to the units of the points; a zero part stays 0 (not inf * 0)
        with np.errstate(over="ignore", under="ignore"):
            scale = np.float64(u) ** p
            scaled = parts[:, 1:]
            np.multiply(scaled, scale, out=scaled, where=scaled != 0.0)
    return parts, assignment


def switching(truth_ids, truth_offsets, estimate_offsets, assigned_ids, n_ids):
    """(steps,) Stone Soup's GOSPA switching count at every step (before the penalty and
    the power 1/p), from the truths' ids (N,) in ``[0, n_ids)`` and the ids of their
    assigned estimates (N,), -1 if none."""
    out = np.zeros(truth_offsets.size - 1)
    _assign.switching_loss(truth_ids, truth_offsets, estimate_offsets, assigned_ids, n_ids,
                           out)
    return out


def ospa(truths, truth_offsets, estimates, estimate_offsets, c, p, stonesoup):
    """(steps,) OSPA at every step, exact to rounding for any finite positive ``c``;
    ``stonesoup`` reproduces Stone Soup 1.9.1's choice of pairs (see
    :func:`fasttrack._jit.metric.ospa_steps`)."""
    out = np.empty(truth_offsets.size - 1)
    _kernels.ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, unit(c), p,
                        bool(stonesoup), out)
    return out
