"""Mirrors of ``fasttrack._jit.jacobian``: measurement and transition Jacobians, analytic
or by forward and central differences."""
import numpy as np

from .likelihood import measure
from .numeric import wrap_angle
from .sensor import BEARING_RANGE, SELECT
from .status import OK
from .user import output_status


ANALYTIC, FORWARD, CENTRAL = 0, 1, 2


def _mod_bearing(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _steps(x, central):
    if central:
        return np.cbrt(np.finfo(float).eps) * np.maximum(np.abs(x), 1.0)
    steps = 1e8 * np.spacing(x)
    steps[steps < 1e-8] = 1e-8
    return steps


def _difference_jacobian(evaluate, x, angles, central):
    """Finite-difference Jacobian of ``evaluate((d, n)) -> (m, n)`` at x (d,)."""
    d = x.size
    steps = _steps(x, central)
    plus = x[:, None] + np.diag(steps)
    if central:
        minus = x[:, None] - np.diag(steps)
        delta = evaluate(plus) - evaluate(minus)
        delta[angles] = wrap_angle(delta[angles])
        return delta / (2 * steps)
    values = evaluate(np.column_stack([plus, x]))
    delta = values[:, :d] - values[:, d:]
    delta[angles] = _mod_bearing(delta[angles])
    return delta / steps


def _polar(kind, points, mapping, offset, rotation):
    """Stone Soup's arithmetic: bearing wrapped by mod_bearing, range by sqrt(x**2 + y**2)."""
    p = rotation @ (points[list(mapping[:2])] - offset[:, None])
    rows = [_mod_bearing(np.arctan2(p[1], p[0]))]
    if kind == BEARING_RANGE:
        rows.append(np.sqrt(p[0] ** 2 + p[1] ** 2))
    return np.array(rows)


def measurement_jacobian(kind, x, mapping, offset, rotation, angles, method, out):
    out[:] = 0.0
    if kind == SELECT:
        out[np.arange(mapping.size), mapping] = 1.0
        return
    p = rotation @ (x[list(mapping[:2])] - offset)
    rho2 = p @ p
    if rho2 == 0.0 and method != FORWARD:
        out[:] = np.nan
        return
    if method == ANALYTIC:
        rows = [np.array([-p[1], p[0]]) / rho2]
        if kind == BEARING_RANGE:
            rows.append(p / np.sqrt(rho2))
        out[:, list(mapping[:2])] = np.array(rows) @ rotation
        return
    def evaluate(points):
        if method != CENTRAL:
            return _polar(kind, points, mapping, offset, rotation)
        values = np.empty((out.shape[0], points.shape[1]))
        measure(kind, points, mapping, offset, rotation, values)
        return values
    out[:] = _difference_jacobian(evaluate, x, angles, method == CENTRAL)


class _BadOutput(Exception):
    """A user function's output failed :func:`output_status`."""


def _checked_jacobian(evaluate, rows, x, angles, central, out):
    """:func:`_difference_jacobian` of a user function, or the status of a bad output."""
    def checked(points):
        values = evaluate(np.ascontiguousarray(points))
        status = output_status(values, rows, points.shape[1])
        if status != OK:
            raise _BadOutput(status)
        return values
    try:
        out[:] = _difference_jacobian(checked, x, angles, central)
    except _BadOutput as bad:
        return bad.args[0]
    return OK


def measurement_jacobian_function(function, x, angles, central, out):
    return _checked_jacobian(function, out.shape[0], x, angles, central, out)


def transition_jacobian_function(function, time_interval, x, central, out):
    return _checked_jacobian(lambda points: function(points, time_interval), x.size, x,
                             np.zeros(x.size, dtype=bool), central, out)
