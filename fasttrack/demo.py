"""The demo behind ``python -m fasttrack demo``: the resampler tutorial's examples, then the
resamplers timed against the NumPy reference (from a source checkout) and Stone Soup (when
installed), in the same run."""
import importlib.util
import pathlib
import time

import numpy as np

import fasttrack as ft

TUTORIAL_WEIGHTS = np.array([1, 5, 1.5, 0.5, 2]) / 10


def _median_time(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _reference_module():
    """tests/reference.py of the source checkout, if this is one (else None)."""
    for root in (pathlib.Path.cwd(), pathlib.Path(__file__).resolve().parents[1]):
        path = root / "tests" / "reference.py"
        if path.is_file():
            spec = importlib.util.spec_from_file_location("fasttrack_reference", path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            return module
    return None


def _stonesoup_resamplers():
    try:
        from stonesoup.resampler import particle as ss
    except ImportError:
        return None
    return {
        "systematic": ss.SystematicResampler(),
        "stratified": ss.StratifiedResampler(),
        "multinomial": ss.MultinomialResampler(),
        "residual": ss.ResidualResampler(residual_method=ss.ResidualMethod.SYSTEMATIC),
    }


def _resamplers():
    return {
        "systematic": (ft.SystematicResampler(rng=1), "systematic", False),
        "stratified": (ft.StratifiedResampler(rng=1), "stratified", False),
        "multinomial": (ft.MultinomialResampler(rng=1), "multinomial", False),
        "residual": (ft.ResidualResampler("systematic", rng=1), "systematic", True),
    }


def _counts(values):
    return " ".join(f"{v:5.3g}" for v in values)


def tutorial_examples(draws):
    """Offspring counts of each resampler on the tutorial's five weights."""
    print("Resampler tutorial: weights", TUTORIAL_WEIGHTS.tolist(), "N = 5")
    print(f"{'resampler':<14}{'one draw':<31}{f'mean of {draws} draws':<31}")
    particles = ft.ParticleState(np.arange(5.0)[None], weight=TUTORIAL_WEIGHTS)
    for name, (resampler, _, _) in _resamplers().items():
        counts = np.zeros(5)
        for i in range(draws):
            drawn = resampler.resample(particles).state_vector[0].astype(int)
            counts += np.bincount(drawn, minlength=5)
            if i == 0:
                first = np.bincount(drawn, minlength=5)
        print(f"{name:<14}{_counts(first):<31}{_counts(counts / draws):<31}")
    print(f"{'expected N w':<45}{_counts(5 * TUTORIAL_WEIGHTS)}")
    ess = ft.ess(particles.log_weight)
    kept = ft.ESSResampler().resample(particles) is particles
    print(f"ESSResampler: ESS = {ess:.2f} against N/2 = 2.5, so the particles are "
          f"{'kept as they are' if kept else 'resampled'}")


def timing(n, repeats):
    """Median time of each resampler at N particles (4-D) for each implementation."""
    reference = _reference_module()
    stonesoup = _stonesoup_resamplers()
    rng = np.random.default_rng(0)
    log_w = np.log(rng.random(n))
    x = rng.standard_normal((4, n))
    state = ft.ParticleState(x, log_weight=log_w)
    if stonesoup:
        from stonesoup.types.array import StateVectors
        from stonesoup.types.state import ParticleState
        ss_state = ParticleState(StateVectors(x), log_weight=log_w - np.logaddexp.reduce(log_w))
    out = np.empty_like(x)
    floor = _median_time(lambda: np.copyto(out, x), repeats)
    print(f"\nResampling N = {n:,} particles (4-D), median of {repeats}; "
          f"floor (np.copyto of the state): {floor * 1e3:.2f} ms")
    print(f"{'resampler':<14}{'fasttrack':>12}{'NumPy ref':>12}{'Stone Soup':>12}"
          f"{'vs NumPy':>10}{'vs Stone Soup':>15}")
    for name, (resampler, method, residual) in _resamplers().items():
        ours = _median_time(lambda: resampler.resample(state), repeats)
        row = f"{name:<14}{ours * 1e3:>9.2f} ms"
        if reference:
            numpy_time = _median_time(
                lambda: x[:, reference.draw(log_w, n, method, residual, 1)], repeats)
            row += f"{numpy_time * 1e3:>9.1f} ms"
        else:
            numpy_time = None
            row += f"{'n/a':>12}"
        if stonesoup:
            print(f"{row}   (timing Stone Soup...)", end="\r", flush=True)
            np.random.seed(0)
            ss_time = _median_time(lambda: stonesoup[name].resample(ss_state),
                                   max(1, repeats // 2))
            row += f"{ss_time * 1e3:>9.1f} ms"
        else:
            ss_time = None
            row += f"{'n/a':>12}"
        row += f"{numpy_time / ours:>9.1f}x" if numpy_time else f"{'':>10}"
        row += f"{ss_time / ours:>14.1f}x" if ss_time else ""
        print(row + " " * 10)
    if reference is None:
        print("(NumPy reference: run from a source checkout, where tests/reference.py is)")
    if stonesoup is None:
        print("(Stone Soup: pip install 'fasttrack[stonesoup]' to compare)")


def run(quick=False):
    """Run the demo; ``quick`` uses N = 1e5 and fewer repeats."""
    start = time.perf_counter()
    print(f"fasttrack {ft.__version__}: compiling kernels (cached after the first run)...")
    print(f"  ready in {ft.warmup():.1f} s\n")
    tutorial_examples(draws=2000 if quick else 10000)
    timing(10**5 if quick else 10**6, repeats=5 if quick else 9)
    print(f"\nDemo finished in {time.perf_counter() - start:.1f} s")
