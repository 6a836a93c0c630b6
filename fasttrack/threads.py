"""How fasttrack's kernels use threads.

The policy, measured on 2 cores (a particle-filter step at N = 1e5; ``bench/test_load.py``):

- **Threading layer.** Numba's parallel kernels run on Intel TBB when it is installed (it is a
  dependency on x86-64): TBB's idle workers yield their core, so when two fasttrack processes
  share two cores each steps about as fast as on one thread (1.9 ms against 1.9 ms), where
  OpenMP's workers spin-wait for a partner that has no core and a step took 80 ms. Alone,
  both run a step in 0.9 ms (1.9x one thread). Without TBB, Numba's default layer is used
  (OpenMP), with the spinning shortened to ``GOMP_SPINCOUNT=1000`` unless ``GOMP_SPINCOUNT`` or
  ``OMP_WAIT_POLICY`` is set. This is arranged when fasttrack's first kernel is needed,
  before Numba starts its threads; nothing is changed if ``NUMBA_THREADING_LAYER`` is set or
  Numba's threads run already.
- **Small work runs on one thread.** Each kernel with parallel regions declares the size of
  its work; below a threshold (where starting threads costs more than it saves) a call from
  Python runs a serial build of the kernel, which also compiles in about half the time, so a
  first step at small N waits less.
- **A limit.** :func:`set_threads` caps the threads of fasttrack's calls (default: Numba's
  ``NUMBA_NUM_THREADS``, the cores). Results never depend on the thread count.
- **Batches of filters** run their compiled (single-threaded, GIL-free) step on chunks of
  the batch in a pool of Python threads: as fast as a parallel kernel,
  without Numba compiling a parallel version of a large step.

Numba's thread count is per Python thread, and fasttrack sets it for its own calls: use
:func:`set_threads` rather than ``numba.set_num_threads``.
"""
import concurrent.futures
import ctypes
import os
import site
import sys
import threading

__all__ = ["get_threads", "set_threads"]

_LIBTBB = {"linux": "libtbb.so.12", "darwin": "libtbb.12.dylib", "win32": "tbb12.dll"}
_local = threading.local()
_limit = None
_pool = None


def _tbb_candidates():
    name = _LIBTBB.get(sys.platform)
    if name is None:
        return []
    folders = [os.path.join(base, *sub) for base in (sys.prefix, site.getuserbase())
               for sub in (("lib",), ("Library", "bin"))]
    return [os.path.join(folder, name) for folder in folders]


def _load_tbb():
    """Load the TBB library of the ``tbb`` package (pip puts it where the dynamic loader
    does not look), so that Numba's default layer choice finds it; True if loaded."""
    for path in _tbb_candidates():
        if os.path.exists(path):
            try:
                ctypes.CDLL(path, mode=getattr(ctypes, "RTLD_GLOBAL", 0))
                return True
            except OSError:
                continue
    return False


def configure():
    """Arrange the threading layer as the module's notes say (called when the kernels'
    dispatchers are first imported, before any parallel region starts)."""
    if os.environ.get("NUMBA_THREADING_LAYER"):
        return
    from numba.np.ufunc import parallel
    if parallel._is_initialized:
        return
    if not _load_tbb() and not ("GOMP_SPINCOUNT" in os.environ
                                or "OMP_WAIT_POLICY" in os.environ):
        os.environ["GOMP_SPINCOUNT"] = "1000"


def set_threads(n):
    """Use at most ``n`` threads in fasttrack's kernels (results do not depend on it).

    Parameters
    ----------
    n : int
        1 to ``NUMBA_NUM_THREADS`` (the number of cores unless set).
    """
    import numba
    from ._validate import count
    global _limit
    _limit = count(n, "n", maximum=numba.config.NUMBA_NUM_THREADS)


def get_threads():
    """The most threads fasttrack's kernels use (see :func:`set_threads`)."""
    if _limit is None:
        import numba
        return numba.config.NUMBA_NUM_THREADS
    return _limit


def use(serial):
    """Set the calling thread's Numba thread count for a kernel call: 1 if ``serial``,
    else :func:`get_threads` (only when it changes: Numba's setter costs a microsecond)."""
    wanted = 1 if serial else get_threads()
    if getattr(_local, "threads", None) != wanted:
        import numba
        numba.set_num_threads(wanted)
        _local.threads = wanted


def in_chunks(run, n, serial_below, align=1):
    """Call ``run(lo, hi)`` over ``[0, n)``: at once below ``serial_below``, else on
    :func:`get_threads` chunks (boundaries multiples of ``align``) in a pool of threads.
    ``run`` must release the GIL (a ``nogil`` kernel) and write disjoint outputs."""
    threads = get_threads()
    if n < serial_below or threads == 1:
        run(0, n)
        return
    global _pool
    if _pool is None or _pool._max_workers != threads:
        _pool = concurrent.futures.ThreadPoolExecutor(threads, thread_name_prefix="fasttrack")
    step = -(-n // threads)
    step = -(-step // align) * align
    for future in [_pool.submit(run, lo, min(lo + step, n)) for lo in range(0, n, step)]:
        future.result()
