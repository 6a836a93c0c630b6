"""All Numba code of fasttrack: njit kernels with private names, no classes.

Every kernel is compiled through :func:`jit`, the one place where compilation options live.

Rules for ``parallel=True`` kernels, each learnt from a wrong result:

- only explicit ``prange`` loops run in parallel: no NumPy reductions or array expressions
  in them (Numba parallelises those too, so their rounding would follow the thread count);
  reductions go over a fixed number of chunks (:func:`numeric.n_chunks`) in chunk order;
- arrays written in a ``prange`` loop are arguments or slices of them taken in the kernel
  itself (Numba's parfor dead-code elimination drops writes to an array returned by a call);
- inner loops run over ``range(view.size)`` of a slice, not ``range(lo, hi)`` of the
  whole array, so that LLVM can prove the index non-negative and vectorise;
- a loop over a literal tuple of coefficients (a Horner polynomial) holds at most 13 of
  them: longer ones are not unrolled, and the loop around them no longer vectorises.

Two properties of the dispatchers made here go beyond Numba's defaults:

- a damaged entry of the on-disk cache (truncated, empty or garbage files) is recompiled
  and replaced, with a warning, instead of failing every call;
- where Numba's threading layer is its ``workqueue`` (no OpenMP or TBB library), which
  aborts the process when two threads run parallel regions at once, calls from Python are
  serialised by one process-wide lock, so kernels may be called from several threads on
  every layer.
"""
import threading
import warnings

import numba
from numba.core import config
from numba.core.caching import CompileResultCacheImpl, FunctionCache
from numba.core.registry import CPUDispatcher

#: Floating-point relaxations allowed in kernels. ``nnan``/``ninf`` are excluded because
#: ``-inf`` log weights are legal; ``reassoc`` is excluded because it lets LLVM rewrite
#: compensated arithmetic (it breaks the Cody-Waite reduction of :func:`fast_exp`) and
#: makes the order of summation a compiler decision.
FASTMATH = frozenset({"nsz", "arcp", "contract", "afn"})

#: Options shared by every dispatcher; a test checks each one against this.
OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


class KernelCache(FunctionCache):
    """Numba's on-disk cache, except that an entry that cannot be read (a truncated, empty
    or garbage index or data file) is compiled again and replaced, with a warning."""

    _impl_class = CompileResultCacheImpl

    def load_overload(self, sig, target_context):
        try:
            return super().load_overload(sig, target_context)
        except Exception as error:  # any unreadable entry: compile instead
            warnings.warn(f"fasttrack: the compile cache entry of {self._py_func.__name__} "
                          f"in {self.cache_path} is damaged ({type(error).__name__}: {error}); "
                          f"compiling it again and replacing it", RuntimeWarning, stacklevel=2)
            return None

    def save_overload(self, sig, data):
        try:
            super().save_overload(sig, data)
        except Exception:  # a damaged index: start a new one
            self._cache_file._save_index({})
            super().save_overload(sig, data)


class Kernel(CPUDispatcher):
    """A CPU dispatcher that caches through :class:`KernelCache`."""

    def enable_caching(self):
        self._cache = KernelCache(self.py_func)


class SerialKernel(Kernel):
    """A :class:`Kernel` whose calls from Python hold :data:`CALL_LOCK` (used where the
    threading layer cannot run two parallel regions at once)."""

    def __call__(self, *args, **kwargs):
        with CALL_LOCK:
            return super().__call__(*args, **kwargs)


#: Held by every call of a :class:`SerialKernel` from Python.
CALL_LOCK = threading.RLock()


def _loads(layer):
    """Whether Numba can load the named threading layer (without starting it)."""
    try:
        if layer == "tbb":
            from numba.np.ufunc.parallel import _check_tbb_version_compatible
            _check_tbb_version_compatible()
            from numba.np.ufunc import tbbpool  # noqa: F401
        elif layer == "omp":
            from numba.np.ufunc import omppool  # noqa: F401
    except ImportError:
        return False
    return True


def layer_is_threadsafe():
    """Whether the threading layer Numba will choose runs parallel regions from several
    threads at once: TBB or OpenMP, not the workqueue (Numba's own choice rule)."""
    wanted = str(config.THREADING_LAYER).lower()
    if wanted in ("tbb", "omp", "threadsafe"):
        return True
    if wanted == "workqueue":
        return False
    candidates = {"safe": ["tbb"], "forksafe": ["tbb", "workqueue"]}.get(
        wanted, list(config.THREADING_LAYER_PRIORITY))
    for layer in candidates:
        if layer == "workqueue":
            return False
        if _loads(layer):
            return True
    return False


_DISPATCHER = Kernel if layer_is_threadsafe() else SerialKernel


def jit(parallel=False, strict=False):
    """Return the decorator that compiles a fasttrack kernel.

    Parameters
    ----------
    parallel : bool
        Compile ``prange`` loops for multi-threaded execution.
    strict : bool
        IEEE arithmetic, no relaxations, for code that must reproduce another library's
        results to the last bit (marked ``dispatcher.strict``).
    """
    def decorate(func):
        fastmath = False if strict else set(FASTMATH)
        options = {"nopython": True, "parallel": parallel, "fastmath": fastmath,
                   "nogil": OPTIONS["nogil"], "error_model": OPTIONS["error_model"]}
        if config.DISABLE_JIT:
            func.strict = strict
            return func
        dispatcher = _DISPATCHER(py_func=func, locals={}, targetoptions=options)
        if OPTIONS["cache"]:
            dispatcher.enable_caching()
        dispatcher.strict = strict
        return dispatcher
    return decorate
