"""The package's layering, read from its source (``DESIGN``: arrows only point down):
only :mod:`fasttrack.core` calls kernels, no module outside :mod:`fasttrack.models` reads
a model's private attributes, no class builds a filter class to use it as an engine, and
no module is long."""
import ast
import pathlib

import fasttrack as ft

PACKAGE = pathlib.Path(ft.__file__).parent
#: Modules of fasttrack._jit that hold no kernel: the status table, the tunables and the
#: cache, which any layer may read, and the decorator's registry of kernels (the
#: warm-up's).
NOT_KERNELS = {"fasttrack._jit", "fasttrack._jit.status", "fasttrack._jit.cache",
               "fasttrack._jit.tunables", "fasttrack._jit.kinds"}
#: The filter classes, which only the faces (demo, CLI, warm-up, Monte Carlo) build.
FILTER_MODULES = ("predictor", "updater", "smoother", "batch", "tracker", "resampler")
FACES = {"__main__.py", "demo.py", "_demo_stonesoup.py", "_warmup.py", "plotting.py",
         "montecarlo", "filtering.py"}


def _sources():
    return sorted(p for p in PACKAGE.rglob("*.py") if "_kernels" not in p.parts)


def _name(path):
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path):
    """Absolute names of the modules ``path`` imports (``from X import m`` names the
    submodule X.m when there is one; ``_jit.lazy("m")`` names fasttrack._jit.m)."""
    package = _name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and node.func.attr == "lazy" and node.args \
                and isinstance(node.args[0], ast.Constant):
            found.add(f"fasttrack._jit.{node.args[0].value}")
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                candidate = f"{module}.{alias.name}"
                relative = pathlib.Path(*candidate.split(".")[1:])
                is_module = (PACKAGE / relative).with_suffix(".py").exists() \
                    or (PACKAGE / relative / "__init__.py").exists()
                found.add(candidate if is_module else module)
    return found


def test_only_the_array_layer_imports_kernels():
    for path in _sources():
        if path.parent.name in ("core", "_jit"):
            continue
        kernels = {m for m in _imports(path)
                   if m.startswith("fasttrack._jit") and m not in NOT_KERNELS}
        assert not kernels, f"{_name(path)} imports kernel modules {sorted(kernels)}"


def _model_private_names():
    """Private attribute and method names the model classes define."""
    names = set()
    for path in (PACKAGE / "models").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                for item in ast.walk(node):
                    if isinstance(item, ast.FunctionDef) and item.name.startswith("_") \
                            and not item.name.endswith("__"):
                        names.add(item.name)
                    if isinstance(item, ast.Attribute) and isinstance(item.ctx, ast.Store) \
                            and isinstance(item.value, ast.Name) and item.value.id == "self" \
                            and item.attr.startswith("_"):
                        names.add(item.attr)
    return names


def test_no_module_outside_the_models_reads_their_private_attributes():
    private = _model_private_names()
    assert {"_mapping", "_noise_covar", "_matrix", "_function"} <= private
    for path in _sources():
        if path.parent.name == "models":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and node.attr in private \
                    and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
                assert False, (f"{_name(path)} line {node.lineno} reads .{node.attr}, a "
                               f"model's private attribute")


def _filter_classes():
    names = set()
    for module in FILTER_MODULES:
        package = PACKAGE / module
        paths = package.glob("*.py") if package.is_dir() else [package.with_suffix(".py")]
        for path in paths:
            for node in ast.parse(path.read_text()).body:
                if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                    names.add(node.name)
    return names


def test_no_class_builds_a_filter_class_as_an_engine():
    """Only the faces build filter classes; a class may default a component to one of its
    own module (``ESSResampler``'s ``SystematicResampler``, as Stone Soup's)."""
    classes = _filter_classes()
    assert {"BatchExtendedKalmanFilter", "MultiTargetTracker", "KalmanUpdater",
            "ParticlePredictor"} <= classes
    for path in _sources():
        if FACES & {path.name, path.parent.name}:
            continue
        tree = ast.parse(path.read_text())
        own = {node.name for node in tree.body if isinstance(node, ast.ClassDef)}
        aliases = {alias.asname: alias.name for node in ast.walk(tree)
                   if isinstance(node, ast.ImportFrom) for alias in node.names if alias.asname}
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                called = getattr(node.func, "id", getattr(node.func, "attr", None))
                called = aliases.get(called, called)
                assert called not in classes - own, (f"{_name(path)} line {node.lineno} "
                                                     f"builds a {called}")


def test_no_module_is_long():
    lengths = {_name(p): len(p.read_text().splitlines()) for p in _sources()}
    assert not {name: n for name, n in lengths.items() if n > 600}


def test_numba_is_imported_with_the_first_kernel_not_with_fasttrack():
    """A script pays Numba's import (and its slower exit) only when it needs a kernel."""
    import subprocess
    import sys
    modules = "fasttrack, fasttrack.stonesoup" if _has("stonesoup") else "fasttrack"
    code = (f"import sys, {modules}; print('numba' in sys.modules); "
            "fasttrack.ess(fasttrack.normalise([0.0, 1.0])); print('numba' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, timeout=600)
    assert done.stdout.split() == ["False", "True"]


def test_no_module_of_the_library_imports_scipy_stats():
    """scipy.stats costs half a second to import: the library computes what it needs of it
    from scipy.special (the drop-in layer imports Stone Soup, which imports it anyway)."""
    import subprocess
    import sys
    code = ("import sys, pkgutil, importlib, fasttrack\n"
            "for info in pkgutil.walk_packages(fasttrack.__path__, 'fasttrack.'):\n"
            "    if not info.name.startswith(('fasttrack.stonesoup', 'fasttrack._demo_stonesoup',"
            " 'fasttrack.montecarlo')):\n"
            "        importlib.import_module(info.name)\n"
            "print(sorted(m for m in sys.modules if m.startswith('scipy.stats')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, timeout=600)
    assert done.stdout.strip() == "[]"


def _has(module):
    import importlib.util
    return importlib.util.find_spec(module) is not None
