"""The array layer: filter steps and multi-target arithmetic on plain arrays, under both
APIs, and the only caller of the compiled kernels.

The native classes and :mod:`fasttrack.stonesoup` convert their states to arrays, call these
functions and wrap the results. Each takes model specs (:mod:`fasttrack.models.spec`),
float64 arrays (particles ``(d, N)``; a Gaussian state ``(d, 1)`` with its ``(d, d)``
covariance; stacks of K Gaussians ``(K, d)`` and ``(K, d, d)``, with ``(K,)`` log weights
and int64 labels where they apply) and intervals in seconds; it calls the kernels and
raises the errors they report, naming the argument or the user's function.

One module per family: :mod:`~fasttrack.core.particle`, :mod:`~fasttrack.core.resample`,
:mod:`~fasttrack.core.kalman`, :mod:`~fasttrack.core.unscented`,
:mod:`~fasttrack.core.akkf`, :mod:`~fasttrack.core.smooth`, :mod:`~fasttrack.core.gating`,
:mod:`~fasttrack.core.assign`, :mod:`~fasttrack.core.jpda`, :mod:`~fasttrack.core.mixture`
and :mod:`~fasttrack.core.metric`; :mod:`~fasttrack.core.stack` runs stacks of filters and
:mod:`~fasttrack.core.kinds` names the kind codes that specs carry.
"""
from .._lazy import exports as _exports

__all__ = ["akkf", "kalman", "particle"]
__getattr__, __dir__ = _exports(__name__, {})  # each module imported when first used
