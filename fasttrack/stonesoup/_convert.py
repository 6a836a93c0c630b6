"""What the drop-in classes share: Stone Soup models and kernels recognised as fasttrack ones,
Stone Soup arrays as float64 arrays, and Stone Soup's random state."""
import numbers
import weakref

import numpy as np
from stonesoup.base import Base
from stonesoup.kernel import GaussianKernel, LinearKernel, PolynomialKernel
from stonesoup.models.control.linear import LinearControlModel
from stonesoup.models.measurement import linear as ss_measurement_linear
from stonesoup.models.measurement import nonlinear as ss_nonlinear
from stonesoup.models.transition import linear as ss_transition_linear
from stonesoup.types.angle import Angle, Bearing
from stonesoup.types.array import StateVector
from stonesoup.types.mixture import GaussianMixture
from stonesoup.types.state import ParticleState

from .. import kernel as ft_kernel
from .. import models as ft_models
from ..core import unscented as ft_unscented


def _polar(cls):
    def build(model):
        return cls(model.ndim_state, model.mapping, floats(model.noise_covar),
                   translation_offset=floats(model.translation_offset).ravel(),
                   rotation_offset=floats(model.rotation_offset).ravel())
    return build


def _combined(model):
    parts = [fast_model(part) for part in model.model_list]
    return None if None in parts else ft_models.CombinedLinearGaussianTransitionModel(parts)


#: Stone Soup model classes (exactly these, not subclasses) and their fasttrack builders.
_BUILDERS = {
    ss_transition_linear.ConstantVelocity:
        lambda model: ft_models.ConstantVelocity(model.noise_diff_coeff),
    ss_transition_linear.CombinedLinearGaussianTransitionModel: _combined,
    ss_transition_linear.ConstantAcceleration:
        lambda model: ft_models.ConstantAcceleration(model.noise_diff_coeff),
    ss_transition_linear.KnownTurnRate:
        lambda model: ft_models.KnownTurnRate(floats(model.turn_noise_diff_coeffs),
                                              float(model.turn_rate)),
    ss_measurement_linear.LinearGaussian:
        lambda model: ft_models.LinearGaussian(model.ndim_state, model.mapping,
                                               floats(model.noise_covar)),
    ss_nonlinear.CartesianToBearingRange: _polar(ft_models.CartesianToBearingRange),
    ss_nonlinear.Cartesian2DToBearing: _polar(ft_models.Cartesian2DToBearing),
}

_FAST_MODELS = weakref.WeakKeyDictionary()


_PLAIN_VALUES = {float, int, bool, str, type(None)}

#: The attribute names under which each Stone Soup class met so far keeps its properties.
_PROPERTY_KEYS = {}


def _snapshot(value):
    """A comparable copy of a model's parameters (arrays by value)."""
    kind = type(value)
    if kind in _PLAIN_VALUES:
        return value
    if isinstance(value, np.ndarray):
        return value.shape, value.dtype.str, value.tobytes()
    keys = _PROPERTY_KEYS.get(kind)
    if keys is None and Base in kind.__mro__:  # (isinstance walks Base's subclasses)
        keys = _PROPERTY_KEYS[kind] = tuple(f"_property_{name}" for name in kind.properties)
    if keys is not None:
        state = vars(value)
        return kind, tuple(_snapshot(state.get(key)) for key in keys)
    if isinstance(value, (list, tuple)):
        return tuple(_snapshot(item) for item in value)
    return value


def fast_model(model):
    """The fasttrack model computing what the Stone Soup ``model`` computes, or None if it
    is not one of the recognised classes.

    Built once per model object and rebuilt when one of its parameters changes.
    """
    builder = _BUILDERS.get(type(model))
    if builder is None:
        return None
    snapshot = _snapshot(model)
    cached = _FAST_MODELS.get(model)
    if cached is None or cached[0] != snapshot:
        cached = (snapshot, builder(model))
        _FAST_MODELS[model] = cached
    return cached[1]


def model_rng(model):
    """Where Stone Soup draws a model's noise: its own random state if it has a seed, else
    NumPy's global one (so ``np.random.seed`` makes runs repeatable)."""
    if getattr(model, "seed", None) is not None:
        return model.random_state
    return np.random.mtrand._rand


def global_rng():
    """NumPy's global random state, which ``np.random.seed`` seeds."""
    return np.random.mtrand._rand


def plain_particles(state):
    """Whether ``state[index]`` is Stone Soup's ``ParticleState`` indexing (no per-particle
    extras)."""
    return type(state).__getitem__ is ParticleState.__getitem__


def floats(array):
    """A C-contiguous float64 ndarray view (or copy) of a Stone Soup array, ``Angle``
    entries as their float values."""
    return np.ascontiguousarray(np.asarray(array, dtype=np.float64))


def mod_bearing(angles):
    """Stone Soup's bearing wrap ``((a + pi) mod 2 pi) - pi`` of a float array."""
    return (angles + np.pi) % (2.0 * np.pi) - np.pi


def angle_rows(array):
    """Rows of an object array whose entries are Stone Soup angles."""
    if array.dtype != object or array.size == 0:
        return ()
    return tuple(row for row in range(array.shape[0]) if isinstance(array[row, 0], Angle))


def typed_measurement(values, model):
    """A (m, 1) ``StateVector`` as Stone Soup's measurement functions give it: the model's
    angle rows as ``Bearing`` objects."""
    vector = StateVector(values)
    if not model.angle_components:
        return vector
    vector = vector.astype(object)
    for row in model.angle_components:
        vector[row, 0] = Bearing(values[row, 0])
    return vector


def zero_control(control_model):
    """Whether a Kalman predictor's control model contributes nothing without an input (the
    default it builds)."""
    return (type(control_model) is LinearControlModel
            and not np.any(control_model.control_matrix))


def fits(state, ndim):
    """Whether a Gaussian state has ``ndim`` dimensions (a mean (ndim, 1), a covariance
    (ndim, ndim))."""
    return (np.shape(state.state_vector) == (ndim, 1)
            and np.shape(getattr(state, "covar", None)) == (ndim, ndim))


def kernel_filter_refusal(regulariser, name, weight):
    """Why Stone Soup's code must run an adaptive kernel Kalman step of ridge
    ``regulariser`` (its property ``name``) on kernel weights ``weight``, or None:
    fasttrack computes a finite regulariser > 0 and finite weights."""
    try:
        value = float(regulariser)
    except (TypeError, ValueError, OverflowError):
        return f"{name} that is not a number"
    if not 0.0 < value < np.inf:
        return f"{name} {value} outside fasttrack's range (finite, > 0)"
    if not np.isfinite(floats(weight)).all():
        return "kernel weights that are not finite"
    return None


def sigma_parameters(component, ndim):
    """``(alpha, beta, kappa)`` of a Stone Soup unscented component as fasttrack's unscented
    kernels take them (``kappa`` None resolved to ``3 - ndim``), or None where they are
    outside the kernels' range (``alpha <= 0``, a spread ``alpha**2 (ndim + kappa)`` outside
    [1e-12, 1e100], values that are not finite reals)."""
    try:
        alpha, beta, kappa = ft_unscented.check_parameters(component.alpha, component.beta,
                                                           component.kappa)
        return alpha, beta, ft_unscented.scaling(alpha, kappa, ndim)
    except (TypeError, ValueError):
        return None


def fast_kernel(kernel):
    """The fasttrack kernel computing what a Stone Soup polynomial or Gaussian kernel
    computes, or None (another kernel, or parameters outside the positive semi-definite
    range)."""
    if isinstance(kernel, GaussianKernel) and type(kernel).__call__ in _CALLS:
        if kernel.variance > 0:
            return ft_kernel.GaussianKernel(variance=float(kernel.variance))
        return None
    if isinstance(kernel, PolynomialKernel) and type(kernel).__call__ in _CALLS:
        power, c, ialpha = kernel.power, kernel.c, kernel.ialpha
        if int(power) == power >= 1 and c >= 0 and ialpha > 0:
            return ft_kernel.PolynomialKernel(int(power), float(c), float(ialpha))
    return None


#: The ``__call__`` methods whose formulas :func:`kernel_spec` knows (Stone Soup's and the
#: drop-in kernels', registered by the kernel module).
_CALLS = {PolynomialKernel.__call__, GaussianKernel.__call__, LinearKernel.__call__}


def uncached(method):
    """The plain function under Stone Soup's memoising decorators."""
    while hasattr(method, "__wrapped__"):
        method = method.__wrapped__
    return method


def all_real(values):
    """Whether every value is a real number (``numbers.Real``): Stone Soup's arithmetic
    raises on a weight such as the string '0.5', which a float conversion would read."""
    return all(isinstance(value, numbers.Real) for value in values)


def mixture_components(mixture):
    """The components of a Stone Soup ``GaussianMixture`` (or any sequence of them) as its
    iteration gives them: the mixture's own component list where its class iterates and
    indexes as Stone Soup's does."""
    kind = type(mixture)
    if isinstance(mixture, GaussianMixture) and isinstance(mixture.components, list) \
            and (kind.__iter__, kind.__getitem__) == (GaussianMixture.__iter__,
                                                      GaussianMixture.__getitem__):
        return mixture.components
    return list(mixture)
