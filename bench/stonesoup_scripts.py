"""Stone Soup's own documentation scripts, plain and with imports switched to
``fasttrack.stonesoup``, timed as whole processes.

Usage: python bench/stonesoup_scripts.py [--repeats 3] [--scripts 01_Kalman ...]
[--json bench/results/stonesoup_scripts.json] [--sdist DIR] [--suite]

The Stone Soup sdist of the installed version is downloaded (``pip download``) once into
``--sdist`` (default: a ``stonesoup-sdist`` folder in the system's temporary folder). Each
chosen script runs in a new process from its own folder, with ``MPLBACKEND=Agg``, twice as
written (``plain``) and twice with every ``from stonesoup.X import Name`` followed by
``from fasttrack.stonesoup import Name`` where fasttrack has a drop-in of that class
(``switched``, what a user does by hand). The two modes alternate; the first run of each
fills the kernel cache and any downloads, and the medians of the next ``--repeats`` runs
are reported, whole process (interpreter start to exit, shutdown included), with the
median of the paired differences (switched minus plain). A third process in each round
runs only the script's own top-level imports, as written (``imports``): the part of its
plain time that no drop-in can shorten. One more switched run counts the
calls that ran Stone Soup's own code (``fasttrack.stonesoup.fallbacks``), with their
reasons.

``--suite`` runs Stone Soup's own test suite (from the sdist) instead, twice: as it is, and
with every drop-in patched in (each Stone Soup class that ``fasttrack.stonesoup`` replaces
is replaced in the module that defines it, before the tests are collected), and prints
pytest's outcome counts of both and the tests that fail only with the drop-ins.
"""
import argparse
import ast
import compileall
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time

import stonesoup

#: Scripts that run offline in under a few minutes, relative to the sdist's ``docs``.
SCRIPTS = [
    "tutorials/01_KalmanFilterTutorial.py",
    "tutorials/02_ExtendedKalmanFilterTutorial.py",
    "tutorials/03_UnscentedKalmanFilterTutorial.py",
    "tutorials/04_ParticleFilter.py",
    "tutorials/05_DataAssociation-Clutter.py",
    "tutorials/06_DataAssociation-MultiTargetTutorial.py",
    "tutorials/07_PDATutorial.py",
    "tutorials/08_JPDATutorial.py",
    "tutorials/09_Initiators_&_Deleters.py",
    "tutorials/10_Simulation_&_Tracking_Components.py",
    "tutorials/filters/AKKF.py",
    "tutorials/filters/GMPHDTutorial.py",
    "examples/metrics/Metrics.py",
    "examples/dataassociation/Comparing_EHM_JPDA_example.py",
]


def drop_ins():
    """Names of the classes ``fasttrack.stonesoup`` replaces."""
    import fasttrack.stonesoup
    return set(fasttrack.stonesoup.__all__)


def switch_imports(source, names):
    """``source`` with ``from fasttrack.stonesoup import ...`` after each Stone Soup import
    of a class in ``names``; the number of classes switched."""
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    inserts, switched = [], 0
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("stonesoup"):
            found = [a for a in node.names if a.name in names]
            if found:
                indent = lines[node.lineno - 1][:node.col_offset]
                clause = ", ".join(f"{a.name} as {a.asname}" if a.asname else a.name
                                   for a in found)
                inserts.append((node.end_lineno, f"{indent}from fasttrack.stonesoup import "
                                                 f"{clause}\n"))
                switched += len(found)
    for line, text in sorted(inserts, reverse=True):
        lines.insert(line, text)
    return "".join(lines), switched


def imports_only(source):
    """The top-level import statements of a script's ``source``, in order."""
    tree = ast.parse(source)
    return "".join(ast.get_source_segment(source, node) + "\n" for node in tree.body
                   if isinstance(node, (ast.Import, ast.ImportFrom)))


#: Appended to a switched script: writes what ``fasttrack.stonesoup.fallbacks`` counted.
_REPORT = """
import json as _json, os as _os
from fasttrack.stonesoup import fallbacks as _fallbacks
with open(_os.environ["FASTTRACK_FALLBACK_REPORT"], "w") as _report:
    _json.dump([[*key, calls] for key, calls in _fallbacks().most_common()], _report)
"""


def sdist(folder):
    """The unpacked Stone Soup sdist of the installed version, under ``folder``."""
    folder = pathlib.Path(folder)
    root = folder / f"stonesoup-{stonesoup.__version__}"
    if not root.exists():
        folder.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
                        "--no-binary", ":all:", f"stonesoup=={stonesoup.__version__}",
                        "-d", str(folder)], check=True)
        with tarfile.open(folder / f"stonesoup-{stonesoup.__version__}.tar.gz") as archive:
            archive.extractall(folder, filter="data")
    return root


def bytecode():
    """Compile fasttrack's modules, so that a source checkout (or an environment with
    ``PYTHONDONTWRITEBYTECODE``) imports them from bytecode, as an installed package does."""
    import fasttrack
    compileall.compile_dir(pathlib.Path(fasttrack.__file__).parent, quiet=1)


def _seconds(path, **extra):
    """Seconds of one whole-process run of ``path``, from its own folder."""
    env = dict(os.environ, MPLBACKEND="Agg", **extra)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, path.name], cwd=path.parent, env=env,
                          capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode:
        raise RuntimeError(f"{path} failed:\n{done.stderr[-3000:]}")
    return seconds


def measure(root, script, names, repeats):
    """Plain and switched times of one script (``root``/docs/``script``), the two modes
    alternating (one unmeasured run of each first)."""
    path = root / "docs" / script
    source = path.read_text()
    switched_source, switched = switch_imports(source, names)
    twin = path.with_name(f"_fasttrack_{path.name}")
    twin.write_text(switched_source)
    floor = path.with_name(f"_fasttrack_imports_{path.name}")
    floor.write_text(imports_only(source))
    report = path.with_name(f"_fasttrack_{path.stem}.json")
    plain, fast, imports = [], [], []
    try:
        for attempt in range(repeats + 1):
            times = _seconds(path), _seconds(twin), _seconds(floor)
            if attempt:
                for kept, seconds in zip((plain, fast, imports), times):
                    kept.append(seconds)
        twin.write_text(switched_source + _REPORT)  # one more run, for the fallbacks
        _seconds(twin, FASTTRACK_FALLBACK_REPORT=str(report))
        fallbacks = json.loads(report.read_text())
    finally:
        twin.unlink()
        floor.unlink()
        report.unlink(missing_ok=True)
    result = {"script": script, "plain": plain, "switched": fast, "imports": imports,
              "classes": switched, "ratio": statistics.median(fast) / statistics.median(plain),
              "difference": statistics.median(f - p for f, p in zip(fast, plain)),
              "fallbacks": fallbacks}
    print(f"{script:<52} plain {statistics.median(plain):6.2f} s  switched "
          f"{statistics.median(fast):6.2f} s  ratio {result['ratio']:.2f}  difference "
          f"{result['difference']:+.2f} s  imports {statistics.median(imports):.2f} s  "
          f"({switched} classes, {sum(f[-1] for f in fallbacks)} calls ran Stone Soup's "
          f"code)", flush=True)
    return result


#: A pytest plugin: every class fasttrack.stonesoup replaces, replaced where it is defined.
_PATCH = """
import sys
import fasttrack.stonesoup as dropins
for name in dropins.__all__:
    dropin = getattr(dropins, name)
    if not isinstance(dropin, type):
        continue
    base = next((c for c in dropin.__mro__[1:]
                 if c.__module__.startswith("stonesoup.") and c.__name__ == name), None)
    if base is not None:  # (not a value such as ResidualMethod)
        setattr(sys.modules[base.__module__], name, dropin)
"""


def suite(root):
    """Outcome counts of Stone Soup's tests in the sdist at ``root``, plain and with the
    drop-ins patched in, and the tests that fail only with the drop-ins."""
    import xml.etree.ElementTree as ElementTree
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        (pathlib.Path(folder) / "_fasttrack_dropins.py").write_text(_PATCH)
        for mode, plugin in (("plain", []), ("drop-ins", ["-p", "_fasttrack_dropins"])):
            report = pathlib.Path(folder) / f"{mode}.xml"
            env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(
                [folder, str(root), *filter(None, [os.environ.get("PYTHONPATH")])]))
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                            "--continue-on-collection-errors", *plugin,
                            f"--junitxml={report}", "stonesoup"], cwd=root, env=env,
                           capture_output=True, text=True)
            outcomes = {}
            for case in ElementTree.parse(report).iter("testcase"):
                kinds = [c.tag for c in case if c.tag in ("failure", "error", "skipped")]
                outcomes[f"{case.get('classname')}::{case.get('name')}"] = \
                    kinds[0] if kinds else "passed"
            results[mode] = outcomes
            counts = {kind: list(outcomes.values()).count(kind)
                      for kind in ("passed", "failure", "error", "skipped")}
            print(f"{mode:<9} {time.perf_counter() - start:6.1f} s  {counts}", flush=True)
    broken = sorted(test for test, outcome in results["drop-ins"].items()
                    if outcome in ("failure", "error")
                    and results["plain"].get(test) not in ("failure", "error"))
    print(f"failing only with the drop-ins ({len(broken)}):", *broken, sep="\n  ")
    return results, broken


def table(results):
    """The Markdown table of ``results``."""
    rows = ["| script | plain (s) | switched (s) | ratio | difference (s) | its imports "
            "alone (s, of plain) | classes switched | calls that ran Stone Soup's code (most "
            "frequent reason) |",
            "|---|---|---|---|---|---|---|---|"]
    for r in results:
        calls = sum(f[-1] for f in r["fallbacks"])
        top = r["fallbacks"][0] if r["fallbacks"] else None
        reason = f" ({top[0]}.{top[1]}: {top[2]})" if top else ""
        rows.append(f"| `{pathlib.PurePath(r['script']).name}` | "
                    f"{statistics.median(r['plain']):.2f} | "
                    f"{statistics.median(r['switched']):.2f} | {r['ratio']:.2f} | "
                    f"{r['difference']:+.2f} | {statistics.median(r['imports']):.2f} "
                    f"({statistics.median(r['imports']) / statistics.median(r['plain']):.2f})"
                    f" | {r['classes']} | {calls}{reason} |")
    return "\n".join(rows)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scripts", nargs="*", default=None,
                        help="parts of script paths to run (default: all)")
    parser.add_argument("--json", default=None)
    parser.add_argument("--sdist", default=pathlib.Path(tempfile.gettempdir(),
                                                        "stonesoup-sdist"))
    parser.add_argument("--suite", action="store_true",
                        help="run Stone Soup's test suite, plain and with the drop-ins")
    args = parser.parse_args(argv)
    root = sdist(args.sdist)
    if args.suite:
        suite(root)
        return
    names = drop_ins()
    bytecode()
    chosen = [s for s in SCRIPTS if not args.scripts or any(p in s for p in args.scripts)]
    results = [measure(root, script, names, args.repeats) for script in chosen]
    print(table(results))
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
