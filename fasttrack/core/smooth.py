"""The smoothers' steps on plain arrays: the Rauch-Tung-Striebel recursion over stacks of
tracks, and forward-filter backward-simulation draws over particle clouds."""
import numpy as np

from .. import _jit

_smooth = _jit.lazy("smooth")


def rts(x, covar, x_pred, covar_pred, recompute, matrices, noises, step):
    """``(x_out, covar_out, status)``: the RTS smoother over K tracks of n steps.

    ``x`` (K, n, d) and ``covar`` (K, n, d, d) are the filtered states; ``x_pred`` and
    ``covar_pred`` the one-step predictions (recomputed from ``matrices`` (S, d, d) and
    ``noises`` (S, d, d) where ``recompute`` (n,) uint8 says so); ``step`` (n,) int64 the
    index of each step's (F, Q). ``status`` is 0, ``1 + k n + t`` for the first track k
    and time t whose predicted covariance is not positive definite, ``-(1 + k n + t)``
    for the first whose filtered covariance is not symmetric positive semi-definite, or
    ``1 + K n + k n + t`` for the first smoothed state that is not finite or has a negative
    variance (see :func:`failure`).
    """
    x_out, covar_out = np.empty_like(x), np.empty_like(covar)
    status = _smooth.rts_kernel(x.shape[-1])(x, covar, x_pred, covar_pred, recompute, matrices,
                                             noises, step, x_out, covar_out)
    if not status:
        variances = np.diagonal(covar_out, axis1=-2, axis2=-1)
        bad = ~(np.isfinite(x_out).all(axis=-1) & np.isfinite(covar_out).all(axis=(-2, -1))
                & (variances >= 0.0).all(axis=-1))
        if bad.any():
            status = 1 + bad.size + int(np.argmax(bad.ravel()))
    return x_out, covar_out, status


def failure(status, k, n):
    """``(k, t, what)`` of a non-zero :func:`rts` ``status`` over k tracks of n steps: the
    track, the time and what failed ('predicted' or 'filtered' covariance, 'smoothed'
    state)."""
    what = "predicted" if status > 0 else "filtered"
    if status > k * n:
        status, what = status - k * n, "smoothed"
    track, t = divmod(abs(status) - 1, n)
    return track, t, what


#: Why a smoothed state is not finite or has a negative variance.
SMOOTHED_UNRESOLVED = ("is not finite or has a negative variance: the filtered states overflow "
                       "the smoother's arithmetic (beyond about 1e150) or their covariances "
                       "span more than float64's 16 digits (e.g. a prior variance of 1e300 "
                       "beside variances of 1)")


def rts_linear(model, x, covar, x_pred, covar_pred, recompute, intervals):
    """:func:`rts` of K tracks on the same ``intervals`` (n - 1,) seconds through a linear
    transition ``model`` (its F and Q at each distinct interval)."""
    values, step = np.unique(intervals, return_inverse=True)
    if values.size == 0:
        values = np.zeros(1)
    specs = [model.spec(float(dt)) for dt in values]
    matrices = np.array([spec.matrix for spec in specs])
    noises = np.array([spec.noise for spec in specs])
    step = np.ascontiguousarray(np.append(step, 0), dtype=np.int64)
    return rts(x, covar, x_pred, covar_pred, recompute, matrices, noises, step)


def ffbs(x, log_weights, mean_next, whitening, n_paths, key, rejection):
    """(T, M) int64 particle indices of ``n_paths`` = M trajectories drawn backwards.

    ``x`` (T, d, N) and ``log_weights`` (T, N) are the filtered clouds, ``mean_next``
    (T - 1, d, N) their noise-free transitions, ``whitening`` (T - 1, d, d) the inverse
    Cholesky factors of each step's Q; ``key`` seeds the draws, ``rejection`` picks
    rejection sampling (else exact O(N) draws per path).
    """
    index = np.empty((x.shape[0], n_paths), dtype=np.int64)
    max_proposals = _smooth.MAX_PROPOSALS if rejection else 0
    _smooth.ffbs(x, log_weights, mean_next, whitening, np.random.default_rng(key),
                 max_proposals, _smooth.PROPOSAL_COST / x.shape[2], index)
    return index
