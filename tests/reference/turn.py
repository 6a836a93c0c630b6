"""Mirror of ``fasttrack._jit.turn``: the constant-turn transition with NumPy, column by
column, the turn as a rotation of the velocity."""
import numpy as np


def constant_turn(states, dt):
    out = np.empty_like(states)
    for n in range(states.shape[1]):
        x, vx, y, vy, w = states[:, n]
        if abs(w * dt) < 1e-8:  # the first-order series of the arc
            a = w * dt
            out[:, n] = [x + vx * dt - 0.5 * a * dt * vy, vx * np.cos(a) - vy * np.sin(a),
                         y + 0.5 * a * dt * vx + vy * dt, vx * np.sin(a) + vy * np.cos(a), w]
            continue
        rotation = np.array([[np.cos(w * dt), -np.sin(w * dt)],
                             [np.sin(w * dt), np.cos(w * dt)]])
        # the position moves by the integral of the rotating velocity (1 - cos a written
        # 2 sin^2(a / 2), exact for a small angle)
        versine = 2.0 * np.sin(0.5 * w * dt) ** 2
        integral = np.array([[np.sin(w * dt), -versine], [versine, np.sin(w * dt)]]) / w
        position = np.array([x, y]) + integral @ [vx, vy]
        velocity = rotation @ [vx, vy]
        out[:, n] = [position[0], velocity[0], position[1], velocity[1], w]
    return out
