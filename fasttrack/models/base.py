"""What the models share: state arrays, Gaussian noise and its square root."""
import functools

import numpy as np

from .. import _validate
from .. import random as _random


def state_columns(state, name="state"):
    """The (d, N) float64 array of a state object (anything with ``state_vector``) or an
    array_like: a (d,) vector becomes one column."""
    value = getattr(state, "state_vector", state)
    array = _validate.finite_array(value, name)
    if array.ndim == 1:
        array = array.reshape(-1, 1)
    if array.ndim != 2 or array.size == 0:
        raise ValueError(f"{name} must be a (d,) vector or a (d, N) array, got {array.shape}")
    return array


def check_rows(array, rows, name):
    if array.shape[0] != rows:
        raise ValueError(f"{name} must have {rows} rows (the model's dimension), "
                         f"got shape {array.shape}")


class GaussianNoise:
    """A zero-mean Gaussian with covariance ``covar``: a square root for sampling and the
    Cholesky whitening for densities."""

    def __init__(self, covar, name):
        self.covar = covar
        values, vectors = np.linalg.eigh(covar)
        top = max(values.max(initial=0.0), np.finfo(float).tiny)
        if values.min(initial=0.0) < -1e-10 * top:
            raise ValueError(f"{name} is not positive semi-definite "
                             f"(smallest eigenvalue {values.min():.3g})")
        self.root = np.ascontiguousarray(vectors * np.sqrt(np.clip(values, 0.0, None)))
        self._name = name
        self._whitening = None

    def sample(self, size, rng):
        """(m, size) samples from ``rng`` (None, int seed or Generator)."""
        z = _random.generator(rng).standard_normal((self.covar.shape[0], size))
        return self.root @ z

    def whitening(self):
        """``(W, log_norm)``: W (lower triangular) with ``W^T W = covar^-1`` and
        ``log_norm = -(m log 2 pi + log det covar) / 2``."""
        if self._whitening is None:
            try:
                lower = np.linalg.cholesky(self.covar)
            except np.linalg.LinAlgError:
                raise ValueError(f"{self._name} must be positive definite for a density") from None
            whiten = np.linalg.inv(lower)
            m = self.covar.shape[0]
            log_norm = -0.5 * (m * np.log(2 * np.pi)) - np.log(np.diag(lower)).sum()
            self._whitening = (np.ascontiguousarray(np.tril(whiten)), float(log_norm))
        return self._whitening

    def logpdf(self, deviations):
        """Log densities of the columns of (m, N) ``deviations``."""
        whiten, log_norm = self.whitening()
        return log_norm - 0.5 * np.sum((whiten @ deviations) ** 2, axis=0)


def gaussian_noise(covar, name):
    """The :class:`GaussianNoise` of a covariance matrix, memoised on its values (so a model
    whose parameters change gets the new one)."""
    covar = np.ascontiguousarray(covar, dtype=np.float64)
    return _noise_by_value(covar.tobytes(), covar.shape, name)


@functools.lru_cache(maxsize=256)
def _noise_by_value(data, shape, name):
    return GaussianNoise(np.frombuffer(data).reshape(shape).copy(), name)


def wrap_angle(a):
    """Angles wrapped to [-pi, pi), by the kernels' formula ``a - 2 pi floor((a + pi) / 2 pi)``."""
    return a - 6.283185307179586 * np.floor((a + 3.141592653589793) * 0.15915494309189535)


def scalar_or_array(values):
    """A float for a single value, else the array (Stone Soup's logpdf convention)."""
    return float(values[0]) if values.size == 1 else values
