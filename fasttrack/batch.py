"""Many independent Kalman filters (extended or unscented) advanced together: one kernel
call, parallel over filters."""
import numpy as np

from . import _errors
from . import _validate
from . import threads as _threads
from ._jit import kalman as _kalman
from ._jit import sensor as _sensor
from ._jit import status as _status
from ._jit import unscented as _unscented
from .models.measurement import NonlinearGaussianMeasurement, MeasurementModel
from .models.transition import LinearGaussianTransitionModel, TransitionModel
from .core import kalman as _kalman_core
from .core import unscented as _unscented_core

__all__ = ["BatchExtendedKalmanFilter", "BatchUnscentedKalmanFilter"]


#: Update: the "prior" of the identity step is the caller's prediction.
_AS_PREDICTION = {_status.PRIOR_NOT_PSD: _status.PREDICTION_NOT_PSD,
                  _status.PRIOR_NOT_SYMMETRIC: _status.PREDICTION_NOT_SYMMETRIC}


def _identity(d):
    """The kernel transition F = I, Q = 0: a step through it (exact) is the update alone."""
    return _kalman.FIXED, np.empty(0), np.eye(d), np.zeros((d, d))


class _BatchFilter:
    """K independent Gaussian filters sharing a transition and a measurement model, each
    with its own state, covariance, measurements and time intervals: the validation, the
    threads and the loop over time of :class:`BatchExtendedKalmanFilter` and
    :class:`BatchUnscentedKalmanFilter`, which provide the kernels: ``_step``, and
    ``_predict``/``_update`` returning the filters' statuses."""

    def __init__(self, transition_model, measurement_model):
        if not isinstance(transition_model, TransitionModel) \
                or not hasattr(transition_model, "matrix"):
            raise TypeError(f"transition_model must be a linear-Gaussian TransitionModel, "
                            f"got {type(transition_model).__name__}")
        if not isinstance(measurement_model, MeasurementModel) \
                or isinstance(measurement_model, NonlinearGaussianMeasurement):
            raise TypeError(f"measurement_model must be a built-in MeasurementModel, "
                            f"got {type(measurement_model).__name__}")
        if measurement_model.ndim_state != transition_model.ndim_state:
            raise ValueError(f"the models disagree on the state dimension: "
                             f"{transition_model.ndim_state} and {measurement_model.ndim_state}")
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
        return means, covars, measurements

    def _spec(self, intervals):
        """The kernel transition for these intervals (seconds)."""
        model = self.transition_model
        first = float(intervals.flat[0])
        kind, rates, matrix, covar = model._kalman_spec(first)
        if kind == _kalman.FIXED and not isinstance(model, LinearGaussianTransitionModel) \
                and np.any(intervals != first):
            raise ValueError(f"{type(model).__name__} mixes constant-velocity and other "
                             f"parts, so its filters need one common time interval")
        return kind, rates, matrix, covar

    def _intervals(self, time_intervals, shape):
        intervals = _validate.finite_array(time_intervals, "time_intervals")
        try:
            return np.broadcast_to(intervals, shape).copy()
        except ValueError:
            raise ValueError(f"time_intervals (seconds) must broadcast to {shape}, "
                             f"got shape {intervals.shape}") from None

    @staticmethod
    def _in_chunks(k, run):
        """``run(lo, hi)`` on chunks of the K filters, in parallel threads."""
        _threads.in_chunks(run, k, serial_below=1024, align=_kalman.FILTERS_PER_BLOCK)

    @staticmethod
    def _raise(status):
        failed = np.flatnonzero(status)
        if failed.size:
            raise ValueError(f"{failed.size} of {status.size} filters failed; filter "
                             f"{failed[0]}: {_errors.MESSAGES[status[failed[0]]]}")

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
        k, d = means.shape
        m = self.measurement_model.ndim_meas
        intervals = self._intervals(time_intervals, (k,))
        out = np.empty((k, d)), np.empty((k, d, d)), np.empty((k, m)), np.empty((k, m, m))
        status = np.zeros(k, dtype=np.int64)
        if k:
            self._raise(self._predict(intervals, means, covars, out, status))
        return out

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
        means, covars, measurements = self._arrays(means, covars, measurements, ())
        means_out, covars_out = np.empty_like(means), np.empty_like(covars)
        status = np.zeros(means.shape[0], dtype=np.int64)
        if means.shape[0]:
            self._raise(self._update(means, covars, measurements, means_out, covars_out,
                                     status))
        return means_out, covars_out

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
        intervals = self._intervals(time_intervals, (k,))
        means_out, covars_out = np.empty_like(means), np.empty_like(covars)
        if k == 0:
            return means_out, covars_out
        status = np.empty(k, dtype=np.int64)
        self._step(self._spec(intervals), intervals, means, covars, measurements, means_out,
                   covars_out, status)
        self._raise(status)
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
        k, d = means.shape
        intervals = _validate.float_array(time_intervals, "time_intervals")
        if intervals.ndim == 1:
            intervals = intervals[:, None]
        intervals = self._intervals(intervals, (steps, k))
        means_out = np.empty((steps, k, d))
        covars_out = np.empty((steps, k, d, d))
        if steps == 0 or k == 0:
            return means_out, covars_out
        spec = self._spec(intervals)
        status = np.empty(k, dtype=np.int64)
        failed_at = np.full(k, steps)
        codes = np.zeros(k, dtype=np.int64)
        for t in range(steps):  # one compiled step kernel, a call per step
            self._step(spec, intervals[t], means, covars, measurements[t], means_out[t],
                       covars_out[t], status)
            new = (status != 0) & (failed_at == steps)
            failed_at[new], codes[new] = t, status[new]
            means, covars = means_out[t], covars_out[t]
        failed = np.flatnonzero(codes)
        if failed.size:
            first = failed[0]
            raise ValueError(f"{failed.size} of {k} filters failed; filter {first} at step "
                             f"{failed_at[first]}: {_errors.MESSAGES[codes[first]]}")
        return means_out, covars_out


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

    def __init__(self, transition_model, measurement_model, use_joseph_cov=True,
                 jacobian="analytic"):
        super().__init__(transition_model, measurement_model)
        self.use_joseph_cov = bool(use_joseph_cov)
        self._method = _kalman_core.JACOBIANS[_kalman_core.check_jacobian(jacobian)]

    def _measurement_spec(self):
        model = self.measurement_model
        return (model.kind, model._mapping, model._offset, model._rotation, model._noise_covar,
                model._angles, self._method, self.use_joseph_cov)

    def _step(self, spec, intervals, means, covars, measurements, means_out, covars_out,
              status):
        """One step of every filter."""
        measurement_spec = self._measurement_spec()

        def run(lo, hi):
            _kalman.batch_step(*spec, intervals[lo:hi], *measurement_spec, means[lo:hi],
                               covars[lo:hi], measurements[lo:hi], means_out[lo:hi],
                               covars_out[lo:hi], status[lo:hi])

        self._in_chunks(means.shape[0], run)

    def _predict(self, intervals, means, covars, out, status):
        k = means.shape[0]
        model = self.measurement_model
        if self._selects and np.all(intervals == intervals[0]):
            dt = float(intervals[0])
            fixed = (self.transition_model.matrix(time_interval=dt),
                     self.transition_model.covar(time_interval=dt), model._mapping,
                     model._noise_covar)

            def run(lo, hi):
                _kalman.linear_predict(*fixed, means[lo:hi], covars[lo:hi],
                                       *[a[lo:hi] for a in out], status[lo:hi])

        else:
            spec = self._spec(intervals)
            measurement_spec = (model.kind, model._mapping, model._offset, model._rotation,
                                model._noise_covar, self._method)

            def run(lo, hi):
                _kalman.batch_predict(*spec, intervals[lo:hi], *measurement_spec,
                                      means[lo:hi], covars[lo:hi],
                                      *[a[lo:hi] for a in out], status[lo:hi])

        self._in_chunks(k, run)
        return status

    def _update(self, means, covars, measurements, means_out, covars_out, status):
        k, d = means.shape
        if self._selects:
            model = self.measurement_model

            def run(lo, hi):
                _kalman.linear_update(model._mapping, model._noise_covar, model._angles,
                                      self.use_joseph_cov, means[lo:hi], covars[lo:hi],
                                      measurements[lo:hi], means_out[lo:hi],
                                      covars_out[lo:hi], status[lo:hi])

            self._in_chunks(k, run)
            return status
        self._step(_identity(d), np.zeros(k), means, covars, measurements, means_out,
                   covars_out, status)
        return np.array([_AS_PREDICTION.get(code, code) for code in status], np.int64)

    @property
    def _selects(self):
        """Whether the sensor measures state components (H selects rows): the lean kernels
        of the linear case apply."""
        return self.measurement_model.kind == _sensor.SELECT


class BatchUnscentedKalmanFilter(_BatchFilter):
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
        As :class:`~fasttrack.UnscentedKalmanUpdater` (default False, the standard form).
    """

    def __init__(self, transition_model, measurement_model, alpha=0.5, beta=2.0, kappa=None,
                 use_joseph_cov=False):
        super().__init__(transition_model, measurement_model)
        self.alpha, self.beta, self.kappa = _unscented_core.check_parameters(alpha, beta, kappa)
        self._kappa = _unscented_core.scaling(self.alpha, self.kappa,
                                              transition_model.ndim_state)
        self.use_joseph_cov = bool(use_joseph_cov)

    def _kernel(self, stages, spec, intervals, means, covars, measurements, outputs, status):
        """:func:`fasttrack._jit.unscented.batch_unscented` over the K filters in chunks;
        ``outputs`` are means, covars, z_hats, innovation_covars ((K, 0) arrays where a
        stage does not write them)."""
        settings = (*self.measurement_model._kalman_args, self.alpha, self.beta, self._kappa,
                    self.use_joseph_cov, stages)

        def run(lo, hi):
            _unscented.batch_unscented(*spec, intervals[lo:hi], *settings, means[lo:hi],
                                       covars[lo:hi], measurements[lo:hi],
                                       *[a[lo:hi] for a in outputs], status[lo:hi])

        self._in_chunks(means.shape[0], run)

    def _step(self, spec, intervals, means, covars, measurements, means_out, covars_out,
              status):
        k = means.shape[0]
        self._kernel(_unscented.PREDICT | _unscented.UPDATE, spec, intervals, means, covars,
                     measurements, (means_out, covars_out, np.empty((k, 0)),
                                    np.empty((k, 0, 0))), status)

    def _predict(self, intervals, means, covars, out, status):
        self._kernel(_unscented.PREDICT | _unscented.MEASURE, self._spec(intervals),
                     intervals, means, covars, np.empty((means.shape[0], 0)), out, status)
        return status

    def _update(self, means, covars, measurements, means_out, covars_out, status):
        k, d = means.shape
        self._kernel(_unscented.UPDATE, _identity(d), np.zeros(k), means, covars, measurements,
                     (means_out, covars_out, np.empty((k, 0)), np.empty((k, 0, 0))), status)
        return status
