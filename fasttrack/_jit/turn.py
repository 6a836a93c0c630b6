"""The constant-turn transition in the plane, state (x, vx, y, vy, w): the function of
:class:`fasttrack.models.kinematic.ConstantTurn`, which its filters call as a model
function."""
import math

import numpy as np

from .dispatch import jit

#: Turns (|w dt|, radians) below which the arc is its series ``dt``, ``w dt^2 / 2``: exact
#: to float64 there (the next terms are below 1e-16 relative), and no division by w.
SMALL_TURN = 1e-8


@jit()
def constant_turn(states, dt):
    """(5, n) states, one a column, moved ``dt`` seconds along their turns of rate w
    (rad/s): the velocity turned by w dt and the position along the arc (below
    :data:`SMALL_TURN` radians, its first-order series: w = 0 is the straight line), and w
    is kept."""
    out = np.empty_like(states)
    for n in range(states.shape[1]):
        vx, vy, w = states[1, n], states[3, n], states[4, n]
        angle = w * dt
        s, c = math.sin(angle), math.cos(angle)
        if abs(angle) < SMALL_TURN:  # the series (no division by a tiny or subnormal w)
            along, across = dt, 0.5 * angle * dt
        else:  # (1 - cos) / w without the cancellation of a small angle
            half = math.sin(0.5 * angle)
            along, across = s / w, 2.0 * half * half / w
        out[0, n] = states[0, n] + along * vx - across * vy
        out[1, n] = c * vx - s * vy
        out[2, n] = states[2, n] + across * vx + along * vy
        out[3, n] = s * vx + c * vy
        out[4, n] = w
    return out
