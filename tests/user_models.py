"""User-defined @njit models shared by the tests (the signatures of docs/models.md)."""
import numpy as np
from numba import njit


@njit(cache=False)
def coordinated_turn(states, dt):
    """(x, vx, y, vy) turning at 0.05 rad/s."""
    w = 0.05
    s, c = np.sin(w * dt), np.cos(w * dt)
    out = np.empty_like(states)
    out[0] = states[0] + s / w * states[1] - (1 - c) / w * states[3]
    out[1] = c * states[1] - s * states[3]
    out[2] = states[2] + (1 - c) / w * states[1] + s / w * states[3]
    out[3] = s * states[1] + c * states[3]
    return out


@njit(cache=False)
def bearing_range_from_50_0(states):
    """(bearing, range) of (x, y) = states[[0, 2]] from a sensor at (50, 0)."""
    out = np.empty((2, states.shape[1]))
    dx, dy = states[0] - 50.0, states[2]
    out[0] = np.arctan2(dy, dx)
    out[1] = np.sqrt(dx * dx + dy * dy)
    return out
