"""Stone Soup's Kalman smoothers, with fasttrack's backward-pass kernel.

``smooth(track)`` returns what Stone Soup's does: a shallow copy of the track whose states
are ``type(state).from_state(state, mean, covar)`` (the last state, and a first state that is
not a Gaussian prediction or update, kept as they are), the predictions read through the
smoother's ``_prediction`` hook and the transition model through ``_transition_model``.

A prediction inside the track (a missed detection) is read as Stone Soup 1.9.1 reads it:
after it has been smoothed, so the state before it keeps its filtered mean and covariance
and the pass restarts from there. The fast path covers tracks whose steps all use one
transition model that fasttrack knows (see ``_convert``), with datetime timestamps; another
model, a keyword argument, an overridden hook, or a step the kernel refuses (a predicted
covariance that is not positive definite, non-finite values) goes through Stone Soup's own
``smooth``.
"""
import copy

import numpy as np
from stonesoup.smoother import kalman as ss_kalman
from stonesoup.types.prediction import Prediction

from ..core import smooth as ft_smooth
from ._convert import fast_model
from ._fallback import fall_back, unknown_model

#: The hooks of Stone Soup's smoothers that the fast path computes itself.
_HOOKS = ("_prediction", "_transition_model", "_transition_matrix", "_smooth_gain")


def _stacked(arrays, shape):
    """``arrays`` as one float64 array (n, *shape), or None if one has another shape or a
    value that is not a number."""
    try:
        out = np.array(arrays, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return out if out.shape[1:] == shape else None


def _segments(body):
    """``(first, last)`` index ranges of ``body`` that Stone Soup smooths independently: a
    prediction in the track ends the range before it (whose last state then keeps its
    filtered values) and starts a new one."""
    starts = [0] + [t for t in range(1, len(body)) if isinstance(body[t], Prediction)]
    return list(zip(starts, starts[1:] + [len(body)]))


class _Kalman:
    """``smooth`` of the Kalman smoothers through fasttrack's Rauch-Tung-Striebel kernel."""

    _stonesoup = ss_kalman.KalmanSmoother

    def smooth(self, track, **kwargs):
        """Smooth ``track`` backwards, as Stone Soup's ``smooth``.

        Parameters
        ----------
        track : Track
            Gaussian predictions and updates in time order.
        **kwargs
            Passed to Stone Soup's hooks (which then run instead of the kernel).

        Returns
        -------
        Track
            A shallow copy of ``track`` with the smoothed states.
        """
        if kwargs or any(getattr(type(self), hook) is not getattr(self._stonesoup, hook)
                         for hook in _HOOKS):
            fall_back(self, "smooth", f"keyword arguments {', '.join(sorted(kwargs))}" if kwargs
                      else "a subclass's own hooks")
            return self._stonesoup.smooth(self, track, **kwargs)
        states = list(track.states)
        start = self._start(states)
        smoothed = self._smooth_body(states[start:])
        if isinstance(smoothed, str):
            fall_back(self, "smooth", smoothed)
            return self._stonesoup.smooth(self, track)
        smoothed_track = copy.copy(track)
        smoothed_track.states = states[:start] + smoothed
        return smoothed_track

    def _start(self, states):
        """1 if the first state is not a Gaussian prediction or update (kept as it is),
        else 0 (Stone Soup's rule)."""
        try:
            self._prediction(states[0])
        except (ValueError, TypeError):
            return 1
        return 0

    def _smooth_body(self, body):
        """The smoothed states of ``body`` (its last one its own), or the reason Stone
        Soup's code must run."""
        if len(body) < 2:
            return "fewer than two states"
        try:
            predictions = [self._prediction(state) for state in body[1:]]
        except (ValueError, TypeError):  # Stone Soup's code raises its error, in its order
            return "a state without its prediction"
        models = {id(model): model for model in map(self._transition_model, predictions)}
        if len(models) > 1:
            return "several transition models"
        model = next(iter(models.values()))
        fast = fast_model(model)
        if fast is None:
            return unknown_model(model)
        moments = self._moments(fast, body, predictions, fast.ndim_state)
        if isinstance(moments, str):
            return moments
        return [type(state).from_state(state, mean, covar)
                for state, mean, covar in zip(body[:-1], *moments)] + [body[-1]]

    @staticmethod
    def _moments(model, body, predictions, d):
        """Smoothed means (n, d, 1) and covariances (n, d, d) of ``body`` through the
        fasttrack transition ``model``, range by range (see :func:`_segments`), or the
        reason Stone Soup's code must run."""
        try:
            intervals = np.array([(later.timestamp - earlier.timestamp).total_seconds()
                                  for earlier, later in zip(body, body[1:])])
        except (TypeError, AttributeError):
            return "missing or mixed timestamps"
        means = _stacked([state.state_vector for state in body], (d, 1))
        covars = _stacked([state.covar for state in body], (d, d))
        # index 0 (the first state's own prediction) is not used
        predicted_means = _stacked([body[0].state_vector]
                                   + [p.state_vector for p in predictions], (d, 1))
        predicted_covars = _stacked([body[0].covar] + [p.covar for p in predictions], (d, d))
        if any(a is None for a in (means, covars, predicted_means, predicted_covars)):
            return "states of other shapes than the model's, or not numbers"
        means, predicted_means = means[..., 0], predicted_means[..., 0]
        for first, end in _segments(body):
            if end - first < 2:
                continue
            part = slice(first, end)
            if not all(np.isfinite(a[part]).all()
                       for a in (means, covars, predicted_means, predicted_covars)):
                return "states that are not finite"
            smoothed_means, smoothed_covars, status = ft_smooth.rts_linear(
                model, means[None, part], covars[None, part], predicted_means[None, part],
                predicted_covars[None, part], np.zeros(end - first, dtype=np.uint8),
                intervals[first:end - 1])
            if status:
                what = ft_smooth.failure(status, 1, end - first)[2]
                return ("a smoothed state beyond the kernels' arithmetic" if what == "smoothed"
                        else "a predicted covariance that is not positive definite")
            means[part], covars[part] = smoothed_means[0], smoothed_covars[0]
        return means[..., None], covars


class KalmanSmoother(_Kalman, ss_kalman.KalmanSmoother):
    """Stone Soup's ``KalmanSmoother``, compiled for its built-in linear transition
    models."""


class ExtendedKalmanSmoother(_Kalman, ss_kalman.ExtendedKalmanSmoother):
    """Stone Soup's ``ExtendedKalmanSmoother``, compiled for its built-in linear transition
    models (whose Jacobian is their matrix); other models go through Stone Soup's
    Jacobian."""

    _stonesoup = ss_kalman.ExtendedKalmanSmoother


class UnscentedKalmanSmoother(_Kalman, ss_kalman.UnscentedKalmanSmoother):
    """Stone Soup's ``UnscentedKalmanSmoother``, compiled for its built-in linear transition
    models, for which the unscented gain ``C P_{k+1|k}^{-1}`` is ``P F^T P_{k+1|k}^{-1}``
    exactly (whatever ``alpha``, ``beta``, ``kappa``); other models go through Stone Soup's
    unscented transform."""

    _stonesoup = ss_kalman.UnscentedKalmanSmoother
