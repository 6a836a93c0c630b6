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

- **NumPy's BLAS threads.** After a threaded product, NumPy's OpenBLAS workers busy-wait for
  2^28 cycles (about 0.1 s), holding the cores a parallel kernel then needs: a particle-filter
  loop at N = 1e5 that draws its prior with ``multivariate_normal`` ran 1.4-1.6x slower than
  with ``OPENBLAS_NUM_THREADS=1``. Before its first parallel call, fasttrack shortens that wait
  to 2^20 cycles (about 0.4 ms), once per process (:func:`calm_blas`), which brings the loop
  to within 1.1x of one BLAS thread. Only a pthreads OpenBLAS that NumPy has loaded is
  touched; a user's ``OPENBLAS_THREAD_TIMEOUT``, or ``FASTTRACK_CALM_BLAS=0``, leaves it as
  it is. BLAS thread counts are not changed.

Numba's thread count is per Python thread, and fasttrack sets it for its own calls: use
:func:`set_threads` rather than ``numba.set_num_threads``.
"""
import concurrent.futures
import ctypes
import glob
import os
import site
import sys
import threading

__all__ = ["get_threads", "set_threads"]

_LIBTBB = {"linux": "libtbb.so.12", "darwin": "libtbb.12.dylib", "win32": "tbb12.dll"}
_local = threading.local()
_limit = None
_pool = None
#: log2 of the cycles NumPy's OpenBLAS workers busy-wait after a product (OpenBLAS: 28).
BLAS_TIMEOUT = 20
_calmed = None  # None: not tried yet; True: done; False: nothing to do in this process
_calm_lock = threading.Lock()


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
    if not serial and _calmed is None:
        calm_blas()
    wanted = 1 if serial else get_threads()
    if getattr(_local, "threads", None) != wanted:
        import numba
        numba.set_num_threads(wanted)
        _local.threads = wanted


def in_chunks(run, n, serial_below, align=1, work=None, per_thread=1):
    """Call ``run(lo, hi)`` over ``[0, n)``: at once where ``work`` (default ``n``) is below
    ``serial_below``, else on ``per_thread`` chunks a thread of :func:`get_threads` threads
    (boundaries multiples of ``align``; several a thread balance items of uneven cost) in a
    pool of threads. ``run`` must release the GIL (a ``nogil`` kernel) and write disjoint
    outputs."""
    threads = get_threads()
    if (n if work is None else work) < serial_below or threads == 1 or n <= align:
        run(0, n)
        return
    if _calmed is None:
        calm_blas()
    global _pool
    if _pool is None or _pool._max_workers != threads:
        _pool = concurrent.futures.ThreadPoolExecutor(threads, thread_name_prefix="fasttrack")
    step = -(-n // (threads * per_thread))
    step = -(-step // align) * align
    for future in [_pool.submit(run, lo, min(lo + step, n)) for lo in range(0, n, step)]:
        future.result()


def calm_blas():
    """Once per process: make NumPy's OpenBLAS workers busy-wait :data:`BLAS_TIMEOUT`
    (log2 cycles) after a product instead of 2^28, so that they leave the cores to
    fasttrack's parallel kernels (see the module notes). OpenBLAS re-reads
    ``OPENBLAS_THREAD_TIMEOUT`` (set for that moment only) and restarts its idle pool.

    Does nothing for another BLAS, an OpenMP OpenBLAS, a user's ``OPENBLAS_THREAD_TIMEOUT``
    or ``FASTTRACK_CALM_BLAS=0``. The pool's restart must not meet a product in another
    thread, so while any other non-daemon Python thread (not fasttrack's own) is alive it
    waits for a later call.
    """
    global _calmed
    with _calm_lock:
        if _calmed is not None:
            return
        if "OPENBLAS_THREAD_TIMEOUT" in os.environ or \
                os.environ.get("FASTTRACK_CALM_BLAS") == "0":
            _calmed = False
            return
        me = threading.current_thread()
        if not all(t is me or t.daemon or t.name.startswith("fasttrack")
                   for t in threading.enumerate()):
            return
        blas = _numpy_openblas()
        if blas is None:
            _calmed = False
            return
        os.environ["OPENBLAS_THREAD_TIMEOUT"] = str(BLAS_TIMEOUT)
        try:
            blas.openblas_read_env()
        finally:
            del os.environ["OPENBLAS_THREAD_TIMEOUT"]  # child processes inherit nothing
        blas.blas_thread_shutdown_()
        _calmed = True


def _numpy_openblas():
    """NumPy's OpenBLAS (a ``ctypes.CDLL``) if it is a pthreads build with the two entry
    points :func:`calm_blas` calls, else None; only a library already loaded is opened."""
    import numpy as np
    base = os.path.dirname(np.__file__)
    paths = (glob.glob(os.path.join(base, os.pardir, "numpy.libs", "*openblas*"))
             + glob.glob(os.path.join(base, ".dylibs", "*openblas*")))
    if not paths and os.path.exists("/proc/self/maps"):  # a system OpenBLAS
        with open("/proc/self/maps") as maps:
            paths = sorted({line.split()[-1] for line in maps
                            if "openblas" in line.rsplit("/", 1)[-1].lower()})
    for path in paths:
        try:
            blas = ctypes.CDLL(path, mode=getattr(os, "RTLD_NOLOAD", 0))
        except OSError:
            continue
        parallel = next((getattr(blas, name) for name in (
            "scipy_openblas_get_parallel64_", "scipy_openblas_get_parallel",
            "openblas_get_parallel64_", "openblas_get_parallel") if hasattr(blas, name)), None)
        if parallel is None or not (hasattr(blas, "openblas_read_env")
                                    and hasattr(blas, "blas_thread_shutdown_")):
            continue
        parallel.restype = ctypes.c_int
        return blas if parallel() == 1 else None  # 0 sequential, 2 OpenMP: no spinning
    return None
