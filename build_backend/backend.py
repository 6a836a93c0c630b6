"""fasttrack's build backend: setuptools' own, plus compiled kernels in the wheel.

``build_wheel`` builds the wheel with setuptools, compiles every kernel family of that
wheel's code on this machine (``fasttrack._warmup.ship``, in separate processes, one a
core) into ``fasttrack/_kernels/<tag>``, adds them to the wheel and tags it for this
interpreter and platform, since it now carries machine code for this CPU. The sdist,
editable installs and metadata are setuptools' own.

Packagers switch the compile off with ``FASTTRACK_COMPILE_KERNELS=0`` or
``pip install . --config-settings compile-kernels=false``: the wheel is then pure Python, and
kernels compile on first use.
"""
import base64
import hashlib
import os
import pathlib
import subprocess
import sys
import sysconfig
import tempfile
import zipfile

from setuptools import build_meta as _setuptools
from setuptools.build_meta import (build_editable, build_sdist,  # noqa: F401 (hooks)
                                   get_requires_for_build_editable,
                                   get_requires_for_build_sdist,
                                   prepare_metadata_for_build_editable,
                                   prepare_metadata_for_build_wheel)

#: The ``--config-settings`` key and the environment variable that switch the compile off.
SETTING = "compile-kernels"
ENVIRONMENT = "FASTTRACK_COMPILE_KERNELS"

_SHIP = """
import sys, time
from fasttrack._warmup import ship
start = time.perf_counter()
def report(family, seconds):
    print(f"fasttrack: {family} kernels compiled ({time.perf_counter() - start:.0f} s)",
          flush=True)
print(f"fasttrack: kernels compiled into {ship(sys.argv[1], report=report)}", flush=True)
"""


def _compiling(config_settings):
    """Whether to compile: the ``compile-kernels`` setting, else :data:`ENVIRONMENT`, else
    yes (1, true, yes, on; 0, false, no, off; anything else is a ValueError naming it)."""
    settings = config_settings or {}
    name, value = (SETTING, settings[SETTING]) if SETTING in settings else \
        (ENVIRONMENT, os.environ.get(ENVIRONMENT, "1"))
    switch = str(value).strip().lower()
    if switch not in ("0", "1", "false", "true", "no", "yes", "off", "on"):
        raise ValueError(f"{name} must be true or false (or 1/0, yes/no, on/off), "
                         f"got {value!r}")
    return switch in ("1", "true", "yes", "on")


def _for_setuptools(config_settings):
    return {k: v for k, v in (config_settings or {}).items() if k != SETTING} or None


def _runtime_requirements():
    """The project's dependencies (pyproject.toml, in the source tree, the hooks' folder)."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:
        import tomli as tomllib
    with open("pyproject.toml", "rb") as f:
        return tomllib.load(f)["project"]["dependencies"]


def get_requires_for_build_wheel(config_settings=None):
    required = _setuptools.get_requires_for_build_wheel(_for_setuptools(config_settings))
    return required + (_runtime_requirements() if _compiling(config_settings) else [])


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    settings = _for_setuptools(config_settings)
    if not _compiling(config_settings):
        return _setuptools.build_wheel(wheel_directory, settings, metadata_directory)
    with tempfile.TemporaryDirectory() as scratch:
        pure = pathlib.Path(scratch) / _setuptools.build_wheel(scratch, settings,
                                                               metadata_directory)
        tree = pathlib.Path(scratch) / "tree"
        with zipfile.ZipFile(pure) as wheel:
            wheel.extractall(tree)
        _compile_kernels(tree)
        return _pack(tree, pure.name, pathlib.Path(wheel_directory))


def _compile_kernels(tree):
    """Compile every kernel family of the package in ``tree`` into its ``_kernels``."""
    path = os.pathsep.join(p for p in (str(tree), os.environ.get("PYTHONPATH")) if p)
    env = dict(os.environ, PYTHONPATH=path, FASTTRACK_SHIPPED_KERNELS="0",
               PYTHONDONTWRITEBYTECODE="1")  # nothing but the kernels added to the tree
    done = subprocess.run([sys.executable, "-c", _SHIP, str(tree / "fasttrack" / "_kernels")],
                          cwd=tree, env=env)
    if done.returncode:
        raise RuntimeError(f"compiling fasttrack's kernels failed (exit status "
                           f"{done.returncode}, its messages above); "
                           f"{ENVIRONMENT}=0 builds a wheel without them, which compiles "
                           f"them on first use")


def _platform_tag():
    """This interpreter's wheel tag, e.g. ``cp311-cp311-linux_x86_64``."""
    implementation = {"cpython": "cp", "pypy": "pp"}.get(sys.implementation.name, "py")
    version = f"{implementation}{sys.version_info.major}{sys.version_info.minor}"
    abi = version + ("t" if sysconfig.get_config_var("Py_GIL_DISABLED") else "")
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{version}-{abi}-{platform}"


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}\n"


def _pack(tree, pure_name, wheel_directory):
    """Zip ``tree`` into a wheel tagged :func:`_platform_tag` (not pure), with a new RECORD;
    returns its file name."""
    tag = _platform_tag()
    dist_info, = (p.name for p in tree.glob("*.dist-info"))
    wheel_file = tree / dist_info / "WHEEL"
    lines = [line for line in wheel_file.read_text().splitlines()
             if not line.startswith(("Tag:", "Root-Is-Purelib:"))]
    wheel_file.write_text("\n".join(lines + ["Root-Is-Purelib: false", f"Tag: {tag}"]) + "\n")
    record = f"{dist_info}/RECORD"
    files = sorted((p for p in tree.rglob("*") if p.is_file()),
                   key=lambda p: (p.relative_to(tree).parts[0] == dist_info, str(p)))
    name = "-".join(pure_name.split("-")[:2] + [tag]) + ".whl"
    lines = []
    with zipfile.ZipFile(wheel_directory / name, "w", zipfile.ZIP_DEFLATED) as wheel:
        for path in files:
            arcname = path.relative_to(tree).as_posix()
            if arcname == record:
                continue
            data = path.read_bytes()
            wheel.writestr(arcname, data)
            lines.append(_record_line(arcname, data))
        wheel.writestr(record, "".join(lines) + f"{record},,\n")
    return name
