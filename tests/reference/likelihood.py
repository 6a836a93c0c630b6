"""Mirrors of ``fasttrack._jit.likelihood``: particles measured by a built-in sensor kind or
a user's function, and their log-likelihoods."""
import numpy as np

from .numeric import wrap_angle
from .sensor import BEARING_RANGE, SELECT
from .status import OK
from .user import output_status


def measure(kind, x, mapping, offset, rotation, out):
    if kind == SELECT:
        out[:] = x[mapping]
        return
    p = rotation @ (x[mapping[:2]] - offset[:, None])
    out[0] = wrap_angle(np.arctan2(p[1], p[0]))
    if kind == BEARING_RANGE:
        out[1] = np.hypot(p[0], p[1])


def _log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out):
    innovation = z[:, None] - predicted
    innovation[angles] = wrap_angle(innovation[angles])
    out[:] = log_w + log_norm - 0.5 * np.sum((whiten @ innovation) ** 2, axis=0)
    return np.nan if np.isnan(out).any() else out.max()


def log_likelihood(kind, z, x, mapping, offset, rotation, angles, whiten, log_norm, log_w, out):
    predicted = np.empty((z.size, x.shape[1]))
    measure(kind, x, mapping, offset, rotation, predicted)
    return _log_likelihoods(z, predicted, angles, whiten, log_norm, log_w, out)


def measure_function(function, x, angles, out):
    values = function(np.ascontiguousarray(x))
    status = output_status(values, out.shape[0], x.shape[1])
    if status == OK:
        out[:] = values
        out[angles] = wrap_angle(out[angles])
    return status


def log_likelihood_function(function, z, x, angles, whiten, log_norm, log_w, out):
    values = function(np.ascontiguousarray(x))
    status = output_status(values, z.size, x.shape[1])
    if status != OK:
        return np.nan, status
    return _log_likelihoods(z, values, angles, whiten, log_norm, log_w, out), status
