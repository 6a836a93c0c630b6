"""Kernels k(x, y) on state or measurement vectors, and their Gram matrices.

A kernel called on (d, A) and (d, B) points returns the (A, B) Gram matrix, computed in a
parallel compiled kernel. Parameters are fixed at construction: calling a kernel never
changes them.
"""
import numbers

import numpy as np

from . import _validate
from ._jit import gram as _gram
from .models.base import state_columns


class Kernel:
    """Base class: a kernel kind and its parameter array (see ``fasttrack._jit.gram``)."""

    _kind = None

    def _parameters(self):
        raise NotImplementedError

    def __call__(self, state1, state2=None, angle_components=()):
        """Gram matrix ``K[a, b] = k(x1[:, a], x2[:, b])``.

        Parameters
        ----------
        state1, state2 : state object or (d,) / (d, N) array_like
            Points as columns (``state2`` defaults to ``state1``).
        angle_components : sequence of int
            Rows that are angles (rad), for the Gaussian kernel (see there); polynomial
            kernels, which see only inner products, ignore them.

        Returns
        -------
        (A, B) float64 ndarray
        """
        x1 = state_columns(state1, "state1")
        x2 = x1 if state2 is None else state_columns(state2, "state2")
        if x2.shape[0] != x1.shape[0]:
            raise ValueError(f"state1 and state2 must have the same number of rows, "
                             f"got {x1.shape[0]} and {x2.shape[0]}")
        out = np.empty((x1.shape[1], x2.shape[1]))
        _gram.gram(self._kind, self._parameters(), self.angle_mask(x1.shape[0], angle_components),
                   x1, x2, out)
        return out

    @staticmethod
    def angle_mask(ndim, angle_components=()):
        """A (ndim,) bool array flagging ``angle_components``."""
        mask = np.zeros(ndim, dtype=np.bool_)
        for row in angle_components:
            if not (isinstance(row, numbers.Integral) and 0 <= row < ndim):
                raise ValueError(f"angle_components must be rows in [0, {ndim}), "
                                 f"got {tuple(angle_components)}")
            mask[row] = True
        return mask

    def _spec(self):
        """``(kind, params)`` for the compiled filters."""
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

    _kind = _gram.POLYNOMIAL

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
    :class:`PolynomialKernel`."""

    _degree = 2


class QuarticKernel(_FixedDegreeKernel):
    """``k(x, y) = (x . y / ialpha + c) ** 4``; ``c`` and ``ialpha`` as in
    :class:`PolynomialKernel`."""

    _degree = 4


class GaussianKernel(Kernel):
    """``k(x, y) = exp(-|x - y|^2 / (2 variance)) / sqrt(2 pi variance)`` (the normaliser is
    one-dimensional whatever the dimension of x).

    An angle component (rad) contributes the squared chord ``(2 sin(diff / 2))^2`` of its
    difference instead of ``diff^2``: the same to within a relative ``diff^2 / 12``, and
    periodic, so that bearings either side of +-pi are close. The wrapped difference
    squared would not do: with it the Gram matrix of angles spread round the circle has
    negative eigenvalues (-0.4 against a largest entry of 0.13 at the default variance).

    Parameters
    ----------
    variance : float
        Squared length scale, > 0.
    """

    _kind = _gram.GAUSSIAN

    def __init__(self, variance=10.0):
        self._variance = _validate.positive(variance, "variance")
        self._params = np.array([self._variance])

    variance = property(lambda self: self._variance, doc="Squared length scale.")

    def _parameters(self):
        return self._params

    def __repr__(self):
        return f"GaussianKernel(variance={self.variance})"


def as_kernel(kernel, name="kernel"):
    """A kernel argument: a :class:`Kernel`, or ``None`` for ``QuadraticKernel()``."""
    if kernel is None:
        return QuadraticKernel()
    if not isinstance(kernel, Kernel):
        raise TypeError(f"{name} must be a Kernel, got {type(kernel).__name__}")
    return kernel
