"""Transition and measurement models (built-in, or built from a user's Numba function)."""
from .measurement import (Cartesian2DToBearing, CartesianToBearingRange, LinearGaussian,
                          MeasurementModel, NonlinearGaussianMeasurement)
from .kinematic import (ConstantAcceleration, ConstantTurn, ConstantVelocity,
                        KnownTurnRate)
from .transition import (CombinedLinearGaussianTransitionModel, EmbeddedTransitionModel,
                         LinearGaussianTransitionModel, NonlinearGaussianTransitionModel,
                         TransitionModel)

__all__ = [
    "Cartesian2DToBearing", "CartesianToBearingRange", "CombinedLinearGaussianTransitionModel",
    "ConstantAcceleration", "ConstantTurn", "ConstantVelocity", "EmbeddedTransitionModel",
    "KnownTurnRate", "LinearGaussian", "LinearGaussianTransitionModel", "MeasurementModel",
    "NonlinearGaussianMeasurement", "NonlinearGaussianTransitionModel", "TransitionModel",
]
