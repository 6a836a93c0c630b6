"""Updaters: ``updater.update(hypothesis)``, one module per family on the
:class:`~fasttrack.updater.base.Updater` base (Stone Soup's split)."""
from .akkf import AdaptiveKernelKalmanUpdater
from .base import Updater
from .kalman import ExtendedKalmanUpdater, KalmanUpdater
from .particle import ParticleUpdater
from .unscented import UnscentedKalmanUpdater

__all__ = ["AdaptiveKernelKalmanUpdater", "ExtendedKalmanUpdater", "KalmanUpdater",
           "ParticleUpdater", "UnscentedKalmanUpdater", "Updater"]
