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
"""
import numba

#: Floating-point relaxations allowed in kernels. ``nnan``/``ninf`` are excluded because
#: ``-inf`` log weights are legal; ``reassoc`` is excluded because it lets LLVM rewrite
#: compensated arithmetic (it breaks the Cody-Waite reduction of :func:`fast_exp`) and
#: makes the order of summation a compiler decision.
FASTMATH = frozenset({"nsz", "arcp", "contract", "afn"})

#: Options shared by every dispatcher; a test checks each one against this.
OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


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
        dispatcher = numba.njit(parallel=parallel, fastmath=fastmath, **OPTIONS)(func)
        dispatcher.strict = strict
        return dispatcher
    return decorate
