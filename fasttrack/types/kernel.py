"""Kernel particle states of the adaptive kernel Kalman filter, with their kernel covariance
in factored form."""
import numpy as np

from .. import _validate
from ..core import akkf as _akkf
from .base import check_timestamp

__all__ = [
    "KernelParticleState", "KernelParticleStatePrediction",
    "KernelParticleStateMeasurementPrediction", "KernelParticleStateUpdate",
]


class KernelParticleState:
    """Particles with kernel weights and a kernel covariance (the adaptive kernel Kalman
    filter's state).

    Parameters
    ----------
    state_vector : (d, M) array_like
        Particles, one column each; finite.
    timestamp : datetime.datetime or float, optional
    weight : (M,) array_like, optional
        Kernel weights, finite (any sign; they need not sum to 1). Default 1/M each.
    kernel_covar : (M, M) array_like, optional
        Kernel covariance S, symmetric positive semi-definite. Default I/M.

    Notes
    -----
    S is held in factored form (see ``fasttrack._jit.akkf``); ``kernel_covar`` builds the
    (M, M) matrix on first access.
    """

    def __init__(self, state_vector, timestamp=None, weight=None, kernel_covar=None):
        self.state_vector = state_vector
        m = self.state_vector.shape[1]
        self.weight = np.full(m, 1.0 / m) if weight is None else weight
        self.timestamp = timestamp
        self._factors = isotropic_factors(m, 1.0 / m) if kernel_covar is None else \
            factor_kernel_covar(kernel_covar, m)
        self._kernel_covar = None

    #: Checked when assigned (here or later): None, a datetime or finite seconds.
    timestamp = _validate.Setting(check_timestamp)
    #: Checked when assigned (here or later): (d, M) finite, M the particles the weights
    #: and the kernel covariance hold.
    state_vector = _validate.Setting("_checked_particles")
    #: Checked when assigned: (M,) finite.
    weight = _validate.Setting("_checked_weight")

    def _checked_particles(self, value, name):
        x = _validate.state_array(value, name)
        held = self.__dict__.get("weight")
        if held is not None and x.shape[1] != held.size:
            raise ValueError(f"{name} must hold the state's {held.size} particles (its weights "
                             f"and kernel covariance are theirs), got {x.shape[1]}: make a new "
                             f"KernelParticleState for another number")
        return x

    def _checked_weight(self, value, name):
        w = _validate.finite_array(value, name, 1).copy()
        m = self.state_vector.shape[1]
        if w.size != m:
            raise ValueError(f"{name} must have length {m}, got {w.size}")
        return w

    @classmethod
    def _trusted(cls, state_vector, weight, factors, timestamp, **attributes):
        """Build from arrays that a kernel produced (no validation, no copies)."""
        state = object.__new__(cls)
        state.__dict__.update(state_vector=state_vector, weight=weight, _factors=factors,
                              timestamp=timestamp, _kernel_covar=None, **attributes)
        return state

    @property
    def kernel_covar(self):
        """The kernel covariance S (M, M)."""
        if self._kernel_covar is None:
            self._kernel_covar = dense_kernel_covar(self._factors)
        return self._kernel_covar

    @property
    def mean(self):
        """``X w`` (d, 1)."""
        return (self.state_vector @ self.weight).reshape(-1, 1)

    @property
    def covar(self):
        """``X S X^T`` (d, d)."""
        return _akkf.covariance(self.state_vector, self._factors)

    def __len__(self):
        return self.state_vector.shape[1]

    @property
    def ndim(self):
        """Number of state dimensions d."""
        return self.state_vector.shape[0]

    def __repr__(self):
        return (f"{type(self).__name__}(ndim={self.ndim}, M={len(self)}, "
                f"timestamp={self.timestamp!r})")


def dense_kernel_covar(factors):
    """The (M, M) kernel covariance ``S = Lt^T Lt + sigma Z Z^T``, ``Z = I - V1 V2^T``, of
    factors ``(Lt, sigma, V1t, V2t)``, as ``sigma I + U B U^T`` with ``U = [Lt^T, V1, V2]``
    (M, p): one NumPy matrix product, O(M^2 p)."""
    lt, sigma, v1t, v2t = factors
    k, r, m = lt.shape[0], v1t.shape[0], lt.shape[1]
    u = np.vstack((lt, v1t, v2t))
    middle = np.zeros((k + 2 * r, k + 2 * r))
    middle[:k, :k] = np.eye(k)
    middle[k:k + r, k:k + r] = sigma * (v2t @ v2t.T)
    middle[k:k + r, k + r:] = middle[k + r:, k:k + r] = -sigma * np.eye(r)
    covar = u.T @ (middle @ u)
    covar[np.diag_indices(m)] += sigma
    return covar


def isotropic_factors(m, sigma):
    """Factors of S = sigma I (M, M)."""
    empty = np.empty((0, m))
    return empty, sigma, empty, empty


def factor_kernel_covar(kernel_covar, m):
    """Factors of a user's S: its pivoted Cholesky factor, checked to reproduce it."""
    s = _validate.covariance(kernel_covar, "kernel_covar", m)
    lt = _akkf.factor_matrix(s)
    scale = max(np.abs(s).max(), np.finfo(float).tiny)
    if np.abs(lt.T @ lt - s).max() > 1e-8 * scale:
        raise ValueError("kernel_covar must be positive semi-definite")
    empty = np.empty((0, m))
    return np.ascontiguousarray(lt), 0.0, empty, empty


class KernelParticleStatePrediction(KernelParticleState):
    """A predicted :class:`KernelParticleState`, with the ``transition_model`` that produced
    it.

    Parameters
    ----------
    state_vector : (d, M) array_like
        Particles, one column each; finite.
    timestamp : datetime.datetime or float, optional
        As :class:`KernelParticleState`.
    weight : (M,) array_like, optional
        As :class:`KernelParticleState`.
    kernel_covar : (M, M) array_like, optional
        As :class:`KernelParticleState`.
    transition_model : TransitionModel, optional
    """

    def __init__(self, state_vector, timestamp=None, weight=None, kernel_covar=None,
                 transition_model=None):
        super().__init__(state_vector, timestamp, weight, kernel_covar)
        self.transition_model = transition_model


class KernelParticleStateMeasurementPrediction(KernelParticleState):
    """Predicted measurements (m, M) of a :class:`KernelParticleState`'s particles, with its
    weights and kernel covariance.

    Parameters
    ----------
    state_vector : (m, M) array_like
        Predicted measurements, one column per particle; finite.
    timestamp : datetime.datetime or float, optional
        As :class:`KernelParticleState`.
    weight : (M,) array_like, optional
        As :class:`KernelParticleState`.
    kernel_covar : (M, M) array_like, optional
        As :class:`KernelParticleState`.
    """


class KernelParticleStateUpdate(KernelParticleState):
    """An updated :class:`KernelParticleState`, with the ``hypothesis`` it came from and the
    ``proposal`` (d, M) particles that the next prediction propagates.

    Parameters
    ----------
    state_vector : (d, M) array_like
        Particles, one column each; finite.
    timestamp : datetime.datetime or float, optional
        As :class:`KernelParticleState`.
    weight : (M,) array_like, optional
        As :class:`KernelParticleState`.
    kernel_covar : (M, M) array_like, optional
        As :class:`KernelParticleState`.
    hypothesis : SingleHypothesis, optional
    proposal : (d, M) array_like, optional
        Particles for the next prediction to propagate; finite.
    """

    def __init__(self, state_vector, timestamp=None, weight=None, kernel_covar=None,
                 hypothesis=None, proposal=None):
        super().__init__(state_vector, timestamp, weight, kernel_covar)
        self.hypothesis = hypothesis
        self.proposal = None if proposal is None else _validate.state_array(proposal,
                                                                              "proposal")
        if self.proposal is not None and self.proposal.shape != self.state_vector.shape:
            raise ValueError(f"proposal must have shape {self.state_vector.shape}, "
                             f"got {self.proposal.shape}")
