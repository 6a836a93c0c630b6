"""The adaptive kernel Kalman filter's steps on kernel particle sets.

A set is its (d, M) particles, (M,) weights and the factors ``(L, sigma, V1, V2)`` of its
kernel covariance ``L L^T + sigma (I - V1 V2^T)(I - V1 V2^T)^T`` (see
:mod:`fasttrack.types`).
"""

import numpy as np

from .. import _jit
from .. import _validate
from .. import random as _random
from . import akkf_numpy as _numpy
from .kinds import MATRIX

_akkf = _jit.lazy("akkf")
_gram = _jit.lazy("gram")


def angle_mask(ndim, angle_components=()):
    """A (ndim,) bool array flagging ``angle_components`` (integer rows in [0, ndim); None
    for none): a TypeError for anything but a sequence of integers."""
    mask = np.zeros(ndim, dtype=np.bool_)
    if angle_components is not None:
        mask[list(_validate.indices(angle_components, "angle_components", ndim))] = True
    return mask


def resolve(kind, params, angles, x1, x2):
    """The kernel parameters with any length scale from the data (the points ``x1`` and
    ``x2`` together, (d, A) and (d, B)) resolved."""
    if _jit.numpy_first(_numpy.work(x1.shape[1] + x2.shape[1])):
        return _numpy.resolve(kind, params, angles, x1, x2)
    return _gram.resolve(kind, params, angles, x1, x2)


def median_variance(angles, x):
    """The median squared distance between the columns of ``x`` (d, N), angle rows
    wrapped."""
    if _jit.numpy_first(_numpy.work(x.shape[1])):
        return _numpy.median_variance(angles, x)
    return _gram.median_variance(angles, x)


def gram(kind, params, angles, x1, x2, others):
    """The (A, B) Gram matrix of the kernel ``(kind, params)`` between the columns of
    ``x1`` (d, A) and ``x2`` (d, B); a length scale from the data comes from ``x1`` and
    ``others`` (d, C) together."""
    params = _gram.resolve(kind, params, angles, x1, others)
    out = np.empty((x1.shape[1], x2.shape[1]))
    _gram.gram(kind, params, angles, x1, x2, out)
    return out


def covariance(x, factors):
    """``X S X^T`` (d, d) of particles ``x`` (d, M) and the factors of the kernel
    covariance S."""
    if _jit.numpy_first(_numpy.work(x.shape[1])):
        return _numpy.sandwich(x, *factors)
    return _akkf.sandwich(x, *factors)


def factor_matrix(s):
    """The pivoted Cholesky factor ``Lt`` (r, M) of a positive semi-definite (M, M) ``s``
    (``Lt^T Lt = s``)."""
    if _jit.numpy_first(_numpy.work(s.shape[0])):
        return _numpy.factor(MATRIX, None, None, s)
    return _gram.factor(MATRIX, np.empty(0), np.zeros(0, dtype=np.bool_), s)


def check_weights(weight, which):
    """Raise if kernel filter weights are not finite (the kernel values overflowed) or all
    zero (nothing carried over)."""
    largest = np.nan if np.isnan(weight).any() else np.abs(weight).max(initial=0.0)
    if not largest <= 1.7976931348623157e308:
        raise ValueError(f"the {which} kernel weights are not finite: the kernel values "
                         f"overflow (rescale the states or use a lower-degree kernel)")
    if largest == 0.0:
        raise ValueError(f"the {which} kernel weights are all zero: the kernel carries no "
                         f"information between the particle sets (its length scale is far "
                         f"from their spread)")


def predict(model, kernel, dt, proposal, x, weight, factors, lambda_predictor):
    """``(states, weight, factors)`` predicted ``dt`` seconds ahead: the ``proposal``
    particles moved through the transition ``model`` (noise-free), and the weights and
    kernel covariance carried over from the prior set ``(x, weight, factors)`` by the
    embedding of ``kernel`` (a fasttrack :class:`~fasttrack.kernel.Kernel` on states)."""
    angles = angle_mask(x.shape[0])
    kind, params = kernel.spec(angles, proposal, x)
    embed = _numpy.predict_embedding if _jit.numpy_first(_numpy.work(weight.size)) \
        else _akkf.predict_embedding
    w, lt, v1t, v2t = embed(kind, params, angles, proposal, x, weight, *factors,
                            lambda_predictor)
    check_weights(w, "predicted")
    return model.spec(dt).mean(proposal), w, (lt, 1.0 / w.size, v1t, v2t)


def update(model, kernel, y, z, x, weight, factors, lambda_updater, rng):
    """``(weight, factors, proposal)`` of the posterior given the measurement ``z`` (m,)
    for predicted particles ``x`` (d, M) with measurements ``y`` (m, M): the weights and
    kernel covariance from the embedding of ``kernel`` (on measurements, the ``model``'s
    angle components wrapped), and new proposal particles (d, M) drawn from ``rng``."""
    angles = model.spec.angles
    z = z.reshape(-1, 1)
    kind, params = kernel.spec(angles, y, z)
    with np.errstate(over="ignore"):
        overflows = not np.isfinite(_numpy.diagonal(kind, params, z)).all()
    if overflows:
        raise ValueError(f"hypothesis.measurement {z.ravel().tolist()} is too large for "
                         f"{type(kernel).__name__}: its kernel value k(z, z) overflows; "
                         f"rescale the measurements or use a lower-degree kernel")
    key = _random.stream_key(rng)
    if _jit.numpy_first(_numpy.work(weight.size)):
        w, lt, v1t, v2t, proposal = _numpy.update_embedding(
            kind, params, angles, y, z, weight, *factors, lambda_updater, x, key)
    else:
        proposal = np.empty_like(x)
        w, lt, v1t, v2t = _akkf.update_embedding(kind, params, angles, y, z, weight,
                                                 *factors, lambda_updater, x, key, proposal)
    check_weights(w, "updated")
    return w, (lt, factors[1], v1t, v2t), proposal
