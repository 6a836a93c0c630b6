"""Kernel covariance factors of Stone Soup's kernel particle states.

The drop-in AKKF returns Stone Soup states with the dense ``kernel_covar`` they must carry,
and keeps fasttrack's factors of it on the state, so that the next step need not factor the
dense matrix again. The factors are used only while ``kernel_covar`` is still the very
array they were made with.
"""
import numpy as np

from .. import types as ft_types
from ._convert import floats

_FACTORS = "_fasttrack_kernel_factors"


def remember_factors(state, factors):
    """Keep ``factors`` of ``state.kernel_covar`` on ``state``; returns ``state``."""
    state.__dict__[_FACTORS] = (state.kernel_covar, factors)
    return state


def kernel_factors(state):
    """fasttrack factors of a Stone Soup state's kernel covariance: the remembered ones if
    ``kernel_covar`` is unchanged, ``(sigma I)`` exactly for a multiple of the identity
    (Stone Soup's default I/M), else a pivoted Cholesky factor of it.

    Raises
    ------
    ValueError
        If the kernel covariance is not symmetric positive semi-definite.
    """
    remembered = state.__dict__.get(_FACTORS)
    if remembered is not None and remembered[0] is state.kernel_covar:
        return remembered[1]
    covar = floats(state.kernel_covar)
    m = covar.shape[0]
    diagonal = np.diagonal(covar)
    if np.count_nonzero(covar - np.diag(diagonal)) == 0 and np.all(diagonal == diagonal[0]) \
            and diagonal[0] >= 0:
        return ft_types.isotropic_factors(m, float(diagonal[0]))
    return ft_types.factor_kernel_covar(covar, m)
