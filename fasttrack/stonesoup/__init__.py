"""Drop-in replacements for Stone Soup 1.9 classes.

Change ``from stonesoup.resampler.particle import SystematicResampler`` into
``from fasttrack.stonesoup import SystematicResampler`` (likewise for the classes below) and
a Stone Soup script runs unchanged, faster. Each class is a subclass of the Stone Soup class
it replaces, takes and returns Stone Soup's own types, memoises ``predict`` as Stone Soup
does and draws its random numbers from NumPy's global state (``np.random.seed``).

Stone Soup's built-in models ``ConstantVelocity``, ``KnownTurnRate``,
``CombinedLinearGaussianTransitionModel``, ``LinearGaussian``, ``CartesianToBearingRange`` and
``Cartesian2DToBearing`` run through fasttrack's kernels; other models work through their own Python code. Each call that runs
Stone Soup's code logs why at debug level (logger ``fasttrack.stonesoup``), and
:func:`fallbacks` counts them.

``IMMPredictor`` and ``IMMUpdater`` have no Stone Soup counterpart: an interacting multiple
model filter on Stone Soup's ``GaussianMixture`` with its Kalman predictors and updaters as
the models.
"""
try:
    import stonesoup  # noqa: F401
except ImportError as error:  # pragma: no cover - depends on the environment
    raise ImportError("fasttrack.stonesoup needs Stone Soup: pip install 'fasttrack[stonesoup]'"
                      ) from error

from .._lazy import exports as _exports

#: The drop-in classes, by the module that defines them (imported when first used).
_MODULES = {
    "dataassociator": ["GlobalNearestNeighbour", "GNNWith2DAssignment", "JPDA", "JPDAwithEHM",
                       "NearestNeighbour", "PDA"],
    "deleter": ["CovarianceBasedDeleter", "UpdateTimeStepsDeleter"],
    "gater": ["DistanceGater"],
    "hypothesiser": ["DistanceHypothesiser", "GaussianMixtureHypothesiser",
                     "GaussianMixtureKDTreeHypothesiser", "PDAHypothesiser"],
    "imm": ["IMMPredictor", "IMMUpdater"],
    "initiator": ["MultiMeasurementInitiator", "SimpleMeasurementInitiator"],
    "kernel": ["GaussianKernel", "LinearKernel", "PolynomialKernel", "QuadraticKernel",
               "QuarticKernel"],
    "measures": ["Mahalanobis"],
    "metricgenerator": ["GOSPAMetric", "OSPAMetric"],
    "mixturereducer": ["GaussianMixtureReducer"],
    "pointprocess": ["LCCUpdater", "PHDUpdater"],
    "predictor": ["AdaptiveKernelKalmanPredictor", "ExtendedKalmanPredictor", "KalmanPredictor",
                  "ParticlePredictor", "UnscentedKalmanPredictor"],
    "resampler": ["ESSResampler", "MultinomialResampler", "ResidualMethod", "ResidualResampler",
                  "StratifiedResampler", "SystematicResampler"],
    "smoother": ["ExtendedKalmanSmoother", "KalmanSmoother", "UnscentedKalmanSmoother"],
    "tracker": ["MultiTargetMixtureTracker", "MultiTargetTracker",
                "PointProcessMultiTargetTracker"],
    "updater": ["AdaptiveKernelKalmanUpdater", "ExtendedKalmanUpdater", "KalmanUpdater",
                "ParticleUpdater", "UnscentedKalmanUpdater"],
    "_fallback": ["fallbacks"],
}

__all__ = sorted((name for names in _MODULES.values() for name in names), key=str.lower)
__getattr__, __dir__ = _exports(__name__, _MODULES)
