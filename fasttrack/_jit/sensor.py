"""The geometry of the built-in sensors: their kinds, positions in a polar sensor's frame,
predicted measurements of a block of states, and the analytic Jacobian of bearing and
range.

- SELECT: ``h(x) = x[mapping]`` (linear-Gaussian measurement of some state components);
- BEARING_RANGE: ``(atan2(p_y, p_x), |p|)`` of ``p = R (x[mapping[:2]] - offset)``, with R the
  top-left 2x2 block of the sensor rotation;
- BEARING: the bearing alone.
"""
import numpy as np

from .dispatch import jit
from .kinds import BEARING, BEARING_RANGE, SELECT
from .numeric import fast_atan2, wrap_angle


@jit(strict=True)
def _sensor_frame(x, y, offset, rotation):
    """The position ``(x, y)`` in the sensor's frame: ``R (p - offset)`` (IEEE arithmetic, as
    Stone Soup computes it)."""
    dx = x - offset[0]
    dy = y - offset[1]
    return rotation[0, 0] * dx + rotation[0, 1] * dy, rotation[1, 0] * dx + rotation[1, 1] * dy


@jit()
def _predict_block(kind, x, lo, hi, mapping, offset, rotation, out, at):
    """Predicted measurements of particles ``lo:hi`` into ``out[:, at:at + hi - lo]``."""
    if kind == SELECT:
        for r in range(mapping.size):
            row = out[r, at:at + hi - lo]
            xr = x[mapping[r], lo:hi]
            for i in range(row.size):
                row[i] = xr[i]
        return
    xs = x[mapping[0], lo:hi]
    ys = x[mapping[1], lo:hi]
    bearings = out[0, at:at + hi - lo]
    # one loop per kind: a test of the kind inside the loop would stop its vectorisation
    if kind == BEARING_RANGE:
        ranges = out[1, at:at + hi - lo]
        for i in range(bearings.size):
            px, py = _sensor_frame(xs[i], ys[i], offset, rotation)
            bearings[i] = wrap_angle(fast_atan2(py, px))
            ranges[i] = np.sqrt(px * px + py * py)
    else:
        for i in range(bearings.size):
            px, py = _sensor_frame(xs[i], ys[i], offset, rotation)
            bearings[i] = wrap_angle(fast_atan2(py, px))


@jit()
def _polar_jacobian(kind, px, py, rotation, mapping, out):
    """The analytic Jacobian rows of bearing (and range) into the (m, d) ``out``, whose other
    entries are left as they are, for a state at ``(px, py)`` in the sensor's frame; False
    (nothing written) at the sensor, where the bearing has no derivative."""
    rho2 = px * px + py * py
    if rho2 == 0.0:
        return False
    for c in range(2):  # d p / d x[mapping[c]] is column c of the rotation
        column = mapping[c]
        out[0, column] = (-py * rotation[0, c] + px * rotation[1, c]) / rho2
        if kind == BEARING_RANGE:
            out[1, column] = (px * rotation[0, c] + py * rotation[1, c]) / np.sqrt(rho2)
    return True
