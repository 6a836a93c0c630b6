"""Process memory settings that matter for large particle clouds."""
import ctypes
import ctypes.util

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def tune_allocator(mmap_threshold_mb=64, trim_threshold_mb=1024):
    """Let glibc's malloc keep freed memory for reuse instead of returning it to the system.

    A filter step allocates arrays of N floats and frees those of the step before. By
    default glibc maps large arrays afresh and hands freed memory back, so every step pays a
    page fault per 4 KiB (2.5 us each on some virtual machines: several milliseconds a step
    at N = 1e5). With this, arrays below ``mmap_threshold_mb`` come from the heap, and up to
    ``trim_threshold_mb`` of freed memory stays there for the next step. It affects the whole
    process (its memory stays near its peak) and is never applied implicitly.

    Parameters
    ----------
    mmap_threshold_mb : float
        Size in MiB from which an allocation is mapped afresh (glibc's
        ``M_MMAP_THRESHOLD``).
    trim_threshold_mb : float
        MiB of free memory at the top of the heap kept before it is returned to the system
        (glibc's ``M_TRIM_THRESHOLD``).

    Returns
    -------
    bool
        True if applied; False where the C library is not glibc (nothing changes).
    """
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    mib = 1 << 20
    return bool(mallopt(_M_MMAP_THRESHOLD, int(mmap_threshold_mb * mib))
                and mallopt(_M_TRIM_THRESHOLD, int(trim_threshold_mb * mib)))
