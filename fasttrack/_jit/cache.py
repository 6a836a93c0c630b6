"""Where compiled kernels are kept: the kernels shipped inside the installed package, read
only, then a per-user directory, where new ones are written.

**Shipped kernels.** ``pip install .`` builds its wheel with fasttrack's build backend,
which compiles every kernel family on the machine that will run them and puts the result in
``fasttrack/_kernels/<tag>`` (:func:`tag`: the numba version, NumPy's major.minor and the
Python implementation), compressed (:func:`compress`), with a manifest of what they were
compiled for: the kernel sources' digest, the CPU (Numba's target triple, CPU name and
features) and the Numba settings that change generated code (:func:`settings`). They are
never written to, so a read-only ``site-packages`` works. A copy of fasttrack without
kernels of its own (a source checkout) reads those of an installed distribution if they were
compiled from the same sources. When they cannot serve (an editable install, another numba
or NumPy, another CPU, other ``NUMBA_*`` settings, other sources), kernels are compiled on
first use as below, and the first compilation in a process says why, once.
``FASTTRACK_SHIPPED_KERNELS=0`` ignores them.

**Per-user kernels.** New entries go to the first writable one of

- ``$FASTTRACK_CACHE_DIR``;
- ``$NUMBA_CACHE_DIR/fasttrack`` (Numba's own setting);
- the platform's user cache directory: ``$XDG_CACHE_HOME/fasttrack`` or
  ``~/.cache/fasttrack`` (Linux), ``~/Library/Caches/fasttrack`` (macOS),
  ``%LOCALAPPDATA%\\fasttrack\\Cache`` (Windows),

each with a sub-directory ``<fasttrack version>-<tag>``. With none writable, fasttrack
compiles in memory and warns once. Entries are saved under a file lock, data before index,
so processes compiling different signatures of one kernel at once lose none and never pair
one signature with another's code.

Every entry is keyed by Numba's key (signature, CPU, bytecode) plus :func:`settings`, and
stamped with a digest of all the kernel sources (a kernel's compiled code contains the
helpers it calls, so an edited helper invalidates its callers). A damaged entry (truncated,
empty, garbage) is compiled again into the per-user directory, with a warning, instead of
failing every call. Users' functions reach kernels as first-class functions typed by their
signature (``UserFunction.callee``), so those kernels are cached like any other; a kernel
compiled for a dispatcher argument is kept in memory only: the function is part of its
type, and no later process could find the entry again.
"""
import contextlib
import functools
import hashlib
import importlib.metadata
import json
import os
import pathlib
import pickle
import sys
import tempfile
import warnings
import zlib

import numba
import numpy as np
from numba.core import config, sigutils, types
from numba.core.caching import (CompileResultCacheImpl, FunctionCache, IndexDataCacheFile,
                                _CacheLocator)

#: The environment variable that names the per-user cache directory.
ENVIRONMENT = "FASTTRACK_CACHE_DIR"

#: The environment variable that, set to 0, ignores the shipped kernels.
SHIPPED_ENVIRONMENT = "FASTTRACK_SHIPPED_KERNELS"

#: Numba settings that change the code generated for the same source and CPU; Numba's own
#: key leaves them out.
CODE_SETTINGS = ("OPT", "LOOP_VECTORIZE", "SLP_VECTORIZE", "BOUNDSCHECK", "DEBUGINFO_DEFAULT",
                 "ENABLE_AVX", "LLVM_REFPRUNE_PASS", "EXTEND_VARIABLE_LIFETIMES")

#: The shipped kernels' folder in this copy of the package, and their manifest's name.
SHIPPED = pathlib.Path(__file__).resolve().parents[1] / "_kernels"
MANIFEST = "manifest.json"

#: How the shipped kernels' entries are stored (:func:`compress`), in their manifest.
ENTRIES = "numba, zlib-compressed"

_SOURCES = pathlib.Path(__file__).resolve().parent


def _version():
    from .._version import __version__
    return __version__


@functools.lru_cache(maxsize=None)
def tag():
    """The name of what makes compiled kernels unusable elsewhere besides the CPU:
    ``numba<version>-numpy<major.minor>-<Python cache tag>``."""
    major_minor = ".".join(np.__version__.split(".")[:2])
    return f"numba{numba.__version__}-numpy{major_minor}-{sys.implementation.cache_tag}"


def settings():
    """The Numba settings of :data:`CODE_SETTINGS` in force, as ``{name: repr(value)}``."""
    return {name: repr(getattr(config, name, None)) for name in CODE_SETTINGS}


def _outside():
    """The ``stacklevel`` that makes a warning issued by this function's caller point at the
    first frame outside fasttrack and Numba (the user's call)."""
    inside = tuple(os.path.dirname(os.path.realpath(module.__file__)) + os.sep
                   for module in (sys.modules[__name__.split(".")[0]], numba))
    frame, level = sys._getframe(2), 2
    while frame is not None and os.path.realpath(frame.f_code.co_filename).startswith(inside):
        frame, level = frame.f_back, level + 1
    return level


def _user_cache_root():
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.expanduser("~\\AppData\\Local")
        return pathlib.Path(base) / "fasttrack" / "Cache"
    if sys.platform == "darwin":
        return pathlib.Path.home() / "Library" / "Caches" / "fasttrack"
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return pathlib.Path(base) / "fasttrack"


def candidates():
    """The per-user directories tried, in order."""
    roots = []
    if os.environ.get(ENVIRONMENT):
        roots.append(pathlib.Path(os.environ[ENVIRONMENT]))
    if os.environ.get("NUMBA_CACHE_DIR"):
        roots.append(pathlib.Path(os.environ["NUMBA_CACHE_DIR"]) / "fasttrack")
    roots.append(_user_cache_root())
    return [root / f"{_version()}-{tag()}" for root in roots]


def _writable(path):
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


@functools.lru_cache(maxsize=None)
def directory():
    """The per-user directory in use, or None (with a warning, once) if none is writable."""
    tried = candidates()
    for path in tried:
        if _writable(path):
            return path
    warnings.warn(f"fasttrack: no writable directory for its compiled kernels (tried "
                  f"{', '.join(map(str, tried))}); they are compiled in memory in every "
                  f"process. Set {ENVIRONMENT} to a writable directory to keep them.",
                  RuntimeWarning, stacklevel=_outside())
    return None


@functools.lru_cache(maxsize=None)
def source_stamp():
    """A digest of every kernel source file (and the fasttrack version): the modules of
    this package but this one, which holds no kernel and no compile option."""
    digest = hashlib.sha256(_version().encode())
    for path in sorted(set(_SOURCES.glob("*.py")) - {pathlib.Path(__file__).resolve()}):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _cpu():
    from numba.core.registry import cpu_target
    return list(cpu_target.target_context.codegen().magic_tuple())


def manifest():
    """What kernels compiled in this process are compiled for (a shipped folder's
    manifest)."""
    return {"fasttrack": _version(), "tag": tag(), "source_stamp": source_stamp(),
            "entries": ENTRIES, "cpu": _cpu(), "settings": settings()}


def write_manifest(path):
    """Write :func:`manifest` into the folder ``path``."""
    (pathlib.Path(path) / MANIFEST).write_text(json.dumps(manifest(), indent=1))


def compress(path):
    """Compress the data files of the kernels in the folder ``path`` in place, as the
    shipped kernels are kept (:class:`_ShippedStore`): less than half the size, about
    0.3 ms a kernel to expand when it is loaded."""
    for data in pathlib.Path(path).glob("*.nbc"):
        data.write_bytes(zlib.compress(data.read_bytes()))


def _installed_kernels():
    """The shipped kernels' folders of the fasttrack distributions on ``sys.path`` (a source
    checkout's build metadata counts as one too, without kernels)."""
    found = (dist.locate_file("fasttrack/_kernels")
             for dist in importlib.metadata.distributions(name="fasttrack"))
    return [pathlib.Path(folder).resolve() for folder in found]


def _mismatch(recorded):
    """Why kernels compiled as ``recorded`` (a manifest) cannot serve this process, or
    None."""
    here = manifest()
    if recorded.get("source_stamp") != here["source_stamp"]:
        return "they were compiled from other fasttrack sources"
    if recorded.get("entries") != here["entries"]:
        return "they are stored in another format (by another version of fasttrack)"
    if recorded.get("cpu") != here["cpu"]:
        there, this = recorded.get("cpu") or ["", "?", ""], here["cpu"]
        which = "with other CPU features" if there[1] == this[1] else \
            f"for another CPU ({there[1]}; this one is {this[1]})"
        return f"they were compiled {which}"
    if recorded.get("settings") != here["settings"]:
        changed = [f"{name} {recorded.get('settings', {}).get(name)} there, {value} here"
                   for name, value in here["settings"].items()
                   if recorded.get("settings", {}).get(name) != value]
        return f"they were compiled with other Numba settings ({'; '.join(changed)})"
    return None


def shipped_enabled():
    """Whether :data:`SHIPPED_ENVIRONMENT` lets the shipped kernels be read (unset, 1, true,
    yes, on; 0, false, no, off do not; anything else is a ValueError naming it)."""
    value = os.environ.get(SHIPPED_ENVIRONMENT, "1").strip().lower()
    if value not in ("0", "1", "false", "true", "no", "yes", "off", "on"):
        raise ValueError(f"{SHIPPED_ENVIRONMENT} must be 0 or 1 (or false/true, no/yes, "
                         f"off/on), got {os.environ[SHIPPED_ENVIRONMENT]!r}")
    return value in ("1", "true", "yes", "on")


@functools.lru_cache(maxsize=None)
def shipped():
    """``(folder, None)`` with the shipped kernels this process can load, or ``(None,
    reason)`` saying why there are none (reason None when they are switched off)."""
    if not shipped_enabled():
        return None, None
    roots = [SHIPPED] if SHIPPED.is_dir() else list(dict.fromkeys(_installed_kernels()))
    reasons = []
    for root in roots:
        folder = root / tag()
        try:
            reason = _mismatch(json.loads((folder / MANIFEST).read_text()))
        except FileNotFoundError:
            others = sorted(p.parent.name for p in root.glob(f"*/{MANIFEST}"))
            if others:
                reasons.append(f"they were compiled for {', '.join(others)}, and this process "
                               f"runs {tag()}")
            continue
        except (OSError, ValueError, TypeError, LookupError, AttributeError) as error:
            reason = f"their manifest {folder / MANIFEST} cannot be read ({error!r})"
        if reason is None:
            return folder, None
        reasons.append(reason)
    if not reasons:
        return None, ("this installation carries none (an editable install, or a wheel built "
                      "with FASTTRACK_COMPILE_KERNELS=0)")
    return None, reasons[0]


@functools.lru_cache(maxsize=None)
def _explain_compiling():
    """Say, once a process, why kernels are compiled although kernels ship with fasttrack."""
    _, reason = shipped()
    if reason is not None:
        warnings.warn(f"fasttrack: compiling kernels on first use (seconds per filter family) "
                      f"because the kernels shipped with fasttrack cannot be used: {reason}. "
                      f"`python -m fasttrack warmup` compiles every family now, for later "
                      f"processes too.", RuntimeWarning, stacklevel=_outside())


@contextlib.contextmanager
def _locked(path):
    """Hold an exclusive lock on the file ``path`` (made if needed) against other
    processes."""
    with open(path, "a+b") as handle:
        if sys.platform == "win32":
            import msvcrt
            while True:
                try:
                    msvcrt.locking(handle.fileno(), msvcrt.LK_LOCK, 1)
                    break
                except OSError:  # gave up after its ten one-second tries
                    continue
            try:
                yield
            finally:
                handle.seek(0)
                msvcrt.locking(handle.fileno(), msvcrt.LK_UNLCK, 1)
        else:
            import fcntl
            fcntl.flock(handle, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(handle, fcntl.LOCK_UN)


class _Store(IndexDataCacheFile):
    """One kernel's index and data files in one folder. A save holds the folder's lock while
    it reads the index, writes the data and then the index; an unreadable index is
    replaced."""

    LOCK = ".lock"

    def save(self, key, data):
        with _locked(os.path.join(self._cache_path, self.LOCK)):
            try:
                overloads = self._load_index()
            except Exception:  # a damaged index: start a new one
                overloads = {}
            name = overloads.get(key)
            if name is None:
                used = set(overloads.values())
                name = next(self._data_name(n) for n in range(1, len(used) + 2)
                            if self._data_name(n) not in used)
            self._save_data(name, data)
            if overloads.get(key) != name:
                overloads[key] = name
                self._save_index(overloads)


class _ShippedStore(_Store):
    """A :class:`_Store` of shipped kernels, whose data files are compressed
    (:func:`compress`)."""

    def _load_data(self, name):
        with open(self._data_path(name), "rb") as f:
            return pickle.loads(zlib.decompress(f.read()))


class _Locator(_CacheLocator):
    """Names every fasttrack kernel by file, qualified name and line, and stamps it with
    :func:`source_stamp` (the folders are chosen by :class:`KernelCache`)."""

    def __init__(self, py_func):
        self._lineno = py_func.__code__.co_firstlineno
        self._py_file = py_func.__code__.co_filename  # named by Numba's uncachable warning

    def get_cache_path(self):
        return str(directory())

    def get_source_stamp(self):
        return source_stamp()

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        return cls(py_func)


class _Impl(CompileResultCacheImpl):
    _locator_classes = [_Locator]


def _takes_functions(sig):
    args, _ = sigutils.normalize_signature(sig)
    return any(isinstance(arg, (types.Dispatcher, types.Function)) for arg in args)


class KernelCache(FunctionCache):
    """Numba's on-disk cache of one kernel, loading from the shipped kernels, then the
    per-user directory, and saving to the per-user directory only (folders chosen on first
    use). An entry that cannot be read is compiled again, with a warning; signatures with
    function arguments are not kept."""

    _impl_class = _Impl

    def __init__(self, py_func):  # Numba's own picks its one folder here; ours are lazy
        self._name = repr(py_func)
        self._py_func = py_func
        self._impl = self._impl_class(py_func)
        self.enable()

    def _store(self, kind, folder):
        return None if folder is None else kind(str(folder), self._impl.filename_base,
                                                source_stamp())

    @functools.cached_property
    def _shipped(self):
        return self._store(_ShippedStore, shipped()[0])

    @functools.cached_property
    def _user(self):
        return self._store(_Store, directory())

    @property
    def cache_path(self):
        return self._user and self._user._cache_path

    def flush(self):
        if self._user is not None:
            self._user.flush()

    def _index_key(self, sig, codegen):
        return super()._index_key(sig, codegen) + (tuple(sorted(settings().items())),)

    def load_overload(self, sig, target_context):
        if not self._enabled or _takes_functions(sig):
            return None
        target_context.refresh()
        key = self._index_key(sig, target_context.codegen())
        for which in ("_shipped", "_user"):  # the per-user folder only if needed
            store = getattr(self, which)
            if store is None:
                continue
            try:
                data = store.load(key)
                if data is not None:
                    return self._impl.rebuild(target_context, data)
            except Exception as error:  # any unreadable entry: compile instead
                mend = "reinstall fasttrack to mend it" if store is self._shipped else \
                    "it is replaced"
                warnings.warn(f"fasttrack: the compile cache entry of "
                              f"{self._py_func.__qualname__} in {store._cache_path} is damaged "
                              f"({type(error).__name__}: {error}); compiling it again ({mend})",
                              RuntimeWarning, stacklevel=_outside())
        _explain_compiling()
        return None

    def save_overload(self, sig, data):
        if not self._enabled or _takes_functions(sig) or self._user is None:
            return
        if self._impl.check_cachable(data):
            self._user.save(self._index_key(sig, data.codegen), self._impl.reduce(data))
