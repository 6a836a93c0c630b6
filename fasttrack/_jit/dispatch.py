"""The dispatchers of fasttrack's kernels: :func:`jit`, the one place where compilation
options live, the serial and constant twins, and the record of compilations (see the
package's notes)."""
import contextlib
import functools
import importlib
import pkgutil
import sys
import threading
import time
import types

import numpy as np

from numba.core import compiler, config, event
from numba.core.codegen import JITCodeLibrary
from numba.core.registry import CPUDispatcher

from . import cache
from .. import threads
from .tunables import SERIAL_BELOW_LIGHT

threads.configure()  # before Numba's threading layer starts (with the first parallel kernel)

#: Floating-point relaxations allowed in kernels. ``nnan``/``ninf`` are excluded because
#: ``-inf`` log weights are legal; ``reassoc`` is excluded because it lets LLVM rewrite
#: compensated arithmetic (it breaks the Cody-Waite reduction of :func:`fast_exp`) and
#: makes the order of summation a compiler decision.
FASTMATH = frozenset({"nsz", "arcp", "contract", "afn"})

#: Options shared by every dispatcher; a test checks each one against this.
OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


class Kernel(CPUDispatcher):
    """A CPU dispatcher that caches through :class:`cache.KernelCache`: the kernels shipped
    with the package, then a per-user directory."""

    def enable_caching(self):
        self._cache = cache.KernelCache(self.py_func)


def kernels():
    """Every kernel defined in this package's modules (importing them all)."""
    for info in pkgutil.iter_modules(sys.modules[__package__].__path__,
                                     __package__ + "."):
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if isinstance(value, CPUDispatcher) and value.py_func.__module__ == module.__name__:
                yield value


#: Numba options of a kernel called only from other kernels: no wrappers for calls from
#: Python (its callers link its code).
KERNEL_ONLY = {"no_cpython_wrapper": True, "no_cfunc_wrapper": True}


class _LinkedLibrary(JITCodeLibrary):
    """The optimised code of a kernel called only from other kernels, linked into each
    caller's code, which holds its machine code: unlike Numba's library it is not made into
    machine code of its own nor given an address (about 6 % of all compile time)."""

    def _finalize_final_module(self):
        self._finalize_dynamic_globals()
        self._verify_declare_only_symbols()
        self._finalized = True

    def get_pointer_to_function(self, name):
        self._ensure_finalized()
        return 0

    @property
    def codegen(self):
        return _Unplaced(self._codegen)


class _Unplaced:
    """The code generator of a :class:`_LinkedLibrary`, which has no environment to set:
    its code runs inside its callers' machine code only (as when they load from the
    cache)."""

    def __init__(self, codegen):
        self._codegen = codegen

    def __getattr__(self, name):
        return getattr(self._codegen, name)

    def set_env(self, env_name, env):
        pass


class _LinkedCompiler(compiler.Compiler):
    """Numba's pipeline, lowering into a :class:`_LinkedLibrary`."""

    def compile_extra(self, func):
        if self.state.library is None:
            self.state.library = _LinkedLibrary(self.state.targetctx.codegen(),
                                                func.__qualname__)
        return super().compile_extra(func)


class KernelOnly(CPUDispatcher):
    """A kernel compiled with :data:`KERNEL_ONLY` into a :class:`_LinkedLibrary`: its
    callers' cache entries hold its code, so it has none of its own, and a call from Python
    (which would crash) raises TypeError instead."""

    def __init__(self, **kwargs):
        super().__init__(pipeline_class=_LinkedCompiler, **kwargs)

    def enable_caching(self):
        pass

    def __call__(self, *args, **kwargs):
        raise TypeError(f"{self.py_func.__module__}.{self.py_func.__qualname__} is called only "
                        f"from other kernels (it has no wrapper for calls from Python)")


class Compiled(types.SimpleNamespace):
    """One compilation of a fasttrack kernel: ``name`` (module.qualified name),
    ``signature`` (its argument types, as text), ``seconds`` (including the kernels it
    compiled for its callees meanwhile) and ``own_seconds`` (excluding them)."""


class _CompileListener(event.Listener):
    def __init__(self, found):
        self.found, self.open = found, []  # open: [start, seconds of nested compiles]

    def on_start(self, ev):
        self.open.append([time.perf_counter(), 0.0])

    def on_end(self, ev):
        start, nested = self.open.pop()
        seconds = time.perf_counter() - start
        if self.open:
            self.open[-1][1] += seconds
        func = ev.data["dispatcher"].py_func
        if func.__module__.startswith(__package__):
            self.found.append(Compiled(name=f"{func.__module__}.{func.__qualname__}",
                                       signature=str(ev.data["args"]), seconds=seconds,
                                       own_seconds=seconds - nested))


@contextlib.contextmanager
def compiles():
    """Record the fasttrack kernels compiled (not loaded) meanwhile: yields a list that
    fills with :class:`Compiled` items, callees before their callers."""
    found = []
    with event.install_listener("numba:compile", _CompileListener(found)):
        yield found


def _reaches_parallel(dispatcher, seen=()):
    """Whether a kernel has parallel regions or calls a kernel that has (transitively)."""
    if dispatcher.targetoptions.get("parallel"):
        return True
    callees = (dispatcher.py_func.__globals__.get(name)
               for name in dispatcher.py_func.__code__.co_names)
    return any(_reaches_parallel(callee, seen + (dispatcher,)) for callee in callees
               if isinstance(callee, CPUDispatcher) and callee not in seen)


def _twin(dispatcher, suffix, names, **options):
    """A kernel compiled from a copy of ``dispatcher``'s function whose globals are
    ``names`` and whose target options are changed by ``options``, cached on disk under its
    own name (the function's qualified name with ``suffix``)."""
    func = dispatcher.py_func
    twin = types.FunctionType(func.__code__, names, func.__name__, func.__defaults__,
                              func.__closure__)
    twin.__qualname__ = f"{func.__qualname__}_{suffix}"
    kind = KernelOnly if isinstance(dispatcher, KernelOnly) else Kernel
    twin_dispatcher = kind(py_func=twin, locals={},
                           targetoptions=dict(dispatcher.targetoptions, **options))
    if OPTIONS["cache"]:
        twin_dispatcher.enable_caching()
    twin_dispatcher.strict = dispatcher.strict
    return twin_dispatcher


@functools.lru_cache(maxsize=None)
def serial_twin(dispatcher):
    """The same kernel compiled without parallel regions: a copy of its function whose
    globals name the serial twins of the kernels it calls that reach parallel regions
    (made on first use, when every kernel module is loaded; cached on disk under its own
    name)."""
    if not _reaches_parallel(dispatcher):
        return dispatcher
    func = dispatcher.py_func
    names = dict(func.__globals__)
    for name in func.__code__.co_names:
        callee = names.get(name)
        if isinstance(callee, CPUDispatcher):
            names[name] = serial_twin(callee)
    return _twin(dispatcher, "serial", names, parallel=False)


@functools.lru_cache(maxsize=None)
def with_constant(dispatcher, name, value):
    """The same kernel compiled with its global ``name`` (an int) set to ``value``: Numba
    reads globals as compile-time constants, so loops bounded by it can be unrolled (made
    on first use; cached on disk under its own name). Uncompiled kernels are returned as
    they are."""
    if not isinstance(dispatcher, CPUDispatcher):
        return dispatcher
    names = dict(dispatcher.py_func.__globals__, **{name: value})
    return _twin(dispatcher, f"{name}{value}", names)


class ThreadedKernel(Kernel):
    """A :class:`Kernel` that reaches parallel regions. A call from Python with work (the
    size of argument ``size``) below ``serial_below`` runs its :func:`serial_twin`, compiled
    only if such a call comes (faster to compile, and no threads to start); larger work
    runs on :func:`fasttrack.threads.get_threads` threads, holding :data:`CALL_LOCK` where
    the threading layer cannot run two parallel regions at once (Numba's workqueue)."""

    def __call__(self, *args, **kwargs):
        if args[self.size].size < self.serial_below:
            return serial_twin(self)(*args, **kwargs)
        threads.use(False)
        if SERIALISE:
            with CALL_LOCK:
                return super().__call__(*args, **kwargs)
        return super().__call__(*args, **kwargs)


#: Held by calls of a :class:`ThreadedKernel` from Python when :data:`SERIALISE`.
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


#: Whether calls must be serialised (the threading layer is not thread-safe).
SERIALISE = not layer_is_threadsafe()


def _uncompiled(func, strict):
    """``func`` run by Python (``NUMBA_DISABLE_JIT=1``), its integer arithmetic wrapping
    silently as compiled code's does (the random stream multiplies modulo 2**64)."""
    @functools.wraps(func)
    def run(*args, **kwargs):
        with np.errstate(over="ignore"):
            return func(*args, **kwargs)
    run.py_func, run.strict = func, strict
    return run


def jit(parallel=False, strict=False, size=None, serial_below=SERIAL_BELOW_LIGHT,
        inline=False):
    """Return the decorator that compiles a fasttrack kernel.

    Parameters
    ----------
    parallel : bool
        Compile ``prange`` loops for multi-threaded execution.
    strict : bool
        IEEE arithmetic, no relaxations, for code that must reproduce another library's
        results to the last bit (marked ``dispatcher.strict``).
    size : int, optional
        For a kernel that reaches parallel regions (its own or a callee's): the position of
        the argument whose ``size`` measures its work (a :class:`ThreadedKernel`).
    serial_below : int
        With ``size``: the work below which a call runs on one thread.
    inline : bool
        Inline the kernel into each caller's code (compiled anew in each), so that a
        caller's compile-time constants, such as a dimension it is built for, reach its
        loops.
    """
    def decorate(func):
        fastmath = False if strict else set(FASTMATH)
        options = {"nopython": True, "parallel": parallel, "fastmath": fastmath,
                   "nogil": OPTIONS["nogil"], "error_model": OPTIONS["error_model"]}
        if inline:
            options["inline"] = "always"
        kind = Kernel if size is None else ThreadedKernel
        if func.__name__.startswith("_"):
            options.update(KERNEL_ONLY)
            kind = KernelOnly
        if config.DISABLE_JIT:
            return _uncompiled(func, strict)
        dispatcher = kind(py_func=func, locals={}, targetoptions=options)
        if OPTIONS["cache"]:
            dispatcher.enable_caching()
        dispatcher.strict = strict
        dispatcher.size, dispatcher.serial_below = size, serial_below
        return dispatcher
    return decorate
