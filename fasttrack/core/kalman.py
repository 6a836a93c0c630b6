"""Kalman and extended Kalman steps of one Gaussian state."""
import numpy as np

from .. import _errors
from .. import _jit
from . import kalman_numpy as _numpy
from . import stack as _stack
from .._jit.status import INNOVATION_NOT_PD, PREDICTION_NOT_PSD, PREDICTION_NOT_SYMMETRIC
from .kinds import ANALYTIC, CENTRAL, FORWARD, FUNCTION, SELECT

_jacobian = _jit.lazy("jacobian")
_kalman = _jit.lazy("kalman")

#: Jacobian methods by name: the built-in sensors' analytic Jacobian, or finite differences
#: (forward: Stone Soup's rule).
JACOBIANS = {"analytic": ANALYTIC, "forward": FORWARD, "central": CENTRAL}


def check_jacobian(method, name="jacobian", allowed=tuple(JACOBIANS)):
    """``method`` if it is one of ``allowed``, else a ValueError naming ``name`` and listing
    them."""
    if not isinstance(method, str) or method not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}, got "
                         f"{method!r}")
    return method


def in_numpy(kind):
    """Whether a one-filter step (Kalman, extended or unscented) on a model of ``kind``
    runs in NumPy (:mod:`kalman_numpy`): on built-in models, a process's first steps do
    (see :func:`fasttrack._jit.numpy_first`)."""
    return kind != FUNCTION and _jit.numpy_first()


def predict(model, dt, x, covar, jacobian="forward"):
    """``(x, P)`` predicted ``dt`` seconds ahead: ``F x``, ``F P F^T + Q`` for a linear
    ``model``; for a model built from a function, ``f(x)`` and the finite-difference
    Jacobian (``jacobian`` 'forward' or 'central') in place of F.

    ``x`` is (d, 1), ``covar`` (d, d); returns new arrays of those shapes. Raises ValueError
    if ``covar`` is not symmetric positive semi-definite, or the user's function returns a
    wrong shape or non-finite values.
    """
    spec = model.spec(dt)
    if in_numpy(spec.kind):
        status, x_out, covar_out = _numpy.predict(spec, x, covar)
    else:
        d = x.shape[0]
        x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
        if spec.kind == FUNCTION:
            status = _kalman.predict_function(spec.function.callee, dt, spec.noise,
                                              jacobian == "central", x, covar, x_out,
                                              covar_out)
        else:
            status = _kalman.predict_one(*spec.kalman(), dt, x, covar, x_out, covar_out)
    if status:
        if not np.isfinite(x).all():  # (a caller's unchecked state: not an overflow)
            raise ValueError("prior.state_vector is not finite (it holds NaN or inf)")
        _errors.check(status, spec.function, x, dt)
    return x_out, covar_out


def transition_jacobian(model, dt, x, jacobian="forward"):
    """The finite-difference Jacobian (d, d) at ``x`` (d, 1) of a function-built
    transition ``model`` over ``dt`` seconds (``jacobian`` 'forward' or 'central'). Raises
    ValueError naming the user's function if it returns a bad output."""
    spec = model.spec(dt)
    d = x.shape[0]
    out = np.empty((d, d))
    status = _jacobian.transition_jacobian_function(
        spec.function.callee, dt, np.ascontiguousarray(x[:, 0]), jacobian == "central", out)
    if status:
        _errors.check(status, spec.function, x, dt)
    return out


def update(model, x, covar, z, jacobian="analytic", joseph=True, strict=True):
    """``(x, P, z_hat, S, cross)`` of one update with measurement ``z`` (m, 1): the
    posterior (d, 1) and (d, d), the predicted measurement (m, 1), its innovation covariance
    (m, m) and the cross covariance ``P H^T`` (d, m).

    ``jacobian`` names the linearisation of a nonlinear ``model`` (see :data:`JACOBIANS`;
    function-built models use finite differences, 'analytic' meaning 'forward'); ``joseph``
    selects the Joseph-form covariance. Raises ValueError when the step is undefined (see
    :mod:`fasttrack._errors`); unless ``strict``, as Stone Soup, not for a standard-form
    posterior that is not positive semi-definite or Stone Soup's forward differences at a
    polar sensor (for the drop-ins, and where only the measurement prediction is kept).
    """
    spec = model.spec
    if strict and jacobian == "forward" and spec.kind not in (SELECT, FUNCTION) \
            and _numpy.at_sensor(spec, x):
        _errors.check(_errors.JACOBIAN_UNDEFINED)
    if in_numpy(spec.kind):
        status, *out = _numpy.update(spec, JACOBIANS[jacobian], joseph, x, covar, z)
        _check_update(status, strict, spec, x)
        return tuple(out)
    m, d = spec.ndim_meas, spec.ndim_state
    x_out, covar_out = np.empty((d, 1)), np.empty((d, d))
    z_hat, s, cross = np.empty((m, 1)), np.empty((m, m)), np.empty((d, m))
    arguments = (x, covar, z, x_out, covar_out, z_hat, s, cross)
    if spec.kind == FUNCTION:
        status = _kalman.update_function(spec.function.callee, spec.noise_covar,
                                         spec.angles, jacobian == "central", joseph,
                                         *arguments)
    else:
        status = _kalman.update_one(*spec.sensor, JACOBIANS[jacobian], joseph, *arguments)
    _check_update(status, strict, spec, x)
    return x_out, covar_out, z_hat, s, cross


def _check_update(status, strict, spec, x):
    """Raise the error of an update's ``status``; unless ``strict``, not for the codes
    whose outputs are still Stone Soup's (``_errors.LENIENT``)."""
    if status and (strict or status not in _errors.LENIENT):
        _errors.check(status, spec.function, x)


# -- stacks of K filters: (K, d) means, (K, d, d) covariances ----------------------------


def stack_predict(transition_model, model, intervals, means, covars, jacobian="analytic",
                  by_interval=False):
    """``(means, covars, z_hats, S)``: K filters predicted ``intervals`` (K,) seconds ahead
    through ``transition_model``, and their measurements by ``model``: (K, d), (K, d, d),
    (K, m) and the innovation covariances ``H P H^T + R`` (K, m, m), H the measurement
    Jacobian (``jacobian``) at each predicted mean. A transition built from a function is
    linearised at each filter's mean by finite differences (central for ``jacobian``
    'central', else forward, as :func:`predict`).

    A transition whose F depends on the interval outside constant-velocity blocks needs
    one interval for all filters: ``by_interval`` predicts each group of equal intervals in
    turn, else it is a ValueError. Raises ValueError naming the first filter whose
    prediction is undefined, or the user's function for a bad output."""
    if by_interval and means.shape[0] and not _stack.one_transition(transition_model,
                                                                     intervals):
        out = None
        for interval in np.unique(intervals):
            rows = np.flatnonzero(intervals == interval)
            part = stack_predict(transition_model, model, intervals[rows], means[rows],
                                 covars[rows], jacobian)
            out = out or [np.empty((means.shape[0],) + a.shape[1:]) for a in part]
            for whole, values in zip(out, part):
                whole[rows] = values
        return tuple(out)
    k, d = means.shape
    sensor = model.spec
    spec = transition_model.spec(float(intervals[0])) if k else None
    if spec is not None and spec.kind == FUNCTION:
        if not np.all(intervals == intervals[0]):
            raise ValueError(f"{type(transition_model).__name__} is a function of the "
                             f"interval, so its filters need one common time interval")
        means, covars = _function_predict(spec, means, covars, jacobian)
        spec = None  # the measurement of the predictions remains
    elif k and sensor.kind != FUNCTION and _jit.numpy_first(k):
        _stack.transition(transition_model, intervals)  # refuses what the kernels refuse
        status, *out = _numpy.stack_predict(transition_model, sensor, JACOBIANS[jacobian],
                                            intervals, means, covars)
        _stack.check(status, means, covars)
        return tuple(out)
    out = (np.empty((k, d)), np.empty((k, d, d)), np.empty((k, sensor.ndim_meas)),
           np.empty((k, sensor.ndim_meas, sensor.ndim_meas)))
    status = np.zeros(k, dtype=np.int64)
    if k == 0:
        return out
    if spec is not None and sensor.kind == SELECT and np.all(intervals == intervals[0]):
        fixed = (spec.matrix, spec.noise, sensor.mapping, sensor.noise_covar)

        def run(lo, hi):
            _kalman.linear_predict(*fixed, means[lo:hi], covars[lo:hi],
                                   *[a[lo:hi] for a in out], status[lo:hi])

    else:
        transition = (_stack.transition(transition_model, intervals) if spec is not None
                      else _stack.identity(d))
        measurement = (*sensor.sensor[:5], JACOBIANS[jacobian])

        def run(lo, hi):
            _kalman.batch_predict(*transition, intervals[lo:hi], *measurement, means[lo:hi],
                                  covars[lo:hi], *[a[lo:hi] for a in out], status[lo:hi])

    _stack.in_chunks(k, run)
    _stack.check(status, means, covars)
    return out


def _function_predict(spec, means, covars, jacobian):
    """``(means, covars)``: K filters (K, d), (K, d, d) through the user transition of a
    FUNCTION ``spec``, linearised by finite differences (central for ``jacobian``
    'central', else forward). Raises ValueError naming the first failed filter, or the
    user's function for a bad output."""
    out = np.empty_like(means), np.empty_like(covars)
    status = np.zeros(means.shape[0], dtype=np.int64)
    fixed = (spec.function.callee, spec.dt, spec.noise, jacobian == "central")
    _stack.in_chunks(means.shape[0], lambda lo, hi: _kalman.stack_predict_function(
        *fixed, means[lo:hi], covars[lo:hi], *[a[lo:hi] for a in out], status[lo:hi]))
    _check_function(status, spec, means)
    return out


def linearise(transition_model, dt, points, jacobian="forward", name="points[{}]".format):
    """``(F, f)``: a transition built from a function linearised at each of the (n, d)
    ``points`` for ``dt`` seconds: its finite-difference Jacobians (n, d, d) (central for
    ``jacobian`` 'central', else forward) and values ``f(x)`` (n, d). Raises ValueError
    naming the first failed point (``name(i)``) and the user's function for a bad
    output."""
    spec = transition_model.spec(dt)
    n, d = points.shape
    out = np.empty((n, d, d)), np.empty((n, d))
    status = np.zeros(n, dtype=np.int64)
    fixed = (spec.function.callee, spec.dt, jacobian == "central")
    _stack.in_chunks(n, lambda lo, hi: _kalman.stack_linearise_function(
        *fixed, points[lo:hi], *[a[lo:hi] for a in out], status[lo:hi]))
    if status.any():
        bad = np.flatnonzero(status)[0]
        raise ValueError(f"at {name(bad)}: {_failure(spec, status[bad], points[bad])}")
    return out


def _check_function(status, spec, states):
    """Raise the ValueError of the first failed filter of ``status`` (K,), naming the user
    function of the FUNCTION ``spec`` for a bad output at its state (a row of ``states``
    (K, d))."""
    bad = np.flatnonzero(np.isin(status, _errors.FUNCTION_CODES)) if status.any() else ()
    if len(bad):
        raise ValueError(f"{np.count_nonzero(status)} of {status.size} filters failed; "
                         f"filter {bad[0]}: {_failure(spec, status[bad[0]], states[bad[0]])}")
    _stack.check(status)


def _failure(spec, code, state):
    """What a kernel's status ``code`` says of the user function of the FUNCTION ``spec``
    at ``state`` (d,): the message of its ValueError."""
    try:
        _errors.check(code, spec.function, state[:, None], spec.dt)
    except ValueError as error:
        return str(error)


def stack_update(model, means, covars, measurements, jacobian="analytic", joseph=True):
    """``(means, covars)``: K predicted filters updated with their ``measurements`` (K, m)
    by ``model``. Raises ValueError naming the first filter whose update is undefined."""
    k, d = means.shape
    means_out, covars_out = np.empty_like(means), np.empty_like(covars)
    status = np.zeros(k, dtype=np.int64)
    if k == 0:
        return means_out, covars_out
    sensor = model.spec
    if sensor.kind == SELECT:
        def run(lo, hi):
            _kalman.linear_update(sensor.mapping, sensor.noise_covar, sensor.angles, joseph,
                                  means[lo:hi], covars[lo:hi], measurements[lo:hi],
                                  means_out[lo:hi], covars_out[lo:hi], status[lo:hi])

        _stack.in_chunks(k, run)
        for i in np.flatnonzero(status == INNOVATION_NOT_PD):  # (the kernel checks S only)
            status[i] = _numpy.covariance_status(covars[i], PREDICTION_NOT_SYMMETRIC,
                                                 PREDICTION_NOT_PSD) or status[i]
    else:
        stack_step(_stack.identity(d), np.zeros(k), means, covars, measurements, means_out,
                   covars_out, status, model=model, jacobian=jacobian, joseph=joseph)
        status = np.array([_stack.AS_PREDICTION.get(code, code) for code in status], np.int64)
    _stack.check(status)
    return means_out, covars_out


def stack_step(transition, intervals, means, covars, measurements, means_out, covars_out,
               status, *, model, jacobian="analytic", joseph=True):
    """One predict + update of K filters through the kernel ``transition`` (see
    :func:`fasttrack.core.stack.transition`) over ``intervals`` (K,) seconds, with their
    ``measurements`` (K, m) by ``model``: writes ``means_out``, ``covars_out`` and each
    filter's ``status``."""
    sensor = (*model.spec.sensor, JACOBIANS[jacobian], joseph)

    def run(lo, hi):
        _kalman.batch_step(*transition, intervals[lo:hi], *sensor, means[lo:hi], covars[lo:hi],
                           measurements[lo:hi], means_out[lo:hi], covars_out[lo:hi],
                           status[lo:hi])

    _stack.in_chunks(means.shape[0], run)
