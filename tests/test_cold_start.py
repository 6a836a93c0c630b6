"""An installed fasttrack computes its first results without compiling: the kernels shipped in
the package serve every first step of the documentation's programs, large and small."""
import json
import os
import pathlib
import re
import runpy
import subprocess
import sys

import pytest

from fasttrack._jit import cache

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: Runs a program (argv[1], as __main__, or -c and a snippet) with its arguments, and prints,
#: last, the fasttrack kernels it compiled.
_COUNTING = """
import json, runpy, sys
from fasttrack._jit import compiles
program = sys.argv[1]
if program == "-c":  # a snippet, and its arguments
    code, sys.argv = sys.argv[2], ["-c"] + sys.argv[3:]
else:
    sys.argv = sys.argv[1:]
with compiles() as found:
    if program == "-c":
        exec(compile(code, "<snippet>", "exec"), {"__name__": "__main__"})
    else:
        runpy.run_path(program, run_name="__main__")
print(json.dumps([c.__dict__ for c in found]))
"""

#: First steps at the sizes that take each kernel's parallel build.
_LARGE = """
import numpy as np
import fasttrack as ft
from fasttrack.scenarios import particle_filter_tutorial
s = particle_filter_tutorial(100_000, steps=2)
d = s.detections[1]
post = ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=2)).update(
    ft.SingleHypothesis(ft.ParticlePredictor(s.transition_model, rng=1).predict(s.prior,
                                                                              d.timestamp), d))
post.mean, post.covar, ft.ess(post.log_weight), ft.residual(post.log_weight, rng=0)
"""


def _guide_snippets():
    guide = (ROOT / "docs" / "guide.md").read_text()
    blocks = re.findall(r"\n##+ ([^\n]+)\n(?:(?!\n##).)*?```python\n(.*?)```", guide, re.S)
    return {f"guide: {title}": code for title, code in blocks
            if "stonesoup" not in code and "run_trials" not in code}


def _readme_snippet():
    readme = (ROOT / "README.md").read_text()
    return re.search(r"```python\n(.*?)```", readme, re.S).group(1)


def _programs():
    programs = {path.stem: [str(path)] for path in sorted((ROOT / "docs" / "examples")
                                                          .glob("*.py"))}
    programs.update({name: ["-c", code] for name, code in _guide_snippets().items()})
    programs["README"] = ["-c", _readme_snippet()]
    programs["particle filter at 1e5"] = ["-c", _LARGE]
    bench = runpy.run_path(str(ROOT / "bench" / "cold_start.py"))
    programs.update({f"first {family} step ({path})": ["-c", bench["FIRST_STEP"], family, path]
                     for family in bench["FAMILIES"] for path in bench["PATHS"]})
    return programs


def _shipped_or_skip():
    folder, reason = cache.shipped()
    if folder is None:
        pytest.skip(f"fasttrack's shipped kernels are not in use here ({reason}): "
                    f"`pip install .` ships them")


@pytest.mark.parametrize("name", sorted(_programs()))
def test_a_first_step_compiles_no_kernel(name, tmp_path):
    _shipped_or_skip()
    env = dict(os.environ, FASTTRACK_CACHE_DIR=str(tmp_path), MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-c", _COUNTING, *_programs()[name]], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    compiled = json.loads(done.stdout.strip().splitlines()[-1])
    assert compiled == [], compiled


# -- The shipped kernels and the per-user cache ---------------------------------------------

#: One small first step; prints the kernels it compiled, then its result.
_ESS = """
import json, numpy as np
import fasttrack as ft
from fasttrack._jit import compiles
with compiles() as found:
    value = ft.ess(np.zeros(10))
print(json.dumps([c.name for c in found]))
print(value)
"""


@pytest.fixture
def package_copy(tmp_path):
    """A copy of the fasttrack package in use, with the shipped kernels it reads, under
    ``tmp_path / "site"``: damage it at will."""
    import shutil

    import fasttrack
    _shipped_or_skip()
    site = tmp_path / "site"
    package = site / "fasttrack"
    shutil.copytree(pathlib.Path(fasttrack.__file__).parent, package,
                    ignore=shutil.ignore_patterns("__pycache__", "_kernels"))
    shutil.copytree(cache.shipped()[0], package / "_kernels" / cache.tag())
    return package


def _run(code, package, tmp_path, **env):
    """Run ``code`` on ``package``'s copy of fasttrack, with a new per-user cache; returns
    (kernels compiled, result line, stderr)."""
    environment = dict(os.environ, PYTHONPATH=str(package.parent),
                       FASTTRACK_CACHE_DIR=str(tmp_path / "user"))
    environment.update(env)
    done = subprocess.run([sys.executable, "-W", "always", "-c", code], cwd=tmp_path,
                          env=environment, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    compiled, result = done.stdout.strip().splitlines()[-2:]
    return json.loads(compiled), result, done.stderr


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_a_read_only_install_with_no_writable_cache_compiles_nothing_and_warns_nothing(
        package_copy, tmp_path):
    blocked = tmp_path / "a-file"
    blocked.write_text("")  # a directory below a file can never be created, even by root
    before = _files(package_copy)
    compiled, result, stderr = _run(_ESS, package_copy, tmp_path, HOME=str(blocked / "home"),
                                    FASTTRACK_CACHE_DIR=str(blocked / "cache"))
    assert compiled == [] and float(result) == 10.0
    assert "Warning" not in stderr, stderr
    assert _files(package_copy) == before


def test_a_damaged_shipped_entry_gives_the_right_result_one_warning_and_a_per_user_entry(
        package_copy, tmp_path):
    shipped = package_copy / "_kernels" / cache.tag()
    for path in shipped.glob("weights.ess_serial-*.nbc"):
        path.write_bytes(path.read_bytes()[:100])
    before = _files(package_copy)
    compiled, result, stderr = _run(_ESS, package_copy, tmp_path)
    assert float(result) == 10.0 and "fasttrack._jit.weights.ess_serial" in compiled
    assert stderr.count("is damaged") == 1 and "entry of ess_serial" in stderr, stderr
    assert "reinstall fasttrack" in stderr
    assert "cannot be used" not in stderr  # the other shipped kernels still serve
    assert list((tmp_path / "user").rglob("weights.ess_serial-*.nbc"))
    assert _files(package_copy) == before  # nothing written into the package
    compiled, result, stderr = _run(_ESS, package_copy, tmp_path)  # now from the user's
    assert compiled == [] and float(result) == 10.0 and stderr.count("is damaged") == 1


@pytest.mark.parametrize("change", ["cpu", "sources", "entries", "numba", "settings"])
def test_shipped_kernels_that_cannot_serve_fall_back_to_compiling_and_say_why_once(
        package_copy, tmp_path, change):
    shipped = package_copy / "_kernels" / cache.tag()
    manifest = json.loads((shipped / cache.MANIFEST).read_text())
    env = {}
    if change == "cpu":
        manifest["cpu"][1] = "a-cpu-of-elsewhere"
    elif change == "sources":
        manifest["source_stamp"] = "0" * 64
    elif change == "entries":
        del manifest["entries"]  # as an older fasttrack wrote them
    elif change == "numba":
        shipped.rename(shipped.with_name("numba0.1.0-numpy1.0-cpython-30"))
    else:
        env["NUMBA_OPT"] = "2"
    if shipped.exists():
        (shipped / cache.MANIFEST).write_text(json.dumps(manifest))
    compiled, result, stderr = _run(_ESS, package_copy, tmp_path, **env)
    assert float(result) == 10.0 and "fasttrack._jit.weights.ess_serial" in compiled
    assert stderr.count("cannot be used") == 1, stderr
    assert "python -m fasttrack warmup" in stderr
    expected = {"cpu": "for another CPU (a-cpu-of-elsewhere", "sources": "other fasttrack sources",
                "entries": "stored in another format",
                "numba": "compiled for numba0.1.0-numpy1.0-cpython-30, and this process runs",
                "settings": "other Numba settings (OPT _OptLevel(3) there, _OptLevel(2) here)"}
    assert expected[change] in stderr, stderr


def test_entries_compiled_under_other_code_settings_are_not_loaded(tmp_path):
    env = dict(os.environ, FASTTRACK_CACHE_DIR=str(tmp_path), FASTTRACK_SHIPPED_KERNELS="0")

    def compiled(**settings):
        done = subprocess.run([sys.executable, "-c", _ESS], cwd=tmp_path, capture_output=True,
                              text=True, env=dict(env, **settings), timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
        return json.loads(done.stdout.splitlines()[-2])

    assert compiled(NUMBA_OPT="2")  # (at 0, Numba caches nothing)
    assert compiled()  # the entries of NUMBA_OPT=2 are not the default's
    assert not compiled(NUMBA_OPT="2") and not compiled()


def test_the_index_key_holds_the_settings_that_change_code(monkeypatch):
    import numba
    from numba.core import config
    from numba.core.registry import cpu_target
    from fasttrack._jit import weights
    kernel_cache = weights.ess._cache
    sig = (numba.float64[::1], numba.float64)  # any signature: the key is computed, not used
    codegen = cpu_target.target_context.codegen()
    default = kernel_cache._index_key(sig, codegen)
    for name, value in (("OPT", 0), ("LOOP_VECTORIZE", 0), ("SLP_VECTORIZE", 1),
                        ("BOUNDSCHECK", 1)):
        with monkeypatch.context() as patch:
            patch.setattr(config, name, value)
            assert kernel_cache._index_key(sig, codegen) != default, name
    assert kernel_cache._index_key(sig, codegen) == default


def test_a_save_waits_for_the_folder_lock_and_writes_its_data_before_its_index(tmp_path):
    import threading
    store = cache._Store(str(tmp_path), "kernel", "stamp")
    store.save("first", b"one")
    with cache._locked(tmp_path / cache._Store.LOCK):
        saving = threading.Thread(target=store.save, args=("second", b"two"))
        saving.start()
        saving.join(0.5)
        assert saving.is_alive() and store.load("second") is None
    saving.join(60)
    assert store.load("first") == b"one" and store.load("second") == b"two"
    assert sorted(p.name for p in tmp_path.glob("kernel.*.nbc")) == ["kernel.1.nbc",
                                                                    "kernel.2.nbc"]


def test_a_damaged_index_is_replaced_by_the_next_save(tmp_path):
    store = cache._Store(str(tmp_path), "kernel", "stamp")
    store.save("first", b"one")
    (tmp_path / "kernel.nbi").write_bytes(b"garbage")
    store.save("second", b"two")
    assert store.load("second") == b"two"


def test_compressed_entries_load_as_saved_and_only_through_the_shipped_store(tmp_path):
    entry = b"kernel code " * 1000
    cache._Store(str(tmp_path), "kernel", "stamp").save("key", entry)
    size = (tmp_path / "kernel.1.nbc").stat().st_size
    cache.compress(tmp_path)
    assert (tmp_path / "kernel.1.nbc").stat().st_size < size / 10
    assert cache._ShippedStore(str(tmp_path), "kernel", "stamp").load("key") == entry
    with pytest.raises(Exception):  # the per-user store reads its entries as saved
        cache._Store(str(tmp_path), "kernel", "stamp").load("key")


def test_the_shipped_kernels_are_compressed():
    import zlib
    _shipped_or_skip()
    data = sorted(cache.shipped()[0].glob("*.nbc"))
    assert data and all(zlib.decompress(path.read_bytes()) for path in data[:20])


_SAME_KERNEL = {"int64": "ft.systematic(np.zeros(8), rng=0)",
                "int32": "ft.SystematicResampler(rng=0).resample("
                         "ft.ParticleState(np.zeros((1, 8))))"}


@pytest.mark.slow
def test_processes_compiling_other_signatures_of_one_kernel_at_once_lose_no_entry(tmp_path):
    code = ("import numpy as np, fasttrack as ft, fasttrack._jit\n"
            "fasttrack._jit.kernels_from_now()\n{}")
    for attempt in range(5):
        env = dict(os.environ, FASTTRACK_CACHE_DIR=str(tmp_path / str(attempt)),
                   FASTTRACK_SHIPPED_KERNELS="0")
        racing = [subprocess.Popen([sys.executable, "-c", code.format(call)], cwd=tmp_path,
                                   env=env, stderr=subprocess.PIPE, text=True)
                  for call in _SAME_KERNEL.values()]
        for process in racing:
            assert process.wait(600) == 0, process.stderr.read()
        third = subprocess.run([sys.executable, "-c", _COUNTING, "-c",
                                code.format("\n".join(_SAME_KERNEL.values()))], cwd=tmp_path,
                               env=env, capture_output=True, text=True, timeout=600)
        assert third.returncode == 0, third.stderr[-3000:]
        assert json.loads(third.stdout.splitlines()[-1]) == [], attempt


@pytest.fixture
def shipped_at(tmp_path, monkeypatch):
    """Point :func:`cache.shipped` at ``tmp_path / "_kernels"`` (no installed copy)."""
    monkeypatch.setattr(cache, "SHIPPED", tmp_path / "_kernels")
    monkeypatch.setattr(cache, "_installed_kernels", lambda: [])
    monkeypatch.delenv(cache.SHIPPED_ENVIRONMENT, raising=False)
    cache.shipped.cache_clear()
    yield tmp_path / "_kernels"
    cache.shipped.cache_clear()


def test_shipped_kernels_are_used_only_with_a_matching_manifest(shipped_at, monkeypatch):
    assert cache.shipped() == (None, "this installation carries none (an editable install, "
                                     "or a wheel built with FASTTRACK_COMPILE_KERNELS=0)")
    folder = shipped_at / cache.tag()
    folder.mkdir(parents=True)
    cache.shipped.cache_clear()
    assert cache.shipped()[0] is None  # a folder without its manifest is unfinished
    for damaged in ("{not json", "[]", '{"source_stamp": 1, "cpu": 2}'):
        (folder / cache.MANIFEST).write_text(damaged)
        cache.shipped.cache_clear()
        assert "cannot be read" in cache.shipped()[1] or "other fasttrack sources" in \
            cache.shipped()[1], damaged
    cache.write_manifest(folder)
    cache.shipped.cache_clear()
    assert cache.shipped() == (folder, None)
    monkeypatch.setenv(cache.SHIPPED_ENVIRONMENT, "0")
    cache.shipped.cache_clear()
    assert cache.shipped() == (None, None)  # switched off: nothing to say
    monkeypatch.setenv(cache.SHIPPED_ENVIRONMENT, "flase")
    cache.shipped.cache_clear()
    with pytest.raises(ValueError, match="FASTTRACK_SHIPPED_KERNELS must be 0 or 1.*'flase'"):
        cache.shipped()


def test_a_manifest_names_what_differs():
    here = cache.manifest()
    assert cache._mismatch(here) is None
    assert "other CPU features" in cache._mismatch(dict(here, cpu=here["cpu"][:2] + ["+x"]))
    assert "another CPU (other;" in cache._mismatch(dict(here, cpu=["t", "other", ""]))
    other = dict(here["settings"], SLP_VECTORIZE="1")
    assert ("SLP_VECTORIZE 1 there, 0 here" in cache._mismatch(dict(here, settings=other)))


# -- The build backend ----------------------------------------------------------------------

@pytest.fixture
def backend(monkeypatch):
    """build_backend/backend.py, imported with the source tree as the working folder (as the
    build hooks run)."""
    import importlib.util
    monkeypatch.chdir(ROOT)
    monkeypatch.delenv("FASTTRACK_COMPILE_KERNELS", raising=False)
    spec = importlib.util.spec_from_file_location("fasttrack_backend",
                                                  ROOT / "build_backend" / "backend.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_backend_compiles_unless_switched_off(backend, monkeypatch):
    assert backend._compiling(None) and backend._compiling({"compile-kernels": "true"})
    for off in ("0", "false", "False", "no", "off"):
        assert not backend._compiling({"compile-kernels": off})
    monkeypatch.setenv("FASTTRACK_COMPILE_KERNELS", "0")
    assert not backend._compiling(None)
    assert backend._compiling({"compile-kernels": "1"})  # the setting wins
    with pytest.raises(ValueError, match="compile-kernels must be true or false.*'maybe'"):
        backend._compiling({"compile-kernels": "maybe"})
    monkeypatch.setenv("FASTTRACK_COMPILE_KERNELS", "nein")
    with pytest.raises(ValueError, match="FASTTRACK_COMPILE_KERNELS must be true or false"):
        backend._compiling(None)
    assert backend._for_setuptools({"compile-kernels": "0", "--build-option": "x"}) == \
        {"--build-option": "x"}


def test_the_build_needs_the_runtime_dependencies_only_to_compile(backend):
    dependencies = backend._runtime_requirements()
    assert any(d.startswith("numba") for d in dependencies)
    compiling = backend.get_requires_for_build_wheel()
    pure = backend.get_requires_for_build_wheel({"compile-kernels": "0"})
    assert set(compiling) - set(pure) == set(dependencies)


def test_a_packed_wheel_is_tagged_for_this_platform_and_records_every_file(backend, tmp_path):
    import base64
    import hashlib
    import sysconfig
    import zipfile
    tree = tmp_path / "tree"
    info = tree / "fasttrack-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "WHEEL").write_text("Wheel-Version: 1.0\nRoot-Is-Purelib: true\n"
                                "Tag: py3-none-any\n")
    (info / "RECORD").write_text("stale\n")
    (tree / "fasttrack" / "_kernels" / "x").mkdir(parents=True)
    (tree / "fasttrack" / "_kernels" / "x" / "k.nbc").write_bytes(b"\x00\x01code")
    (tree / "fasttrack" / "__init__.py").write_text("")
    name = backend._pack(tree, "fasttrack-1.0-py3-none-any.whl", tmp_path)
    tag = backend._platform_tag()
    assert name == f"fasttrack-1.0-{tag}.whl"
    assert tag.split("-")[2] == sysconfig.get_platform().replace("-", "_").replace(".", "_")
    with zipfile.ZipFile(tmp_path / name) as wheel:
        names = wheel.namelist()
        wheel_file = wheel.read("fasttrack-1.0.dist-info/WHEEL").decode()
        record = wheel.read("fasttrack-1.0.dist-info/RECORD").decode().splitlines()
        contents = {n: wheel.read(n) for n in names}
    assert names[-1].endswith("RECORD") and "Root-Is-Purelib: false" in wheel_file
    assert f"Tag: {tag}" in wheel_file and "py3-none-any" not in wheel_file
    assert len(record) == len(names)
    for line in record[:-1]:
        path, digest, size = line.split(",")
        data = contents[path]
        expected = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=")
        assert digest == "sha256=" + expected.decode() and int(size) == len(data)
    assert record[-1] == "fasttrack-1.0.dist-info/RECORD,,"


@pytest.mark.slow
def test_switched_off_the_wheel_is_pure_and_the_sdist_is_source_only(backend, tmp_path):
    import tarfile
    import zipfile
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet",
                           "--config-settings", "compile-kernels=false", "-w", str(tmp_path),
                           str(ROOT)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    wheel_path, = tmp_path.glob("*.whl")
    assert wheel_path.name.endswith("-py3-none-any.whl")
    with zipfile.ZipFile(wheel_path) as wheel:
        assert not [n for n in wheel.namelist() if "_kernels" in n or n.endswith(".nbc")]
    sdist = backend.build_sdist(str(tmp_path))
    with tarfile.open(tmp_path / sdist) as archive:
        names = archive.getnames()
    assert any(n.endswith("build_backend/backend.py") for n in names)
    assert not [n for n in names if n.endswith((".nbi", ".nbc")) or "_kernels" in n]


def test_a_copy_without_kernels_borrows_an_installed_copys_and_one_with_kernels_does_not(
        shipped_at, tmp_path, monkeypatch):
    installed = tmp_path / "site-packages" / "fasttrack" / "_kernels"
    (installed / cache.tag()).mkdir(parents=True)
    cache.write_manifest(installed / cache.tag())
    monkeypatch.setattr(cache, "_installed_kernels", lambda: [installed])
    assert cache.shipped() == (installed / cache.tag(), None)  # a source checkout
    (shipped_at / "numba0.1.0-numpy1.0-cpython-30").mkdir(parents=True)
    (shipped_at / "numba0.1.0-numpy1.0-cpython-30" / cache.MANIFEST).write_text("{}")
    cache.shipped.cache_clear()
    assert cache.shipped()[0] is None  # its own kernels, compiled for another numba
    assert "compiled for numba0.1.0-numpy1.0-cpython-30" in cache.shipped()[1]


#: Kernels no first step reaches: error paths and kernels the library does not call.
_UNSHIPPED = {"unscented.sigma_points", "unscented.unscented_moments", "weights.log_sum_exp"}


def test_every_kernel_a_first_step_can_reach_is_shipped():
    from fasttrack import _jit
    from fasttrack._jit import imm_smooth, smooth
    _shipped_or_skip()
    shipped = {path.name.split("-")[0] for path in cache.shipped()[0].glob("*.nbi")}
    wanted = [f"smooth.rts__DIMENSION{d}" for d in smooth.UNROLLED_DIMENSIONS]
    wanted += [f"imm_smooth.imm_smooth__DIMENSION{d}" for d in imm_smooth.SMOOTH_DIMENSIONS]
    for kernel in _jit.kernels():
        name = f"{kernel.py_func.__module__.rsplit('.', 1)[1]}.{kernel.py_func.__qualname__}"
        if name.endswith("_function") or name.startswith("user.") or name in _UNSHIPPED:
            continue  # compiled for each user's function; not reached by a first step
        if isinstance(kernel, _jit.KernelOnly):
            continue  # compiled into its callers only
        wanted.append(name)
        if isinstance(kernel, _jit.ThreadedKernel) and kernel.serial_below > 0:
            wanted.append(f"{name}_serial")
    assert sorted(set(wanted) - shipped) == []


def test_warmup_after_install_loads_the_shipped_kernels_and_compiles_nothing(tmp_path):
    _shipped_or_skip()
    done = subprocess.run([sys.executable, "-m", "fasttrack", "warmup", "--cache-dir",
                           str(tmp_path), "--families", "resample", "--processes", "1"],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("the kernels shipped with fasttrack serve these families")
    assert not list(tmp_path.rglob("*.nbc"))
