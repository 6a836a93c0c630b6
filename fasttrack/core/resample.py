"""Resampling on plain arrays: ancestor indices from log weights.

Every function takes unnormalised log weights (``-inf`` allowed), normalises them in log space,
and returns ascending int64 ancestor indices of length ``nparts`` (default: N). A particle
of zero weight is never drawn, whatever the rounding of the cumulative weights.

Random numbers come from a counter-based stream keyed by one draw from ``rng`` (None: the
package default generator, see :func:`fasttrack.seed`; an int seed; or a
``numpy.random.Generator``), so the indices for a seed do not depend on the thread count.
"""
import enum

import numpy as np

from .. import _buffers
from .. import _jit
from .. import _validate
from .. import random as _random
from . import particle_numpy as _numpy

__all__ = ["ResidualMethod", "ess", "multinomial", "normalise", "resampling_points", "residual",
           "stratified", "systematic"]

_kernels = _jit.lazy("resample")
_weights = _jit.lazy("weights")

_NO_ROWS = np.empty((0, 0))


class ResidualMethod(str, enum.Enum):
    """How residual resampling draws the particles left after its deterministic stage."""

    MULTINOMIAL = "multinomial"
    SYSTEMATIC = "systematic"
    STRATIFIED = "stratified"

    @classmethod
    def parse(cls, value, name="residual_method"):
        """The member named by ``value`` (a member or its string value).

        Parameters
        ----------
        value : str or ResidualMethod
            'multinomial', 'systematic' or 'stratified', or a member.
        name : str
            Name of the argument in the error message.

        Returns
        -------
        ResidualMethod

        Raises
        ------
        ValueError
            If ``value`` names no member.
        """
        try:
            return cls(value)
        except ValueError:
            valid = ", ".join(repr(m.value) for m in cls)
            raise ValueError(f"{name} must be one of {valid} (or a ResidualMethod), "
                             f"got {value!r}") from None


def _cdf(log_w, log_w_max):
    cdf = _buffers.empty_like(log_w)
    _weights.relative_weights(log_w, log_w_max, cdf)
    _kernels.cumulate(cdf)
    return cdf


def _index_dtype(*sizes):
    """int32 for indices and counts up to ``max(sizes)`` where they fit (less memory traffic,
    and one build of each kernel), else int64."""
    return np.int32 if max(sizes) < 2**31 - 1 else np.int64


def _occupancy(n, key, dtype):
    points = _buffers.empty(n + 1)
    _kernels.sorted_uniforms(key, n, points)
    occupancy = _buffers.empty(n + 1, dtype)
    _kernels.stratum_occupancy(points, n, occupancy)
    return occupancy


def _multinomial_starts(cdf, n, key, starts):
    _kernels.multinomial_starts(cdf, n, key, _occupancy(n, key, starts.dtype), starts)


def _scheme_starts(method, cdf, n, key, dtype):
    starts = _buffers.empty(cdf.size, dtype)
    if method is ResidualMethod.SYSTEMATIC:
        _kernels.systematic_starts(cdf, n, key, starts)
    elif method is ResidualMethod.STRATIFIED:
        _kernels.stratified_starts(cdf, n, key, starts)
    else:
        _multinomial_starts(cdf, n, key, starts)
    return starts


def _residual_starts(log_w, log_w_max, cdf, n, method, key, dtype):
    floors = _buffers.empty(cdf.size, dtype)
    residuals = _buffers.empty_like(cdf)
    _kernels.residual_floors(cdf, log_w, log_w_max, n, floors, residuals)
    _kernels.cumulate(floors)
    n_rest = n - int(floors[-1])
    if n_rest > 0:
        _kernels.cumulate(residuals)
        starts = _scheme_starts(method, residuals, n_rest, key, dtype)
    else:
        starts = np.zeros(cdf.size, dtype=dtype)
    _kernels.add_floors(starts, floors)
    return starts


def draw(log_weights, nparts=None, method=ResidualMethod.SYSTEMATIC, residual=False,
         rng=None, columns=None, name="log_weights", compact=False):
    """Ancestor indices of one resampling draw, and optionally the gathered columns.

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights.
    nparts : int, optional
        Number of particles to draw (default N).
    method : ResidualMethod
        Multinomial, systematic or stratified; with ``residual``, the method of stage two.
    residual : bool
        Residual resampling.
    rng : None, int or numpy.random.Generator
    columns : (d, N) float64 C-contiguous ndarray, optional
        Array whose columns are gathered by the indices.
    name : str
        Name of the weights in error messages.
    compact : bool
        Return int32 indices when N and nparts allow (less memory traffic), for callers that
        only use the indices internally. The stratum starts behind them are int32 whenever
        N and nparts allow, either way (one build of each kernel).

    Returns
    -------
    idx : (nparts,) int64 (or int32, see ``compact``)
    gathered : (d, nparts) ndarray
        Only if ``columns`` is given.
    """
    log_w, log_w_max = _validate.log_weights(log_weights, name)
    n = _validate.count(nparts, "nparts", default=log_w.size)
    _validate.storable(n, 8 * (1 if columns is None else 1 + columns.shape[0]), "nparts")
    key = _random.stream_key(rng)
    starts_dtype = _index_dtype(n, log_w.size)
    dtype = starts_dtype if compact else np.int64
    if not residual and method is not ResidualMethod.MULTINOMIAL \
            and _jit.numpy_first(_numpy.work(log_w) + n // 4096):
        starts = _numpy.starts(method is ResidualMethod.STRATIFIED, log_w, log_w_max, n, key)
        idx = _numpy.expand(starts, n).astype(dtype)
        return idx if columns is None else (idx, columns[:, idx])
    cdf = _cdf(log_w, log_w_max)
    if residual:
        starts = _residual_starts(log_w, log_w_max, cdf, n, method, key, starts_dtype)
    else:
        starts = _scheme_starts(method, cdf, n, key, starts_dtype)
    idx = _buffers.empty(n, dtype)
    if columns is None:
        _kernels.expand(starts, idx, _NO_ROWS, _NO_ROWS)
        return idx
    gathered = _buffers.empty((columns.shape[0], n))
    _kernels.expand(starts, idx, columns, gathered)
    return idx, gathered


def systematic(log_weights, nparts=None, rng=None):
    """Systematic resampling: points ``(j + u) / n`` for one uniform u.

    Each particle gets ``floor(n w_i)`` or ``ceil(n w_i)`` copies.

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights; ``-inf`` marks a zero weight.
    nparts : int, optional
        Number of particles to draw, >= 1 (default N).
    rng : None, int or numpy.random.Generator
        Source of the stream's key (None: the package default generator).

    Returns
    -------
    (nparts,) int64 ndarray
        Ascending ancestor indices.
    """
    return draw(log_weights, nparts, ResidualMethod.SYSTEMATIC, rng=rng)


def stratified(log_weights, nparts=None, rng=None):
    """Stratified resampling: one uniform point in each stratum ``[j/n, (j+1)/n)``.

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights; ``-inf`` marks a zero weight.
    nparts : int, optional
        Number of particles to draw, >= 1 (default N).
    rng : None, int or numpy.random.Generator
        Source of the stream's key (None: the package default generator).

    Returns
    -------
    (nparts,) int64 ndarray
        Ascending ancestor indices.
    """
    return draw(log_weights, nparts, ResidualMethod.STRATIFIED, rng=rng)


def multinomial(log_weights, nparts=None, rng=None):
    """Multinomial resampling: ``nparts`` independent draws from the weights.

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights; ``-inf`` marks a zero weight.
    nparts : int, optional
        Number of particles to draw, >= 1 (default N).
    rng : None, int or numpy.random.Generator
        Source of the stream's key (None: the package default generator).

    Returns
    -------
    (nparts,) int64 ndarray
        Ascending ancestor indices (the draws are exchangeable, so they are returned
        sorted).
    """
    return draw(log_weights, nparts, ResidualMethod.MULTINOMIAL, rng=rng)


def residual(log_weights, nparts=None, rng=None, method="multinomial"):
    """Residual resampling: ``floor(n w_i)`` copies of each particle, the rest drawn from the
    residual weights with ``method``.

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights; ``-inf`` marks a zero weight.
    nparts : int, optional
        Number of particles to draw, >= 1 (default N).
    rng : None, int or numpy.random.Generator
        Source of the stream's key (None: the package default generator).
    method : {'multinomial', 'systematic', 'stratified'} or ResidualMethod
        Scheme of the second stage.

    Returns
    -------
    (nparts,) int64 ndarray
        Ascending ancestor indices.
    """
    return draw(log_weights, nparts, ResidualMethod.parse(method, "method"), residual=True,
                rng=rng)


_SCHEME_CODES = {ResidualMethod.SYSTEMATIC: 0, ResidualMethod.STRATIFIED: 1,
                 ResidualMethod.MULTINOMIAL: 2}


def resampling_points(nparts, method="systematic", rng=None):
    """The uniform points a resampling draw tests against the cumulative weights.

    With the same ``rng`` (the same int seed, or a generator in the same state), a draw of
    ``nparts`` particles by :func:`systematic`, :func:`stratified` or :func:`multinomial`
    selects, for each point p, the particle i with ``cdf[i-1] <= p < cdf[i]`` of the
    normalised cumulative weights: the picture of the resampler tutorial.

    Parameters
    ----------
    nparts : int
        Number of particles drawn, >= 1.
    method : {'systematic', 'stratified', 'multinomial'} or ResidualMethod
        The scheme whose points to draw.
    rng : None, int or numpy.random.Generator
        The same as the draw's: one key is drawn from it.

    Returns
    -------
    (nparts,) float64 ndarray
        Points in [0, 1): ascending for systematic and stratified, one per stratum
        ``[j/n, (j+1)/n)``; for multinomial, iid uniform (unsorted).
    """
    method = ResidualMethod.parse(method, "method")
    n = _validate.count(nparts, "nparts")
    key = _random.stream_key(rng)
    occupancy = (_occupancy(n, key, _index_dtype(n)) if method is ResidualMethod.MULTINOMIAL
                 else np.zeros(1, _index_dtype(n)))
    out = _buffers.empty(n)
    _kernels.scheme_points(_SCHEME_CODES[method], key, n, occupancy, out)
    return out


def ess(log_weights):
    """Kish's effective sample size ``(sum w)**2 / sum(w**2)`` of unnormalised log weights.

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights: no NaN or ``+inf``, not all ``-inf`` (``-inf`` marks a
        zero weight).

    Returns
    -------
    float
        Between 1 and N.
    """
    log_w, log_w_max = _validate.log_weights(log_weights, "log_weights")
    return float(_weights.ess(log_w, log_w_max))


def normalise(log_weights):
    """Log weights shifted so that their exponentials sum to 1 (computed with logsumexp).

    Parameters
    ----------
    log_weights : (N,) array_like
        Unnormalised log weights: no NaN or ``+inf``, not all ``-inf`` (``-inf`` marks a
        zero weight, and stays ``-inf``).

    Returns
    -------
    (N,) float64 ndarray
        A new array.
    """
    log_w, log_w_max = _validate.log_weights(log_weights, "log_weights")
    out = log_w.copy()
    _weights.normalise_in_place(out, log_w_max)
    return out
