"""Filter steps on plain arrays, under both APIs.

The native classes and :mod:`fasttrack.stonesoup` convert their states to arrays, call these
functions and wrap the results. Each takes fasttrack models and kernel specifications,
float64 arrays (particles ``(d, N)``, a Gaussian state ``(d, 1)`` with its ``(d, d)``
covariance) and intervals in seconds; it calls the compiled kernels and raises the errors
they report, naming the argument or the user's function.
"""
from . import akkf, kalman, particle

__all__ = ["akkf", "kalman", "particle"]
