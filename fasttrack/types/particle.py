"""Particle states: a (d, N) float64 cloud with (N,) log weights, and its predictions and
updates."""
import copy
import numbers

import numpy as np

from .. import _buffers
from .. import _validate
from ..core import particle as _particle
from .base import Link, check_timestamp

__all__ = ["Particle", "ParticleState", "ParticleStatePrediction", "ParticleStateUpdate"]


class Particle:
    """One weighted particle.

    Parameters
    ----------
    state_vector : (d,) or (d, 1) array_like
        Finite state; stored as a (d, 1) float64 column.
    weight : float
        Linear weight, finite and >= 0 (need not be normalised).
    parent : Particle, optional
    """

    def __init__(self, state_vector, weight, parent=None):
        sv = _validate.finite_array(state_vector, "state_vector")
        if sv.ndim not in (1, 2) or (sv.ndim == 2 and sv.shape[1] != 1) or sv.size == 0:
            raise ValueError(f"state_vector must have shape (d,) or (d, 1), got {sv.shape}")
        if not isinstance(weight, numbers.Real) or isinstance(weight, bool):
            raise TypeError(f"weight must be a real number, got {type(weight).__name__}")
        if not (np.isfinite(weight) and weight >= 0):
            raise ValueError(f"weight must be finite and >= 0, got {weight}")
        if parent is not None and not isinstance(parent, Particle):
            raise TypeError(f"parent must be a Particle or None, got {type(parent).__name__}")
        self.state_vector = sv.reshape(-1, 1)
        self.weight = float(weight)
        self.parent = parent

    @property
    def ndim(self):
        """Number of state dimensions d."""
        return self.state_vector.shape[0]

    def __repr__(self):
        return f"Particle(state_vector={self.state_vector.ravel()}, weight={self.weight})"


class ParticleState:
    """A weighted particle cloud.

    Parameters
    ----------
    state_vector : (d, N) array_like, optional
        Particle states, one column per particle; finite. Kept without a copy when it is
        already a C-contiguous float64 array. Omit it to build the state from
        ``particle_list``.
    timestamp : datetime.datetime or float, optional
        Time of the state (a datetime, or seconds).
    weight : (N,) array_like, optional
        Linear weights: finite, >= 0, not all zero, need not sum to 1.
    log_weight : (N,) array_like, optional
        Log weights: no NaN or +inf, not all -inf. Give ``weight`` or ``log_weight``, not
        both; with neither, the weights are equal.
    parent : ParticleState, optional
        The particles these were derived from.
    particle_list : list of Particle, optional
        Build the state, weights and (if every particle has one) parents from particles.
    fixed_covar : (d, d) array_like, optional
        Covariance returned by :attr:`covar` instead of the weighted sample covariance.
    """

    parent = Link()

    #: Checked when assigned (here or later): None, a datetime or finite seconds.
    timestamp = _validate.Setting(check_timestamp)

    def __init__(self, state_vector=None, timestamp=None, weight=None, log_weight=None,
                 parent=None, particle_list=None, fixed_covar=None):
        self._source = None
        if weight is not None and log_weight is not None:
            raise ValueError("give weight or log_weight, not both")
        if particle_list is not None:
            if state_vector is not None or weight is not None or log_weight is not None:
                raise ValueError("give particle_list or state_vector and weights, not both")
            state_vector, weight, list_parent = _from_particles(particle_list)
            parent = parent if list_parent is None else list_parent
        if state_vector is None:
            raise ValueError("state_vector (or particle_list) is required")
        self._state_vector = _validate.state_array(state_vector, "state_vector")
        n = self._state_vector.shape[1]
        if weight is not None:
            self._log_weight = _validate.linear_weights(weight, "weight", n)
        elif log_weight is not None:
            self._log_weight = _validate.log_weights(log_weight, "log_weight", n)[0].copy()
        else:
            self._log_weight = np.full(n, -np.log(n))
        if parent is not None and not isinstance(parent, ParticleState):
            raise TypeError(f"parent must be a ParticleState or None, "
                            f"got {type(parent).__name__}")
        self.parent = parent
        self.timestamp = timestamp
        self.fixed_covar = None if fixed_covar is None else _validate.psd_covariance(
            fixed_covar, "fixed_covar", self.ndim)
        self._moments = None

    @classmethod
    def _trusted(cls, state_vector, log_weight, timestamp=None, parent=None, **attributes):
        """Build from arrays that a kernel produced (no validation, no copies); ``parent``
        may be a weak link (:func:`weak`), and so may ``_prior`` (the slot of a
        prediction's ``prior``) among the ``attributes``."""
        state = cls.__new__(cls)
        state._state_vector = state_vector
        state._log_weight = log_weight
        state.timestamp = timestamp
        state._parent = parent
        state.fixed_covar = None
        state._moments = None
        state._source = None
        state.__dict__.update(attributes)
        return state

    def _detached(self):
        """A shallow copy of the same type without links to other states (``parent``,
        ``prior``, ``hypothesis``): the same arrays, none of the history."""
        state = self._replace(parent=None)
        for slot in ("_prior", "hypothesis"):
            if slot in state.__dict__:
                state.__dict__[slot] = None
        return state

    def _replace(self, **changes):
        """A shallow copy of the same type with some attributes replaced (the arrays given
        are trusted, as in :meth:`_trusted`)."""
        if self._source is not None:
            self._gather()
        state = copy.copy(self)
        state._moments = None
        for name, value in changes.items():
            setattr(state, "_" + name if name in ("state_vector", "log_weight") else name,
                    value)
        return state

    def _indexed(self, idx):
        """A :meth:`_detached` copy holding the particles ``idx``, gathered on first access:
        most parents are never read."""
        state = self._detached()
        state._source = (state._state_vector, state._log_weight, idx)
        state._state_vector = state._log_weight = None
        return state

    def _gather(self):
        source, source_log_weight, idx = self._source
        columns = _particle.gather(source, idx, _buffers.empty((source.shape[0], idx.size)))
        self._state_vector, self._log_weight = columns, source_log_weight[idx]
        self._source = None

    @property
    def state_vector(self):
        """(d, N) float64 particle states."""
        if self._source is not None:
            self._gather()
        return self._state_vector

    @state_vector.setter
    def state_vector(self, value):
        sv = _validate.state_array(value, "state_vector")
        if sv.shape[1] != len(self):
            raise ValueError(f"state_vector must have {len(self)} columns, got {sv.shape[1]}")
        if self.fixed_covar is not None and sv.shape[0] != self.fixed_covar.shape[0]:
            raise ValueError(f"state_vector must have {self.fixed_covar.shape[0]} rows (the "
                             f"dimension of fixed_covar), got {sv.shape[0]}")
        if self._source is not None:
            self._gather()
        self._state_vector = sv
        self._moments = None

    @property
    def log_weight(self):
        """(N,) float64 log weights (unnormalised; ``-inf`` is a zero weight). A resampled
        state's are read-only (shared by the states resampled to the same size); assign a
        new array to change them."""
        if self._source is not None:
            self._gather()
        return self._log_weight

    @log_weight.setter
    def log_weight(self, value):
        log_weight = _validate.log_weights(value, "log_weight", len(self))[0].copy()
        _ = self.state_vector  # gather a pending state first
        self._log_weight = log_weight
        self._moments = None

    @property
    def weight(self):
        """(N,) float64 linear weights ``exp(log_weight)``: a new read-only array (a write
        into it would change nothing; assign ``weight``, or write into ``log_weight``)."""
        weight = np.exp(self.log_weight)
        weight.flags.writeable = False
        return weight

    @weight.setter
    def weight(self, value):
        self.log_weight = _validate.linear_weights(value, "weight", len(self))

    def __len__(self):
        if self._source is not None:
            return self._source[2].size
        return self._state_vector.shape[1]

    @property
    def ndim(self):
        """Number of state dimensions d."""
        if self._source is not None:
            return self._source[0].shape[0]
        return self._state_vector.shape[0]

    @property
    def mean(self):
        """(d, 1) weighted mean of the particles (computed once, in one pass)."""
        if self._moments is None:
            self._moments = _particle.mean(self.state_vector, self.log_weight), None
        return self._moments[0]

    @property
    def covar(self):
        """(d, d) weighted covariance ``sum w (x - mean)(x - mean)^T / sum w``, or
        ``fixed_covar`` when set (computed once, with the mean, in two passes)."""
        if self.fixed_covar is not None:
            return self.fixed_covar
        if self._moments is None or self._moments[1] is None:
            mean, covar = _particle.mean_covar(self.state_vector, self.log_weight)
            known = self._moments  # a mean already read stays what it was
            self._moments = (mean if known is None else known[0]), covar
        return self._moments[1]

    def __getitem__(self, item):
        """``state[i]`` for an int is a :class:`Particle`; an int array, boolean mask or
        slice gives a new state of the same type (with ``parent`` indexed alike)."""
        parent = None if self.parent is None else self.parent._detached()[item]
        if isinstance(item, numbers.Integral):
            return Particle(self.state_vector[:, item], float(np.exp(self.log_weight[item])),
                            parent=parent)
        log_weight = self.log_weight[item]
        if log_weight.size == 0:
            raise IndexError("indexing selected no particles")
        return self._replace(state_vector=np.ascontiguousarray(self.state_vector[:, item]),
                             log_weight=log_weight, parent=parent)

    def __repr__(self):
        return (f"{type(self).__name__}(ndim={self.ndim}, particles={len(self)}, "
                f"timestamp={self.timestamp!r})")


def _from_particles(particles):
    """State array, weights and parent state of a list of :class:`Particle`."""
    particles = list(particles)
    if not particles:
        raise ValueError("particle_list is empty")
    for p in particles:
        if not isinstance(p, Particle):
            raise TypeError(f"particle_list must hold Particle objects, got {type(p).__name__}")
    dims = {p.ndim for p in particles}
    if len(dims) > 1:
        raise ValueError(f"particle_list mixes state dimensions {sorted(dims)}")
    state_vector = np.hstack([p.state_vector for p in particles])
    weight = np.array([p.weight for p in particles])
    parents = [p.parent for p in particles]
    with_parent = sum(p is not None for p in parents)
    if with_parent == 0:
        return state_vector, weight, None
    if with_parent < len(parents):
        raise ValueError("either every particle in particle_list has a parent or none has")
    return state_vector, weight, ParticleState(particle_list=parents)


def as_particle_state(value, name="particles"):
    """A :class:`ParticleState`, or one built from a list of :class:`Particle`."""
    if isinstance(value, ParticleState):
        return value
    if isinstance(value, (list, tuple)):
        return ParticleState(particle_list=value)
    raise TypeError(f"{name} must be a ParticleState or a list of Particle, "
                    f"got {type(value).__name__}")


class ParticleStatePrediction(ParticleState):
    """A predicted particle state: a :class:`ParticleState` with the ``transition_model`` that
    produced it and the ``prior`` it came from (also its ``parent``; weak links when a
    predictor made them, see the module's notes).

    Parameters
    ----------
    state_vector : (d, N) array_like, optional
        As :class:`ParticleState`.
    timestamp : datetime.datetime or float, optional
        As :class:`ParticleState`.
    weight : (N,) array_like, optional
        As :class:`ParticleState`.
    log_weight : (N,) array_like, optional
        As :class:`ParticleState`.
    parent : ParticleState, optional
        As :class:`ParticleState`.
    particle_list : list of Particle, optional
        As :class:`ParticleState`.
    fixed_covar : (d, d) array_like, optional
        As :class:`ParticleState`.
    transition_model : TransitionModel, optional
    prior : ParticleState, optional
        The state predicted from; held strongly (see :mod:`fasttrack.types`).
    """

    prior = Link()

    def __init__(self, state_vector=None, timestamp=None, weight=None, log_weight=None,
                 parent=None, particle_list=None, fixed_covar=None, transition_model=None,
                 prior=None):
        super().__init__(state_vector, timestamp, weight, log_weight, parent, particle_list,
                         fixed_covar)
        self.transition_model = transition_model
        self.prior = prior


class ParticleStateUpdate(ParticleState):
    """An updated particle state: a :class:`ParticleState` with the ``hypothesis`` (prediction
    and measurement) it was updated from.

    A :class:`~fasttrack.ParticleUpdater` also records ``ess``, the effective sample size of
    the weights after the update and before any resampling (what an
    :class:`~fasttrack.ESSResampler` decided on), and ``resampled``, whether its resampler
    drew new particles.

    Parameters
    ----------
    state_vector : (d, N) array_like, optional
        As :class:`ParticleState`.
    timestamp : datetime.datetime or float, optional
        As :class:`ParticleState`.
    weight : (N,) array_like, optional
        As :class:`ParticleState`.
    log_weight : (N,) array_like, optional
        As :class:`ParticleState`.
    parent : ParticleState, optional
        As :class:`ParticleState`.
    particle_list : list of Particle, optional
        As :class:`ParticleState`.
    fixed_covar : (d, d) array_like, optional
        As :class:`ParticleState`.
    hypothesis : SingleHypothesis, optional
    """

    #: Effective sample size before resampling (None if not made by a ParticleUpdater).
    ess = None
    #: Whether the updater's resampler drew new particles.
    resampled = False

    def __init__(self, state_vector=None, timestamp=None, weight=None, log_weight=None,
                 parent=None, particle_list=None, fixed_covar=None, hypothesis=None):
        super().__init__(state_vector, timestamp, weight, log_weight, parent, particle_list,
                         fixed_covar)
        self.hypothesis = hypothesis
