"""Predictors: ``predictor.predict(prior, timestamp)``, one module per family on the
:class:`~fasttrack.predictor.base.Predictor` base (Stone Soup's split)."""
from .akkf import AdaptiveKernelKalmanPredictor
from .base import Predictor
from .kalman import ExtendedKalmanPredictor, KalmanPredictor
from .particle import ParticlePredictor
from .unscented import UnscentedKalmanPredictor

__all__ = ["AdaptiveKernelKalmanPredictor", "ExtendedKalmanPredictor", "KalmanPredictor",
           "ParticlePredictor", "Predictor", "UnscentedKalmanPredictor"]
