"""Stone Soup's ``stonesoup.measures``: the ``Mahalanobis`` measure, by a Cholesky factor."""
import numpy as np
from stonesoup import measures as ss_measures
from stonesoup.types.angle import Angle, Bearing
from stonesoup.types.state import GaussianState, ParticleState

from ..core.gating import squared_distance
from ._convert import floats, mod_bearing
from ._pending import pending_values
from ._fallback import fall_back

__all__ = ["Mahalanobis"]


def _angle_rows(vectors, m):
    """Rows of the (m, 1) ``vectors`` where Stone Soup's subtraction wraps (an entry of
    either is a ``Bearing``); None if one holds another kind of angle (wrapped otherwise)."""
    rows = np.zeros(m, dtype=np.bool_)
    for vector in vectors:
        if vector.dtype != object:
            continue
        for r in range(m):
            entry = vector[r, 0]
            if isinstance(entry, Angle):
                if type(entry) is not Bearing:
                    return None
                rows[r] = True
    return rows


def _particle_values(state):
    """``(values (m, N) floats, angles (m,) bool)``: a particle state's vectors and the rows
    of ``Bearing`` entries (read from a particle measurement prediction not yet made
    objects); or the reason Stone Soup's own code is needed."""
    pending_vectors = pending_values(state)
    if pending_vectors is not None:  # the bearings as their Bearing objects will hold them
        values = pending_vectors.values.copy()
        angles = np.zeros(values.shape[0], dtype=np.bool_)
        angles[pending_vectors.angles] = True
        values[angles] = mod_bearing(values[angles])
        return values, angles
    vectors = state.state_vector
    if not isinstance(vectors, np.ndarray) or vectors.ndim != 2 or vectors.shape[1] == 0:
        return "particle state vectors that are not a 2-D array"
    angles = _angle_rows((vectors,), vectors.shape[0])  # by each row's first entry
    if angles is None:
        return "angles other than bearings"
    try:
        return floats(vectors), angles
    except (TypeError, ValueError):
        return "values that are not numbers"


def _particle_moments(state):
    """``(mean (m, 1), covar (m, m), angles (m,))`` of a particle state as Stone Soup's
    ``mean`` and ``covar`` compute them from its (m, N) state vectors and log weights, on
    floats: the ``angles`` rows (of ``Bearing`` entries) by their circular mean and wrapped
    deviations; or the reason Stone Soup's own code is needed."""
    values = _particle_values(state)
    if isinstance(values, str):
        return values
    values, angles = values
    m, n = values.shape
    try:
        log_weight = floats(state.log_weight)
        covar = None if state.fixed_covar is None else floats(state.fixed_covar)
    except (TypeError, ValueError):
        return "values that are not numbers"
    if n == 1:
        mean = values
    else:
        weights = np.exp(log_weight - log_weight.max())
        total = weights.sum()
        mean = (values @ weights / total)[:, None]
        turns = values[angles]
        mean[angles, 0] = mod_bearing(np.arctan2(np.sin(turns) @ weights / total,
                                                 np.cos(turns) @ weights / total))
    if covar is None:
        if n == 1:
            return mean, np.zeros((m, m)), angles
        deviations = values - mean
        deviations[angles] = mod_bearing(deviations[angles])
        covar = deviations @ (deviations * weights).T * (1.0 / total)
    return mean, covar, angles


def _squared_mahalanobis(measure, state1, state2):
    """Stone Soup's squared Mahalanobis distance of a Gaussian or particle ``state1`` and
    one vector ``state2`` by a Cholesky factor, or the reason Stone Soup's own code is
    needed (a mapping, several columns, an asymmetric, singular or ill-conditioned
    covariance)."""
    if measure.mapping is not None:
        return "a mapping"
    if isinstance(state1, ParticleState):
        moments = _particle_moments(state1)
        if isinstance(moments, str):
            return moments
        u, covar, u_angles = moments
    elif isinstance(state1, GaussianState):
        u, covar, u_angles = getattr(state1, "mean", state1.state_vector), state1.covar, None
    else:
        return f"state1 {type(state1).__name__} is not Gaussian or particles"
    v = getattr(state2, "mean", state2.state_vector)
    if not isinstance(u, np.ndarray) or not isinstance(v, np.ndarray):
        return "state vectors that are not arrays"
    m = u.shape[0]
    if u.shape != (m, 1) or v.shape != (m, 1) or np.shape(covar) != (m, m):
        return "several columns, or shapes that do not match"
    angles = _angle_rows((u, v), m)
    if angles is None:
        return "angles other than bearings"
    if u_angles is not None:
        angles |= u_angles
    try:
        u, v, covar = floats(u).ravel(), floats(v).ravel(), floats(covar)
    except (TypeError, ValueError):
        return "values that are not numbers"
    if not np.isfinite(covar).all():
        return "a covariance that is not finite"
    if (np.abs(covar - covar.T) > 1e-9 * np.abs(covar).max()).any():
        return "an asymmetric covariance (a Cholesky factor reads one triangle)"
    difference = v - u
    difference[angles] = mod_bearing(difference[angles])
    d2 = squared_distance(difference, covar)
    if d2 is None:
        return "a covariance that is singular or ill-conditioned (Stone Soup's pseudo-inverse)"
    return d2 if np.isfinite(d2) else "a distance that is not finite"


class Mahalanobis(ss_measures.Mahalanobis):
    """Stone Soup's ``Mahalanobis`` measure.

    Between a Gaussian or particle state and one state vector, with no ``mapping``, the
    distance is computed from a Cholesky factor (bearings wrapped as Stone Soup's
    ``Bearing`` arithmetic wraps them) instead of a pseudo-inverse; a particle state's mean
    and covariance as Stone Soup computes them (circular means of bearings), on floats
    instead of ``Bearing`` objects. Equal to rounding. Other cases (a mapping, several
    columns, an asymmetric, singular or ill-conditioned covariance) run Stone Soup's code. The
    drop-in associators recognise this measure and Stone Soup's.
    """

    def __call__(self, state1, state2):
        """The Mahalanobis distance of ``state2`` from the distribution ``state1``.

        Parameters
        ----------
        state1 : stonesoup.types.state.State
            Its mean and covariance define the distance.
        state2 : stonesoup.types.state.State

        Returns
        -------
        float or numpy.ndarray
            As Stone Soup: an array for a ``state2`` of several columns.
        """
        d2 = _squared_mahalanobis(self, state1, state2)
        if isinstance(d2, str):
            fall_back(self, "__call__", d2)
            return super().__call__(state1, state2)
        return np.sqrt(np.float64(d2))


def _measure_kind(measure):
    """'mahalanobis' or 'euclidean' for the measures the vectorised path computes."""
    if getattr(measure, "mapping", None) is not None:
        return None
    if type(measure) in (Mahalanobis, ss_measures.Mahalanobis):
        return "mahalanobis"
    if type(measure) is ss_measures.Euclidean:
        return "euclidean"
    return None
