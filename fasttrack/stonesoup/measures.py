"""Stone Soup's ``stonesoup.measures``: the ``Mahalanobis`` measure, by a Cholesky factor."""
import numpy as np
from stonesoup import measures as ss_measures
from stonesoup.types.angle import Angle, Bearing
from stonesoup.types.state import GaussianState

from ._convert import floats
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


def _squared_mahalanobis(measure, state1, state2):
    """Stone Soup's squared Mahalanobis distance of a Gaussian ``state1`` and one vector
    ``state2`` by a Cholesky factor, or the reason Stone Soup's own code is needed (a
    mapping, several columns, a covariance that is not positive definite)."""
    if measure.mapping is not None:
        return "a mapping"
    if not isinstance(state1, GaussianState):
        return f"state1 {type(state1).__name__} is not Gaussian"
    u = getattr(state1, "mean", state1.state_vector)
    v = getattr(state2, "mean", state2.state_vector)
    if not isinstance(u, np.ndarray) or not isinstance(v, np.ndarray):
        return "state vectors that are not arrays"
    m = u.shape[0]
    if u.shape != (m, 1) or v.shape != (m, 1) or np.shape(state1.covar) != (m, m):
        return "several columns, or shapes that do not match"
    angles = _angle_rows((u, v), m)
    if angles is None:
        return "angles other than bearings"
    try:
        u, v, covar = floats(u).ravel(), floats(v).ravel(), floats(state1.covar)
    except (TypeError, ValueError):
        return "values that are not numbers"
    if not np.isfinite(covar).all():
        return "a covariance that is not finite"
    try:
        lower = np.linalg.cholesky(covar)
    except np.linalg.LinAlgError:
        return "a covariance that is not positive definite"
    difference = v - u
    difference[angles] -= 2 * np.pi * np.floor((difference[angles] + np.pi) / (2 * np.pi))
    whitened = np.linalg.solve(lower, difference)
    d2 = float(whitened @ whitened)
    return d2 if np.isfinite(d2) else "a distance that is not finite"


class Mahalanobis(ss_measures.Mahalanobis):
    """Stone Soup's ``Mahalanobis`` measure.

    Between a Gaussian state and one state vector, with no ``mapping``, the distance is
    computed from a Cholesky factor by fasttrack's kernel (bearings wrapped as Stone Soup's
    ``Bearing`` arithmetic wraps them) instead of a pseudo-inverse; equal to rounding. Other
    cases (a mapping, several columns, a covariance that is not positive definite) run
    Stone Soup's code. The drop-in associators recognise this measure and Stone Soup's.
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
