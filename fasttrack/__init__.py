"""fasttrack: Numba-accelerated tracking and state estimation.

Classes keep Stone Soup's names and call patterns; the hot loops run in compiled kernels.
Each public name is imported when first used (so is Numba, with the first kernel), so that
``import fasttrack`` costs only what a program uses.
"""
from ._lazy import exports as _exports
from ._version import __version__

#: The public names, by the module that defines them.
_MODULES = {
    "batch": ["BatchExtendedKalmanFilter", "BatchUnscentedKalmanFilter"],
    "imm": ["BatchGPBFilter", "BatchIMMFilter", "IMMPredictor", "IMMUpdater"],
    "filtering": ["run_filter"],
    "kernel": ["GaussianKernel", "Kernel", "LinearKernel", "PolynomialKernel",
               "QuadraticKernel", "QuarticKernel"],
    "memory": ["tune_allocator"],
    "metrics": ["position_rmse"],
    "mixturereducer": ["GaussianMixtureReducer"],
    "models": ["Cartesian2DToBearing", "CartesianToBearingRange",
               "CombinedLinearGaussianTransitionModel", "ConstantAcceleration",
               "ConstantTurn", "ConstantVelocity", "EmbeddedTransitionModel", "KnownTurnRate",
               "LinearGaussian", "LinearGaussianTransitionModel", "MeasurementModel",
               "NonlinearGaussianMeasurement", "NonlinearGaussianTransitionModel",
               "TransitionModel"],
    "montecarlo": ["MetricSummary", "RunFailure", "TrialResults", "local_cluster", "run_seeds",
                   "run_trial", "run_trials"],
    "phd": ["CPHDTracker", "PHDTracker"],
    "predictor": ["AdaptiveKernelKalmanPredictor", "ExtendedKalmanPredictor", "KalmanPredictor",
                  "ParticlePredictor", "UnscentedKalmanPredictor"],
    "random": ["seed"],
    "resampler": ["ESSResampler", "MultinomialResampler", "Resampler", "ResidualResampler",
                  "StratifiedResampler", "SystematicResampler"],
    "resampling": ["ResidualMethod", "ess", "multinomial", "normalise", "residual",
                   "resampling_points", "stratified", "systematic"],
    "simulate": ["detections", "ground_truth"],
    "smoother": ["ExtendedKalmanSmoother", "KalmanSmoother", "UnscentedKalmanSmoother", "ffbs"],
    "threads": ["get_threads", "set_threads"],
    "tracker": ["IMMTracker", "MultiTargetTracker"],
    "types": ["Detection", "GaussianMeasurementPrediction", "GaussianMixture", "GaussianState",
              "GaussianStatePrediction", "GaussianStateUpdate", "GroundTruthPath",
              "GroundTruthState", "KernelParticleState",
              "KernelParticleStateMeasurementPrediction", "KernelParticleStatePrediction",
              "KernelParticleStateUpdate", "Particle", "ParticleState",
              "ParticleStatePrediction", "ParticleStateUpdate", "SingleHypothesis", "State",
              "Track", "WeightedGaussianState"],
    "updater": ["AdaptiveKernelKalmanUpdater", "ExtendedKalmanUpdater", "KalmanUpdater",
                "ParticleUpdater", "UnscentedKalmanUpdater"],
    "_warmup": ["warmup"],
}

__all__ = sorted((name for names in _MODULES.values() for name in names), key=str.lower)
__getattr__, __dir__ = _exports(__name__, _MODULES)
