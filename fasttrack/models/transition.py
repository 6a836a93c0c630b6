"""Transition models: x_k = f(x_{k-1}, dt) + w, w ~ N(0, Q(dt)).

Time intervals are ``datetime.timedelta`` or seconds. States are (d, N) arrays, one column per
particle, or state objects (their ``state_vector``).

Parameters may be assigned after construction; each assignment is validated and honoured
from the next call. Array parameters are stored read-only (assign a new array to change
one), and ``ndim_state`` is fixed.
"""
import functools
import itertools

import numpy as np

from .. import _validate
from ..types import seconds
from .base import (UserFunction, check_rows, gaussian_noise, read_only, scalar_or_array,
                   state_columns)
from .spec import CV, FIXED, FUNCTION, TransitionSpec

__all__ = [
    "TransitionModel", "LinearGaussianTransitionModel", "CombinedLinearGaussianTransitionModel",
    "EmbeddedTransitionModel", "NonlinearGaussianTransitionModel",
]


class TransitionModel:
    """Base class: ``function``, ``rvs``, ``logpdf`` and ``pdf`` from ``_mean`` and ``covar``.

    Subclasses define ``ndim_state``, ``covar(time_interval)``, ``_mean(x, dt)`` and
    ``spec(dt)``, the :class:`~fasttrack.models.spec.TransitionSpec` the array layer reads.
    """

    ndim_state = None
    #: Whether F and Q are the same for every time interval.
    time_invariant = False
    #: The checked user function (:class:`~fasttrack.models.base.UserFunction`) of a model
    #: built from one, else None.
    _function = None

    def _noise(self, dt):
        return gaussian_noise(self.covar(dt), f"{type(self).__name__}.covar")

    def _covar(self, dt):
        """Q(dt) as a C-contiguous float64 array for the kernels."""
        return np.ascontiguousarray(self.covar(dt), dtype=np.float64)

    def _columns(self, state, name="state"):
        x = state_columns(state, name)
        check_rows(x, self.ndim_state, name)
        return x

    def function(self, state, noise=False, time_interval=None, rng=None):
        """Propagate ``state`` over ``time_interval``.

        Parameters
        ----------
        state : state object or (d,) / (d, N) array_like
        noise : bool or (d, N) array_like
            False: the noise-free transition; True: add a draw of the process noise from
            ``rng``; an array: add it as given.
        time_interval : datetime.timedelta or float seconds
        rng : None, int or numpy.random.Generator

        Returns
        -------
        (d, N) float64 ndarray
        """
        x = self._columns(state)
        dt = self._seconds(time_interval)
        mean = self._mean(x, dt)
        if noise is True:
            return mean + self._noise(dt).sample(x.shape[1], rng)
        if noise is False or noise is None:
            return mean
        noise = _validate.finite_array(noise, "noise")
        if noise.shape not in (x.shape, (x.shape[0], 1), (x.shape[0],)):
            raise ValueError(f"noise must have shape {x.shape}, got {noise.shape}")
        return mean + noise.reshape(x.shape[0], -1)

    def rvs(self, num_samples=1, time_interval=None, rng=None):
        """(d, num_samples) draws of the process noise w ~ N(0, Q(dt)).

        Parameters
        ----------
        num_samples : int
            Number of draws, >= 1.
        time_interval : datetime.timedelta or float seconds
            Required, except by :class:`LinearGaussianTransitionModel` (which does not
            depend on it).
        rng : None, int or numpy.random.Generator
            Source of the draws (None: the package default generator).

        Returns
        -------
        (d, num_samples) float64 ndarray
        """
        num = _validate.count(num_samples, "num_samples")
        return self._noise(self._seconds(time_interval)).sample(num, rng)

    def logpdf(self, state1, state2, time_interval=None):
        """Log density of ``state1`` given ``state2`` (columns pair up; a float for one).

        Parameters
        ----------
        state1 : state object or (d,) / (d, N) array_like
            The states after the interval.
        state2 : state object or (d,) / (d, N) array_like
            The states before it; columns pair up with ``state1``'s (a single column of
            either is broadcast).
        time_interval : datetime.timedelta or float seconds
            Required, except by :class:`LinearGaussianTransitionModel` (which does not
            depend on it).

        Returns
        -------
        float or (N,) float64 ndarray
        """
        x1 = self._columns(state1, "state1")
        x2 = self._columns(state2, "state2")
        dt = self._seconds(time_interval)
        return scalar_or_array(self._noise(dt).logpdf(x1 - self._mean(x2, dt)))

    def pdf(self, state1, state2, time_interval=None):
        """Density of ``state1`` given ``state2``.

        Parameters
        ----------
        state1 : state object or (d,) / (d, N) array_like
            The states after the interval.
        state2 : state object or (d,) / (d, N) array_like
            The states before it; columns pair up with ``state1``'s (a single column of
            either is broadcast).
        time_interval : datetime.timedelta or float seconds
            Required, except by :class:`LinearGaussianTransitionModel` (which does not
            depend on it).

        Returns
        -------
        float or (N,) float64 ndarray
        """
        return np.exp(self.logpdf(state1, state2, time_interval))

    def _seconds(self, time_interval):
        if time_interval is None:
            raise TypeError(f"{type(self).__name__} needs a time_interval "
                            f"(a datetime.timedelta or seconds)")
        return seconds(time_interval)


@functools.lru_cache(maxsize=64)
def _rates_array(rates):
    """The rates as an array (shared: kernels only read it)."""
    return np.array(rates, dtype=np.float64)


def _block_diag(blocks):
    """Square blocks on the diagonal of a zero matrix."""
    size = sum(block.shape[0] for block in blocks)
    out = np.zeros((size, size))
    start = 0
    for block in blocks:
        stop = start + block.shape[0]
        out[start:stop, start:stop] = block
        start = stop
    return out


#: How many intervals a model remembers F(dt) and Q(dt) for.
MEMO_INTERVALS = 8


def _memoised(model, name, key, compute):
    """``compute()``, remembered in ``model``'s dictionary ``name`` under ``key`` (the
    dictionary emptied when it holds :data:`MEMO_INTERVALS` keys)."""
    memo = model.__dict__.setdefault(name, {})
    value = memo.get(key)
    if value is None:
        if len(memo) >= MEMO_INTERVALS:
            memo.clear()
        value = memo[key] = compute()
    return value


#: Revision numbers of model parameters, unique over the process's lifetime.
_REVISIONS = itertools.count()


class _LinearGaussian(TransitionModel):
    """x_k = F(dt) x_{k-1} + w: subclasses define ``matrix(time_interval)`` and
    ``_parameters()``, a hashable value that changes whenever F can, and may define
    ``_noise_parameters()``, one that changes whenever Q can (None: Q is not
    remembered)."""

    def _noise_parameters(self):
        return None

    def _covar(self, dt):
        """Q(dt) as a C-contiguous array, memoised for the last few intervals and the noise
        parameters where the model names them."""
        parameters = self._noise_parameters()
        if parameters is None:
            return super()._covar(dt)
        return _memoised(self, "_covar_memo", (dt, parameters),
                         lambda: super(_LinearGaussian, self)._covar(dt))

    def _mean(self, x, dt):
        return self._matrix(dt) @ x

    def _matrix(self, dt):
        """F(dt) as a C-contiguous array, memoised for the last few intervals and the
        parameters (filters step at a few intervals, and building F costs more than
        applying it)."""
        return _memoised(self, "_matrix_memo", (dt, self._parameters()),
                         lambda: np.ascontiguousarray(self.matrix(dt), dtype=np.float64))

    def jacobian(self, state=None, time_interval=None):
        """The transition matrix F(dt) (d, d) (the model is linear).

        Parameters
        ----------
        state : state object or array_like, optional
            Ignored: the Jacobian is the same at every state.
        time_interval : datetime.timedelta or float seconds
            Required, except by :class:`LinearGaussianTransitionModel` (which does not
            depend on it).
        """
        return self.matrix(self._seconds(time_interval))

    def spec(self, dt):
        """What the array layer reads: CV blocks when every part is a
        :class:`ConstantVelocity` (the kernels build F and Q for any interval), else FIXED
        with F(dt) and Q(dt).

        Parameters
        ----------
        dt : float
            The time interval, seconds.

        Returns
        -------
        fasttrack.models.spec.TransitionSpec
        """
        rates = self.cv_rates()
        if rates is not None:
            return TransitionSpec(self, dt, CV, _rates_array(rates))
        return TransitionSpec(self, dt, FIXED)

    def cv_rates(self):
        """The noise rates q (m^2 s^-3 for positions in metres) of the model's
        constant-velocity blocks, in order, as a tuple; None if a part is not a
        :class:`ConstantVelocity` (F and Q of such a model are built for any interval from
        these rates alone)."""
        return None


class LinearGaussianTransitionModel(_LinearGaussian):
    """A time-invariant linear-Gaussian transition: x_k = F x_{k-1} + w, w ~ N(0, Q).

    Parameters
    ----------
    transition_matrix : (d, d) array_like
    covariance_matrix : (d, d) array_like
        Symmetric positive semi-definite.
    """

    time_invariant = True

    def __init__(self, transition_matrix, covariance_matrix):
        matrix = _validate.finite_array(transition_matrix, "transition_matrix", 2)
        self._ndim_state = matrix.shape[0]
        self.transition_matrix = matrix
        self.covariance_matrix = covariance_matrix

    ndim_state = property(lambda self: self._ndim_state, doc="Number of state dimensions d.")

    @property
    def transition_matrix(self):
        """F (d, d) (read-only array; assign a new one to change it)."""
        return read_only(self._transition_matrix)

    @transition_matrix.setter
    def transition_matrix(self, value):
        self._transition_matrix = _validate.square_matrix(value, "transition_matrix",
                                                          self.ndim_state).copy()
        self._revision = next(_REVISIONS)

    @property
    def covariance_matrix(self):
        """Q (d, d), symmetric positive semi-definite (read-only array)."""
        return read_only(self._covariance_matrix)

    @covariance_matrix.setter
    def covariance_matrix(self, value):
        self._covariance_matrix = _validate.psd_covariance(value, "covariance_matrix",
                                                           self.ndim_state).copy()

    def matrix(self, time_interval=None):
        """F (d, d); the time interval is ignored.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds, optional
            Ignored (the model is time-invariant).
        """
        return self.transition_matrix

    def _matrix(self, dt):
        return self._transition_matrix

    def _parameters(self):
        return self._revision

    def covar(self, time_interval=None):
        """Q (d, d); the time interval is ignored.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds, optional
            Ignored (the model is time-invariant).
        """
        return self.covariance_matrix

    def _covar(self, dt):
        return self._covariance_matrix

    def _seconds(self, time_interval):
        return 0.0 if time_interval is None else seconds(time_interval)


class CombinedLinearGaussianTransitionModel(_LinearGaussian):
    """Independent linear-Gaussian models stacked: block-diagonal F and Q.

    Parameters
    ----------
    model_list : sequence of linear-Gaussian transition models
    """

    def __init__(self, model_list):
        self.model_list = model_list

    @property
    def model_list(self):
        """The parts (a tuple; assign a new sequence to change them)."""
        return self._models

    @model_list.setter
    def model_list(self, value):
        if not hasattr(value, "__iter__"):
            raise TypeError(f"model_list must be a sequence of linear-Gaussian transition "
                            f"models, got {type(value).__name__}")
        models = tuple(value)
        if not models:
            raise ValueError("model_list is empty")
        for model in models:
            if not isinstance(model, _LinearGaussian):
                raise TypeError(f"model_list must hold linear-Gaussian transition models, "
                                f"got {type(model).__name__}")
        dimension = sum(model.ndim_state for model in models)
        if "_models" in self.__dict__ and dimension != self.ndim_state:
            raise ValueError(f"model_list must keep {self.ndim_state} state dimensions, "
                             f"got {dimension}")
        self._models = models
        self._revision = next(_REVISIONS)

    @property
    def ndim_state(self):
        """Number of state dimensions d (the parts' sum)."""
        return sum(model.ndim_state for model in self._models)

    def _parameters(self):
        return self._revision, tuple(model._parameters() for model in self._models)

    def _noise_parameters(self):
        parts = tuple(model._noise_parameters() for model in self._models)
        return None if None in parts else (self._revision, parts)

    def matrix(self, time_interval):
        """F(dt) (d, d): the parts' transition matrices on the diagonal.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
        """
        dt = self._seconds(time_interval)
        return _block_diag([model.matrix(dt) for model in self.model_list])

    def covar(self, time_interval):
        """Q(dt) (d, d): the parts' process noise covariances on the diagonal.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
        """
        dt = self._seconds(time_interval)
        return _block_diag([model.covar(dt) for model in self.model_list])

    def cv_rates(self):
        rates = ()
        for model in self._models:
            part = model.cv_rates()
            if part is None:
                return None
            rates += part
        return rates


class EmbeddedTransitionModel(_LinearGaussian):
    """A linear model of d components acting on d of a larger state's D components: the
    model's component c is the state's ``state_map[c]``; the others are carried unchanged,
    without noise (e.g. a constant-velocity model (x, vx, y, vy) in a constant-acceleration
    state (x, vx, ax, y, vy, ay) with ``state_map=(0, 1, 3, 4)``).

    Parameters
    ----------
    model : linear TransitionModel
        Of d components (with ``matrix``).
    state_map : (d,) sequence of int
        Distinct indices in ``[0, ndim_state)``.
    ndim_state : int
        D >= d.
    """

    def __init__(self, model, state_map, ndim_state):
        if not isinstance(model, _LinearGaussian):
            raise TypeError(f"model must be a linear transition model, got "
                            f"{type(model).__name__}")
        self.model = model
        self._ndim_state = _validate.count(ndim_state, "ndim_state")
        self.state_map = state_map_indices(state_map, model.ndim_state, self._ndim_state,
                                           "state_map")

    ndim_state = property(lambda self: self._ndim_state, doc="Number of state dimensions D.")

    def _parameters(self):
        return self.model._parameters()

    def _noise_parameters(self):
        return self.model._noise_parameters()

    def matrix(self, time_interval):
        """F(dt) (D, D): the model's on its components, the identity elsewhere.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
        """
        out = np.eye(self._ndim_state)
        out[np.ix_(self.state_map, self.state_map)] = self.model.matrix(time_interval)
        return out

    def covar(self, time_interval):
        """Q(dt) (D, D): the model's on its components, 0 elsewhere.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
        """
        out = np.zeros((self._ndim_state, self._ndim_state))
        out[np.ix_(self.state_map, self.state_map)] = self.model.covar(time_interval)
        return out


def state_map_indices(state_map, d, ndim_state, name):
    """``state_map`` as a read-only (d,) int64 array of distinct indices in
    ``[0, ndim_state)``, or a ValueError naming ``name``."""
    indices = np.asarray(state_map)
    if indices.shape != (d,) or indices.dtype.kind not in "iu" \
            or np.unique(indices).size != d or (indices < 0).any() \
            or (indices >= ndim_state).any():
        raise ValueError(f"{name} must be {d} distinct indices in [0, {ndim_state}) (where "
                         f"each of the model's components sits in the state), got "
                         f"{np.asarray(state_map).tolist()}")
    return read_only(indices.astype(np.int64))


class NonlinearGaussianTransitionModel(TransitionModel):
    """A transition built from a user's Numba function, with additive Gaussian noise.

    Parameters
    ----------
    function : numba.njit function ``f(states, dt) -> new_states``
        ``states`` is a C-contiguous (d, n) float64 array, one state per column (a block of
        particles, or one state), ``dt`` the time interval in seconds; it returns a (d, n)
        float64 array. It is compiled and tried on a probe at construction, and its output
        is checked on every call (shape, finite values): see
        :class:`~fasttrack.models.base.UserFunction`.
    covariance : (d, d) array_like or callable
        Q, or ``covariance(dt) -> (d, d)`` for a Q that depends on the interval.
    ndim_state : int
        d.
    """

    def __init__(self, function, covariance, ndim_state):
        self._ndim_state = _validate.count(ndim_state, "ndim_state")
        self._function = UserFunction(function, "transition function", self._ndim_state,
                                      self._ndim_state, interval=True)
        if callable(covariance):
            self._covariance = covariance
        else:
            fixed = _validate.psd_covariance(covariance, "covariance", self.ndim_state)
            self._covariance = lambda dt: fixed

    ndim_state = property(lambda self: self._ndim_state, doc="Number of state dimensions d.")
    transition_function = property(lambda self: self._function.function,
                                   doc="The user's function f (fixed).")

    def covar(self, time_interval):
        """Q(dt) (d, d): the fixed Q, or ``covariance(dt)`` (checked to be finite, symmetric
        and positive semi-definite) when a callable was given.

        Parameters
        ----------
        time_interval : datetime.timedelta or float seconds
            dt, passed to a callable ``covariance`` in seconds.
        """
        covar = _validate.covariance(self._covariance(self._seconds(time_interval)),
                                     "covariance(dt)", self.ndim_state)
        return gaussian_noise(covar, "covariance(dt)").covar  # (PSD: checked once a value)

    def _mean(self, x, dt):
        return self._function(x, dt)

    def spec(self, dt):
        """What the array layer reads: FUNCTION, with the checked user function.

        Parameters
        ----------
        dt : float
            The time interval, seconds.

        Returns
        -------
        fasttrack.models.spec.TransitionSpec
        """
        return TransitionSpec(self, dt, FUNCTION, function=self._function)
