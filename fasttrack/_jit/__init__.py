"""All Numba code of fasttrack: njit kernels with private names, no classes.

Every kernel is compiled through :func:`jit` (:mod:`dispatch`), the one place where
compilation options live. This package and its modules of constants (``status``,
``tunables``, ``kinds``) import without Numba; the array layer holds the kernel modules
through :func:`lazy`, so that Numba is imported with the first kernel a program needs;
until then, a program's first small calls run in NumPy (:func:`numpy_first`).

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

Three properties of the dispatchers made here go beyond Numba's defaults:

- a kernel whose name starts with an underscore is called only from other kernels: it is
  compiled without the wrappers for calls from Python and without machine code or a cache
  entry of its own (:class:`KernelOnly`; each caller optimises it with its own code), and
  tests call it through a kernel of their own;
- they load from the kernels compiled when the package was built, then from a per-user
  directory, and save to the per-user one (:mod:`cache`), where a damaged entry is
  recompiled, with a warning, instead of failing every call;
- kernels that reach parallel regions choose their thread count per call (one thread for
  small work; see :mod:`fasttrack.threads`), and where Numba's threading layer is its
  ``workqueue`` (no OpenMP or TBB library), which aborts the process when two threads run
  parallel regions at once, their calls from Python are serialised by one process-wide
  lock, so kernels may be called from several threads on every layer.
"""
import importlib
import sys

from .tunables import NUMPY_WORK

#: What :mod:`dispatch` defines, read through this package (``fasttrack._jit.jit``).
_DISPATCH = frozenset({
    "CALL_LOCK", "Compiled", "FASTMATH", "KERNEL_ONLY", "Kernel", "KernelOnly", "OPTIONS",
    "SERIALISE", "SERIAL_BELOW_LIGHT", "ThreadedKernel", "compiles",
    "jit", "kernels", "layer_is_threadsafe", "serial_twin", "with_constant"})


def __getattr__(name):
    if name in _DISPATCH:
        return getattr(importlib.import_module(f"{__name__}.dispatch"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _Kernels:
    """A kernel module's stand-in: the first attribute read imports the module (and Numba)
    and copies its names in, so later reads are plain lookups (safe from several threads:
    the import system serialises the import and the copy is idempotent)."""

    def __init__(self, name):
        self._module = name

    def __getattr__(self, name):
        module = importlib.import_module(self._module)
        self.__dict__.update(vars(module))
        return getattr(module, name)


def lazy(name):
    """The kernel module ``fasttrack._jit.<name>``, imported when one of its attributes is
    first read: the array layer holds these, so Numba is imported with the first kernel a
    program needs, not with fasttrack."""
    return _Kernels(f"{__name__}.{name}")


#: Work units (filters, tracks, detections) still to run in NumPy before the first kernel.
_numpy_work = NUMPY_WORK


def kernels_loaded():
    """Whether the process runs kernels: one has been loaded (from then on every call
    does)."""
    return f"{__name__}.dispatch" in sys.modules


def numpy_first(work=1):
    """Whether a call of ``work`` units (the filters, tracks and detections it handles)
    runs in NumPy: while no kernel is loaded, a process's calls do until their work totals
    :data:`~fasttrack._jit.tunables.NUMPY_WORK`; a larger call, and every call after it,
    loads the kernels (a short script never pays Numba's set-up, a long one pays NumPy's
    slower steps a bounded number of times). The NumPy twins use the kernels' formulas,
    tolerances and status codes: results equal to rounding, the same errors."""
    global _numpy_work
    if work > _numpy_work or kernels_loaded():
        return False
    _numpy_work -= work
    return True


def kernels_from_now():
    """End the NumPy first calls: the kernels run from the next call on, for work whose
    results must not depend on what the process ran before (the bits of a Monte Carlo run
    wherever it runs, a warmup that compiles every kernel)."""
    global _numpy_work
    _numpy_work = 0
