"""Stone Soup's kernels with their Gram matrices from fasttrack's parallel kernel.

As in Stone Soup, keywords naming a parameter (``kernel(x, variance=5)``) set it on the
kernel. The Gaussian kernel also works on Stone Soup's bearing measurements: rows of
``Angle`` objects are recognised and measured by their chord (see
``fasttrack.GaussianKernel``), where Stone Soup raises TypeError.
"""
import numpy as np
from stonesoup import kernel as ss
from stonesoup.types.array import StateVectors

from ._convert import _CALLS, angle_rows, fast_kernel, floats


class _Gram:
    def __call__(self, state1, state2=None, **kwargs):
        self.update_parameters(kwargs)
        x1, x2 = self._get_state_vectors(state1, state2)
        kernel = fast_kernel(self)
        if kernel is None:
            raise ValueError(f"{type(self).__name__} parameters out of range: {self}")
        angles = angle_rows(np.asarray(x1))
        return StateVectors(kernel(floats(x1), floats(x2), angle_components=angles))


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
