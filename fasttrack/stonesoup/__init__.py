"""Drop-in replacements for Stone Soup 1.9 classes.

Change ``from stonesoup.resampler.particle import SystematicResampler`` into
``from fasttrack.stonesoup import SystematicResampler`` (likewise for the classes below) and
a Stone Soup script runs unchanged, faster. Each class is a subclass of the Stone Soup class
it replaces, takes and returns Stone Soup's own types, memoises ``predict`` as Stone Soup
does and draws its random numbers from NumPy's global state (``np.random.seed``).

Stone Soup's built-in models ``ConstantVelocity``, ``CombinedLinearGaussianTransitionModel``,
``LinearGaussian``, ``CartesianToBearingRange`` and ``Cartesian2DToBearing`` run through
fasttrack's kernels; other models work through their own Python code.
"""
try:
    import stonesoup  # noqa: F401
except ImportError as error:  # pragma: no cover - depends on the environment
    raise ImportError("fasttrack.stonesoup needs Stone Soup: pip install 'fasttrack[stonesoup]'"
                      ) from error

from .dataassociator import (JPDA, PDA, GlobalNearestNeighbour, GNNWith2DAssignment,
                             JPDAwithEHM, NearestNeighbour)
from .deleter import CovarianceBasedDeleter, UpdateTimeStepsDeleter
from .gater import DistanceGater
from .hypothesiser import DistanceHypothesiser, PDAHypothesiser
from .initiator import MultiMeasurementInitiator, SimpleMeasurementInitiator
from .kernel import (GaussianKernel, LinearKernel, PolynomialKernel, QuadraticKernel,
                     QuarticKernel)
from .measures import Mahalanobis
from .metricgenerator import GOSPAMetric, OSPAMetric
from .predictor import (AdaptiveKernelKalmanPredictor, ExtendedKalmanPredictor, KalmanPredictor,
                        ParticlePredictor, UnscentedKalmanPredictor)
from .resampler import (ESSResampler, MultinomialResampler, ResidualMethod, ResidualResampler,
                        StratifiedResampler, SystematicResampler)
from .smoother import ExtendedKalmanSmoother, KalmanSmoother, UnscentedKalmanSmoother
from .tracker import MultiTargetMixtureTracker, MultiTargetTracker
from .updater import (AdaptiveKernelKalmanUpdater, ExtendedKalmanUpdater, KalmanUpdater,
                      ParticleUpdater, UnscentedKalmanUpdater)

__all__ = [
    "AdaptiveKernelKalmanPredictor", "AdaptiveKernelKalmanUpdater", "CovarianceBasedDeleter",
    "DistanceGater", "DistanceHypothesiser", "ESSResampler", "ExtendedKalmanPredictor",
    "ExtendedKalmanSmoother", "ExtendedKalmanUpdater", "GaussianKernel",
    "GlobalNearestNeighbour", "GNNWith2DAssignment", "GOSPAMetric", "JPDA", "JPDAwithEHM",
    "KalmanPredictor", "KalmanSmoother", "KalmanUpdater", "LinearKernel",
    "Mahalanobis", "MultiMeasurementInitiator", "MultinomialResampler",
    "MultiTargetMixtureTracker", "MultiTargetTracker", "NearestNeighbour", "OSPAMetric",
    "ParticlePredictor", "ParticleUpdater", "PDA", "PDAHypothesiser", "PolynomialKernel",
    "QuadraticKernel", "QuarticKernel", "ResidualMethod", "ResidualResampler",
    "SimpleMeasurementInitiator", "StratifiedResampler", "SystematicResampler",
    "UnscentedKalmanPredictor", "UnscentedKalmanSmoother", "UnscentedKalmanUpdater",
    "UpdateTimeStepsDeleter",
]
