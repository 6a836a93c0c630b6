"""What the Gaussian stacks share: K filters as (K, d) means and (K, d, d) covariances,
run in chunks over threads, with one int64 status per filter.

:mod:`fasttrack.core.kalman` and :mod:`fasttrack.core.unscented` build their stack steps
on these; a single Gaussian state is a stack of one.
"""
import numpy as np

from .. import _errors
from .. import _jit
from .. import threads as _threads
from .._jit import status as _status
from .kinds import CV, FIXED
from .._jit.tunables import SERIAL_BELOW_FILTERS

_kalman = _jit.lazy("kalman")


#: An update's "prior" is the caller's prediction: statuses named for it.
AS_PREDICTION = {_status.PRIOR_NOT_PSD: _status.PREDICTION_NOT_PSD,
                 _status.PRIOR_NOT_SYMMETRIC: _status.PREDICTION_NOT_SYMMETRIC}


def in_chunks(k, run):
    """``run(lo, hi)`` on chunks of the K filters, in parallel threads."""
    _threads.in_chunks(run, k, serial_below=SERIAL_BELOW_FILTERS, align=_kalman.FILTERS_PER_BLOCK)


def identity(d):
    """The kernel transition F = I, Q = 0: a step through it (exact) is the update alone."""
    return FIXED, np.empty(0), np.eye(d), np.zeros((d, d))


def one_transition(model, intervals):
    """Whether one kernel transition of ``model`` serves every interval (seconds) of
    ``intervals``: CV blocks (built per interval), a time-invariant model, or equal
    intervals (a function of the interval needs them equal)."""
    return _serves(model.spec(float(intervals.flat[0])), intervals)


def _serves(spec, intervals):
    return spec.kind == CV or spec.time_invariant or np.all(intervals == spec.dt)


def transition(model, intervals):
    """``(kind, rates, F, Q)``: the kernel transition of a linear ``model`` for the
    filters' ``intervals`` (seconds); F and Q of the first interval unless CV blocks."""
    spec = model.spec(float(intervals.flat[0]))
    if not _serves(spec, intervals):
        raise ValueError(f"{type(model).__name__} mixes constant-velocity and other "
                         f"parts, so its filters need one common time interval")
    return spec.kalman()


def check(status, means=None, covars=None):
    """Raise the ValueError naming the first failed filter of ``status`` (K,), if any; a
    prediction that is not finite from its input ``means`` or ``covars`` (K, ...), if
    given, that was not finite already is named as such."""
    failed = np.flatnonzero(status)
    if failed.size:
        k = failed[0]
        message = _message(status[k], k)
        if status[k] == _status.PREDICTION_OVERFLOW and means is not None:
            given = [f"{name}[{k}]" for name, values in (("means", means), ("covars", covars))
                     if not np.isfinite(values[k]).all()]
            if given:
                message = f"{' and '.join(given)} {'are' if len(given) > 1 else 'is'} not finite"
        raise ValueError(f"{failed.size} of {status.size} filters failed; filter {k}: "
                         f"{message}")


def _message(code, k):
    """The message of filter ``k``'s status ``code``, naming its input mean ``means[k]`` or
    covariance ``covars[k]`` where the code is about it."""
    message = _errors.MESSAGES[code]
    for name, own in (("prior.covar", "covars"), ("the prediction's covariance", "covars"),
                      ("prior.state_vector", "means"), ("the prediction's mean", "means")):
        message = message.replace(name, f"{own}[{k}]")
    return message


def run(step, transition_args, intervals, means, covars, measurements):
    """``(means, covars)`` (T, K, d) and (T, K, d, d): the K filters through T steps of
    ``step(transition_args, intervals[t], means, covars, measurements[t], means_out,
    covars_out, status)``. Raises ValueError naming the first failed filter and step."""
    steps, k, d = measurements.shape[0], means.shape[0], means.shape[1]
    means_out, covars_out = np.empty((steps, k, d)), np.empty((steps, k, d, d))
    if steps == 0 or k == 0:
        return means_out, covars_out
    status = np.empty(k, dtype=np.int64)
    failed_at = np.full(k, steps)
    codes = np.zeros(k, dtype=np.int64)
    for t in range(steps):  # one compiled step kernel, a call per step
        step(transition_args, intervals[t], means, covars, measurements[t], means_out[t],
             covars_out[t], status)
        new = (status != 0) & (failed_at == steps)
        failed_at[new], codes[new] = t, status[new]
        means, covars = means_out[t], covars_out[t]
    failed = np.flatnonzero(codes)
    if failed.size:
        first = failed[0]
        message = (_message(codes[first], first) if failed_at[first] == 0
                   else _errors.MESSAGES[codes[first]])
        raise ValueError(f"{failed.size} of {k} filters failed; filter {first} at step "
                         f"{failed_at[first]}: {message}")
    return means_out, covars_out
