"""Kinematic transition models of one axis or the plane: nearly constant velocity and
acceleration, a turn at a known rate, and a turn whose rate is in the state (Stone Soup's
``ConstantVelocity``, ``ConstantAcceleration``, ``KnownTurnRate`` and ``ConstantTurn``);
combine axes with :class:`~fasttrack.models.transition.CombinedLinearGaussianTransitionModel`."""
import numpy as np

from .. import _validate
from ..core.kinematic import constant_turn
from .base import read_only
from .transition import NonlinearGaussianTransitionModel, _block_diag, _LinearGaussian

__all__ = ["ConstantAcceleration", "ConstantTurn", "ConstantVelocity", "KnownTurnRate"]


class _OneAxis(_LinearGaussian):
    """A model of one axis driven by white noise of rate q on its highest derivative
    (``noise_diff_coeff``); F does not depend on q."""

    def __init__(self, noise_diff_coeff):
        self.noise_diff_coeff = noise_diff_coeff

    @property
    def noise_diff_coeff(self):
        """q >= 0, in (state units)^2 / s^(2 n + 1) for the n-th derivative."""
        return self._q

    @noise_diff_coeff.setter
    def noise_diff_coeff(self, value):
        self._q = _validate.non_negative(value, "noise_diff_coeff")

    def _parameters(self):
        return None  # F does not depend on q

    def _noise_parameters(self):
        return self._q


class ConstantVelocity(_OneAxis):
    """Nearly constant velocity in one dimension, state (position, velocity).

    ``F = [[1, dt], [0, 1]]``, ``Q = q [[t^3/3, t^2/2], [t^2/2, t]]`` with ``t = |dt|``.

    Parameters
    ----------
    noise_diff_coeff : float
        q >= 0, in (state units)^2 / s^3.
    """

    ndim_state = property(lambda self: 2, doc="Number of state dimensions (2).")

    def matrix(self, time_interval):
        """F(dt) = ``[[1, dt], [0, 1]]`` (2, 2).

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt (may be negative).
        """
        dt = self._seconds(time_interval)
        return np.array([[1.0, dt], [0.0, 1.0]])

    def covar(self, time_interval):
        """Q(dt) = ``q [[t^3/3, t^2/2], [t^2/2, t]]`` (2, 2) with ``t = |dt|``.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt (may be negative).
        """
        return _velocity_noise(self.noise_diff_coeff, self._seconds(time_interval))

    def cv_rates(self):
        return (self._q,)


class ConstantAcceleration(_OneAxis):
    """Nearly constant acceleration in one dimension, state (position, velocity,
    acceleration) (Stone Soup's ``ConstantAcceleration``).

    ``F = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]``; white noise of rate q on the jerk
    gives ``Q = q [[t^5/20, t^4/8, t^3/6], [t^4/8, t^3/3, t^2/2], [t^3/6, t^2/2, t]]`` with
    ``t = |dt|``.

    Parameters
    ----------
    noise_diff_coeff : float
        q >= 0, in (state units)^2 / s^5.
    """

    ndim_state = property(lambda self: 3, doc="Number of state dimensions (3).")

    def matrix(self, time_interval):
        """F(dt) (3, 3).

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt (may be negative).
        """
        dt = self._seconds(time_interval)
        return np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])

    def covar(self, time_interval):
        """Q(dt) (3, 3), with ``t = |dt|``.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt (may be negative).
        """
        t = np.float64(abs(self._seconds(time_interval)))
        with np.errstate(over="ignore"):
            noise = self._q * np.array([[t**5 / 20, t**4 / 8, t**3 / 6],
                                        [t**4 / 8, t**3 / 3, t**2 / 2],
                                        [t**3 / 6, t**2 / 2, t]])
        if not np.isfinite(noise).all():
            raise ValueError(f"time_interval of {t:g} s overflows Q(dt) (q t^5 / 20 with "
                             f"q = {self._q:g})")
        return noise


def _axis_rates(value, name):
    """Two noise rates (along x and y), each >= 0, as a new array; a ValueError names
    ``name``."""
    qs = _validate.finite_array(value, name, 1)
    if qs.shape != (2,) or (qs < 0).any():
        raise ValueError(f"{name} must be two numbers >= 0, got {qs.tolist()}")
    return qs.copy()


def _velocity_noise(q, dt):
    """``q [[t^3/3, t^2/2], [t^2/2, t]]`` with ``t = |dt|``: the noise of a nearly constant
    velocity over dt seconds; a ValueError if it overflows."""
    t = np.float64(abs(dt))
    with np.errstate(over="ignore"):
        noise = q * np.array([[t**3 / 3, t**2 / 2], [t**2 / 2, t]])
    if not np.isfinite(noise).all():
        raise ValueError(f"time_interval of {t:g} s overflows Q(dt) (q t^3 / 3 with "
                         f"q = {q:g})")
    return noise


class KnownTurnRate(_LinearGaussian):
    """A nearly constant turn at a known rate w in the plane, state (x, vx, y, vy) (Stone
    Soup's ``KnownTurnRate``).

    With ``s = sin(w dt)`` and ``c = cos(w dt)``, ``F(dt) = [[1, s/w, 0, -(1 - c)/w],
    [0, c, 0, -s], [0, (1 - c)/w, 1, s/w], [0, s, 0, c]]`` turns the velocity by w dt and
    moves the position along the arc (w = 0 is its limit, constant velocity); Q is a
    constant-velocity noise per axis, ``q_i [[t^3/3, t^2/2], [t^2/2, t]]`` with
    ``t = |dt|``.

    Parameters
    ----------
    turn_noise_diff_coeffs : (2,) array_like
        q1 (along x) and q2 (along y), >= 0, in (state units)^2 / s^3.
    turn_rate : float
        w in rad/s, positive anticlockwise.
    """

    ndim_state = property(lambda self: 4, doc="Number of state dimensions (4).")

    def __init__(self, turn_noise_diff_coeffs, turn_rate):
        self.turn_noise_diff_coeffs = turn_noise_diff_coeffs
        self.turn_rate = turn_rate

    @property
    def turn_noise_diff_coeffs(self):
        """(q1, q2), each >= 0 (a read-only array)."""
        return read_only(self._qs)

    @turn_noise_diff_coeffs.setter
    def turn_noise_diff_coeffs(self, value):
        self._qs = _axis_rates(value, "turn_noise_diff_coeffs")

    @property
    def turn_rate(self):
        """w, rad/s."""
        return self._turn_rate

    @turn_rate.setter
    def turn_rate(self, value):
        self._turn_rate = _validate.real(value, "turn_rate")

    def _parameters(self):
        return self._turn_rate

    def _noise_parameters(self):
        return self._qs.tobytes()

    def matrix(self, time_interval):
        """F(dt) (4, 4).

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt (may be negative).
        """
        dt, w = self._seconds(time_interval), self._turn_rate
        s, c = np.sin(w * dt), np.cos(w * dt)
        along, across = (s / w, (1.0 - c) / w) if w != 0.0 else (dt, 0.0)
        return np.array([[1.0, along, 0.0, -across], [0.0, c, 0.0, -s],
                         [0.0, across, 1.0, along], [0.0, s, 0.0, c]])

    def covar(self, time_interval):
        """Q(dt) (4, 4): a constant-velocity noise per axis.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt (may be negative).
        """
        dt = self._seconds(time_interval)
        return _block_diag([_velocity_noise(q, dt) for q in self._qs])


class ConstantTurn(NonlinearGaussianTransitionModel):
    """Nearly constant speed and turn rate in the plane, state (x, vx, y, vy, w) with the
    turn rate w in rad/s (Stone Soup's ``ConstantTurn``): the velocity turns by w dt and
    the position moves along the arc; w = 0 is the straight-line limit (Stone Soup turns a
    rate of exactly 0 into machine epsilon). Nonlinear in w: filter it with the extended or
    unscented Kalman filter or a particle filter.

    ``Q(dt)`` is ``q_x [[t^3/3, t^2/2], [t^2/2, t]]`` on (x, vx), the same with ``q_y`` on
    (y, vy), and ``q_w t`` on w, with ``t = |dt|``.

    Parameters
    ----------
    linear_noise_coeffs : (2,) array_like
        q_x and q_y, >= 0, in (state units)^2 / s^3.
    turn_noise_coeff : float
        q_w >= 0, in rad^2 / s^3.
    """

    def __init__(self, linear_noise_coeffs, turn_noise_coeff):
        self.linear_noise_coeffs = linear_noise_coeffs
        self.turn_noise_coeff = turn_noise_coeff
        super().__init__(constant_turn(), self._process_noise, 5)

    @property
    def linear_noise_coeffs(self):
        """(q_x, q_y), each >= 0 (a read-only array)."""
        return read_only(self._linear_qs)

    @linear_noise_coeffs.setter
    def linear_noise_coeffs(self, value):
        self._linear_qs = _axis_rates(value, "linear_noise_coeffs")

    @property
    def turn_noise_coeff(self):
        """q_w >= 0, in rad^2 / s^3."""
        return self._turn_q

    @turn_noise_coeff.setter
    def turn_noise_coeff(self, value):
        self._turn_q = _validate.non_negative(value, "turn_noise_coeff")

    def _process_noise(self, dt):
        """Q(dt) (5, 5): the velocity blocks and the turn rate's random walk."""
        noise = np.zeros((5, 5))
        noise[:4, :4] = _block_diag([_velocity_noise(q, dt) for q in self._linear_qs])
        noise[4, 4] = self._turn_q * abs(dt)
        return noise
