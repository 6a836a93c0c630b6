"""What a model tells the array layer: kind codes and arrays.

:mod:`fasttrack.core` reads a model only through these specs (``model.spec(dt)`` of a
transition, ``model.spec`` of a measurement model), never through its own attributes.
"""
from typing import NamedTuple

import numpy as np

from ..core.kinds import BEARING, BEARING_RANGE, CV, FIXED, FUNCTION, SELECT

_NO_RATES = np.empty(0)
_NO_MATRIX = np.empty((0, 0))


class TransitionSpec:
    """A transition over one interval of ``dt`` seconds.

    Attributes
    ----------
    kind : int64
        FIXED (F and Q given), CV (constant-velocity blocks, F and Q built by the kernels
        from ``rates``) or FUNCTION (a user's function).
    rates : (blocks,) float64 ndarray
        The noise rates q of the CV blocks (empty unless CV).
    function : UserFunction or None
        The checked user function of a FUNCTION transition.
    dt : float
        The interval, seconds.
    matrix, noise, noise_root : (d, d) float64 ndarray
        F(dt) (linear models), Q(dt) and a square root of Q(dt), computed when read (the
        model memoises F for the last interval).
    """

    __slots__ = ("kind", "rates", "function", "dt", "_model")

    def __init__(self, model, dt, kind, rates=_NO_RATES, function=None):
        self._model, self.dt = model, dt
        self.kind, self.rates, self.function = kind, rates, function

    @property
    def matrix(self):
        return self._model._matrix(self.dt)

    @property
    def noise(self):
        return self._model._covar(self.dt)

    @property
    def noise_root(self):
        return self._model._noise(self.dt).root

    @property
    def time_invariant(self):
        """Whether F and Q are the same for every interval."""
        return self._model.time_invariant

    def mean(self, x):
        """The noise-free transition of (d, N) states ``x``: ``F x`` or ``f(x, dt)``."""
        return self._model._mean(x, self.dt)

    def kalman(self):
        """``(kind, rates, F, Q)``, the transition arguments of the Kalman kernels (F and Q
        empty for CV blocks, which the kernels build). Linear transitions only."""
        if self.kind == CV:
            return CV, self.rates, _NO_MATRIX, _NO_MATRIX
        return FIXED, _NO_RATES, self.matrix, self.noise


class MeasurementSpec(NamedTuple):
    """A measurement model's parameters.

    ``kind`` is SELECT, BEARING_RANGE or BEARING (built-in sensors, with ``mapping`` (int64
    state rows), sensor ``offset`` (2,) and ``rotation`` (2, 2)) or FUNCTION (``function``
    the checked user function, the arrays empty); ``noise_covar`` is R (m, m), ``noise``
    its :class:`~fasttrack.models.base.GaussianNoise`, ``angles`` the (m,) bool mask of
    angle rows.
    """

    kind: np.int64
    mapping: np.ndarray
    offset: np.ndarray
    rotation: np.ndarray
    noise_covar: np.ndarray
    angles: np.ndarray
    noise: object
    function: object
    ndim_state: int
    ndim_meas: int

    @property
    def sensor(self):
        """``(kind, mapping, offset, rotation, R, angles)``: the sensor arguments of the
        Kalman and unscented kernels (built-in sensors)."""
        return self[:6]

    @property
    def is_function(self):
        return self.kind == FUNCTION


__all__ = ["BEARING", "BEARING_RANGE", "CV", "FIXED", "FUNCTION", "MeasurementSpec", "SELECT",
           "TransitionSpec"]
