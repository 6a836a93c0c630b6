"""Many independent Kalman filters (extended or unscented) advanced together: one kernel
call, parallel over filters."""
import functools

import numpy as np

from . import _validate
from ._sigma import SigmaPointSettings
from ._validate import Setting
from .core import imm as _imm
from .core import kalman as _kalman
from .core import stack as _stack
from .core import unscented as _unscented
from .models.base import check_same_states
from .models.measurement import MeasurementModel, NonlinearGaussianMeasurement
from .models.transition import TransitionModel

__all__ = ["BatchExtendedKalmanFilter", "BatchUnscentedKalmanFilter"]


def check_models(transition_model, measurement_model, nonlinear=False):
    """A TypeError unless the models are a linear-Gaussian transition (or with
    ``nonlinear`` any TransitionModel, e.g. one built from a function) and a built-in
    measurement model (what the stack kernels know), a ValueError if their state
    dimensions differ."""
    check_transition_model(transition_model, nonlinear)
    check_measurement_model(measurement_model)
    check_same_states(transition_model, measurement_model)


def check_transition_model(transition_model, nonlinear=False):
    """A TypeError unless ``transition_model`` is a linear-Gaussian TransitionModel (with
    ``nonlinear``, any TransitionModel)."""
    if not isinstance(transition_model, TransitionModel) \
            or not (nonlinear or hasattr(transition_model, "matrix")):
        kind = "TransitionModel" if nonlinear else "linear-Gaussian TransitionModel"
        raise TypeError(f"transition_model must be a {kind}, "
                        f"got {type(transition_model).__name__}")


def check_model_set(transition_models, measurement_model):
    """``(models, has)``: the ``transition_models`` of a multiple-model filter as a list (at
    least one, each a TransitionModel that fits ``measurement_model``) and the components
    each carries (:func:`fasttrack.core.imm.components`), else an error naming the
    argument."""
    models = _validate.instances(transition_models, TransitionModel, "transition_models")
    if not models:
        raise ValueError("transition_models must hold at least one model")
    check_measurement_model(measurement_model)
    has = _imm.components(models, measurement_model.ndim_state)
    for model in models:
        check_models(model, measurement_model, nonlinear=True)
    return models, has


def check_measurement_model(measurement_model):
    """A TypeError unless ``measurement_model`` is a built-in MeasurementModel."""
    if not isinstance(measurement_model, MeasurementModel) \
            or isinstance(measurement_model, NonlinearGaussianMeasurement):
        raise TypeError(f"measurement_model must be a built-in MeasurementModel, "
                        f"got {type(measurement_model).__name__}")


class ModelSettings:
    """``transition_model`` and ``measurement_model`` as settings of their owner: each
    assignment, the constructor's and any later one, is checked as :func:`check_models`
    checks the pair (against the other model once it is set), so that the kernels never
    meet models of another kind or dimension than they were checked for. Assign the
    transition model first."""

    #: Whether the transition model may be one built from a function.
    _nonlinear_transitions = False

    transition_model = Setting("_checked_transition")
    measurement_model = Setting("_checked_measurement")

    def _checked_transition(self, model, name):
        check_transition_model(model, self._nonlinear_transitions)
        measurement = self.__dict__.get("measurement_model")
        if measurement is not None:
            check_models(model, measurement, self._nonlinear_transitions)
        return model

    def _checked_measurement(self, model, name):
        check_measurement_model(model)
        transition = self.__dict__.get("transition_model")
        if transition is not None:
            check_models(transition, model, self._nonlinear_transitions)
        return model


class ModelSetSettings:
    """``transition_models`` (a multiple-model filter's), ``measurement_model`` and the
    switching ``transition_matrix`` as settings, checked as :func:`check_model_set` and
    :func:`fasttrack.core.imm.transition_matrix` check them on every assignment; the number
    of models is kept (the switching matrix's). Assign the measurement model first."""

    transition_models = Setting("_checked_model_set")
    measurement_model = Setting("_checked_measurement")
    transition_matrix = Setting("_checked_switching")

    def _checked_model_set(self, value, name):
        models, self._has = check_model_set(value, self.measurement_model)
        before = self.__dict__.get("transition_models")
        if before is not None and len(models) != len(before):
            raise ValueError(f"transition_models must keep {len(before)} models (the "
                             f"switching matrix's), got {len(models)}")
        return models

    def _checked_switching(self, value, name):
        return _imm.transition_matrix(value, len(self.transition_models))

    def _checked_measurement(self, model, name):
        models = self.__dict__.get("transition_models")
        if models is not None:
            check_model_set(models, model)
        else:
            check_measurement_model(model)
        return model


class _BatchFilter(ModelSettings):
    """K independent Gaussian filters sharing a transition and a measurement model, each
    with its own state, covariance, measurements and time intervals: the validation of
    :class:`BatchExtendedKalmanFilter` and :class:`BatchUnscentedKalmanFilter`, which
    call their array-layer stack functions in ``_predict``, ``_update`` and ``_step``."""

    def __init__(self, transition_model, measurement_model):
        self.transition_model = transition_model
        self.measurement_model = measurement_model

    def _arrays(self, means, covars, measurements, leading):
        """Validated float64 arrays: means (*leading, K, d) etc."""
        d, m = self.transition_model.ndim_state, self.measurement_model.ndim_meas
        means = _validate.finite_array(means, "means", 2)
        k = means.shape[0]
        if means.shape[1] != d:
            raise ValueError(f"means must have shape (K, {d}), got {means.shape}")
        covars = _validate.finite_array(covars, "covars", 3)
        if covars.shape != (k, d, d):
            raise ValueError(f"covars must have shape ({k}, {d}, {d}), got {covars.shape}")
        if measurements is None:
            return means, covars, None
        measurements = _validate.finite_array(measurements, "measurements", len(leading) + 2)
        if measurements.shape != (*leading, k, m):
            raise ValueError(f"measurements must have shape {(*leading, k, m)}, "
                             f"got {measurements.shape}")
        self.measurement_model.check_angle_columns(measurements, "measurements")
        return means, covars, measurements

    def predict(self, means, covars, time_intervals):
        """Predict every filter and its measurement, for gating and association.

        Parameters
        ----------
        means : (K, d) array_like
        covars : (K, d, d) array_like
            Positive semi-definite.
        time_intervals : float or (K,) array_like
            Seconds from each filter's state to the prediction.

        Returns
        -------
        means, covars : (K, d), (K, d, d) ndarray
            The predicted states.
        z_hats : (K, m) ndarray
            The predicted measurements.
        innovation_covars : (K, m, m) ndarray
            Their covariances plus the measurement noise R: ``H P H^T + R`` with H the
            measurement Jacobian at the predicted mean (extended), or from the sigma
            points of the prediction (unscented).

        Raises
        ------
        ValueError
            If a filter's prediction is undefined (naming the first such filter and why).
        """
        means, covars, _ = self._arrays(means, covars, None, ())
        intervals = _validate.intervals(time_intervals, (means.shape[0],))
        return self._predict(intervals, means, covars)

    def update(self, means, covars, measurements):
        """Update every (predicted) filter with its measurement.

        Parameters
        ----------
        means : (K, d) array_like
        covars : (K, d, d) array_like
            Positive semi-definite.
        measurements : (K, m) array_like

        Returns
        -------
        means, covars : (K, d), (K, d, d) ndarray
            The posteriors.

        Raises
        ------
        ValueError
            If a filter's update is undefined (naming the first such filter and why).
        """
        if measurements is None:
            raise TypeError("measurements must be a (K, m) array, got None")
        means, covars, measurements = self._arrays(means, covars, measurements, ())
        return self._update(means, covars, measurements)

    def step(self, means, covars, measurements, time_intervals):
        """One predict + update of every filter.

        Parameters
        ----------
        means : (K, d) array_like
        covars : (K, d, d) array_like
            Positive definite.
        measurements : (K, m) array_like
        time_intervals : float or (K,) array_like
            Seconds from each filter's state to its measurement.

        Returns
        -------
        means : (K, d) ndarray
        covars : (K, d, d) ndarray
            Empty for K = 0.

        Raises
        ------
        ValueError
            If any filter's step is undefined (naming the first such filter and why).
        """
        means, covars, measurements = self._arrays(means, covars, measurements, ())
        k, d = means.shape
        intervals = _validate.intervals(time_intervals, (k,))
        means_out, covars_out = np.empty_like(means), np.empty_like(covars)
        if k == 0:
            return means_out, covars_out
        status = np.empty(k, dtype=np.int64)
        self._step(_stack.transition(self.transition_model, intervals), intervals, means,
                   covars, measurements, means_out, covars_out, status)
        _stack.check(status)
        return means_out, covars_out

    def run(self, means, covars, measurements, time_intervals):
        """Filter every filter over T measurements.

        Parameters
        ----------
        means : (K, d) array_like
            The prior means.
        covars : (K, d, d) array_like
            The prior covariances, positive definite.
        measurements : (T, K, m) array_like
        time_intervals : float, (T,) or (T, K) array_like
            Seconds before each measurement.

        Returns
        -------
        means : (T, K, d) ndarray
        covars : (T, K, d, d) ndarray
            The posterior after each measurement (empty for T = 0 or K = 0).
        """
        measurements = _validate.float_array(measurements, "measurements", 3)
        steps = measurements.shape[0]
        means, covars, measurements = self._arrays(means, covars, measurements, (steps,))
        intervals = _validate.float_array(time_intervals, "time_intervals")
        if intervals.ndim == 1:
            intervals = intervals[:, None]
        intervals = _validate.intervals(intervals, (steps, means.shape[0]))
        transition = (_stack.transition(self.transition_model, intervals)
                      if steps and means.shape[0] else None)
        return _stack.run(self._step, transition, intervals, means, covars, measurements)


class BatchExtendedKalmanFilter(_BatchFilter):
    """K independent (extended) Kalman filters sharing a transition and a measurement model,
    each with its own state, covariance, measurements and time intervals.

    Exact Kalman filtering for linear models. Built-in models only: a linear-Gaussian
    transition (constant-velocity blocks may take a different interval per filter), and a
    built-in measurement model.

    Parameters
    ----------
    transition_model : linear-Gaussian TransitionModel
    measurement_model : built-in MeasurementModel
    use_joseph_cov : bool
        Joseph-form covariance update (the default; see
        :class:`~fasttrack.KalmanUpdater`).
    jacobian : {'analytic', 'forward', 'central'}
        As :class:`~fasttrack.ExtendedKalmanUpdater`.
    """

    #: The Jacobian's method (checked when assigned, here or later).
    jacobian = Setting(_kalman.check_jacobian)

    def __init__(self, transition_model, measurement_model, use_joseph_cov=True,
                 jacobian="analytic"):
        super().__init__(transition_model, measurement_model)
        self.use_joseph_cov = _validate.flag(use_joseph_cov, "use_joseph_cov")
        self.jacobian = jacobian

    def _predict(self, intervals, means, covars):
        return _kalman.stack_predict(self.transition_model, self.measurement_model, intervals,
                                     means, covars, self.jacobian)

    def _update(self, means, covars, measurements):
        return _kalman.stack_update(self.measurement_model, means, covars, measurements,
                                    self.jacobian, self.use_joseph_cov)

    @property
    def _step(self):
        return functools.partial(_kalman.stack_step, model=self.measurement_model,
                                 jacobian=self.jacobian, joseph=self.use_joseph_cov)


class BatchUnscentedKalmanFilter(SigmaPointSettings, _BatchFilter):
    """K independent unscented Kalman filters sharing a transition and a measurement
    model, each with its own state, covariance, measurements and time intervals; each
    filter's step is that of :class:`~fasttrack.UnscentedKalmanPredictor` and
    :class:`~fasttrack.UnscentedKalmanUpdater`.

    Built-in models only: a linear-Gaussian transition (constant-velocity blocks may take a
    different interval per filter), and a built-in measurement model.

    Parameters
    ----------
    transition_model : linear-Gaussian TransitionModel
    measurement_model : built-in MeasurementModel
    alpha : float
        Primary spread of the sigma points, > 0.
    beta : float
        Prior knowledge of the distribution (2 is optimal for a Gaussian).
    kappa : float, optional
        Secondary spread; None means ``3 - ndim_state``.
    use_joseph_cov : bool
        As :class:`~fasttrack.UnscentedKalmanUpdater` (default True, the Joseph form).
    """

    def __init__(self, transition_model, measurement_model, alpha=0.5, beta=2.0, kappa=None,
                 use_joseph_cov=True):
        super().__init__(transition_model, measurement_model)
        self.alpha, self.beta, self.kappa = alpha, beta, kappa
        self._resolved_kappa(transition_model.ndim_state)  # (the spread checked now)
        self.use_joseph_cov = _validate.flag(use_joseph_cov, "use_joseph_cov")

    @property
    def _parameters(self):
        return (self.alpha, self.beta, self._resolved_kappa(self.transition_model.ndim_state),
                self.use_joseph_cov)

    def _predict(self, intervals, means, covars):
        return _unscented.stack_predict(self.transition_model, self.measurement_model,
                                        intervals, means, covars, self._parameters)

    def _update(self, means, covars, measurements):
        return _unscented.stack_update(self.measurement_model, means, covars, measurements,
                                       self._parameters)

    @property
    def _step(self):
        return functools.partial(_unscented.stack_step, model=self.measurement_model,
                                 parameters=self._parameters)
