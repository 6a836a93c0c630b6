"""What a new user waits for: installing, and each first result, in fresh environments.

Usage: python bench/cold_start.py [--repeats 3] [--json bench/results/cold_start.json]
[--parts installed pure editable]

Each part makes a new virtual environment in a temporary folder, with an empty HOME (so no
pip cache and no per-user kernel cache), installs this checkout into it and times, each in
new Python processes (import included; the median of ``--repeats``):

- ``installed``: ``pip install .`` (the README's way: the kernels are compiled while the
  wheel is built), the installed size, then the first particle-filter, EKF, UKF and AKKF
  update and the first multi-target tracker step, each as a user's script runs it and on
  the kernels from the first call, with the fasttrack kernels each compiled (0 is the
  target), and ``python -m fasttrack demo --quick``; then
  the same first steps with ``NUMBA_CPU_NAME=generic``, so that the shipped kernels cannot
  serve (another CPU): the fall-back compiles, and says why once;
- ``pure``: ``pip install .`` with ``FASTTRACK_COMPILE_KERNELS=0``, the install as it was
  before kernels shipped (its time and size);
- ``editable``: ``pip install -e .`` (no shipped kernels), then the same first steps from an
  empty per-user cache, and ``python -m fasttrack warmup``.

``python bench/report.py ... --cold bench/results/cold_start.json`` prints the table again.
"""
import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: A first step of each kernel family, timed from interpreter start (import included), run
#: with argv[2] "user" as a user's script runs it (a process's first small calls may run in
#: NumPy, see ``fasttrack._jit.numpy_first``) or "kernels" (the kernels from the first call:
#: the compile path); prints, as JSON, the seconds, whether Numba was loaded, and for
#: "kernels" the fasttrack kernels compiled (Numba's compile events), the seconds spent in
#: LLVM (its llvm_lock events) and the five kernels whose own compilation took longest.
FIRST_STEP = """
import contextlib, json, sys, time
start = time.perf_counter()
import numpy as np
import fasttrack as ft
from fasttrack.scenarios import (adaptive_kernel_tutorial, extended_kalman_tutorial,
                                 grid_targets, particle_filter_tutorial)
family, path = sys.argv[1:3]
found, llvm, recording = [], [], contextlib.ExitStack()
if path == "kernels":
    from numba.core import event
    from fasttrack import _jit
    from fasttrack._jit.dispatch import compiles
    _jit.kernels_from_now()
    found = recording.enter_context(compiles())
    recording.enter_context(event.install_timer("numba:llvm_lock", llvm.append))
def step(predictor, updater, scenario):
    d = scenario.detections[1]
    return updater.update(ft.SingleHypothesis(predictor.predict(scenario.prior, d.timestamp), d))
with recording:
    if family == "particle filter":
        s = particle_filter_tutorial(1000)
        step(ft.ParticlePredictor(s.transition_model, rng=1),
             ft.ParticleUpdater(s.measurement_model, ft.SystematicResampler(rng=2)), s).mean
    elif family == "extended Kalman filter":
        s = extended_kalman_tutorial()
        step(ft.ExtendedKalmanPredictor(s.transition_model),
             ft.ExtendedKalmanUpdater(s.measurement_model), s)
    elif family == "unscented Kalman filter":
        s = extended_kalman_tutorial()
        step(ft.UnscentedKalmanPredictor(s.transition_model),
             ft.UnscentedKalmanUpdater(s.measurement_model), s)
    elif family == "AKKF":
        s = adaptive_kernel_tutorial(30)
        step(ft.AdaptiveKernelKalmanPredictor(s.transition_model),
             ft.AdaptiveKernelKalmanUpdater(s.measurement_model, rng=1), s)
    elif family == "multi-target tracker":
        s = grid_targets(n_targets=20, steps=2, seed=0)
        tracker = ft.MultiTargetTracker(s.transition_model, s.measurement_model, np.zeros(4),
                                        np.diag([100.0, 1.0, 100.0, 1.0]))
        tracker.step(s.detections[0], 0.0)
seconds = time.perf_counter() - start
top = sorted(found, key=lambda c: -c.own_seconds)[:5]
print(json.dumps({"seconds": seconds, "numba_loaded": "numba" in sys.modules,
                  "compiled": len(found), "llvm_seconds": sum(llvm),
                  "top": [[c.name.split("._jit.")[1], round(c.own_seconds, 2)] for c in top]}))
"""

#: The two ways :data:`FIRST_STEP` runs: as a user's script, and on the kernels.
PATHS = ("user", "kernels")

FAMILIES = ["particle filter", "extended Kalman filter", "unscented Kalman filter", "AKKF",
            "multi-target tracker"]

#: Seconds, from a new process (import included): after ``pip install .`` (all families,
#: and the quick demo), in an editable install from an empty cache, and for the install.
TARGETS = {"installed": {**dict.fromkeys(FAMILIES, 1.0), "demo --quick": 15.0},
           "editable": {"particle filter": 4.0, "extended Kalman filter": 6.0, "AKKF": 9.0,
                        "warmup": 20.0},
           "install": {"pip install .": 90.0, "installed megabytes added": 25.0}}


class Environment:
    """A new virtual environment with an empty HOME, in ``folder``."""

    def __init__(self, folder):
        self.folder = pathlib.Path(folder)
        self.home = self.folder / "home"
        self.home.mkdir(parents=True)
        subprocess.run([sys.executable, "-m", "venv", str(self.folder / "venv")], check=True)
        self.python = str(self.folder / "venv" / "bin" / "python")

    def env(self, **extra):
        env = {k: v for k, v in os.environ.items()
               if not k.startswith(("FASTTRACK_", "NUMBA_", "PYTHON", "XDG_"))}
        return dict(env, HOME=str(self.home), **extra)

    def run(self, *args, **extra):
        """Run ``python *args`` here (in ``home``); returns (seconds, stdout)."""
        start = time.perf_counter()
        done = subprocess.run([self.python, *args], cwd=self.home, env=self.env(**extra),
                              capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if done.returncode:
            raise RuntimeError(f"{args} failed:\n{done.stderr[-3000:]}")
        return seconds, done.stdout, done.stderr

    def first_step(self, family, path, **extra):
        """The JSON record of :data:`FIRST_STEP` on ``path`` (one of :data:`PATHS`), and the
        warnings printed."""
        _, out, err = self.run("-c", FIRST_STEP, family, path, **extra)
        return json.loads(out.splitlines()[-1]), err

    def site_packages(self):
        _, out, _ = self.run("-c", "import sysconfig; print(sysconfig.get_path('purelib'))")
        return pathlib.Path(out.strip())


def _megabytes(folder):
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) / 1e6


def _first_steps(environment, repeats, empty_cache, **extra):
    """Per family and path (:data:`PATHS`): seconds, kernels compiled and fallback warnings
    of ``repeats`` new processes; each starts from an empty per-user cache if
    ``empty_cache``. On the "user" path, ``compiled`` counts the kernel files the process
    wrote to that cache (0 when Numba was never loaded)."""
    found = {}
    for family in FAMILIES:
        found[family] = {}
        for path in PATHS:
            records, warnings = [], 0
            for attempt in range(repeats):
                cache = environment.folder / f"cache-{family}-{path}-{attempt}"
                settings = dict(extra, FASTTRACK_CACHE_DIR=str(cache)) if empty_cache else extra
                record, err = environment.first_step(family, path, **settings)
                if path == "user":
                    record["compiled"] = len(list(cache.rglob("*.nbc"))) if empty_cache else 0
                records.append(record)
                warnings += err.count("cannot be used")
            done = {key: [r[key] for r in records]
                    for key in ("seconds", "compiled", "llvm_seconds", "numba_loaded")}
            done.update(fallback_warnings=warnings, top=records[0]["top"])
            found[family][path] = done
            line = f"  {family:<24} {path:<8} {_runs(done['seconds'])}; kernels compiled " \
                   f"{done['compiled']}; Numba loaded {sum(done['numba_loaded'])} of {repeats}"
            if records[0]["top"]:
                line += (f"; LLVM {statistics.median(done['llvm_seconds']):.1f} s; "
                         f"longest: {', '.join(f'{n} {t} s' for n, t in records[0]['top'])}")
            print(line, flush=True)
    return found


def _runs(values):
    return f"median {statistics.median(values):.2f} s ({', '.join(f'{v:.2f}' for v in values)})"


def installed(folder, repeats):
    environment = Environment(folder)
    print("pip install . (kernels compiled while the wheel is built)", flush=True)
    seconds, _, _ = environment.run("-m", "pip", "install", "--quiet", str(ROOT))
    package = environment.site_packages() / "fasttrack"
    result = {"install_seconds": seconds, "package_megabytes": _megabytes(package),
              "kernels_megabytes": _megabytes(package / "_kernels")}
    print(f"  {seconds:.1f} s; package {result['package_megabytes']:.1f} MB, of which "
          f"kernels {result['kernels_megabytes']:.1f} MB", flush=True)
    environment.run("-m", "pip", "install", "--quiet", f"{ROOT}[stonesoup]")  # the demo's
    print("first steps after install (empty per-user cache)", flush=True)
    result["first_steps"] = _first_steps(environment, repeats, empty_cache=True)
    demo = [environment.run("-m", "fasttrack", "demo", "--quick", "--no-plots")[0]
            for _ in range(repeats)]
    result["demo_quick"] = demo
    print(f"  python -m fasttrack demo --quick: {_runs(demo)}", flush=True)
    print("mismatch: NUMBA_CPU_NAME=generic (the shipped kernels cannot serve)", flush=True)
    result["mismatch"] = _first_steps(environment, repeats, empty_cache=True,
                                      NUMBA_CPU_NAME="generic", NUMBA_CPU_FEATURES="")
    return result


def pure(folder):
    """The install as it was before kernels shipped: a pure wheel, nothing compiled."""
    environment = Environment(folder)
    print("pip install . with FASTTRACK_COMPILE_KERNELS=0 (a pure wheel)", flush=True)
    seconds, _, _ = environment.run("-m", "pip", "install", "--quiet", str(ROOT),
                                    FASTTRACK_COMPILE_KERNELS="0")
    package = environment.site_packages() / "fasttrack"
    print(f"  {seconds:.1f} s; package {_megabytes(package):.1f} MB", flush=True)
    return {"install_seconds": seconds, "package_megabytes": _megabytes(package)}


def editable(folder, repeats):
    environment = Environment(folder)
    print("pip install -e . (no shipped kernels)", flush=True)
    seconds, _, _ = environment.run("-m", "pip", "install", "--quiet", "-e", str(ROOT))
    print(f"  {seconds:.1f} s", flush=True)
    result = {"install_seconds": seconds}
    print("first steps from an empty per-user cache", flush=True)
    result["first_steps"] = _first_steps(environment, repeats, empty_cache=True)
    warmup = []
    for attempt in range(repeats):
        cache = environment.folder / f"cache-warmup-{attempt}"
        warmup.append(environment.run("-m", "fasttrack", "warmup",
                                      FASTTRACK_CACHE_DIR=str(cache))[0])
    result["warmup"] = warmup
    print(f"  python -m fasttrack warmup: {_runs(warmup)}", flush=True)
    return result


def table(results):
    """The measurements as a Markdown table with the targets."""
    lines = ["| new process, import included | seconds (median) | kernels compiled | target |",
             "|---|---|---|---|"]

    def row(name, values, compiled="", target=None):
        median = statistics.median(values) if isinstance(values, list) else values
        lines.append(f"| {name} | {median:.2f} | {compiled} | "
                     f"{'' if target is None else f'<= {target:g}'} |")

    if "installed" in results:
        done = results["installed"]
        row("`pip install .`", done["install_seconds"], "",
            TARGETS["install"]["pip install ."])
        if "pure" in results:
            row("`pip install .`, kernels not compiled (`FASTTRACK_COMPILE_KERNELS=0`)",
                results["pure"]["install_seconds"])
            added = done["package_megabytes"] - results["pure"]["package_megabytes"]
            lines.append(f"| installed size added by the kernels | {added:.1f} MB | | "
                         f"<= {TARGETS['install']['installed megabytes added']:g} MB |")
        for family, paths in done["first_steps"].items():
            for path, step in paths.items():
                row(f"installed: first {family} step ({path})", step["seconds"],
                    max(step["compiled"]), TARGETS["installed"].get(family))
        row("installed: `python -m fasttrack demo --quick`", done["demo_quick"], "",
            TARGETS["installed"]["demo --quick"])
        for family, paths in done["mismatch"].items():
            for path, step in paths.items():
                warned = f"{step['fallback_warnings']} of {len(step['seconds'])}"
                row(f"shipped kernels unusable (another CPU): first {family} step ({path})",
                    step["seconds"], f"{max(step['compiled'])} (said why in {warned} runs)")
    if "editable" in results:
        done = results["editable"]
        for family, paths in done["first_steps"].items():
            for path, step in paths.items():
                row(f"editable, empty cache: first {family} step ({path})", step["seconds"],
                    max(step["compiled"]), TARGETS["editable"].get(family))
        row("editable: `python -m fasttrack warmup`", done["warmup"], "",
            TARGETS["editable"]["warmup"])
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="also write the measurements here")
    parser.add_argument("--parts", nargs="+", choices=["installed", "pure", "editable"],
                        default=["installed", "pure", "editable"])
    args = parser.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory() as scratch:
        for part in args.parts:
            folder = pathlib.Path(scratch) / part
            results[part] = (pure(folder) if part == "pure" else
                             globals()[part](folder, args.repeats))
    print("\n" + table(results))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
