"""The kernel layer: the decorator factory and its options, mirrors, the compile cache, threads,
serial builds, warmup and kernels run with the JIT off."""
import importlib
import json
import os
import pathlib
import pkgutil
import subprocess
import sys

import numpy as np
import pytest
from numba.core.caching import FunctionCache
from numba.core.registry import CPUDispatcher

import fasttrack
import fasttrack._jit as jit_pkg
from fasttrack._jit import cache

import reference


def _dispatchers(package):
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module.__name__:
                yield f"{module.__name__}.{name}", obj


def test_every_kernel_uses_the_factory_options():
    found = dict(_dispatchers(jit_pkg))
    assert len(found) >= 20
    for name, dispatcher in found.items():
        options = dispatcher.targetoptions
        for key, value in jit_pkg.OPTIONS.items():
            if key == "cache":  # held by the dispatcher, not in its target options
                kernel_only = isinstance(dispatcher, jit_pkg.KernelOnly)  # its callers hold it
                assert isinstance(dispatcher._cache, FunctionCache) is (value and not kernel_only), name
            else:
                assert options.get(key) == value, (name, key)
        if dispatcher.strict:
            assert not options["fastmath"], name
        else:
            assert set(options["fastmath"]) == set(jit_pkg.FASTMATH), name
        kernel_only = name.rsplit(".", 1)[1].startswith("_")
        assert isinstance(dispatcher, jit_pkg.KernelOnly) is kernel_only, name
        assert all(options.get(k, False) is kernel_only for k in jit_pkg.KERNEL_ONLY), name


def test_a_kernel_only_kernel_called_from_python_raises_instead_of_crashing():
    from fasttrack._jit import smooth
    with pytest.raises(TypeError, match="_search is called only from other kernels"):
        smooth._search(np.zeros(3), 2, 0.5)
    assert isinstance(jit_pkg.serial_twin(fasttrack._jit.weights._power_sums),
                      jit_pkg.KernelOnly)


def test_no_numba_dispatchers_outside_jit():
    outside = [name for name, _ in _dispatchers(fasttrack)
               if not name.startswith("fasttrack._jit.")]
    assert outside == []


_THREAD_SCRIPT = r"""
import json, sys
import numpy as np
import pytest
import fasttrack as ft
if sys.argv[1:] == ["serial"]:  # every kernel runs its serial build
    import importlib, pkgutil, fasttrack._jit as jit_pkg
    for info in pkgutil.walk_packages(jit_pkg.__path__, "fasttrack._jit."):
        for obj in vars(importlib.import_module(info.name)).values():
            if isinstance(obj, jit_pkg.ThreadedKernel):
                obj.serial_below = 2**62
rng = np.random.default_rng(7)
n = 300_000
log_w = np.log(rng.random(n))
log_w[::97] = -np.inf
x = rng.standard_normal((3, n))
state = ft.ParticleState(x, log_weight=log_w)
out = {}
for name in ("systematic", "stratified", "multinomial"):
    out[name] = getattr(ft, name)(log_w, rng=11).tolist()
for method in ("systematic", "multinomial"):
    out["residual-" + method] = ft.residual(log_w, rng=11, method=method).tolist()
out["ess"] = ft.ess(log_w).hex()
out["mean"] = [v.hex() for v in state.mean.ravel()]
out["covar"] = [v.hex() for v in state.covar.ravel()]
out["normalise"] = ft.normalise(log_w)[:1000].tolist()
transition = ft.CombinedLinearGaussianTransitionModel([ft.ConstantVelocity(0.05)] * 2)
sensor = ft.CartesianToBearingRange(4, (0, 2), np.diag([0.01, 1.0]), translation_offset=[50, 0])
prior = ft.ParticleState(rng.standard_normal((4, n)), log_weight=log_w, timestamp=0.0)
prediction = ft.ParticlePredictor(transition, rng=3).predict(prior, 1.0)
update = ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=4)).update(
    ft.SingleHypothesis(prediction, ft.Detection([0.5, 49.0])))
out["predicted"] = [v.hex() for v in prediction.state_vector[:, ::997].ravel()]
out["updated"] = [v.hex() for v in update.state_vector[:, ::997].ravel()]
out["updated_mean"] = [v.hex() for v in update.mean.ravel()]
json.dump(out, sys.stdout)
"""


def _run_with_threads(threads, *args):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    done = subprocess.run([sys.executable, "-c", _THREAD_SCRIPT, *args], env=env,
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


@pytest.mark.slow
def test_results_do_not_depend_on_the_thread_count_or_the_serial_builds():
    one, two, serial = _run_with_threads(1), _run_with_threads(2), _run_with_threads(2, "serial")
    assert one.keys() == two.keys() == serial.keys()
    for name in one:
        assert one[name] == two[name] == serial[name], name


def test_every_kernel_has_a_mirror_with_the_same_arguments():
    """The kernel ``fasttrack._jit.<module>.<name>`` has its mirror ``<name>``, defined (not
    imported) in ``reference.<module>`` (tests/reference/<module>.py); every mirror module
    names a kernel module."""
    import inspect
    kernel_modules = {info.name for info in pkgutil.iter_modules(jit_pkg.__path__)}
    mirror_modules = {info.name for info in pkgutil.iter_modules(reference.__path__)}
    stray = sorted(mirror_modules - kernel_modules)
    assert not stray, f"tests/reference modules without a kernel module: {stray}"
    for name, dispatcher in _dispatchers(jit_pkg):
        module, short = name[len("fasttrack._jit."):].rsplit(".", 1)
        if short.startswith("_"):
            continue  # private helpers are covered through the kernels that call them
        assert module in mirror_modules, f"{name} has no module tests/reference/{module}.py"
        mirrors = importlib.import_module(f"reference.{module}")
        mirror = getattr(mirrors, short, None)
        assert mirror is not None, f"{name} has no mirror in tests/reference/{module}.py"
        assert mirror.__module__ == mirrors.__name__, (
            f"{name}'s mirror is imported into tests/reference/{module}.py, not defined there")
        assert (list(inspect.signature(mirror).parameters)
                == list(inspect.signature(dispatcher.py_func).parameters)), name


def test_public_names_are_importable_from_the_package_and_their_module():
    import importlib
    domains = [importlib.import_module(f"fasttrack.{name}") for name in (
        "batch", "filtering", "imm", "kernel", "memory", "metrics", "mixturereducer", "models",
        "montecarlo", "phd", "predictor", "random", "resampler", "resampling", "simulate",
        "smoother", "threads", "tracker", "types", "updater")]
    for name in fasttrack.__all__:
        obj = getattr(fasttrack, name)
        if name == "warmup":
            continue
        assert any(getattr(module, name, None) is obj for module in domains), name


_SMALL_KERNEL = "import fasttrack._jit.numeric as n; print(n.wrap_angle(7.0))"


def _python(code, **env):
    return subprocess.run([sys.executable, "-W", "always", "-c", code],
                          env=dict(os.environ, **env), capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_a_damaged_cache_entry_is_compiled_again_and_replaced(tmp_path):
    env = {"FASTTRACK_CACHE_DIR": str(tmp_path),  # the first place the cache is looked for
           "FASTTRACK_SHIPPED_KERNELS": "0"}
    first = _python(_SMALL_KERNEL, **env)
    assert first.returncode == 0, first.stderr
    files = {kind: sorted(tmp_path.rglob(f"numeric.wrap_angle-*.{kind}")) for kind in ("nbi", "nbc")}
    assert files["nbi"] and files["nbc"]
    for kind in ("nbi", "nbc"):
        for damage in ("truncated", "empty", "garbage"):
            for path in files[kind]:
                data = path.read_bytes()
                path.write_bytes({"truncated": data[:len(data) // 2], "empty": b"",
                                  "garbage": os.urandom(len(data))}[damage])
            damaged = _python(_SMALL_KERNEL, **env)
            assert damaged.returncode == 0, (kind, damage, damaged.stderr)
            assert damaged.stdout.strip() == first.stdout.strip()
            assert "compile cache entry of wrap_angle" in damaged.stderr
            assert "damaged" in damaged.stderr and "compiling it again" in damaged.stderr
            again = _python(_SMALL_KERNEL, **env)  # replaced: loads quietly
            assert again.returncode == 0 and "damaged" not in again.stderr, again.stderr
            files = {k: sorted(tmp_path.rglob(f"numeric.wrap_angle-*.{k}")) for k in ("nbi", "nbc")}


_TWO_THREADS = """
import sys, threading
import numpy as np
import pytest
import fasttrack as ft
from fasttrack import _jit
from fasttrack.scenarios import particle_filter_tutorial
_jit.kernels_from_now()  # (NumPy's first steps agree to rounding only)

def run(results, key):
    scenario = particle_filter_tutorial(20_000, seed=key)
    predictor = ft.ParticlePredictor(scenario.transition_model, rng=key)
    updater = ft.ParticleUpdater(scenario.measurement_model, ft.SystematicResampler(rng=key))
    state = scenario.prior
    for detection in scenario.detections[1:]:
        state = updater.update(ft.SingleHypothesis(predictor.predict(state, detection.timestamp),
                                                   detection))
    results[key] = state.mean.ravel().tolist()

alone, together = {}, {}
for key in (1, 2):
    run(alone, key)
threads = [threading.Thread(target=run, args=(together, key)) for key in (1, 2)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
import numba, fasttrack._jit as jit
print(numba.threading_layer(), type(jit.CALL_LOCK).__name__, jit.layer_is_threadsafe())
assert alone == together, (alone, together)
print("same")
"""


@pytest.mark.parametrize("layer", ["workqueue", "default"])
def test_two_python_threads_may_run_filters_at_once_on_any_layer(layer):
    result = _python(_TWO_THREADS, NUMBA_THREADING_LAYER=layer)
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.split("\n")
    if layer == "workqueue":
        assert lines[0].startswith("workqueue") and lines[0].endswith("False")
    assert lines[1] == "same"


_ONE_STEP = """
import warnings
warnings.simplefilter("always")
import numpy as np
import fasttrack as ft
from fasttrack.scenarios import particle_filter_tutorial
from fasttrack._jit import cache
s = particle_filter_tutorial(200, steps=2)
d = s.detections[1]
u = ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=1)).update(
    ft.SingleHypothesis(ft.ParticlePredictor(s.transition_model, rng=0).predict(s.prior, d.timestamp), d))
print(cache.directory(), u.mean.ravel()[0])
"""


def _package_cache_files():
    root = pathlib.Path(fasttrack.__file__).parent
    return sorted(str(p) for p in root.rglob("*.nb[ic]"))


_SMALL_CALL = ("import fasttrack._jit.numeric as n; from fasttrack._jit import cache; "
               "print(cache.directory(), n.wrap_angle(7.0))")


def test_new_entries_are_per_user_and_never_in_the_package(tmp_path):
    before = _package_cache_files()
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME",
                                                           "FASTTRACK_CACHE_DIR")}
    env["FASTTRACK_SHIPPED_KERNELS"] = "0"  # compile, rather than load the shipped kernels
    folder = f"{fasttrack.__version__}-{cache.tag()}"
    chosen = subprocess.run([sys.executable, "-c", _SMALL_CALL], capture_output=True, text=True,
                            env={**env, "FASTTRACK_CACHE_DIR": str(tmp_path / "mine")}, timeout=600)
    assert chosen.returncode == 0, chosen.stderr
    assert chosen.stdout.split()[0] == str(tmp_path / "mine" / folder)
    assert list((tmp_path / "mine").rglob("numeric.wrap_angle-*.nbi"))
    home = subprocess.run([sys.executable, "-c", _SMALL_CALL], capture_output=True, text=True,
                          env={**env, "HOME": str(tmp_path / "home")}, timeout=600)
    assert home.returncode == 0, home.stderr
    assert home.stdout.split()[0] == str(tmp_path / "home" / ".cache" / "fasttrack" / folder)
    assert _package_cache_files() == before


_CALM_BLAS = """
import os, sys, threading
import numpy as np
import fasttrack as ft
import fasttrack._jit
from fasttrack import threads
fasttrack._jit.kernels_from_now()
blas = threads._numpy_openblas()
a = np.random.default_rng(0).random((300, 300))
a @ a  # wakes NumPy's BLAS workers
release = threading.Event()
if sys.argv[1] == "other-thread":
    other = threading.Thread(target=release.wait)
    other.start()
ft.systematic(np.zeros(10**6), rng=0)  # a parallel kernel call
first = threads._calmed
if sys.argv[1] == "other-thread":
    release.set()
    other.join()
    ft.systematic(np.zeros(10**6), rng=0)
print(blas is not None, first, threads._calmed, "OPENBLAS_THREAD_TIMEOUT" in os.environ,
      np.allclose(a @ a, a.dot(a)))
"""


@pytest.mark.parametrize("case, env, want", [
    ("default", {}, "True True True False True"),
    ("user-timeout", {"OPENBLAS_THREAD_TIMEOUT": "8"}, "True False False True True"),
    ("opted-out", {"FASTTRACK_CALM_BLAS": "0"}, "True False False False True"),
    ("other-thread", {}, "True None True False True"),
])
def test_numpys_blas_workers_are_calmed_once_unless_told_not_to(case, env, want):
    """Before the first parallel kernel, a pthreads OpenBLAS that NumPy loaded is told to
    busy-wait less, once: not against the user's own timeout or FASTTRACK_CALM_BLAS=0, not
    while another thread might be inside a product (then at a later call), and without
    leaving the variable to child processes."""
    clean = {k: v for k, v in os.environ.items()
             if k not in ("OPENBLAS_THREAD_TIMEOUT", "FASTTRACK_CALM_BLAS")}
    done = subprocess.run([sys.executable, "-c", _CALM_BLAS, case], capture_output=True,
                          text=True, env={**clean, **env}, timeout=600)
    assert done.returncode == 0, done.stderr
    found = done.stdout.split()
    if found[0] == "False":  # not a pthreads OpenBLAS: nothing is done
        assert "True" not in found[1:3]
        pytest.skip("NumPy's BLAS is not a pthreads OpenBLAS")
    assert found == want.split()


_USER_MODEL_STEP = """
import json
import numpy as np
from numba import njit
import fasttrack as ft
from fasttrack import _jit
from fasttrack._jit.dispatch import compiles
_jit.kernels_from_now()

@njit
def shift(states, dt):
    return states + dt

@njit
def first_two(states):
    return states[:2].copy()

transition = ft.NonlinearGaussianTransitionModel(shift, np.eye(2), ndim_state=2)
sensor = ft.NonlinearGaussianMeasurement(first_two, ndim_state=2, noise_covar=np.eye(2))
prior = ft.ParticleState(np.zeros((2, 100)), timestamp=0.0)
gaussian = ft.GaussianState([0.0, 1.0], np.eye(2), timestamp=0.0)
detection = ft.Detection([1.0, 1.0], timestamp=1.0)
with compiles() as found:
    for predictor, updater, state in (
            (ft.ParticlePredictor(transition, rng=0), ft.ParticleUpdater(sensor), prior),
            (ft.ExtendedKalmanPredictor(transition), ft.ExtendedKalmanUpdater(sensor), gaussian),
            (ft.UnscentedKalmanPredictor(transition), ft.UnscentedKalmanUpdater(sensor),
             gaussian)):
        updater.update(ft.SingleHypothesis(predictor.predict(state, 1.0), detection))
print(json.dumps(sorted({c.name.split("._jit.")[1] for c in found})))
"""


@pytest.mark.slow
def test_kernels_taking_user_functions_compile_once_and_load_in_later_processes(tmp_path):
    """Typed by the functions' signature, not the functions: the second process loads every
    kernel, and the cache holds the same files after it (nothing piles up)."""
    script = tmp_path / "model.py"
    script.write_text(_USER_MODEL_STEP)
    env = dict(os.environ, FASTTRACK_CACHE_DIR=str(tmp_path / "cache"),
               FASTTRACK_SHIPPED_KERNELS="0")
    listings, compiled = [], []
    for _ in range(2):
        done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                              env=env, timeout=600)
        assert done.returncode == 0, done.stderr
        compiled.append(json.loads(done.stdout.splitlines()[-1]))
        listings.append(sorted(p.name for p in (tmp_path / "cache").rglob("*.nb[ic]")))
    assert {"kalman.predict_function", "unscented.unscented_predict_function",
            "propagate.propagate_function_serial"} <= set(compiled[0])
    assert compiled[1] == []
    assert listings[0] == listings[1]


@pytest.mark.slow
def test_with_nothing_writable_fasttrack_still_runs_and_warns_once(tmp_path):
    blocked = tmp_path / "a-file"
    blocked.write_text("")  # a directory below a file can never be created, even by root
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env.update(HOME=str(blocked / "home"), FASTTRACK_CACHE_DIR=str(blocked / "cache"),
               FASTTRACK_SHIPPED_KERNELS="0")
    before = _package_cache_files()
    done = subprocess.run([sys.executable, "-c", _ONE_STEP], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[0] == "None"
    assert done.stderr.count("no writable directory for its compiled kernels") == 1
    assert "Set FASTTRACK_CACHE_DIR" in done.stderr
    assert _package_cache_files() == before


def _reaches_parallel(dispatcher, seen=None):
    """Whether a kernel has parallel regions, or calls a kernel that has (transitively)."""
    seen = set() if seen is None else seen
    if id(dispatcher) in seen:
        return False
    seen.add(id(dispatcher))
    if dispatcher.targetoptions.get("parallel"):
        return True
    names = dispatcher.py_func.__code__.co_names
    return any(_reaches_parallel(g, seen) for g in (dispatcher.py_func.__globals__.get(n)
                                                    for n in names)
               if isinstance(g, CPUDispatcher))


def test_kernels_that_reach_parallel_regions_choose_their_threads():
    import inspect
    for name, dispatcher in _dispatchers(jit_pkg):
        threaded = isinstance(dispatcher, jit_pkg.ThreadedKernel)
        if name.rsplit(".", 1)[1].startswith("_"):
            assert not threaded, name  # private: called from kernels only
            continue
        assert threaded == _reaches_parallel(dispatcher), name
        if threaded:
            assert dispatcher.size < len(inspect.signature(dispatcher.py_func).parameters), name


def test_a_build_with_a_constant_reads_it_and_is_cached_under_its_own_name():
    from fasttrack._jit import smooth
    build = jit_pkg.with_constant(smooth.rts, "_DIMENSION", 4)
    assert build is jit_pkg.with_constant(smooth.rts, "_DIMENSION", 4)
    assert build.py_func.__globals__["_DIMENSION"] == 4 and smooth._DIMENSION == 0
    assert build.py_func.__qualname__ == "rts__DIMENSION4"
    assert build.targetoptions == smooth.rts.targetoptions and build.strict == smooth.rts.strict
    assert isinstance(build._cache, FunctionCache)


def test_small_work_runs_a_serial_build_and_the_limit_holds():
    import numba
    from fasttrack._jit import weights
    twin = jit_pkg.serial_twin(weights.ess)
    assert twin is not weights.ess and not twin.targetoptions["parallel"]
    log_w = np.zeros(jit_pkg.SERIAL_BELOW_LIGHT - 1)
    fasttrack.ess(log_w)
    assert twin.signatures
    fasttrack.ess(np.zeros(jit_pkg.SERIAL_BELOW_LIGHT))
    assert numba.get_num_threads() == fasttrack.get_threads() == numba.config.NUMBA_NUM_THREADS
    try:
        fasttrack.set_threads(1)
        fasttrack.ess(np.zeros(10**6))
        assert numba.get_num_threads() == 1
    finally:
        fasttrack.set_threads(numba.config.NUMBA_NUM_THREADS)
    with pytest.raises(ValueError, match="n must be <="):
        fasttrack.set_threads(numba.config.NUMBA_NUM_THREADS + 1)
    with pytest.raises(TypeError, match="n must be an int"):
        fasttrack.set_threads(1.5)



@pytest.mark.parametrize("n, work, per_thread, align", [
    (10, None, 1, 1), (10, 0, 1, 1), (1000, 10**6, 4, 1), (1000, 10**6, 1, 128),
    (1, 10**6, 4, 1), (0, 10**6, 4, 1), (7, 10**6, 4, 1)])
def test_chunks_cover_the_items_once_on_threads_only_above_the_limit(n, work, per_thread,
                                                                      align):
    import threading
    calls = []
    fasttrack.threads.in_chunks(
        lambda lo, hi: calls.append((lo, hi, threading.current_thread())), n, 100,
        align=align, work=work, per_thread=per_thread)
    bounds = sorted((lo, hi) for lo, hi, _ in calls)
    assert [lo for lo, _ in bounds] == [0] + [hi for _, hi in bounds[:-1]]
    assert bounds[-1][1] == n and all(lo % align == 0 for lo, _ in bounds)
    threaded = (n if work is None else work) >= 100 and n > align and fasttrack.get_threads() > 1
    if threaded:
        assert 1 < len(calls) <= fasttrack.get_threads() * per_thread
        assert all(t is not threading.current_thread() for *_, t in calls)
    else:
        assert len(calls) == 1 and calls[0][2] is threading.current_thread()

@pytest.mark.slow
def test_the_warmup_command_fills_the_named_cache_with_a_line_per_family(tmp_path):
    done = subprocess.run([sys.executable, "-m", "fasttrack", "warmup", "--cache-dir",
                           str(tmp_path), "--families", "resample", "--processes", "1"],
                          capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, FASTTRACK_SHIPPED_KERNELS="0"))
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("compiling 1 kernel families into " + str(tmp_path))
    assert lines[1].split()[:3] == ["resample", "ready", "after"] and lines[-1].startswith("done")
    assert list((tmp_path / f"{fasttrack.__version__}-{cache.tag()}").glob("resample.*.nbc"))
    wrong = subprocess.run([sys.executable, "-m", "fasttrack", "warmup", "--families", "pf"],
                           capture_output=True, text=True, timeout=600)
    assert wrong.returncode == 2 and "unknown families ['pf']" in wrong.stderr


def test_warmup_checks_its_arguments():
    with pytest.raises(ValueError, match="unknown families"):
        fasttrack.warmup(["pf"])
    with pytest.raises(ValueError, match="processes"):
        fasttrack.warmup(processes=0)
    assert fasttrack.warmup([]) >= 0


def test_warmup_compiles_families_sharing_kernels_in_one_worker():
    from fasttrack import _warmup
    tasks = _warmup._tasks(list(_warmup.FAMILIES))
    assert sorted(sum(tasks, [])) == sorted(_warmup.FAMILIES)
    for group in _warmup.TOGETHER:
        assert [t for t in tasks if set(group) & set(t)] == [list(group)]
    assert _warmup._tasks(["unscented", "resample"]) == [["unscented"], ["resample"]]
    assert _warmup._tasks(["unscented", "resample", "kalman"]) == [["unscented", "kalman"],
                                                                   ["resample"]]


_EVERY_KERNEL = r"""
import json, sys
import numpy as np
from numba import njit
import fasttrack as ft
from fasttrack.scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial,
                                 particle_filter_tutorial)
out = {}
rng = np.random.default_rng(3)
log_w = np.log(rng.random(500))
log_w[::7] = -np.inf
for name in ("systematic", "stratified", "multinomial"):
    out[name] = getattr(ft, name)(log_w, rng=5)
for method in ("systematic", "multinomial"):
    out["residual-" + method] = ft.residual(log_w, nparts=300, rng=5, method=method)
out["ess"] = ft.ess(log_w)
out["normalise"] = ft.normalise(log_w)
state = ft.ParticleState(rng.standard_normal((3, 500)), log_weight=log_w)
out["mean"], out["covar"] = state.mean, state.covar
pf = particle_filter_tutorial(200, steps=3)
track = ft.run_filter(ft.ParticlePredictor(pf.transition_model, rng=1),
                      ft.ParticleUpdater(pf.measurement_model, ft.SystematicResampler(rng=2)),
                      pf.prior, pf.detections)
out["pf"] = track[-1].state_vector
ekf = extended_kalman_tutorial(steps=4)
for jacobian in ("analytic", "forward", "central"):
    track = ft.run_filter(ft.ExtendedKalmanPredictor(ekf.transition_model),
                          ft.ExtendedKalmanUpdater(ekf.measurement_model, jacobian=jacobian),
                          ekf.prior, ekf.detections)
    out["ekf-" + jacobian] = np.hstack([track[-1].state_vector, track[-1].covar])
batch = ft.BatchExtendedKalmanFilter(ekf.transition_model, ekf.measurement_model)
x, p = batch.step(np.zeros((5, 4)) + [0, 1, 0, 1], np.broadcast_to(np.eye(4), (5, 4, 4)).copy(),
                  np.array([[0.5, 49.0]] * 5), 1.0)
out["batch"] = np.hstack([x, p.reshape(5, -1)])
akkf = adaptive_kernel_tutorial(20, steps=3)
for kernel in (ft.QuadraticKernel(c=1, ialpha=1), ft.GaussianKernel()):
    track = ft.run_filter(ft.AdaptiveKernelKalmanPredictor(akkf.transition_model, kernel),
                          ft.AdaptiveKernelKalmanUpdater(akkf.measurement_model, kernel, rng=4),
                          akkf.prior, akkf.detections)
    out["akkf-" + type(kernel).__name__] = np.vstack([track[-1].state_vector,
                                                      track[-1].weight[None]])

@njit
def shift(states, dt):
    return states + 0.1 * dt

@njit
def first_two(states):
    return states[:2].copy()

model = ft.NonlinearGaussianTransitionModel(shift, np.eye(2) * 0.01, ndim_state=2)
sensor = ft.NonlinearGaussianMeasurement(first_two, ndim_state=2, noise_covar=np.eye(2))
detections = [ft.Detection([0.1 * k, 0.2 * k], timestamp=float(k)) for k in range(1, 4)]
track = ft.run_filter(ft.ParticlePredictor(model, rng=6),
                      ft.ParticleUpdater(sensor, ft.SystematicResampler(rng=7)),
                      ft.ParticleState(rng.standard_normal((2, 300)), timestamp=0.0), detections)
out["user-pf"] = track[-1].state_vector
track = ft.run_filter(ft.ExtendedKalmanPredictor(model), ft.ExtendedKalmanUpdater(sensor),
                      ft.GaussianState([0, 0], np.eye(2), timestamp=0.0), detections)
out["user-ekf"] = np.hstack([track[-1].state_vector, track[-1].covar])
out["gram"] = ft.GaussianKernel()(rng.standard_normal((2, 30)), angle_components=(0,))
mixture = ft.types.GaussianMixture(rng.standard_normal((6, 2)),
                                   np.broadcast_to(np.eye(2), (6, 2, 2)), rng.normal(size=6),
                                   [0, 1, 0, 2, 1, 0]).reduce()
out["mixture"] = np.hstack([mixture.means, mixture.covars.reshape(3, -1),
                            mixture.log_weights[:, None]])
many = ft.GaussianMixture(rng.standard_normal((80, 2)) * 5.0,
                          np.broadcast_to(np.eye(2), (80, 2, 2)), rng.normal(size=80))
for mode in ("textbook", "stonesoup"):
    reduced = ft.GaussianMixtureReducer(merge_threshold=4.0, mode=mode).reduce(many)
    out["reduce-" + mode] = np.hstack([reduced.means, reduced.covars.reshape(-1, 4),
                                       reduced.log_weights[:, None]])
imm = ft.BatchIMMFilter([ft.ConstantVelocity(0.1), ft.ConstantVelocity(1.0)],
                       ft.LinearGaussian(2, (0,), np.eye(1)), [[0.9, 0.1], [0.1, 0.9]])
means, covars, probs = imm.step(np.zeros((3, 2, 2)), np.broadcast_to(np.eye(2), (3, 2, 2, 2)),
                                np.full((3, 2), 0.5), rng.normal(size=(3, 1)), 1.0)
out["imm"] = np.hstack([means.reshape(3, -1), covars.reshape(3, -1), probs])
json.dump({k: [np.asarray(v).dtype.kind, np.asarray(v).tolist()] for k, v in out.items()},
          sys.stdout)
"""


@pytest.mark.slow
def test_every_kernel_runs_uncompiled_with_the_compiled_results():
    runs = {}
    for jit_off in ("0", "1"):
        done = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-c",
                               _EVERY_KERNEL], env=dict(os.environ, NUMBA_DISABLE_JIT=jit_off),
                              capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, done.stderr[-3000:]
        runs[jit_off] = json.loads(done.stdout)
    compiled, uncompiled = runs["0"], runs["1"]
    assert compiled.keys() == uncompiled.keys()
    for name, (kind, values) in compiled.items():
        other_kind, others = uncompiled[name]
        assert kind == other_kind, name
        if kind in "iub":
            assert values == others, name
        else:
            # finite-difference Jacobians divide differences of nearby values by small steps,
            # amplifying the last bit of atan2 (libm's compiled, NumPy's in Python) and of
            # fused multiply-adds: 1e-9 to 1e-6 relative in the state after 4 steps
            rtol = 1e-5 if name in ("ekf-forward", "ekf-central", "user-ekf") else 1e-12
            np.testing.assert_allclose(others, values, rtol=rtol, atol=1e-12, err_msg=name)
