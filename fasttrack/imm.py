"""Interacting multiple models (IMM) on stacks of filters: :class:`BatchIMMFilter` (see
:mod:`fasttrack.core.imm`)."""
import numpy as np

from . import _validate
from .batch import check_models
from .core import imm as _imm

__all__ = ["BatchIMMFilter"]


class BatchIMMFilter:
    """K independent IMM filters, each a bank of M Kalman filters (one a transition model)
    sharing a measurement model: mix, predict and update each model, weigh the models by
    their measurement likelihoods (in logs), and combine.

    Parameters
    ----------
    transition_models : sequence of TransitionModel
        M linear-Gaussian models of one state dimension (e.g. constant velocity with two
        noise levels).
    measurement_model : MeasurementModel
        A built-in model (linear, or polar through the extended Kalman filter).
    transition_matrix : (M, M) array_like
        ``transition_matrix[i, j]``: the probability of switching from model i to model j
        in one step; rows sum to one. One model (a 1 x 1 matrix) is the Kalman filter.

    Examples
    --------
    >>> import numpy as np, fasttrack as ft
    >>> models = [ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(q)] * 2)
    ...           for q in (0.01, 10.0)]
    >>> imm = ft.BatchIMMFilter(models, ft.LinearGaussian(4, (0, 2), np.eye(2)),
    ...                         [[0.95, 0.05], [0.05, 0.95]])
    >>> means, covars = np.zeros((1, 2, 4)), np.broadcast_to(np.eye(4), (1, 2, 4, 4))
    >>> means, covars, probs = imm.step(means, covars, [[0.5, 0.5]], [[1.0, 0.0]], 1.0)
    >>> probs.shape
    (1, 2)
    """

    def __init__(self, transition_models, measurement_model, transition_matrix):
        models = list(transition_models)
        if not models:
            raise ValueError("transition_models must hold at least one model")
        for model in models:
            check_models(model, measurement_model)
        self.transition_models = models
        self.measurement_model = measurement_model
        self.transition_matrix = _imm.transition_matrix(transition_matrix, len(models))

    def step(self, means, covars, mode_probs, measurements, time_intervals):
        """One IMM step of every filter.

        Parameters
        ----------
        means : (K, M, d) array_like
            Each filter's model means.
        covars : (K, M, d, d) array_like
            Positive semi-definite.
        mode_probs : (K, M) array_like
            Each filter's mode probabilities (rows sum to one).
        measurements : (K, m) array_like
        time_intervals : float or (K,) array_like
            Seconds from each filter's state to its measurement.

        Returns
        -------
        means, covars, mode_probs : (K, M, d), (K, M, d, d), (K, M) ndarray
            Each model's posterior and the posterior mode probabilities.

        Raises
        ------
        ValueError
            For arrays of the wrong shape or values, or a step that is undefined (naming
            the filter and the model).
        """
        models, d = len(self.transition_models), self.measurement_model.ndim_state
        means = _validate.finite_array(means, "means", 3)
        k = means.shape[0]
        if means.shape[1:] != (models, d):
            raise ValueError(f"means must have shape (K, {models}, {d}), got {means.shape}")
        covars = _validate.finite_array(covars, "covars", 4)
        if covars.shape != (k, models, d, d):
            raise ValueError(f"covars must have shape ({k}, {models}, {d}, {d}), got "
                             f"{covars.shape}")
        mode_probs = _imm.mode_probabilities(mode_probs, k, models)
        m = self.measurement_model.ndim_meas
        measurements = _validate.finite_array(measurements, "measurements", 2)
        if measurements.shape != (k, m):
            raise ValueError(f"measurements must have shape ({k}, {m}), got "
                             f"{measurements.shape}")
        intervals = _validate.finite_array(time_intervals, "time_intervals")
        try:
            intervals = np.broadcast_to(intervals, (k,)).copy()
        except ValueError:
            raise ValueError(f"time_intervals (seconds) must broadcast to ({k},), got shape "
                             f"{intervals.shape}") from None
        if k == 0:
            return means.copy(), covars.copy(), mode_probs.copy()
        return _imm.step(self.transition_models, self.measurement_model,
                         self.transition_matrix, means, covars, mode_probs, measurements,
                         intervals)

    @staticmethod
    def combine(means, covars, mode_probs):
        """Each filter's combined estimate, the moment match of its models.

        Parameters
        ----------
        means : (K, M, d) array_like
        covars : (K, M, d, d) array_like
        mode_probs : (K, M) array_like

        Returns
        -------
        means, covars : (K, d), (K, d, d) ndarray
        """
        means = _validate.finite_array(means, "means", 3)
        covars = _validate.finite_array(covars, "covars", 4)
        if covars.shape != means.shape + means.shape[-1:]:
            raise ValueError(f"covars must have shape {means.shape + means.shape[-1:]}, got "
                             f"{covars.shape}")
        mode_probs = _imm.mode_probabilities(mode_probs, *means.shape[:2])
        return _imm.combine(means, covars, mode_probs)
