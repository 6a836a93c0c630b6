"""State types. A particle cloud is a (d, N) float64 state array (one column per particle)
with (N,) float64 log weights; linear weights are derived on request.

The types live in modules by kind: :mod:`~fasttrack.types.particle`,
:mod:`~fasttrack.types.kernel` (the AKKF's), :mod:`~fasttrack.types.gaussian` (and
detections), :mod:`~fasttrack.types.mixture` (stacks of Gaussians: mixtures and track sets),
:mod:`~fasttrack.types.tracks` (tracks and hypotheses) and
:mod:`~fasttrack.types.base` (timestamps and links); every name is importable from here.

Ownership of history: a state's links to the states it came from (``prior`` of a
prediction, ``parent`` of a particle state, the ``prediction`` of a hypothesis once an
updater has used it) are weak when a filter makes them, so a filter loop keeps only what
the program itself keeps. ``prediction.prior`` is the prior object while anything else (a
variable, a :class:`Track`) still holds it, and None after; an update holds its
``hypothesis`` (the detection and measurement prediction) strongly, and the prediction
while the program holds it. A :class:`Track` of updates thus keeps the updates, not the
particle clouds of the predictions between them. Links given to a constructor, and the
indexed parent a resampler makes (which has no links of its own), are held strongly.
"""
from .._lazy import exports as _exports

#: The public names, by the module that defines them (imported when first used).
_MODULES = {
    "base": ["Link", "check_timestamp", "seconds", "time_interval", "weak"],
    "gaussian": ["Detection", "GaussianMeasurementPrediction", "GaussianState",
                 "GaussianStatePrediction", "GaussianStateUpdate", "GroundTruthState", "State",
                 "WeightedGaussianState", "column_vector"],
    "mixture": ["GaussianMixture", "IMMTrackSet", "TrackSet"],
    "kernel": ["KernelParticleState", "KernelParticleStateMeasurementPrediction",
               "KernelParticleStatePrediction", "KernelParticleStateUpdate",
               "dense_kernel_covar", "factor_kernel_covar", "isotropic_factors"],
    "particle": ["Particle", "ParticleState", "ParticleStatePrediction", "ParticleStateUpdate",
                 "as_particle_state"],
    "tracks": ["GroundTruthPath", "SingleHypothesis", "StateSequence", "Track"],
}

__all__ = sorted(name for names in _MODULES.values() for name in names)
__getattr__, __dir__ = _exports(__name__, _MODULES)
