"""Stone Soup's kernels with their Gram matrices from fasttrack's parallel kernel.

As in Stone Soup, keywords naming a parameter (``kernel(x, variance=5)``) set it on the
kernel. The Gaussian kernel also works on Stone Soup's bearing measurements: rows of
``Angle`` objects are recognised and measured by their chord (see
``fasttrack.GaussianKernel``), where Stone Soup raises TypeError.
"""
import numpy as np
from stonesoup import kernel as ss
from stonesoup.types.array import StateVectors

from .._jit import gram as _gram
from ._convert import _CALLS, angle_rows, floats, kernel_spec


class _Gram:
    def __call__(self, state1, state2=None, **kwargs):
        self.update_parameters(kwargs)
        x1, x2 = self._get_state_vectors(state1, state2)
        spec = kernel_spec(self)
        if spec is None:
            raise ValueError(f"{type(self).__name__} parameters out of range: {self}")
        angles = np.zeros(x1.shape[0], dtype=np.bool_)
        angles[list(angle_rows(np.asarray(x1)))] = True
        x1, x2 = floats(x1), floats(x2)
        out = np.empty((x1.shape[1], x2.shape[1]))
        _gram.gram(*spec, angles, x1, x2, out)
        return StateVectors(out)


class PolynomialKernel(_Gram, ss.PolynomialKernel):
    """Stone Soup's ``PolynomialKernel``, compiled."""


class LinearKernel(_Gram, ss.LinearKernel):
    """Stone Soup's ``LinearKernel``, compiled."""


class QuadraticKernel(_Gram, ss.QuadraticKernel):
    """Stone Soup's ``QuadraticKernel``, compiled."""


class QuarticKernel(_Gram, ss.QuarticKernel):
    """Stone Soup's ``QuarticKernel``, compiled."""


class GaussianKernel(_Gram, ss.GaussianKernel):
    """Stone Soup's ``GaussianKernel``, compiled, and working on bearings."""


_CALLS.add(_Gram.__call__)
