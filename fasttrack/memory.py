"""Process memory settings that matter for large particle clouds."""
import ctypes
import ctypes.util

from . import _validate

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
        ``M_MMAP_THRESHOLD``), in [0, 2048) (mallopt takes a C int of bytes).
    trim_threshold_mb : float
        MiB of free memory at the top of the heap kept before it is returned to the system
        (glibc's ``M_TRIM_THRESHOLD``), in [0, 2048).

    Returns
    -------
    bool
        True if applied; False where the C library is not glibc (nothing changes).

    Raises
    ------
    TypeError, ValueError
        For a size that is not a real number in [0, 2048).
    """
    mib = 1 << 20
    sizes = [_megabytes(mmap_threshold_mb, "mmap_threshold_mb") * mib,
             _megabytes(trim_threshold_mb, "trim_threshold_mb") * mib]
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, int(sizes[0]))
                and mallopt(_M_TRIM_THRESHOLD, int(sizes[1])))


def _megabytes(value, name):
    """``value`` MiB, checked to be a number in [0, 2048) (its bytes fit a C int)."""
    value = _validate.non_negative(value, name)
    if value >= 2048:
        raise ValueError(f"{name} must be below 2048 MiB (mallopt takes a C int of bytes), "
                         f"got {value:g}")
    return value
