"""Smoothers: ``smoother.smooth(track)`` returns the track's states given all its
measurements (the Rauch-Tung-Striebel backward pass), as Stone Soup's smoothers do.

The backward pass needs, for each state after the first, the prediction it was updated
from. Stone Soup reads it from ``state.hypothesis.prediction``; fasttrack filters hold that
link weakly (see :mod:`fasttrack.types`), so in a track from :func:`~fasttrack.run_filter`
the predictions are usually gone. Where a prediction is missing, the smoother recomputes it
from the previous state of the track with its transition model, which is what the filter
did (``run_filter`` predicts each state from the one before it); where it is present, it
is used as given, with its own ``transition_model`` if it has one (Stone Soup's rule).

A prediction in the track itself (a missed detection) is both the filtered state and the
prediction at its time, and is smoothed like any other state. Stone Soup 1.9.1 instead reads
the prediction of such a state after smoothing it, so the correction of the state before it
is zero (that state keeps its filtered mean and covariance, and the states before it differ
from the exact smoother's); ``predictions="stonesoup"`` reproduces that.
"""
import numpy as np

from . import _validate
from ._validate import Setting
from ._sigma import SigmaPointSettings
from ._states import check_finite, stack, step_intervals, track_intervals
from .core import kalman as _kalman
from .core import smooth as _smooth
from .core import unscented as _unscented
from .models.base import check_model
from .models.transition import TransitionModel
from .types import GaussianStatePrediction, GaussianStateUpdate, StateSequence

__all__ = ["KalmanSmoother", "ExtendedKalmanSmoother", "UnscentedKalmanSmoother", "ffbs"]


_STEP_TYPES = (GaussianStatePrediction, GaussianStateUpdate)


def _is_gaussian_step(state):
    """Whether ``state`` is a Gaussian prediction or update (a state that has, or had, a
    prediction)."""
    return isinstance(state, (GaussianStatePrediction, GaussianStateUpdate))


def _predictions_of(states):
    """The prediction each of ``states`` came from: itself for a prediction, its
    hypothesis' prediction for an update (None where the link is gone)."""
    return [state if isinstance(state, GaussianStatePrediction)
            else getattr(getattr(state, "hypothesis", None), "prediction", None)
            for state in states]


def _check_step_types(body, offset):
    """A TypeError naming the first state of ``body`` that is not a Gaussian prediction or
    update."""
    if all(issubclass(kind, _STEP_TYPES) for kind in set(map(type, body))):
        return
    k = next(k for k, state in enumerate(body) if not isinstance(state, _STEP_TYPES))
    raise TypeError(f"track[{offset + k}] must be a GaussianStatePrediction or "
                    f"GaussianStateUpdate, got {type(body[k]).__name__}")


def _held_predictions(body, model, offset):
    """``(x_pred, covar_pred, recompute, models)`` from the predictions the states of
    ``body`` still hold: the means (1, n, d) and covariances (1, n, d, d) at their times,
    ``recompute[t]`` (n,) 1 where none is held (the kernel computes it) else 0, and the
    steps (by the index of the later state) whose prediction names another transition
    model than ``model``."""
    n, d = len(body), model.ndim_state
    x_pred, covar_pred = np.empty((1, n, d)), np.empty((1, n, d, d))
    recompute = np.ones(n, dtype=np.uint8)
    models = {}
    held = [(t, prediction) for t, prediction in enumerate(_predictions_of(body[1:]), start=1)
            if prediction is not None]
    for t, prediction in held:
        if prediction.state_vector.shape != (d, 1) or prediction.covar.shape != (d, d):
            raise ValueError(f"the prediction of track[{offset + t}] must have dimension "
                             f"{d}, got {prediction.state_vector.shape[0]}")
        x_pred[0, t] = prediction.state_vector[:, 0]
        covar_pred[0, t] = prediction.covar
        recompute[t] = 0
        own = getattr(prediction, "transition_model", None)
        if own is not None and own is not model:
            if getattr(own, "ndim_state", None) != d:
                raise ValueError(f"the transition_model of the prediction of "
                                 f"track[{offset + t}] must have ndim_state {d}, got "
                                 f"{getattr(own, 'ndim_state', None)}")
            models[t] = own
    return x_pred, covar_pred, recompute, models


def _with_moments(states, means, covars):
    """New states of the types and attributes of ``states`` (Stone Soup's ``from_state``)
    holding ``means`` and ``covars``."""
    new = object.__new__
    out = []
    for state, mean, covar in zip(states, means, covars):
        attributes = state.__dict__.copy()
        attributes["state_vector"] = mean
        attributes["covar"] = covar
        smoothed = new(type(state))
        smoothed.__dict__ = attributes
        out.append(smoothed)
    return out

def _predictions(predicted_means, predicted_covars, shape, d):
    """The predicted means (``shape``, i.e. (T, d) or (K, T, d)) and covariances given to
    ``smooth_arrays``, checked where they are read: finite and (covariances) symmetric from
    time 1 on (time 0's are not read)."""
    out = []
    for name, value, like, want in (("predicted_means", predicted_means, "means", shape),
                                    ("predicted_covars", predicted_covars, "covars",
                                     shape + (d,))):
        value = _validate.float_array(value, name)
        if value.shape != want:
            raise ValueError(f"{name} must have the shape of {like} {want}, got "
                             f"{value.shape}")
        read = value[1:] if len(shape) == 2 else value[:, 1:]
        if not np.isfinite(read).all():
            raise ValueError(f"{name} contains NaN or infinite values (past time 0, whose "
                             f"prediction is not read)")
        out.append(value)
    covars = out[1] if len(shape) == 3 else out[1][None]
    bad = _validate.asymmetric(covars[:, 1:].reshape(-1, d, d))
    if bad.any():
        k, t = np.unravel_index(np.argmax(bad), (covars.shape[0], covars.shape[1] - 1))
        where = f"{t + 1}" if len(shape) == 2 else f"{k}, {t + 1}"
        raise ValueError(f"predicted_covars[{where}] is not symmetric")
    return out


class KalmanSmoother:
    """The Rauch-Tung-Striebel (Kalman) smoother for a linear-Gaussian transition model.

    From the last state back, with the prediction ``x_{k+1|k}, P_{k+1|k}`` of the next
    state and the transition matrix ``F`` between them::

        G_k   = P_k F^T P_{k+1|k}^{-1}
        x^s_k = x_k + G_k (x^s_{k+1} - x_{k+1|k})
        P^s_k = P_k + G_k (P^s_{k+1} - P_{k+1|k}) G_k^T

    with ``x^s, P^s`` of the last state its filtered values. The whole pass runs in one
    compiled kernel.

    Parameters
    ----------
    transition_model : TransitionModel
        A linear-Gaussian fasttrack transition model (with ``matrix``): gives ``F(dt)`` (and
        ``Q(dt)`` for predictions that must be recomputed) unless a prediction carries its
        own ``transition_model``.
    predictions : {'exact', 'stonesoup'}
        How a prediction in the track (a missed step) is read: 'exact' (the RTS smoother:
        it is the prediction of its time) or 'stonesoup' (Stone Soup 1.9.1's result: its
        smoothed value is used as the prediction, so the state before it is not smoothed;
        see the module's notes). Tracks without predictions give the same result either way.
    """

    def __init__(self, transition_model, predictions="exact"):
        check_model(transition_model, TransitionModel, "transition_model")
        self._check_model(transition_model)
        self.transition_model = transition_model
        if predictions not in ("exact", "stonesoup"):
            raise ValueError(f"predictions must be 'exact' or 'stonesoup', got {predictions!r}")
        self.predictions = predictions

    def _check_model(self, model):
        if not hasattr(model, "matrix"):
            raise TypeError(f"{type(self).__name__} needs a linear transition_model (with "
                            f"matrix); use ExtendedKalmanSmoother for "
                            f"{type(model).__name__}")

    # -- the per-step linearisation ----------------------------------------------------

    def _linearise(self, model, dt, x, covar, need_prediction):
        """``(F, Q, prediction)`` of one step from the state ``(x, covar)`` over ``dt``
        seconds: a linear model's matrix and noise (the kernel recomputes the prediction),
        so ``prediction`` is None."""
        if not hasattr(model, "matrix"):
            raise TypeError(f"{type(self).__name__} needs linear transition models (with "
                            f"matrix), got a prediction's {type(model).__name__}; use "
                            f"ExtendedKalmanSmoother")
        return (np.ascontiguousarray(model.matrix(dt), dtype=np.float64),
                np.ascontiguousarray(model.covar(dt), dtype=np.float64), None)

    # -- public API -------------------------------------------------------------------

    def smooth(self, track):
        """Smooth ``track`` backwards (Stone Soup's ``smooth(track)``).

        Parameters
        ----------
        track : Track
            Gaussian predictions and updates in time order (for example from
            :func:`~fasttrack.run_filter`), all of the transition model's dimension, with
            timestamps. A first state that is neither a prediction nor an update (a prior
            :class:`~fasttrack.GaussianState`) is kept unchanged, as Stone Soup does.

        Returns
        -------
        Track
            A shallow copy of ``track`` (same ``id``) whose states are new states of the
            same types (and attributes: hypothesis, timestamp) holding the smoothed means
            and covariances; the last state (and a kept first state) is the input's own
            object.

        Raises
        ------
        TypeError
            If ``track`` is not a Track, or a state is not a Gaussian prediction or update,
            or timestamps are missing or of mixed kinds.
        ValueError
            If ``track`` is empty, a state has the wrong dimension, holds NaN or infinite
            values or a covariance that is not symmetric positive semi-definite, the
            timestamps go backwards, or a predicted covariance is not positive definite.
        """
        if not isinstance(track, StateSequence):
            raise TypeError(f"track must be a Track, got {type(track).__name__}")
        states = track.states
        if not states:
            raise ValueError("track must hold at least one state, got an empty track")
        start = 0 if _is_gaussian_step(states[0]) else 1
        body = states[start:]
        smoothed = self._smooth_states(body, start) if body else []
        result = object.__new__(type(track))
        result.__dict__ = dict(track.__dict__)
        result.states = states[:start] + smoothed
        return result

    def _smooth_states(self, body, offset):
        _check_step_types(body, offset)
        n = len(body)
        if n == 1:
            return [body[0]]
        model = self.transition_model
        d = model.ndim_state
        x = stack(body, "state_vector", (d, 1), offset).reshape(1, n, d)
        covar = stack(body, "covar", (d, d), offset).reshape(1, n, d, d)
        check_finite(x[0], "track[{}].state_vector", offset)
        check_finite(covar[0], "track[{}].covar", offset)
        intervals = track_intervals(body, offset, strict=False)
        x_pred, covar_pred, recompute, models = _held_predictions(body, model, offset)
        if self.predictions == "stonesoup":
            for t in range(1, n):
                if isinstance(body[t], GaussianStatePrediction):
                    recompute[t] = 2
        matrices, step = self._steps(models, intervals, x, covar, x_pred, covar_pred,
                                     recompute)
        x_out, covar_out, status = _smooth.rts(x, covar, x_pred, covar_pred, recompute,
                                               np.array([m[0] for m in matrices]),
                                               np.array([m[1] for m in matrices]), step)
        if status:
            _, t, what = _smooth.failure(status, 1, n)
            if what == "filtered":
                raise ValueError(f"track[{offset + t}].covar is not symmetric positive "
                                 f"semi-definite")
            if what == "smoothed":
                raise ValueError(f"the smoothed state of track[{offset + t}] "
                                 f"{_smooth.SMOOTHED_UNRESOLVED}")
            raise ValueError(f"the predicted covariance of track[{offset + t}] is not "
                             f"positive definite: cannot form the smoothing gain")
        return _with_moments(body[:-1], x_out.reshape(n, d, 1), covar_out[0]) + [body[-1]]

    def _steps(self, models, intervals, x, covar, x_pred, covar_pred, recompute):
        """The (F, Q) pairs of the track's steps and, for each t < n - 1, the index of the
        one from t to t + 1; predictions the linearisation makes (nonlinear models) go into
        ``x_pred``/``covar_pred``."""
        model = self.transition_model
        n, d = x.shape[1:]
        step = np.zeros(n, dtype=np.int64)
        if not models and hasattr(model, "matrix"):
            values, inverse = np.unique(intervals, return_inverse=True)
            step[:n - 1] = inverse
            return [self._linearise(model, dt, None, None, False)[:2] for dt in values], step
        matrices, table = [], {}
        for t in range(n - 1):
            step_model = models.get(t + 1, model)
            key = (id(step_model), intervals[t])
            index = table.get(key)
            if index is None or not hasattr(step_model, "matrix"):
                f, q, prediction = self._linearise(
                    step_model, intervals[t], x[0, t].reshape(d, 1), covar[0, t],
                    recompute[t + 1] == 1)
                if prediction is not None:
                    x_pred[0, t + 1] = prediction[0][:, 0]
                    covar_pred[0, t + 1] = prediction[1]
                    recompute[t + 1] = 0
                index = len(matrices)
                matrices.append((f, q))
                table[key] = index
            step[t] = index
        return matrices, step

    def smooth_arrays(self, means, covars, time_intervals, predicted_means=None,
                      predicted_covars=None):
        """Smooth one track, or K tracks of equal length on the same time steps, given as
        arrays of filtered states (the batched entry: one kernel call for all K).

        Parameters
        ----------
        means : (T, d) or (K, T, d) array_like
            Filtered means, in time order.
        covars : (T, d, d) or (K, T, d, d) array_like
            Filtered covariances.
        time_intervals : float, datetime.timedelta or (T - 1,) array_like
            The interval from each state to the next, in seconds (one value: every step).
        predicted_means : (T, d) or (K, T, d) array_like, optional
            The prediction at each time from the previous one (index 0 unused). Default:
            recomputed with the transition model, ``F x``.
        predicted_covars : (T, d, d) or (K, T, d, d) array_like, optional
            With ``predicted_means``: ``F P F^T + Q`` if not given.

        Returns
        -------
        means : ndarray
            Smoothed means, the shape of ``means``.
        covars : ndarray
            Smoothed covariances, the shape of ``covars``.

        Raises
        ------
        TypeError
            If the transition model is not linear, or an argument is not numeric.
        ValueError
            If a shape does not match, a value is not finite, a filtered covariance is not
            symmetric positive semi-definite, an interval is negative, or a predicted
            covariance is not positive definite.
        """
        model = self.transition_model
        if not hasattr(model, "matrix"):
            raise TypeError(f"smooth_arrays needs a linear transition_model (with matrix), "
                            f"got {type(model).__name__}")
        d = model.ndim_state
        x = _validate.finite_array(means, "means")
        shape = x.shape
        single = x.ndim == 2
        if x.ndim not in (2, 3) or x.shape[-1] != d or x.shape[-2] < 1:
            raise ValueError(f"means must have shape (T, {d}) or (K, T, {d}), got {x.shape}")
        x = x.reshape((1,) + x.shape) if single else x
        k_tracks, n = x.shape[:2]
        covar = _validate.finite_array(covars, "covars")
        if covar.shape != shape + (d,):
            raise ValueError(f"covars must have shape {shape + (d,)}, got {covar.shape}")
        covar = covar.reshape(x.shape + (d,))
        if (predicted_means is None) != (predicted_covars is None):
            raise ValueError("predicted_means and predicted_covars must be given together")
        if predicted_means is None:
            x_pred, covar_pred = np.empty_like(x), np.empty_like(covar)
            recompute = np.ones(n, dtype=np.uint8)
        else:
            x_pred, covar_pred = _predictions(predicted_means, predicted_covars, shape, d)
            x_pred, covar_pred = x_pred.reshape(x.shape), covar_pred.reshape(covar.shape)
            recompute = np.zeros(n, dtype=np.uint8)
        intervals = step_intervals(time_intervals, n)
        x_out, covar_out, status = _smooth.rts_linear(model, x, covar, x_pred, covar_pred,
                                                      recompute, intervals)
        if status:
            k, t, what = _smooth.failure(status, k_tracks, n)
            where = f"[{t}]" if single else f"[{k}, {t}]"
            if what == "filtered":
                raise ValueError(f"covars{where} is not symmetric positive semi-definite")
            if what == "smoothed":
                raise ValueError(f"the smoothed state{where} {_smooth.SMOOTHED_UNRESOLVED}")
            predicted = ("predicted_covars" if predicted_covars is not None
                         else "the predicted covariance F P F^T + Q at ")
            raise ValueError(f"{predicted}{where} is not positive definite: cannot form the "
                             f"smoothing gain")
        if single:
            return x_out[0], covar_out[0]
        return x_out, covar_out


class ExtendedKalmanSmoother(KalmanSmoother):
    """The extended Kalman (Rauch-Tung-Striebel) smoother: as :class:`KalmanSmoother`, with
    ``F`` the transition's Jacobian at each filtered state for a nonlinear model (a
    linear model's matrix otherwise). A missing prediction is recomputed as the extended
    Kalman predictor does, ``f(x)`` and ``J P J^T + Q``.

    Parameters
    ----------
    transition_model : TransitionModel
        Any fasttrack transition model: linear (its matrix) or built from a Numba function
        (finite-difference Jacobian).
    jacobian : {'forward', 'central'}
        Finite differences for function-built models (forward: Stone Soup's rule, and the
        :class:`~fasttrack.ExtendedKalmanPredictor` default).
    predictions : {'exact', 'stonesoup'}
        How a prediction in the track is read (see :class:`KalmanSmoother`).
    """

    #: The Jacobian's method (checked when assigned, here or later).
    jacobian = Setting(_kalman.check_jacobian, allowed=("forward", "central"))

    def __init__(self, transition_model, jacobian="forward", predictions="exact"):
        super().__init__(transition_model, predictions)
        self.jacobian = jacobian

    def _check_model(self, model):
        pass

    def _linearise(self, model, dt, x, covar, need_prediction):
        """A linear model as :class:`KalmanSmoother`; for a function-built one the
        finite-difference Jacobian at ``x``, and the prediction ``(f(x), J P J^T + Q)``
        when ``need_prediction``."""
        if hasattr(model, "matrix"):
            return super()._linearise(model, dt, x, covar, need_prediction)
        d = x.shape[0]
        f = _kalman.transition_jacobian(model, dt, x, self.jacobian)
        prediction = None
        if need_prediction:
            prediction = _kalman.predict(model, dt, x, covar, self.jacobian)
        return f, np.zeros((d, d)), prediction



class UnscentedKalmanSmoother(SigmaPointSettings, KalmanSmoother):
    """The unscented Kalman (Rauch-Tung-Striebel) smoother: as :class:`KalmanSmoother`, with
    the gain ``G = C P_{k+1|k}^{-1}`` from the unscented transform (Stone Soup's
    ``UnscentedKalmanSmoother``): C is the cross covariance of the sigma points of the
    filtered state and their transition. For a linear model ``C = P F^T`` exactly, so the
    Kalman smoother's formulas are used; for a model built from a Numba function the sigma
    points go through it. A missing prediction is recomputed as
    :class:`~fasttrack.UnscentedKalmanPredictor` does with this smoother's parameters (give
    it the filter's, for the filter's predictions).

    Parameters
    ----------
    transition_model : TransitionModel
        A built-in linear-Gaussian model or a
        :class:`~fasttrack.NonlinearGaussianTransitionModel`.
    alpha : float
        Primary spread of the sigma points, > 0.
    beta : float
        Prior knowledge of the distribution (2 is optimal for a Gaussian).
    kappa : float, optional
        Secondary spread; None means ``3 - ndim_state``, the default of the unscented
        filters and of Stone Soup's documentation (Stone Soup 1.9.1's smoother uses 0).
    predictions : {'exact', 'stonesoup'}
        How a prediction in the track is read (see :class:`KalmanSmoother`).
    """

    def __init__(self, transition_model, alpha=0.5, beta=2.0, kappa=None, predictions="exact"):
        self.alpha, self.beta, self.kappa = alpha, beta, kappa
        super().__init__(transition_model, predictions)
        self._resolved_kappa(transition_model.ndim_state)  # (the spread checked now)

    def _check_model(self, model):
        _unscented.check_transition(model)

    def _linearise(self, model, dt, x, covar, need_prediction):
        """A linear model as :class:`KalmanSmoother`; for a function-built one the
        statistical linearisation ``F = C^T P^+`` (so that ``P F^T = C``, the cross
        covariance of the unscented transform, C lying in the range of P) and, when
        ``need_prediction``, the unscented prediction."""
        if hasattr(model, "matrix"):
            return super()._linearise(model, dt, x, covar, need_prediction)
        self._check_model(model)
        x_pred, covar_pred, cross = _unscented.transition_moments(
            model, dt, x, covar, self.alpha, self.beta, self._resolved_kappa(x.shape[0]))
        f = np.linalg.lstsq(covar, cross, rcond=None)[0].T
        prediction = (x_pred, covar_pred) if need_prediction else None
        return f, np.zeros_like(f), prediction

def ffbs(particle_states, transition_model, n_paths, rng=None, method="rejection"):
    """Forward-filter backward-simulation particle smoother: trajectories drawn from the
    smoothing distribution that a particle filter's posteriors approximate.

    A path ends at a particle of the last posterior drawn by weight; going back, the
    particle at time t is drawn with weight ``w_t^i p(x_{t+1} | x_t^i)`` (the transition
    density of the model's Gaussian noise), one compiled pass for all paths.

    The exact draw weighs all N particles, O(N) per path and step. The rejection draw
    (Douc, Garivier, Moulines and Olsson, 2011) proposes a particle by filter weight
    ``w_t^i`` (a bisection of the cumulative weights, computed once per step) and accepts it
    with probability ``exp(-|L^{-1} (x_{t+1} - f(x_t^i))|^2 / 2)``, the density over its
    maximum (``Q = L L^T``), so it costs O(1) expected proposals per path and step where the
    transition density overlaps the filter's particles: about O(N T + M T log N) in all
    instead of O(N M T). After 32 rejections a path makes the exact draw, which bounds the
    cost of a path in the tail of the density; and once a step's acceptance rate falls below
    64 / N (a proposal costs about as much as 64 particles' terms of an exact draw), as when
    the noise is small against the spread of the particles, the remaining paths of that step
    draw exactly. Each index has the same distribution either way; for the same seed the two
    methods draw different paths.

    Parameters
    ----------
    particle_states : sequence of ParticleState
        The filter's posteriors in time order (for example a :class:`~fasttrack.Track`
        from :func:`~fasttrack.run_filter` with a particle filter), all with the same
        number of particles N and dimension d, with timestamps.
    transition_model : TransitionModel
        The model the filter predicted with (linear or built from a Numba function); its
        noise covariance must be positive definite.
    n_paths : int
        Number of trajectories M to draw (>= 1).
    rng : None, int or numpy.random.Generator
        Source of the uniforms (``None``: the package generator, see :func:`fasttrack.seed`):
        one integer is drawn from it to seed the generator the compiled pass draws from, so
        the same seed gives the same paths.
    method : {"rejection", "exact"}
        How each backward index is drawn: by rejection with the exact draw as fallback
        (the default), or always exactly.

    Returns
    -------
    ndarray
        (T, d, M) float64: trajectory m is ``paths[:, :, m]``; ``paths[t]`` is a (d, M)
        equally weighted sample of the smoothing marginal at time t.

    Raises
    ------
    TypeError
        If an argument has the wrong type.
    ValueError
        If ``particle_states`` is empty, its states differ in shape, hold NaN or infinite
        values or are not in increasing time order, ``n_paths < 1``, ``method`` is not one
        of the two, or the noise covariance is not positive definite.
    """
    from . import random as _random

    if not (isinstance(method, str) and method in ("rejection", "exact")):
        raise ValueError(f"method must be 'rejection' or 'exact', got {method!r}")
    check_model(transition_model, TransitionModel, "transition_model")
    m = _validate.count(n_paths, "n_paths")
    states = list(particle_states.states if isinstance(particle_states, StateSequence)
                  else _validate.iterator(particle_states, "particle_states"))
    if not states:
        raise ValueError("particle_states must hold at least one state, got none")
    for k, state in enumerate(states):
        if not (hasattr(state, "state_vector") and hasattr(state, "log_weight")):
            raise TypeError(f"particle_states[{k}] must be a ParticleState, "
                            f"got {type(state).__name__}")
    d = transition_model.ndim_state
    shape = np.shape(states[0].state_vector)
    if len(shape) != 2 or shape[0] != d:
        raise ValueError(f"particle_states[0].state_vector must have shape ({d}, N), got {shape}")
    for k, state in enumerate(states):
        if np.shape(state.state_vector) != shape:
            raise ValueError(f"particle_states[{k}].state_vector must have shape {shape}, "
                             f"got {np.shape(state.state_vector)}")
    n_times = len(states)
    x = np.ascontiguousarray([state.state_vector for state in states], dtype=np.float64)
    log_weights = np.ascontiguousarray([state.log_weight for state in states],
                                       dtype=np.float64)
    check_finite(x, "particle_states[{}].state_vector")
    bad = np.isnan(log_weights).any(axis=1) | (log_weights == np.inf).any(axis=1) \
        | (log_weights == -np.inf).all(axis=1)
    if bad.any():
        raise ValueError(f"particle_states[{np.argmax(bad)}].log_weight must hold no NaN or "
                         f"+inf and not be all -inf")
    intervals = track_intervals(states, 0, "particle_states", strict=True) \
        if n_times > 1 else np.empty(0)
    mean_next = np.empty((max(n_times - 1, 0), d, shape[1]))
    for t in range(n_times - 1):
        mean_next[t] = transition_model.spec(intervals[t]).mean(x[t])
    durations, step = np.unique(intervals, return_inverse=True)
    roots = np.empty((durations.size, d, d))
    for k, dt in enumerate(durations):
        q = np.asarray(transition_model.covar(dt), dtype=np.float64)
        try:
            lower = np.linalg.cholesky(q)
        except np.linalg.LinAlgError:
            raise ValueError(f"transition_model.covar({dt}) must be positive "
                             f"definite for the transition density") from None
        roots[k] = np.linalg.inv(lower)
    roots = np.ascontiguousarray(roots[step.reshape(-1)])
    index = _smooth.ffbs(x, log_weights, mean_next, roots, m, _random.stream_key(rng),
                         method == "rejection")
    return np.take_along_axis(x, index[:, None, :], axis=2)
