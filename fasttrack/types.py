"""State types. A particle cloud is a (d, N) float64 state array (one column per particle)
with (N,) float64 log weights; linear weights are derived on request.

Ownership of history: a state's links to the states it came from (``prior`` of a
prediction, ``parent`` of a particle state, the ``prediction`` of a hypothesis once an
updater has used it) are weak when a filter makes them, so a filter loop keeps only what
the program itself keeps. ``prediction.prior`` is the prior object while anything else (a
variable, a :class:`Track`) still holds it, and None after; an update holds its
``hypothesis`` (the detection and measurement prediction) strongly, and the prediction
while the program holds it. A :class:`Track` of updates thus keeps the updates, not the
particle clouds of the predictions between them. Links given to a constructor, and the
indexed parent a resampler makes (which has no links of its own), are held strongly.
"""
import copy
import datetime
import numbers
import uuid
import weakref

import numpy as np

from . import _buffers
from . import _validate
from ._jit import akkf as _akkf
from ._jit import gram as _gram
from ._jit import weights as _weights
from ._jit.resample import take_columns as _take_columns


def check_timestamp(value, name="timestamp"):
    """A timestamp: ``None``, a ``datetime.datetime`` or a real number of seconds."""
    if value is None or isinstance(value, datetime.datetime):
        return value
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        if not np.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
        return value
    raise TypeError(f"{name} must be None, a datetime or a number of seconds, "
                    f"got {type(value).__name__}")


class Link:
    """An attribute linking to an earlier state: held strongly when assigned the state,
    weakly when assigned a ``weakref.ref`` to it (then None once the state is gone)."""

    def __set_name__(self, owner, name):
        self.slot = "_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return self
        value = obj.__dict__.get(self.slot)
        return value() if type(value) is weakref.ref else value

    def __set__(self, obj, value):
        obj.__dict__[self.slot] = value


def weak(state):
    """A weak link to ``state`` (None stays None)."""
    return None if state is None else weakref.ref(state)


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
        self.timestamp = check_timestamp(timestamp)
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
        columns = _buffers.empty((source.shape[0], idx.size))
        _take_columns(source, idx, columns)
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
        if self._source is not None:
            self._gather()
        self._state_vector = sv
        self._moments = None

    @property
    def log_weight(self):
        """(N,) float64 log weights (unnormalised; ``-inf`` is a zero weight)."""
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
        """(N,) float64 linear weights ``exp(log_weight)`` (a new array)."""
        return np.exp(self.log_weight)

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
            d = self.ndim
            mean = np.empty(d)
            log_w = self.log_weight
            _weights.weighted_mean(self.state_vector, log_w, log_w.max(), mean)
            self._moments = mean.reshape(d, 1), None
        return self._moments[0]

    @property
    def covar(self):
        """(d, d) weighted covariance ``sum w (x - mean)(x - mean)^T / sum w``, or
        ``fixed_covar`` when set (computed once, with the mean, in two passes)."""
        if self.fixed_covar is not None:
            return self.fixed_covar
        if self._moments is None or self._moments[1] is None:
            d = self.ndim
            mean = np.empty(d)
            covar = np.empty((d, d))
            log_w = self.log_weight
            _weights.weighted_mean_covar(self.state_vector, log_w, log_w.max(), mean, covar)
            known = self._moments  # a mean already read stays what it was
            self._moments = (mean.reshape(d, 1) if known is None else known[0]), covar
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
    predictor made them, see the module's notes)."""

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
        self.state_vector = _validate.state_array(state_vector, "state_vector")
        m = self.state_vector.shape[1]
        if weight is None:
            self.weight = np.full(m, 1.0 / m)
        else:
            self.weight = _validate.finite_array(weight, "weight", 1).copy()
            if self.weight.size != m:
                raise ValueError(f"weight must have length {m}, got {self.weight.size}")
        self.timestamp = check_timestamp(timestamp)
        self._factors = isotropic_factors(m, 1.0 / m) if kernel_covar is None else \
            factor_kernel_covar(kernel_covar, m)
        self._kernel_covar = None

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
        return _akkf.sandwich(self.state_vector, *self._factors)

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
    lt = _gram.factor(_gram.MATRIX, np.empty(0), np.zeros(0, dtype=np.bool_), s)
    scale = max(np.abs(s).max(), np.finfo(float).tiny)
    if np.abs(lt.T @ lt - s).max() > 1e-8 * scale:
        raise ValueError("kernel_covar must be positive semi-definite")
    empty = np.empty((0, m))
    return np.ascontiguousarray(lt), 0.0, empty, empty


class KernelParticleStatePrediction(KernelParticleState):
    """A predicted :class:`KernelParticleState`, with the ``transition_model`` that produced
    it."""

    def __init__(self, state_vector, timestamp=None, weight=None, kernel_covar=None,
                 transition_model=None):
        super().__init__(state_vector, timestamp, weight, kernel_covar)
        self.transition_model = transition_model


class KernelParticleStateMeasurementPrediction(KernelParticleState):
    """Predicted measurements (m, M) of a :class:`KernelParticleState`'s particles, with its
    weights and kernel covariance."""


class KernelParticleStateUpdate(KernelParticleState):
    """An updated :class:`KernelParticleState`, with the ``hypothesis`` it came from and the
    ``proposal`` (d, M) particles that the next prediction propagates."""

    def __init__(self, state_vector, timestamp=None, weight=None, kernel_covar=None,
                 hypothesis=None, proposal=None):
        super().__init__(state_vector, timestamp, weight, kernel_covar)
        self.hypothesis = hypothesis
        self.proposal = None if proposal is None else _validate.state_array(proposal,
                                                                              "proposal")
        if self.proposal is not None and self.proposal.shape != self.state_vector.shape:
            raise ValueError(f"proposal must have shape {self.state_vector.shape}, "
                             f"got {self.proposal.shape}")


def column_vector(value, name="state_vector"):
    """A finite (d, 1) float64 column from a (d,) or (d, 1) array_like (d >= 1)."""
    v = _validate.finite_array(value, name)
    if v.ndim == 0 or v.ndim > 2 or (v.ndim == 2 and v.shape[1] != 1) or v.size == 0:
        raise ValueError(f"{name} must have shape (d,) or (d, 1), got {v.shape}")
    return v.reshape(-1, 1)


class State:
    """A point state: a (d, 1) ``state_vector`` at a ``timestamp``."""

    def __init__(self, state_vector, timestamp=None):
        self.state_vector = column_vector(state_vector)
        self.timestamp = check_timestamp(timestamp)

    @property
    def ndim(self):
        """Number of state dimensions d."""
        return self.state_vector.shape[0]

    def __repr__(self):
        return (f"{type(self).__name__}(state_vector={self.state_vector.ravel()}, "
                f"timestamp={self.timestamp!r})")


class GaussianState(State):
    """A Gaussian state: mean ``state_vector`` (d, 1) and covariance ``covar`` (d, d).

    The covariance must be finite and symmetric (to 1e-9 relative); positive definiteness is
    checked where a filter needs it.
    """

    def __init__(self, state_vector, covar, timestamp=None):
        super().__init__(state_vector, timestamp)
        self.covar = _validate.covariance(covar, "covar", self.ndim)

    @property
    def mean(self):
        """The mean, ``state_vector``."""
        return self.state_vector

    @classmethod
    def _trusted(cls, state_vector, covar, timestamp, extra=None):
        """Build from arrays that a kernel produced (no validation, no copies), with the
        ``extra`` attributes (a dict) if given; a :class:`Link` goes under its slot name
        (``_prior``)."""
        state = object.__new__(cls)
        state.__dict__ = {"state_vector": state_vector, "covar": covar, "timestamp": timestamp}
        if extra:
            state.__dict__.update(extra)
        return state


class GaussianStatePrediction(GaussianState):
    """A predicted Gaussian state, with the ``transition_model`` that produced it and the
    ``prior`` it came from (a weak link when a predictor made it, see the module's
    notes)."""

    prior = Link()

    def __init__(self, state_vector, covar, timestamp=None, transition_model=None, prior=None):
        super().__init__(state_vector, covar, timestamp)
        self.transition_model = transition_model
        self.prior = prior


class GaussianMeasurementPrediction(GaussianState):
    """A predicted measurement: mean ``state_vector`` (m, 1), innovation covariance
    ``covar`` (m, m) and ``cross_covar`` (d, m) between state and measurement."""

    def __init__(self, state_vector, covar, timestamp=None, cross_covar=None):
        super().__init__(state_vector, covar, timestamp)
        self.cross_covar = cross_covar


class GaussianStateUpdate(GaussianState):
    """An updated Gaussian state, with the ``hypothesis`` it was updated from."""

    def __init__(self, state_vector, covar, hypothesis=None, timestamp=None):
        super().__init__(state_vector, covar, timestamp)
        self.hypothesis = hypothesis


class GroundTruthState(State):
    """A true state, with optional ``metadata``."""

    def __init__(self, state_vector, timestamp=None, metadata=None):
        super().__init__(state_vector, timestamp)
        self.metadata = {} if metadata is None else dict(metadata)


class Detection(State):
    """A measurement ``state_vector`` (m, 1) at a ``timestamp``; its ``measurement_model``, if
    set, is used by updaters instead of their own."""

    def __init__(self, state_vector, timestamp=None, measurement_model=None, metadata=None):
        super().__init__(state_vector, timestamp)
        self.measurement_model = measurement_model
        self.metadata = {} if metadata is None else dict(metadata)


class StateSequence:
    """States kept in time order: indexing is by position, iteration in time order, and
    attributes not found here (``state_vector``, ``mean``, ``covar``, ...) are the last
    state's."""

    def __init__(self, states=None):
        self.states = []
        for state in states or ():
            self.append(state)

    def append(self, state):
        """Add a state, keeping time order (after any states with the same timestamp)."""
        if not hasattr(state, "timestamp"):
            raise TypeError(f"a {type(self).__name__} holds states, got {type(state).__name__}")
        if state.timestamp is None or not self.states or self.states[-1].timestamp is None \
                or _time_order(self.states[-1].timestamp, state.timestamp) <= 0:
            self.states.append(state)
            return
        position = len(self.states)
        while position > 0 and _time_order(self.states[position - 1].timestamp,
                                           state.timestamp) > 0:
            position -= 1
        self.states.insert(position, state)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return type(self)(self.states[index])
        return self.states[index]

    def __iter__(self):
        return iter(self.states)

    def __len__(self):
        return len(self.states)

    @property
    def state(self):
        """The last state."""
        return self.states[-1]

    @property
    def timestamps(self):
        return [state.timestamp for state in self.states]

    def __getattr__(self, name):
        if name.startswith("_") or name == "states":
            raise AttributeError(name)
        if not self.__dict__.get("states"):
            raise AttributeError(f"{type(self).__name__} is empty: no {name!r}")
        return getattr(self.states[-1], name)


def _time_order(a, b):
    """-1, 0 or 1 as timestamp a is before, at or after b (same kind required)."""
    both_real = isinstance(a, numbers.Real) and isinstance(b, numbers.Real)
    if type(a) is not type(b) and not both_real:
        raise TypeError(f"cannot order timestamps {a!r} and {b!r}: mix of datetimes and numbers")
    return (a > b) - (a < b)


class Track(StateSequence):
    """A track: estimated states in time order, with an ``id``."""

    def __init__(self, states=None, id=None):
        super().__init__(states)
        self.id = str(uuid.uuid4()) if id is None else id


class GroundTruthPath(StateSequence):
    """A true path: :class:`GroundTruthState` objects in time order, with an ``id``."""

    def __init__(self, states=None, id=None):
        super().__init__(states)
        self.id = str(uuid.uuid4()) if id is None else id


class SingleHypothesis:
    """A prediction paired with a measurement (a :class:`Detection`, or None for a missed
    detection); updaters store their ``measurement_prediction`` on it.

    The hypothesis holds its ``prediction`` until an updater has used it; from then on the
    link is weak (see the module's notes): an update, kept in a :class:`Track`, does not
    keep its prediction's particle cloud alive unless the program holds the prediction.
    """

    prediction = Link()

    def __init__(self, prediction, measurement, measurement_prediction=None):
        self.prediction = prediction
        self.measurement = measurement
        self.measurement_prediction = measurement_prediction

    def _used(self):
        """Turn the link to the prediction weak (an updater has used it)."""
        value = self.__dict__.get("_prediction")
        if value is not None and type(value) is not weakref.ref:
            self.__dict__["_prediction"] = weakref.ref(value)

    def __bool__(self):
        return self.measurement is not None

    def __repr__(self):
        return (f"SingleHypothesis(prediction={self.prediction!r}, "
                f"measurement={self.measurement!r})")


def time_interval(later, earlier, name="timestamp"):
    """Seconds from ``earlier`` to ``later`` (two datetimes or two numbers of seconds)."""
    if isinstance(later, datetime.datetime) and isinstance(earlier, datetime.datetime):
        return (later - earlier).total_seconds()
    if isinstance(later, numbers.Real) and isinstance(earlier, numbers.Real) \
            and not isinstance(later, bool) and not isinstance(earlier, bool):
        return float(later) - float(earlier)
    raise TypeError(f"{name} {later!r} and the prior's timestamp {earlier!r} must both be "
                    f"datetimes or both numbers of seconds")


def seconds(interval, name="time_interval"):
    """A time interval in seconds from a ``datetime.timedelta`` or a real number."""
    if isinstance(interval, datetime.timedelta):
        return interval.total_seconds()
    if isinstance(interval, numbers.Real) and not isinstance(interval, bool):
        if not np.isfinite(interval):
            raise ValueError(f"{name} must be finite, got {interval}")
        return float(interval)
    raise TypeError(f"{name} must be a datetime.timedelta or a number of seconds, "
                    f"got {type(interval).__name__}")
