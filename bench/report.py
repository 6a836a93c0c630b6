"""Turn pytest-benchmark JSON into a markdown table of speed-up ratios and check targets.

Usage: python bench/report.py [bench/results/latest.json] [--check] [--plot PNG]

Each benchmark group is "<workload> N=<n>"; the implementation comes from the test name
(test_fasttrack..., test_numpy_reference..., test_stonesoup...). Ratios compare medians
measured in the same run. ``--check`` exits 1 if a ratio misses its target, naming it;
``--plot`` writes a PNG of time against N, one panel per workload.
"""
import argparse
import json
import re
import sys
from collections import defaultdict

import numpy as np

# (workload, N, ratio, minimum): ratio "stonesoup" = Stone Soup time / fasttrack time,
# "floor" = floor time / fasttrack time (so 1/3 means "within 3x of the floor")
TARGETS = [
    ("resample-systematic", 10**6, "stonesoup", 50.0),
    ("resample-stratified", 10**6, "stonesoup", 50.0),
    ("resample-multinomial", 10**6, "stonesoup", 50.0),
    ("resample-residual", 10**6, "stonesoup", 100.0),
    ("resample-systematic", 10**6, "floor", 1 / 3),
    ("pf-loop", 10**5, "stonesoup", 20.0),
    ("pf-loop", 10**6, "stonesoup", 20.0),
    ("pf-step", 10**5, "stonesoup", 20.0),
    ("pf-step", 10**6, "stonesoup", 20.0),
    ("pf-step", 10**6, "floor", 1 / 1.5),
    ("ekf-step", 1, "stonesoup", 60.0),
    ("akkf-quadratic", 30, "stonesoup", 10.0),
    ("akkf-quadratic", 1000, "stonesoup", 20.0),
    ("akkf-quartic", 1000, "stonesoup", 20.0),
    ("gnn-associate", 100, "stonesoup", 100.0),
    ("jpda-ehm", 100, "stonesoup", 100.0),
    ("gospa-50-tracks", 100, "stonesoup", 100.0),
    ("ukf-step", 1, "stonesoup", 50.0),
]
# (workload, N, most microseconds per item): batches timed as one call over N items
PER_ITEM_TARGETS = [("ekf-batch", 10**4, 0.5), ("ukf-batch", 10**4, 1.0)]
#: (workload, N, seconds): the most a whole call may take (multi-target tracking).
TIME_TARGETS = [("gnn-associate", 1000, 10e-3), ("gnn-associate", 10**4, 150e-3),
                ("jpda-ehm", 100, 10e-3), ("gospa-50-tracks", 100, 5e-3),
                ("gospa-40-tracks", 30_000, 2.0), ("tracker-100-scans", 1000, 10.0),
                ("rts-smoother", 1000, 1e-3), ("rts-smoother-arrays", 1000, 1e-3),
                ("ffbs", 1000, 50e-3)]
# (configuration, bound on default / one-thread step time) of bench/test_load.py; at
# N = 1000 both run the same one-thread code, so "never slower" allows the 5 % of noise
LOAD_TARGETS = [("alone", 1 / 1.6), ("pair", 1.3), ("small", 1.05), ("beside-numpy", 1.15)]

IMPLEMENTATIONS = ("fasttrack", "numpy_reference", "stonesoup", "dropin")
#: Workloads timed over many steps, to which a family's one-step floor does not apply.
WHOLE_LOOPS = ("pf-loop",)


def load(path):
    """Medians (seconds) by workload, N and implementation, and floors by workload family."""
    with open(path) as f:
        data = json.load(f)
    medians = defaultdict(dict)
    floors = {}
    for bench in data["benchmarks"]:
        median = bench["stats"]["median"]
        group = bench["group"] or ""
        if group.endswith("-floor"):
            floors[(group[: -len("-floor")], bench["extra_info"]["n"])] = median
            continue
        match = re.fullmatch(r"(.+) N=(\d+)", group)
        impl = (bench.get("params") or {}).get("implementation") or next(
            (i for i in IMPLEMENTATIONS if bench["name"].startswith(f"test_{i}")
             or f"_{i}[" in bench["name"] or bench["name"].endswith(f"_{i}")), None)
        if match and impl:
            medians[(match[1], int(match[2]))][impl] = median
    return medians, floors, data.get("machine_info", {})


def ratios(medians, floors):
    """Rows of (workload, n, medians, {ratio name: value})."""
    rows = []
    for (workload, n), times in sorted(medians.items()):
        ours = times.get("fasttrack")
        found = {}
        if ours:
            if "stonesoup" in times:
                found["stonesoup"] = times["stonesoup"] / ours
            if "numpy_reference" in times:
                found["numpy"] = times["numpy_reference"] / ours
            if "dropin" in times:
                found["dropin"] = times.get("stonesoup", np.nan) / times["dropin"]
                found["overhead"] = times["dropin"] / ours
            family = workload.split("-")[0]
            floor = floors.get((workload, n), floors.get((family, n)))
            if floor and workload not in WHOLE_LOOPS:
                found["floor"] = floor / ours
        rows.append((workload, n, times, found))
    return rows


def _ms(seconds):
    return "" if seconds is None else f"{seconds * 1e3:.3g} ms"


def _x(value):
    return "" if value is None else f"{value:.3g}x"


def table(rows):
    lines = ["| workload | N | fasttrack | NumPy ref | Stone Soup | vs Stone Soup | vs NumPy "
             "| fasttrack / floor |", "|---|---|---|---|---|---|---|---|"]
    for workload, n, times, found in rows:
        if "dropin" in times:
            continue
        floor = found.get("floor")
        lines.append(
            f"| {workload} | {n:.0e} | {_ms(times.get('fasttrack'))} "
            f"| {_ms(times.get('numpy_reference'))} | {_ms(times.get('stonesoup'))} "
            f"| {_x(found.get('stonesoup'))} | {_x(found.get('numpy'))} "
            f"| {_x(1 / floor) if floor else ''} |")
    return "\n".join(lines)


def dropin_table(rows):
    """The drop-in layer's rows: its time against Stone Soup's and the native API's."""
    lines = ["| workload | N | fasttrack (native) | fasttrack.stonesoup | Stone Soup "
             "| drop-in vs Stone Soup | drop-in / native |", "|---|---|---|---|---|---|---|"]
    for workload, n, times, found in rows:
        if "dropin" in times:
            speedup = found.get("dropin")
            lines.append(
                f"| {workload} | {n:.0e} | {_ms(times.get('fasttrack'))} "
                f"| {_ms(times['dropin'])} | {_ms(times.get('stonesoup'))} "
                f"| {_x(speedup) if speedup == speedup else ''} "
                f"| {_x(found.get('overhead'))} |")
    return "\n".join(lines) if len(lines) > 2 else ""


def montecarlo_table(path):
    """Runs per second of the Monte Carlo benchmark per setup, and the Dask path's overhead
    per run over the local pool (both with 2 workers)."""
    with open(path) as f:
        benchmarks = json.load(f)["benchmarks"]
    runs, startup = {}, {}
    for bench in benchmarks:
        group, setup = bench["group"] or "", (bench.get("params") or {}).get("setup")
        if group.startswith("montecarlo-pf"):
            runs[setup] = (bench["extra_info"]["runs"], bench["stats"]["median"])
        elif group == "montecarlo-startup":
            startup[setup] = bench["stats"]["median"]
    if not runs:
        return ""
    serial = runs.get("serial", (1, None))[1]
    lines = ["| setup | runs | time | runs / s | vs serial | fresh start |",
             "|---|---|---|---|---|---|"]
    for setup in ("serial", "local-2", "dask-2"):
        if setup in runs:
            n, seconds = runs[setup]
            lines.append(f"| {setup} | {n:,} | {seconds:.3g} s | {n / seconds:.0f} "
                         f"| {_x(serial / seconds) if serial else ''} "
                         f"| {f'{startup[setup]:.2g} s' if setup in startup else ''} |")
    if "local-2" in runs and "dask-2" in runs:
        (n, local), (_, dask) = runs["local-2"], runs["dask-2"]
        lines.append(f"\nDask overhead per run over the local pool: "
                     f"{(dask - local) / n * 1e3:.2g} ms")
    return "\n".join(lines)


def load_steps(path):
    """Step seconds of ``bench/test_load.py`` by configuration and thread setting."""
    with open(path) as f:
        benchmarks = json.load(f)["benchmarks"]
    steps = {}
    for bench in benchmarks:
        group, info = bench["group"] or "", bench.get("extra_info", {})
        if group.startswith("load-") and "default_step_seconds" in info:
            steps[group[len("load-"):]] = {"default": info["default_step_seconds"],
                                           "one": info["one_step_seconds"]}
    return steps


def load_table(steps):
    """The load benchmark: default threads against one thread, per configuration."""
    if not steps:
        return ""
    lines = ["| configuration | default threads | one thread (BLAS's for beside-numpy) | "
             "default / one thread |",
             "|---|---|---|---|"]
    for config, times in sorted(steps.items()):
        default, one = times.get("default"), times.get("one")
        ratio = f"{default / one:.2f}" if default and one else ""
        lines.append(f"| {config} | {_ms(default)} | {_ms(one)} | {ratio} |")
    return "\n".join(lines)


def check_load(steps):
    """Messages for the load targets that are missed (only if the benchmark ran)."""
    failures = []
    for config, most in LOAD_TARGETS:
        times = steps.get(config, {})
        if "default" in times and "one" in times and times["default"] / times["one"] > most:
            failures.append(f"load-{config}: default / one thread "
                            f"{times['default'] / times['one']:.2f} > target {most:.2f}")
    return failures


def cold_table(path):
    """The cold-start measurements of ``bench/cold_start.py --json``, with targets."""
    with open(path) as f:
        cold = json.load(f)
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from cold_start import table
    return table(cold)


def check(rows):
    """Messages for the targets that are missed or not measured."""
    found = {(w, n): r for w, n, _, r in rows}
    times = {(w, n): t for w, n, t, _ in rows}
    failures = []
    for workload, n, most in PER_ITEM_TARGETS:
        seconds = times.get((workload, n), {}).get("fasttrack")
        if seconds is None:
            failures.append(f"{workload} N={n}: not measured")
        elif seconds / n * 1e6 > most:
            failures.append(f"{workload} N={n}: {seconds / n * 1e6:.3g} us per item > "
                            f"target {most:.3g}")
    for workload, n, most in TIME_TARGETS:
        seconds = times.get((workload, n), {}).get("fasttrack")
        if seconds is None:
            failures.append(f"{workload} N={n}: not measured")
        elif seconds > most:
            failures.append(f"{workload} N={n}: {seconds:.3g} s > target {most:.3g} s")
    for workload, n, ratio, minimum in TARGETS:
        value = found.get((workload, n), {}).get(ratio)
        if value is None:
            failures.append(f"{workload} N={n}: {ratio} ratio not measured")
        elif value < minimum:
            failures.append(f"{workload} N={n}: {ratio} ratio {value:.3g} < target {minimum:.3g}")
    return failures


def plot(medians, path):
    """One log-log panel per workload: median time against N for each implementation."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    workloads = sorted({w for w, _ in medians})
    columns = 4
    rows = -(-len(workloads) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4 * columns, 3.2 * rows),
                                squeeze=False)
    for ax, workload in zip(axes.flat, workloads):
        sizes = sorted(n for w, n in medians if w == workload)
        for impl in IMPLEMENTATIONS:
            points = [(n, medians[(workload, n)][impl]) for n in sizes
                      if impl in medians[(workload, n)]]
            if points:
                n, t = zip(*points)
                ax.plot(n, np.array(t) * 1e3, marker="o", label=impl)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(workload, fontsize="small")
        ax.set_xlabel("N")
        ax.set_ylabel("ms")
        ax.legend(fontsize="x-small")
    for ax in axes.flat[len(workloads):]:
        ax.axis("off")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="?", default="bench/results/latest.json")
    parser.add_argument("--check", action="store_true", help="exit 1 if a target is missed")
    parser.add_argument("--plot", metavar="PNG", help="write a plot of time against N")
    parser.add_argument("--cold", metavar="JSON", help="bench/cold_start.py --json output to "
                                                       "show too")
    args = parser.parse_args(argv)
    medians, floors, machine = load(args.json)
    rows = ratios(medians, floors)
    print(table(rows))
    steps = load_steps(args.json)
    for extra in (dropin_table(rows), montecarlo_table(args.json), load_table(steps),
                  cold_table(args.cold) if args.cold else ""):
        if extra:
            print("\n" + extra)
    cpu = machine.get("cpu", {}).get("brand_raw", "")
    print(f"\nMedians from {args.json} ({cpu}, {machine.get('cpu', {}).get('count', '?')} cores).")
    if args.plot:
        print(f"Plot: {plot(medians, args.plot)}")
    if args.check:
        failures = check(rows) + check_load(steps)
        for failure in failures:
            print("MISSED:", failure)
        return 1 if failures else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
