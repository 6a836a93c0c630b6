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
from .base import Link, check_timestamp, seconds, time_interval, weak
from .gaussian import (Detection, GaussianMeasurementPrediction, GaussianState,
                       GaussianStatePrediction, GaussianStateUpdate, GroundTruthState, State,
                       WeightedGaussianState, column_vector)
from .mixture import GaussianMixture, IMMTrackSet, TrackSet
from .kernel import (KernelParticleState, KernelParticleStateMeasurementPrediction,
                     KernelParticleStatePrediction, KernelParticleStateUpdate,
                     dense_kernel_covar, factor_kernel_covar, isotropic_factors)
from .particle import (Particle, ParticleState, ParticleStatePrediction, ParticleStateUpdate,
                       as_particle_state)
from .tracks import GroundTruthPath, SingleHypothesis, StateSequence, Track

__all__ = [
    "Detection", "GaussianMeasurementPrediction", "GaussianState", "GaussianStatePrediction",
    "GaussianMixture", "GaussianStateUpdate", "GroundTruthPath", "GroundTruthState",
    "IMMTrackSet", "KernelParticleState",
    "KernelParticleStateMeasurementPrediction", "KernelParticleStatePrediction",
    "KernelParticleStateUpdate", "Link", "Particle", "ParticleState", "ParticleStatePrediction",
    "ParticleStateUpdate", "SingleHypothesis", "State", "StateSequence", "Track", "TrackSet",
    "WeightedGaussianState",
    "as_particle_state", "check_timestamp", "column_vector", "dense_kernel_covar",
    "factor_kernel_covar", "isotropic_factors", "seconds", "time_interval", "weak",
]
