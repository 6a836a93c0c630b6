"""Transition and measurement models (built-in, or built from a user's Numba function)."""
from .measurement import (Cartesian2DToBearing, CartesianToBearingRange, LinearGaussian,
                          MeasurementModel, NonlinearGaussianMeasurement)
from .transition import (CombinedLinearGaussianTransitionModel, ConstantVelocity,
                         KnownTurnRate, LinearGaussianTransitionModel,
                         NonlinearGaussianTransitionModel, TransitionModel)

__all__ = [
    "Cartesian2DToBearing", "CartesianToBearingRange", "CombinedLinearGaussianTransitionModel",
    "ConstantVelocity", "KnownTurnRate", "LinearGaussian", "LinearGaussianTransitionModel",
    "MeasurementModel", "NonlinearGaussianMeasurement", "NonlinearGaussianTransitionModel",
    "TransitionModel",
]
