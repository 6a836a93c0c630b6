"""The kind codes that specs carry: the kernels' own codes of transitions, sensors and
kernel functions k(x, y), plus FUNCTION for a model built from a user's Numba function."""
import numpy as np

from .._jit.gram import GAUSSIAN, MATRIX, POLYNOMIAL
from .._jit.kalman import CV, FIXED
from .._jit.sensor import BEARING, BEARING_RANGE, SELECT

#: A transition or sensor built from a user's function (no kernel kind of its own).
FUNCTION = np.int64(-1)

__all__ = ["BEARING", "BEARING_RANGE", "CV", "FIXED", "FUNCTION", "GAUSSIAN", "MATRIX",
           "POLYNOMIAL", "SELECT"]
