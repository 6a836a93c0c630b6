"""fasttrack: Numba-accelerated tracking and state estimation.

Classes keep Stone Soup's names and call patterns; the hot loops run in compiled kernels.
"""
from ._version import __version__
from . import threads as _threads
_threads.configure()
from .threads import get_threads, set_threads  # noqa: E402
from .random import seed  # noqa: E402
from .resampler import (ESSResampler, MultinomialResampler, Resampler, ResidualResampler,
                        StratifiedResampler, SystematicResampler)
from .resampling import (ResidualMethod, ess, multinomial, normalise, residual,
                         resampling_points, stratified, systematic)
from .models import (Cartesian2DToBearing, CartesianToBearingRange,
                     CombinedLinearGaussianTransitionModel, ConstantVelocity, LinearGaussian,
                     LinearGaussianTransitionModel, MeasurementModel,
                     NonlinearGaussianMeasurement, NonlinearGaussianTransitionModel,
                     TransitionModel)
from .batch import BatchExtendedKalmanFilter, BatchUnscentedKalmanFilter
from .filtering import run_filter
from .memory import tune_allocator
from .metrics import position_rmse
from .montecarlo import (MetricSummary, RunFailure, TrialResults, local_cluster, run_seeds,
                         run_trial, run_trials)
from .kernel import (GaussianKernel, Kernel, LinearKernel, PolynomialKernel, QuadraticKernel,
                     QuarticKernel)
from .predictor import (AdaptiveKernelKalmanPredictor, ExtendedKalmanPredictor, KalmanPredictor,
                        ParticlePredictor, UnscentedKalmanPredictor)
from .simulate import detections, ground_truth
from .smoother import ExtendedKalmanSmoother, KalmanSmoother, UnscentedKalmanSmoother, ffbs
from .tracker import MultiTargetTracker
from .types import (Detection, GaussianMeasurementPrediction, GaussianState,
                    GaussianStatePrediction, GaussianStateUpdate, GroundTruthPath,
                    GroundTruthState, KernelParticleState,
                    KernelParticleStateMeasurementPrediction, KernelParticleStatePrediction,
                    KernelParticleStateUpdate, Particle, ParticleState, ParticleStatePrediction,
                    ParticleStateUpdate, SingleHypothesis, State, Track)
from ._warmup import warmup
from .updater import (AdaptiveKernelKalmanUpdater, ExtendedKalmanUpdater, KalmanUpdater,
                      ParticleUpdater, UnscentedKalmanUpdater)


__all__ = [
    "AdaptiveKernelKalmanPredictor", "AdaptiveKernelKalmanUpdater", "BatchExtendedKalmanFilter",
    "BatchUnscentedKalmanFilter",
    "Cartesian2DToBearing", "CartesianToBearingRange", "CombinedLinearGaussianTransitionModel",
    "ConstantVelocity", "Detection", "ESSResampler", "ExtendedKalmanPredictor",
    "ExtendedKalmanSmoother", "ExtendedKalmanUpdater", "GaussianKernel",
    "GaussianMeasurementPrediction", "GaussianState",
    "GaussianStatePrediction", "GaussianStateUpdate", "GroundTruthPath", "GroundTruthState",
    "KalmanPredictor", "KalmanSmoother", "KalmanUpdater", "Kernel", "KernelParticleState",
    "KernelParticleStateMeasurementPrediction", "KernelParticleStatePrediction",
    "KernelParticleStateUpdate", "LinearGaussian", "LinearGaussianTransitionModel",
    "LinearKernel", "MeasurementModel", "MetricSummary", "MultiTargetTracker",
    "MultinomialResampler", "NonlinearGaussianMeasurement", "NonlinearGaussianTransitionModel",
    "Particle", "ParticlePredictor", "ParticleState", "ParticleStatePrediction",
    "ParticleStateUpdate", "ParticleUpdater", "PolynomialKernel", "QuadraticKernel",
    "QuarticKernel", "Resampler", "ResidualMethod", "ResidualResampler", "RunFailure",
    "SingleHypothesis", "State", "StratifiedResampler", "SystematicResampler", "Track",
    "TransitionModel", "TrialResults", "UnscentedKalmanPredictor", "UnscentedKalmanSmoother",
    "UnscentedKalmanUpdater", "detections", "ess", "ffbs", "get_threads", "ground_truth",
    "local_cluster", "multinomial", "normalise", "position_rmse", "resampling_points", "residual",
    "run_filter", "run_seeds", "run_trial", "run_trials", "seed", "set_threads", "stratified",
    "systematic", "tune_allocator", "warmup",
]
