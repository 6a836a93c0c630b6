"""Jacobians of measurement and transition functions: analytic for the built-in sensors,
finite differences otherwise.

FORWARD differences reproduce Stone Soup's ``functions.jacobian`` to the last bit: steps
``delta_i = 1e8 * spacing(x_i)`` raised to at least 1e-8 (every negative component steps by
exactly 1e-8), one evaluation at each ``x + delta_i e_i`` and one at x, angle outputs and
their differences wrapped by ``((a + pi) mod 2 pi) - pi``, in strict IEEE arithmetic.
CENTRAL differences step by ``cbrt(eps) max(|x_i|, 1)`` both ways (error O(delta^2)).
Differences of angles are wrapped either way, so derivatives are right across the +-pi cut.
"""
import numpy as np

from .dispatch import jit
from .kinds import ANALYTIC, CENTRAL, FORWARD
from .sensor import BEARING_RANGE, SELECT, _polar_jacobian, _predict_block, _sensor_frame
from .numeric import fill, wrap_angle
from .status import OK
from .user import output_status


@jit(strict=True)
def _mod_bearing(a):
    """Stone Soup's bearing wrap ``((a + pi) mod 2 pi) - pi``, bit for bit."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@jit(strict=True)
def _evaluation_points(x, central, steps, points):
    """Steps, and columns ``x + steps_i e_i`` (i < d) then x (forward) or
    ``x - steps_i e_i`` (central)."""
    d = x.size
    for i in range(d):
        if central:
            steps[i] = 6.0554544523933395e-06 * max(abs(x[i]), 1.0)
        else:
            step = 1e8 * np.spacing(x[i])
            steps[i] = step if step >= 1e-8 else 1e-8
    for c in range(points.shape[1]):
        for r in range(d):
            points[r, c] = x[r]
    for i in range(d):
        points[i, i] += steps[i]
        if central:
            points[i, d + i] -= steps[i]


@jit(strict=True)
def _differences(values, steps, angles, central, out):
    """Jacobian (m, d) from the function values at the evaluation points."""
    m, d = out.shape
    for r in range(m):
        for i in range(d):
            if central:
                delta = values[r, i] - values[r, d + i]
                out[r, i] = (wrap_angle(delta) if angles[r] else delta) / (2.0 * steps[i])
            else:
                delta = values[r, i] - values[r, d]
                out[r, i] = (_mod_bearing(delta) if angles[r] else delta) / steps[i]


@jit(strict=True)
def _polar_values(kind, points, mapping, offset, rotation, values):
    """Bearing (and range) at each column, computed as Stone Soup computes them."""
    for c in range(points.shape[1]):
        px, py = _sensor_frame(points[mapping[0], c], points[mapping[1], c], offset, rotation)
        values[0, c] = _mod_bearing(np.arctan2(py, px))
        if kind == BEARING_RANGE:
            values[1, c] = np.sqrt(px ** 2 + py ** 2)


@jit()
def measurement_jacobian(kind, x, mapping, offset, rotation, angles, method, out):
    """Jacobian (m, d) of a built-in measurement at the state x (d,).

    SELECT is exact whatever ``method``; the polar sensors are analytic for ANALYTIC, finite
    differences otherwise. A bearing's derivative is undefined at the sensor: NaN there, but
    for FORWARD (Stone Soup's rule, which gives numbers there too).
    """
    d = x.size
    fill(out, 0.0)
    if kind == SELECT:
        for r in range(mapping.size):
            out[r, mapping[r]] = 1.0
        return
    px, py = _sensor_frame(x[mapping[0]], x[mapping[1]], offset, rotation)
    if px == 0.0 and py == 0.0 and method != FORWARD:
        fill(out, np.nan)
        return
    if method == ANALYTIC:
        _polar_jacobian(kind, px, py, rotation, mapping, out)
        return
    central = method == CENTRAL
    columns = 2 * d if central else d + 1
    points = np.empty((d, columns))
    steps = np.empty(d)
    _evaluation_points(x, central, steps, points)
    values = np.empty((out.shape[0], columns))
    if central:
        _predict_block(kind, points, np.int64(0), columns, mapping, offset, rotation, values,
                       np.int64(0))
    else:
        _polar_values(kind, points, mapping, offset, rotation, values)
    _differences(values, steps, angles, central, out)


@jit()
def measurement_jacobian_function(function, x, angles, central, out):
    """Finite-difference Jacobian (m, d) of a user measurement ``h((d, n)) -> (m, n)``;
    returns the status of the function's outputs (``out`` is written only if OK)."""
    d = x.size
    points = np.empty((d, 2 * d if central else d + 1))
    steps = np.empty(d)
    _evaluation_points(x, central, steps, points)
    values = function(points)
    code = output_status(values, out.shape[0], points.shape[1])
    if code == OK:
        _differences(np.ascontiguousarray(values), steps, angles, central, out)
    return code


@jit()
def transition_jacobian_function(function, time_interval, x, central, out):
    """Finite-difference Jacobian (d, d) of a user transition ``f((d, n), dt) -> (d, n)``;
    returns the status of the function's outputs (``out`` is written only if OK)."""
    d = x.size
    points = np.empty((d, 2 * d if central else d + 1))
    steps = np.empty(d)
    _evaluation_points(x, central, steps, points)
    values = function(points, time_interval)
    code = output_status(values, d, points.shape[1])
    if code == OK:
        _differences(np.ascontiguousarray(values), steps, np.zeros(d, dtype=np.bool_),
                     central, out)
    return code

