"""Kernels k(x, y) on state or measurement vectors, and their Gram matrices.

A kernel called on (d, A) and (d, B) points returns the (A, B) Gram matrix, computed in a
parallel compiled kernel. Parameters are fixed at construction: calling a kernel never
changes them.
"""
import numbers

import numpy as np

from . import _validate
from .core import akkf as _akkf
from .core.kinds import GAUSSIAN, POLYNOMIAL
from .models.base import state_columns
from ._jit.tunables import NEGLIGIBLE_KERNEL as NEGLIGIBLE

__all__ = [
    "Kernel", "PolynomialKernel", "LinearKernel", "QuadraticKernel", "QuarticKernel",
    "GaussianKernel",
]


class Kernel:
    """Base class: a kernel kind and its parameter array (see ``fasttrack._jit.gram``);
    ``spec`` gives them to the array layer."""

    _kind = None

    def _parameters(self):
        raise NotImplementedError

    def __call__(self, state1, state2=None, angle_components=()):
        """Gram matrix ``K[a, b] = k(x1[:, a], x2[:, b])``.

        Parameters
        ----------
        state1, state2 : state object or (d,) / (d, N) array_like
            Points as columns (``state2`` defaults to ``state1``).
        angle_components : sequence of int, optional
            Rows that are angles (rad), integer indices in [0, d), for the Gaussian kernel
            (see there); polynomial kernels, which see only inner products, ignore them.
            None or empty for none.

        Returns
        -------
        (A, B) float64 ndarray
            A data-chosen length scale (``GaussianKernel()``) comes from the points of
            ``state1`` and ``state2`` together.

        Raises
        ------
        TypeError
            If ``angle_components`` is not a sequence of integers (a bool, a float, a string
            or a boolean mask is not an index), or the points are not real numbers.
        ValueError
            For an angle row out of range, points that are not finite, or a Gram matrix
            that is not finite (the points' distances or inner products overflow float64,
            e.g. points around 1e154 or beyond): rescale ``state1`` and ``state2``.
        """
        x1 = state_columns(state1, "state1")
        x2 = x1 if state2 is None else state_columns(state2, "state2")
        if x2.shape[0] != x1.shape[0]:
            raise ValueError(f"state1 and state2 must have the same number of rows, "
                             f"got {x1.shape[0]} and {x2.shape[0]}")
        angles = self.angle_mask(x1.shape[0], angle_components)
        others = np.empty((x1.shape[0], 0)) if state2 is None else x2
        gram = _akkf.gram(self._kind, self._parameters(), angles, x1, x2, others)
        if not np.isfinite(gram).all():
            raise ValueError("the kernel values are not finite (the points' distances or "
                             "inner products overflow): rescale state1 and state2")
        return gram

    @staticmethod
    def angle_mask(ndim, angle_components=()):
        """A (ndim,) bool array flagging ``angle_components`` (rows in [0, ndim)).

        Parameters
        ----------
        ndim : int
            Number of rows of the points.
        angle_components : sequence of int or None
            Rows that are angles, integer indices each in [0, ndim); None for none.

        Returns
        -------
        bool ndarray
            Of length ``ndim``.

        Raises
        ------
        TypeError
            For anything but a sequence of integers (a bool, float or string entry, or a
            boolean mask, is refused rather than read as an index).
        ValueError
            For an index outside [0, ndim).
        """
        return _akkf.angle_mask(ndim, angle_components)

    def spec(self, angles, x1, x2):
        """``(kind, params)`` for a filter's Gram matrices of the points ``x1`` and ``x2``
        (together), with any length scale from the data resolved.

        Parameters
        ----------
        angles : (d,) bool ndarray
            Rows of the points that are angles.
        x1, x2 : (d, A), (d, B) float64 ndarray
            The points, one per column.

        Returns
        -------
        kind : int64
        params : float64 ndarray

        Raises
        ------
        ValueError
            If the kernel cannot carry information between these points.
        """
        return self._kind, self._parameters()


class PolynomialKernel(Kernel):
    """``k(x, y) = (x . y / ialpha + c) ** power``.

    Parameters
    ----------
    power : int
        Degree, >= 1.
    c : float
        Offset, >= 0 (a negative offset does not give a positive semi-definite kernel).
    ialpha : float
        Inverse scale of the inner product, > 0.
    """

    _kind = POLYNOMIAL

    def __init__(self, power, c=1.0, ialpha=10.0):
        self._power = _validate.count(power, "power")
        if not isinstance(c, numbers.Real) or isinstance(c, bool):
            raise TypeError(f"c must be a real number, got {type(c).__name__}")
        if not (np.isfinite(c) and c >= 0):
            raise ValueError(f"c must be finite and >= 0, got {c}")
        self._c = float(c)
        self._ialpha = _validate.positive(ialpha, "ialpha")
        self._params = np.array([self._power, self._c, self._ialpha])

    power = property(lambda self: self._power, doc="Degree of the polynomial.")
    c = property(lambda self: self._c, doc="Offset added to the scaled inner product.")
    ialpha = property(lambda self: self._ialpha, doc="Divisor of the inner product.")

    def _parameters(self):
        return self._params

    def __repr__(self):
        return (f"{type(self).__name__}(power={self.power}, c={self.c}, "
                f"ialpha={self.ialpha})")


class LinearKernel(PolynomialKernel):
    """``k(x, y) = x . y``."""

    def __init__(self):
        super().__init__(1, c=0.0, ialpha=1.0)

    def __repr__(self):
        return "LinearKernel()"


class _FixedDegreeKernel(PolynomialKernel):
    _degree = None

    def __init__(self, c=1.0, ialpha=10.0):
        super().__init__(self._degree, c, ialpha)

    def __repr__(self):
        return f"{type(self).__name__}(c={self.c}, ialpha={self.ialpha})"


class QuadraticKernel(_FixedDegreeKernel):
    """``k(x, y) = (x . y / ialpha + c) ** 2``; ``c`` and ``ialpha`` as in
    :class:`PolynomialKernel`.

    Parameters
    ----------
    c : float
        Offset, >= 0.
    ialpha : float
        Inverse scale of the inner product, > 0.
    """

    _degree = 2


class QuarticKernel(_FixedDegreeKernel):
    """``k(x, y) = (x . y / ialpha + c) ** 4``; ``c`` and ``ialpha`` as in
    :class:`PolynomialKernel`.

    Parameters
    ----------
    c : float
        Offset, >= 0.
    ialpha : float
        Inverse scale of the inner product, > 0.
    """

    _degree = 4


class GaussianKernel(Kernel):
    """The Gaussian kernel, with its length scale from the data by default.

    - ``GaussianKernel()``: ``k(x, y) = exp(-|x - y|^2 / (2 v))`` with the length scale
      ``sqrt(v)`` equal to ``width`` times the median distance between the points of each
      Gram matrix (both point sets together, e.g. the proposal and prior particles of an
      AKKF prediction). The kernel then does not depend on the units of the states: the
      same filter tracks a target at 1 m or at 10 km, and ``k(x, x) = 1``, so the filters'
      regularisation ``lambda`` is relative to the kernel's scale. The adaptive kernel
      Kalman filter needs a kernel that is wide compared with the particles' spread (at
      ``width`` 1, the median heuristic of kernel statistics, its weights drift to zero
      and the track to the sensor); the default ``width`` 100 tracks the AKKF tutorial as
      well as ``variance=10`` does there (position RMSE 0.64 vs 0.61 over 10 seeds at
      M = 30, 0.63 vs 0.63 at M = 300), at any scale.
    - ``GaussianKernel(variance)``: Stone Soup's formula,
      ``k(x, y) = exp(-|x - y|^2 / (2 variance)) / sqrt(2 pi variance)`` (a one-dimensional
      normaliser whatever the dimension of x). A fixed variance must suit the data: at 10
      km with Stone Soup's default ``variance=10`` every kernel value between distinct
      particles underflows to 0 and the AKKF's weights collapse (the filters then raise).

    An angle component (rad) contributes the squared chord ``(2 sin(diff / 2))^2`` of its
    difference instead of ``diff^2``: the same to within a relative ``diff^2 / 12``, and
    periodic, so that bearings either side of +-pi are close. The wrapped difference
    squared would not do: with it the Gram matrix of angles spread round the circle has
    negative eigenvalues (-0.4 against a largest entry of 0.13 at variance 10).

    Parameters
    ----------
    variance : float, optional
        Squared length scale, > 0, in the points' units squared; None (the default) for a
        length scale from the data.
    width : float
        With ``variance`` None, the length scale in units of the median distance between
        the points, > 0.
    """

    _kind = GAUSSIAN

    def __init__(self, variance=None, width=100.0):
        self._width = _validate.positive(width, "width")
        if variance is None:
            self._variance = None
            self._params = np.array([0.0, 1.0, self._width])
        else:
            self._variance = _validate.positive(variance, "variance")
            self._params = np.array([self._variance,
                                     1.0 / np.sqrt(2.0 * np.pi * self._variance), 0.0])

    variance = property(lambda self: self._variance,
                        doc="Squared length scale, or None for one from the data.")
    width = property(lambda self: self._width,
                     doc="Length scale in median distances between the points (with "
                         "variance None).")

    def _parameters(self):
        return self._params

    def spec(self, angles, x1, x2):
        if self.variance is None:
            return self._kind, _akkf.resolve(self._kind, self._params, angles, x1, x2)
        median = _akkf.median_variance(angles, np.hstack((x1, x2)))
        typical = np.exp(-median / (2.0 * self.variance))
        if typical < NEGLIGIBLE:
            raise ValueError(
                f"{self!r} is too narrow for these points: their median squared distance is "
                f"{median:.3g}, so the kernel between typical pairs is {typical:.1e} and the "
                f"filter learns nothing from them; use GaussianKernel() (a length scale from "
                f"the data) or a variance of at least {median / (-2.0 * np.log(NEGLIGIBLE)):.3g}")
        return self._kind, self._params

    def __repr__(self):
        if self.variance is None:
            return f"GaussianKernel(width={self.width})"
        return f"GaussianKernel(variance={self.variance})"


def as_kernel(kernel, name="kernel"):
    """A kernel argument: a :class:`Kernel`, or ``None`` for ``QuadraticKernel()``."""
    if kernel is None:
        return QuadraticKernel()
    if not isinstance(kernel, Kernel):
        raise TypeError(f"{name} must be a Kernel, got {type(kernel).__name__}")
    return kernel
