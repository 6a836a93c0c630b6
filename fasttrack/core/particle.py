"""The particle filter's steps: propagation, measurement, weighting, the resampling
decision and the gather of drawn particles."""
import numpy as np

from .. import _buffers
from .. import _errors
from .. import _jit
from .. import _validate
from .. import random as _random
from . import particle_numpy as _numpy
from .kinds import FUNCTION

_likelihood = _jit.lazy("likelihood")
_propagate = _jit.lazy("propagate")
_resample = _jit.lazy("resample")
_weights = _jit.lazy("weights")


def predict(model, particles, dt, rng):
    """``(d, N)`` particles moved ``dt`` seconds through the transition ``model``, with its
    process noise drawn from ``rng`` (a Generator or RandomState)."""
    return propagate(model.spec(dt), particles, _random.stream_key(rng))


def propagate(spec, x, key):
    """A new (d, N) array: the states ``x`` (d, N) through the transition ``spec`` (a
    :class:`~fasttrack.models.spec.TransitionSpec`) plus process noise from the stream
    ``key``. Raises ValueError naming the user's function if it returns a bad output."""
    if spec.kind != FUNCTION and _jit.numpy_first(_numpy.work(x)):
        return _numpy.propagate(spec, x, key)
    out = _buffers.empty_like(x)
    if spec.kind == FUNCTION:
        code = _propagate.propagate_function(spec.function.callee, spec.dt, x,
                                             spec.noise_root, key, out)
        _errors.check(code, spec.function, x, spec.dt)
    else:
        _propagate.propagate_linear(x, spec.matrix, spec.noise_root, key, out)
    return out


def measure(spec, x):
    """The noise-free measurements (m, N) of states ``x`` (d, N) by the measurement
    ``spec`` (a :class:`~fasttrack.models.spec.MeasurementSpec`)."""
    if spec.kind != FUNCTION and _jit.numpy_first(_numpy.work(x)):
        return _numpy.measure(spec, x)
    out = np.empty((spec.ndim_meas, x.shape[1]))
    if spec.kind == FUNCTION:
        code = _likelihood.measure_function(spec.function.callee, x, spec.angles, out)
        _errors.check(code, spec.function, x)
    else:
        _likelihood.measure(spec.kind, x, spec.mapping, spec.offset, spec.rotation, out)
    return out


def log_likelihood(spec, z, x, log_w, out):
    """``out = log_w + log p(z | x[:, i])`` for the measurement ``spec``, a validated (m,)
    ``z`` and (d, N) ``x``, with (N,) ``log_w`` and ``out``; returns ``max(out)``."""
    if spec.kind != FUNCTION and _jit.numpy_first(_numpy.work(x)):
        out[:], top = _numpy.log_likelihood(spec, z, x, log_w)
        return top
    whiten, log_norm = spec.noise.whitening()
    if spec.kind != FUNCTION:
        return _likelihood.log_likelihood(spec.kind, z, x, spec.mapping, spec.offset,
                                          spec.rotation, spec.angles, whiten, log_norm,
                                          log_w, out)
    top, code = _likelihood.log_likelihood_function(spec.function.callee, z, x,
                                                    spec.angles, whiten, log_norm, log_w,
                                                    out)
    _errors.check(code, spec.function, x)
    return top


def weigh(model, z, particles, log_weight):
    """``(log_w, ess)``: normalised log weights ``log_weight + log p(z | particle)``
    (logsumexp), a new (N,) array, and their effective sample size.

    Parameters
    ----------
    model : fasttrack MeasurementModel
    z : (m,) float64 ndarray
        The measurement (validated by ``model.measurement_vector``).
    particles : (d, N) float64 ndarray
    log_weight : (N,) float64 ndarray

    Raises
    ------
    ValueError
        If the likelihoods are NaN, every particle has zero likelihood, or a log weight is
        +inf.
    """
    log_w = _buffers.empty(particles.shape[1])
    top = model.log_likelihood(z, particles, log_weight, log_w)
    if np.isnan(top):
        for name, bad in (("particles are not finite", ~np.isfinite(particles).all(axis=0)),
                          ("log weights are NaN", np.isnan(log_weight))):
            if bad.any():
                raise ValueError(f"the prediction's {name} ({np.count_nonzero(bad)} "
                                 f"particles, the first at index {np.argmax(bad)})")
        raise ValueError(f"{type(model).__name__} gave NaN log-likelihoods for this "
                         f"measurement")
    if top == -np.inf:
        raise ValueError("every particle has zero likelihood for this measurement: "
                         "no weight survives")
    if top == np.inf:
        bad = np.isposinf(log_weight)
        raise ValueError(f"the prediction's log weights include +inf ({np.count_nonzero(bad)} "
                         f"particles, the first at index {np.argmax(bad)}): an infinite "
                         f"weight cannot be normalised")
    if _jit.numpy_first(_numpy.work(log_w)):
        log_w[:], ess = _numpy.normalise(log_w, top)
        return log_w, float(ess)
    return log_w, float(_weights.normalise_in_place(log_w, top))


def resampling_decision(log_weight, threshold=None):
    """``(ess, resample)``: Kish's effective sample size of unnormalised log weights, and
    whether it is below ``threshold`` (None: half the number of particles)."""
    log_w, log_w_max = _validate.log_weights(log_weight, "particles.log_weight")
    ess = float(_numpy.ess(log_w, log_w_max) if _jit.numpy_first(_numpy.work(log_w))
                else _weights.ess(log_w, log_w_max))
    return ess, ess < (log_w.size / 2 if threshold is None else threshold)


def gather(particles, index, out=None):
    """The columns ``particles[:, index]`` as a C-contiguous ``(d, n)`` array (a parallel
    gather), written into ``out`` if given, else a new array."""
    if out is None:
        out = np.empty((particles.shape[0], index.size))
    if _jit.numpy_first(_numpy.work(out)):
        np.take(particles, index, axis=1, out=out)
    else:
        _resample.take_columns(particles, index, out)
    return out


def mean(particles, log_weight):
    """The (d, 1) weighted mean of (d, N) ``particles`` with (N,) unnormalised
    ``log_weight``, in one pass. Raises ValueError if its sums overflow float64."""
    if _buffers.is_uniform(log_weight):  # a resampled state's: the plain mean
        with np.errstate(over="ignore", invalid="ignore"):
            out = particles.mean(axis=1)
    elif _jit.numpy_first(_numpy.work(particles)):
        with np.errstate(over="ignore", invalid="ignore"):
            out = _numpy.mean(particles, log_weight)[0]
    else:
        out = np.empty(particles.shape[0])
        _weights.weighted_mean(particles, log_weight, log_weight.max(), out)
    return _finite_moments(out.reshape(-1, 1))


def mean_covar(particles, log_weight):
    """``(mean, covar)``, (d, 1) and (d, d): the weighted mean and covariance
    ``sum w (x - mean)(x - mean)^T / sum w`` of (d, N) ``particles``, in two passes.
    Raises ValueError if their sums overflow float64."""
    if _jit.numpy_first(_numpy.work(particles)):
        with np.errstate(over="ignore", invalid="ignore"):
            return _finite_moments(*_numpy.mean_covar(particles, log_weight))
    d = particles.shape[0]
    mean_out, covar = np.empty(d), np.empty((d, d))
    _weights.weighted_mean_covar(particles, log_weight, log_weight.max(), mean_out, covar)
    return _finite_moments(mean_out.reshape(d, 1), covar)


def _finite_moments(*moments):
    """``moments`` (the first alone if it is the only one), or ValueError if one is not
    finite: finite particles whose weighted sums overflow float64."""
    if not all(np.isfinite(m).all() for m in moments):
        raise ValueError("the particles' weighted mean or covariance is beyond float64's "
                         "range (states or spreads near 1.8e308, or their squares)")
    return moments if len(moments) > 1 else moments[0]
