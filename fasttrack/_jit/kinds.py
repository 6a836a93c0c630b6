"""The kind codes that kernels branch on (compile-time constants), importable without
Numba: transitions, built-in sensors, kernel functions k(x, y) and Jacobian methods."""
import numpy as np

#: Transitions: F and Q given, or nearly-constant-velocity blocks built from rates.
FIXED, CV = np.int64(0), np.int64(1)
#: Built-in sensors: state rows selected, or bearing and range, or bearing only.
SELECT, BEARING_RANGE, BEARING = np.int64(0), np.int64(1), np.int64(2)
#: Kernel functions k(x, y).
POLYNOMIAL, GAUSSIAN, MATRIX = np.int64(0), np.int64(1), np.int64(2)
#: Measurement Jacobians: analytic (built-in sensors), forward or central differences.
ANALYTIC, FORWARD, CENTRAL = np.int64(0), np.int64(1), np.int64(2)
#: Mixture reduction rules: Stone Soup's ``GaussianMixtureReducer`` (quirks included) or the
#: textbook ones (Vo and Ma 2006, the spread of the means kept in merged covariances).
STONESOUP, TEXTBOOK = np.int64(0), np.int64(1)
