"""The multi-target metrics on stacked points: GOSPA (with Stone Soup's switching count)
and OSPA at every step, one optimal assignment per step.

Step k's truths are ``truths[truth_offsets[k]:truth_offsets[k + 1]]`` of (N, d) stacked
truths, its estimates likewise; :mod:`fasttrack.metrics` validates and wraps. A process's
first small OSPA calls run in NumPy (:mod:`.metric_numpy`).
"""
import numpy as np

from .. import _jit
from .. import threads as _threads
from .._jit.tunables import SERIAL_BELOW_ASSIGN
from . import metric_numpy as _numpy

_assign = _jit.lazy("assign")


def gospa(truths, truth_offsets, estimates, estimate_offsets, c, p, alpha):
    """``(parts, assignment)``: (steps, 4) distance, localisation, missed and false parts
    of GOSPA at each step, and (N,) int64 each truth's estimate (its row within the step,
    -1 if unassigned)."""
    assignment = np.empty(truths.shape[0], dtype=np.int64)
    parts = np.empty((truth_offsets.size - 1, 4))
    _by_steps(lambda t, e, lo, hi: _assign.gospa_steps(truths, t, estimates, e, c, p, alpha,
                                                       assignment, parts[lo:hi]),
              truths, truth_offsets, estimate_offsets)
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
    """(steps,) OSPA at every step; ``stonesoup`` reproduces Stone Soup 1.9.1's choice of
    pairs (see :func:`fasttrack._jit.assign.ospa_steps`)."""
    out = np.empty(truth_offsets.size - 1)
    if _jit.numpy_first(truths.shape[0] + estimates.shape[0]):
        _numpy.ospa_steps(truths, truth_offsets, estimates, estimate_offsets, c, p,
                          bool(stonesoup), out)
        return out
    _by_steps(lambda t, e, lo, hi: _assign.ospa_steps(truths, t, estimates, e, c, p,
                                                      bool(stonesoup), out[lo:hi]),
              truths, truth_offsets, estimate_offsets)
    return out


def _by_steps(run, truths, truth_offsets, estimate_offsets):
    """``run(truth_offsets, estimate_offsets, lo, hi)`` on chunks ``[lo, hi)`` of the steps
    (the offsets sliced to them), on threads."""
    _threads.in_chunks(lambda lo, hi: run(truth_offsets[lo:hi + 1],
                                          estimate_offsets[lo:hi + 1], lo, hi),
                       truth_offsets.size - 1, SERIAL_BELOW_ASSIGN, work=truths.size,
                       per_thread=4)
