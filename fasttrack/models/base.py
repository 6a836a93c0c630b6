"""What the models share: state arrays, Gaussian noise and its square root, and the
checked wrapper of a user's model function."""
import functools

import numpy as np

from .. import _errors
from .. import _validate
from .. import random as _random
from .._jit import status as _status
from .._jit.tunables import BLOCK


def check_model(model, kind, name):
    """``model`` if it is an instance of ``kind`` (TransitionModel or MeasurementModel), else
    a TypeError naming ``name``, pointing Stone Soup's models to :mod:`fasttrack.stonesoup`."""
    if isinstance(model, kind):
        return model
    hint = ""
    if type(model).__module__.split(".")[0] == "stonesoup":
        hint = ("; for Stone Soup's models use the drop-in classes of fasttrack.stonesoup, "
                "which take them")
    raise TypeError(f"{name} must be a {kind.__name__} of fasttrack.models, got "
                    f"{type(model).__module__}.{type(model).__name__}{hint}")


def check_same_states(transition_model, measurement_model):
    """ValueError, naming both, unless the models' state dimensions agree."""
    if measurement_model.ndim_state != transition_model.ndim_state:
        raise ValueError(f"measurement_model measures {measurement_model.ndim_state}-D "
                         f"states, transition_model's are {transition_model.ndim_state}-D")


def state_columns(state, name="state"):
    """The (d, N) float64 array of a state object (anything with ``state_vector``) or an
    array_like: a (d,) vector becomes one column."""
    value = getattr(state, "state_vector", state)
    array = _validate.finite_array(value, name)
    if array.ndim == 1:
        array = array.reshape(-1, 1)
    if array.ndim != 2:
        raise ValueError(f"{name} must be a (d,) vector or a (d, N) array, got {array.shape}")
    if array.size == 0:
        raise ValueError(f"{name} must hold at least one state of at least one component, "
                         f"got an empty array of shape {array.shape}")
    return array


def check_rows(array, rows, name):
    if array.shape[0] != rows:
        raise ValueError(f"{name} must have {rows} rows (the model's dimension), "
                         f"got shape {array.shape}")


class GaussianNoise:
    """A zero-mean Gaussian with covariance ``covar``: a square root for sampling and the
    Cholesky whitening for densities."""

    def __init__(self, covar, name):
        self.covar = covar
        values, vectors = np.linalg.eigh(covar)
        top = max(values.max(initial=0.0), np.finfo(float).tiny)
        if values.min(initial=0.0) < -1e-10 * top:
            raise ValueError(f"{name} is not positive semi-definite "
                             f"(smallest eigenvalue {values.min():.3g})")
        self.root = np.ascontiguousarray(vectors * np.sqrt(np.clip(values, 0.0, None)))
        self._name = name
        self._whitening = None

    def sample(self, size, rng):
        """(m, size) samples from ``rng`` (None, int seed or Generator)."""
        z = _random.generator(rng).standard_normal((self.covar.shape[0], size))
        return self.root @ z

    def whitening(self):
        """``(W, log_norm)``: W (lower triangular) with ``W^T W = covar^-1`` and
        ``log_norm = -(m log 2 pi + log det covar) / 2``."""
        if self._whitening is None:
            try:
                lower = np.linalg.cholesky(self.covar)
            except np.linalg.LinAlgError:
                raise ValueError(f"{self._name} must be positive definite for a density") from None
            whiten = np.linalg.inv(lower)
            m = self.covar.shape[0]
            log_norm = -0.5 * (m * np.log(2 * np.pi)) - np.log(np.diag(lower)).sum()
            self._whitening = (np.ascontiguousarray(np.tril(whiten)), float(log_norm))
        return self._whitening

    def logpdf(self, deviations):
        """Log densities of the columns of (m, N) ``deviations``."""
        whiten, log_norm = self.whitening()
        return log_norm - 0.5 * np.sum((whiten @ deviations) ** 2, axis=0)


def gaussian_noise(covar, name):
    """The :class:`GaussianNoise` of a covariance matrix, memoised on its values (so a model
    whose parameters change gets the new one)."""
    covar = np.ascontiguousarray(covar, dtype=np.float64)
    return _noise_by_value(covar.tobytes(), covar.shape, name)


@functools.lru_cache(maxsize=256)
def _noise_by_value(data, shape, name):
    return GaussianNoise(np.frombuffer(data).reshape(shape).copy(), name)


def read_only(array):
    """A read-only view of ``array``: what a model shows of a parameter, keeping the
    writable original for its kernels (which compile for writable arrays)."""
    view = array.view()
    view.flags.writeable = False
    return view


def wrap_angle(a):
    """Angles wrapped to [-pi, pi), by the kernels' formula ``a - 2 pi floor((a + pi) / 2 pi)``."""
    return a - 6.283185307179586 * np.floor((a + 3.141592653589793) * 0.15915494309189535)


def scalar_or_array(values):
    """A float for a single value, else the array (Stone Soup's logpdf convention)."""
    return float(values[0]) if values.size == 1 else values


class _FirstClassFunction:
    """A ``numba.cfunc`` as Numba's first-class function protocol (its address and
    signature), with its Numba type given (``_numba_type_``): a kernel call then types it
    at once, where typing the cfunc object itself costs about 6 us a call."""

    def __init__(self, compiled, signature):
        from numba import typeof
        self._compiled, self._signature = compiled, signature
        self._numba_type_ = typeof(compiled)

    def __wrapper_address__(self):
        return self._compiled.address

    def signature(self):
        return self._signature


class UserFunction:
    """A user's ``@numba.njit`` model function, checked before anything is read from its
    output.

    At construction it is compiled for the argument types the kernels pass (a C-contiguous
    (d, n) float64 array, and a float interval for a transition), its return type must be
    a 2-D float64 array, and a call on a probe of 3 states must return ``(rows, 3)``. Every
    later call (in a kernel or from Python) checks the shape and that the values are
    finite, and a bad output raises ValueError naming the function.

    Parameters
    ----------
    function : numba dispatcher
    role : str
        'transition function' or 'measurement function' (for messages).
    ndim_state, rows : int
        d, and the number of rows it must return.
    interval : bool
        Whether it takes a time interval (seconds) after the states.
    """

    def __init__(self, function, role, ndim_state, rows, interval):
        signature = "f(states, dt)" if interval else "h(states)"
        self.function, self.role, self.rows = function, role, rows
        self.ndim_state, self.interval = ndim_state, interval
        from numba import types  # the user's function is Numba's: Numba is loaded
        from numba.core import config
        self._signature = None
        if config.DISABLE_JIT and callable(function):  # run by Python: only the probe
            self.name = getattr(function, "__name__", repr(function))
            self._probe()
            return
        if not (hasattr(function, "py_func") and hasattr(function, "compile")):
            raise TypeError(f"the {role} must be a numba.njit function {signature}, "
                            f"got {type(function).__name__}")
        self.name = getattr(function.py_func, "__name__", repr(function))
        # What kernels and Python calls both pass: a C-contiguous (d, n) float64 array (and,
        # for a transition, the interval in seconds).
        states = types.Array(types.float64, 2, "C")
        arguments = (states, types.float64) if interval else (states,)
        try:
            function.compile(arguments)
        except Exception as error:
            raise TypeError(f"{self._label} cannot be compiled for a (d, n) float64 array of "
                            f"states{' and a float interval' if interval else ''} "
                            f"(signature {signature}, states one per column): "
                            f"{_first_line(error)}") from error
        returned = function.overloads[arguments].signature.return_type
        if not (isinstance(returned, types.Array) and returned.ndim == 2
                and returned.dtype == types.float64):
            raise TypeError(f"{self._label} must return a 2-D float64 array of shape "
                            f"({rows}, n), one column per state; it returns {returned}")
        self._probe()
        self._signature = returned(*arguments)

    @functools.cached_property
    def callee(self):
        """What kernels call: a first-class function of the checked signature (a
        ``numba.cfunc`` calling the function, whose compiled code it links, as a
        :class:`_FirstClassFunction`), so that the kernels taking it are typed by the
        signature alone and load from the on-disk cache in later processes (typed by the
        function itself, they would compile in every process). An exception raised inside
        it cannot cross into the kernel: Numba prints it, the kernel finds no output, and
        the error then raised calls the function again from Python, which raises it."""
        if self._signature is None:  # run by Python
            return self.function
        from numba import cfunc
        function = self.function
        if self.interval:
            def call(states, dt):
                return function(states, dt)
        else:
            def call(states):
                return function(states)
        return _FirstClassFunction(cfunc(self._signature)(call), self._signature)

    def _probe(self):
        """A call on 3 states must return ``(rows, 3)``."""
        probe = 1.0 + 0.25 * np.arange(self.ndim_state)[:, None] + 0.125 * np.arange(3)
        try:
            values = self._raw(probe, 1.0)
        except Exception:  # the probe may lie outside its domain: calls still check
            return
        if np.shape(values) != (self.rows, 3):
            raise ValueError(self._shape_message(np.shape(values), probe.shape))

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("callee", None)  # compiled code: made again on first use
        return state

    @property
    def _label(self):
        return f"{self.role} {self.name!r}"

    def _raw(self, states, dt):
        return self.function(states, dt) if self.interval else self.function(states)

    def __call__(self, states, dt=None):
        """The checked output for (d, n) C-contiguous float64 ``states`` (and the interval
        ``dt`` in seconds, for a transition)."""
        values = self._raw(states, dt)
        if np.shape(values) != (self.rows, states.shape[1]):
            _errors.check(_status.FUNCTION_SHAPE, self, states, dt)
        if not np.isfinite(values).all():
            _errors.check(_status.FUNCTION_NOT_FINITE, self, states, dt)
        return values

    def _shape_message(self, got, states_shape):
        return (f"{self._label} returned an array of shape {got} for states of shape "
                f"{states_shape}; expected ({self.rows}, {states_shape[1]}), one column per "
                f"state")

    def error(self, code, states, dt=None):
        """The ValueError for a kernel's status ``code`` about this function's output on
        (d, n) ``states``: for a wrong shape, the function is called again here on the
        states in blocks of :data:`~fasttrack._jit.tunables.BLOCK` (as kernels call it) to
        find the block it fails on, its own error (which compiled code cannot pass on) the
        cause."""
        if code != _status.FUNCTION_SHAPE:
            return ValueError(f"{self._label} returned NaN or infinite values for states of "
                              f"shape {states.shape}")
        for lo in range(0, states.shape[1], BLOCK):
            block = np.ascontiguousarray(states[:, lo:lo + BLOCK])
            try:
                got = np.shape(self._raw(block, 1.0 if dt is None else dt))
            except Exception as raised:
                error = ValueError(f"{self._label} raised {_first_line(raised)} for states "
                                   f"{lo} to {lo + block.shape[1] - 1} (of {states.shape[1]})")
                error.__cause__ = raised
                return error
            if got != (self.rows, block.shape[1]):
                return ValueError(self._shape_message(got, block.shape))
        return ValueError(f"{self._label} returned an array of the wrong shape when a kernel "
                          f"called it (or raised an error there, which compiled code cannot "
                          f"pass on), not when called again on these states of shape "
                          f"{states.shape}: it must return ({self.rows}, n) for any n states")


def _first_line(error):
    lines = [line for line in str(error).splitlines() if line.strip()]
    return f"{type(error).__name__}: {' '.join(lines[:3])}"
