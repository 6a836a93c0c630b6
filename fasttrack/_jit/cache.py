"""Where compiled kernels are kept: a per-user directory, never inside the installed package.

The directory is the first of

- ``$FASTTRACK_CACHE_DIR``;
- ``$NUMBA_CACHE_DIR/fasttrack`` (Numba's own setting);
- the platform's user cache directory: ``$XDG_CACHE_HOME/fasttrack`` or
  ``~/.cache/fasttrack`` (Linux), ``~/Library/Caches/fasttrack`` (macOS),
  ``%LOCALAPPDATA%\\fasttrack\\Cache`` (Windows),

with one sub-directory per fasttrack version, that can be written to. Entries are stamped
with a digest of all the kernel sources (not only the function's own file: a kernel's
compiled code contains the helpers it calls), so an edited helper invalidates its callers.
With no writable directory, fasttrack compiles in memory and warns once.

A damaged entry (a truncated, empty or garbage index or data file) is compiled again and
replaced, with a warning, instead of failing every call. A kernel compiled for a user's
function (an argument of a function type) is kept in memory only: the function is part of
its type, and no later process could find the entry again.
"""
import functools
import hashlib
import os
import pathlib
import sys
import tempfile
import warnings

from numba.core import sigutils, types
from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator

#: The environment variable that names the cache directory.
ENVIRONMENT = "FASTTRACK_CACHE_DIR"

_SOURCES = pathlib.Path(__file__).resolve().parent


def _version():
    from .._version import __version__
    return __version__


def _user_cache_root():
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.expanduser("~\\AppData\\Local")
        return pathlib.Path(base) / "fasttrack" / "Cache"
    if sys.platform == "darwin":
        return pathlib.Path.home() / "Library" / "Caches" / "fasttrack"
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return pathlib.Path(base) / "fasttrack"


def candidates():
    """The directories tried, in order (each with the version's sub-directory)."""
    roots = []
    if os.environ.get(ENVIRONMENT):
        roots.append(pathlib.Path(os.environ[ENVIRONMENT]))
    if os.environ.get("NUMBA_CACHE_DIR"):
        roots.append(pathlib.Path(os.environ["NUMBA_CACHE_DIR"]) / "fasttrack")
    roots.append(_user_cache_root())
    return [root / _version() for root in roots]


def _writable(path):
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


@functools.lru_cache(maxsize=None)
def directory():
    """The cache directory in use, or None (with a warning, once) if none is writable."""
    tried = candidates()
    for path in tried:
        if _writable(path):
            return path
    warnings.warn(f"fasttrack: no writable directory for its compiled kernels (tried "
                  f"{', '.join(map(str, tried))}); they are compiled in memory in every "
                  f"process. Set {ENVIRONMENT} to a writable directory to keep them.",
                  RuntimeWarning, stacklevel=2)
    return None


@functools.lru_cache(maxsize=None)
def source_stamp():
    """A digest of every kernel source file (and the fasttrack version)."""
    digest = hashlib.sha256(_version().encode())
    for path in sorted(_SOURCES.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


class _Locator(_CacheLocator):
    """Every fasttrack kernel in :func:`directory`, stamped with :func:`source_stamp`."""

    def __init__(self, py_func):
        self._lineno = py_func.__code__.co_firstlineno
        self._py_file = py_func.__code__.co_filename  # named by Numba's uncachable warning
        self._path = str(directory())

    def get_cache_path(self):
        return self._path

    def get_source_stamp(self):
        return source_stamp()

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        return None if directory() is None else cls(py_func)


class _Impl(CompileResultCacheImpl):
    _locator_classes = [_Locator]


def _takes_functions(sig):
    args, _ = sigutils.normalize_signature(sig)
    return any(isinstance(arg, (types.Dispatcher, types.Function)) for arg in args)


class KernelCache(FunctionCache):
    """Numba's on-disk cache in :func:`directory`, except that an entry that cannot be
    read is compiled again and replaced, with a warning, and signatures with function
    arguments are not kept."""

    _impl_class = _Impl

    def load_overload(self, sig, target_context):
        if _takes_functions(sig):
            return None
        try:
            return super().load_overload(sig, target_context)
        except Exception as error:  # any unreadable entry: compile instead
            warnings.warn(f"fasttrack: the compile cache entry of {self._py_func.__name__} "
                          f"in {self.cache_path} is damaged ({type(error).__name__}: {error}); "
                          f"compiling it again and replacing it", RuntimeWarning, stacklevel=2)
            return None

    def save_overload(self, sig, data):
        if _takes_functions(sig):
            return
        try:
            super().save_overload(sig, data)
        except Exception:  # a damaged index: start a new one
            self._cache_file._save_index({})
            super().save_overload(sig, data)
