"""The particle filter's steps: propagation, weighting, the resampling decision and the
gather of drawn particles."""
import numpy as np

from .. import _buffers
from .. import _validate
from .. import random as _random
from .._jit import resample as _resample
from .._jit import weights as _weights


def predict(model, particles, dt, rng):
    """``(d, N)`` particles moved ``dt`` seconds through the transition ``model``, with its
    process noise drawn from ``rng`` (a Generator or RandomState)."""
    return model._propagate(particles, dt, _random.stream_key(rng))


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
        If the likelihoods are NaN, or every particle has zero likelihood.
    """
    log_w = _buffers.empty(particles.shape[1])
    top = model.log_likelihood(z, particles, log_weight, log_w)
    if np.isnan(top):
        raise ValueError(f"{type(model).__name__} gave NaN log-likelihoods for this "
                         f"measurement")
    if top == -np.inf:
        raise ValueError("every particle has zero likelihood for this measurement: "
                         "no weight survives")
    return log_w, float(_weights.normalise_in_place(log_w, top))


def resampling_decision(log_weight, threshold=None):
    """``(ess, resample)``: Kish's effective sample size of unnormalised log weights, and
    whether it is below ``threshold`` (None: half the number of particles)."""
    log_w, log_w_max = _validate.log_weights(log_weight, "particles.log_weight")
    ess = float(_weights.ess(log_w, log_w_max))
    return ess, ess < (log_w.size / 2 if threshold is None else threshold)


def gather(particles, index):
    """The columns ``particles[:, index]`` as a new C-contiguous ``(d, n)`` array (a parallel
    gather)."""
    out = np.empty((particles.shape[0], index.size))
    _resample.take_columns(particles, index, out)
    return out
