"""The kind codes that specs carry: the kernels' own codes of transitions, sensors,
kernel functions k(x, y) and Jacobian methods, plus FUNCTION for a model built from a
user's Numba function."""
import numpy as np

from .._jit.kinds import (ANALYTIC, BEARING, BEARING_RANGE, CENTRAL, CV, FIXED, FORWARD,
                          GAUSSIAN, MATRIX, POLYNOMIAL, SELECT)

#: A transition or sensor built from a user's function (no kernel kind of its own).
FUNCTION = np.int64(-1)

__all__ = ["ANALYTIC", "BEARING", "BEARING_RANGE", "CENTRAL", "CV", "FIXED", "FORWARD",
           "FUNCTION", "GAUSSIAN", "MATRIX", "POLYNOMIAL", "SELECT"]
