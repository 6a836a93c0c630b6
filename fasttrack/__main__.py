"""Command line: ``python -m fasttrack {demo,warmup} ...`` (``--help`` for each)."""
import argparse
import difflib
import sys


#: Options users reach for that go by another name here.
_SYNONYMS = {"--fast": "--quick", "--short": "--quick", "--small": "--quick",
             "--output": "--out", "--dir": "--out", "--noplots": "--no-plots"}


class _Parser(argparse.ArgumentParser):
    """An argument parser that suggests the nearest option for a mistyped one."""

    def error(self, message):
        if message.startswith("unrecognized arguments:"):
            known = _options(self)
            for word in message.split(":", 1)[1].split():
                word = word.split("=")[0]
                close = [_SYNONYMS[word]] if word in _SYNONYMS else \
                    difflib.get_close_matches(word, known, n=1, cutoff=0.6)
                if close:
                    message += f" (did you mean {close[0]}?)"
        super().error(message)


def _options(parser):
    """Every option string of ``parser`` and of its sub-commands."""
    found = []
    for action in parser._actions:
        found += action.option_strings
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found += _options(sub)
    return found


def main(argv=None):
    from ._version import __version__
    parser = _Parser(prog="python -m fasttrack",
                     description="fasttrack: fast, trustworthy tracking and state estimation "
                                 "(Stone Soup's classes, compiled kernels).")
    parser.add_argument("--version", action="version", version=f"fasttrack {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    demo = commands.add_parser(
        "demo", help="run the tutorial scenarios and time them",
        description="Track the four tutorial scenarios (resamplers, particle filter, EKF, "
                    "AKKF), print position RMSE and time per step against Stone Soup, and "
                    "write PNG plots. On 2 cores: --quick about 50 s the first time "
                    "(30 s of it compiling), 6 s once compiled; the full demo a few minutes.")
    demo.add_argument("--quick", action="store_true",
                      help="smaller sizes and fewer repeats (under a minute)")
    demo.add_argument("--out", default="fasttrack-demo",
                      help="folder for the PNG plots (default: ./fasttrack-demo)")
    demo.add_argument("--no-plots", action="store_true", help="write no plots")
    warm = commands.add_parser(
        "warmup", help="compile every kernel family into the per-user cache now (an "
                       "editable install, a changed numba or NumPy, a container image)",
        description="Compile the kernels of each family into fasttrack's per-user cache, a "
                    "line per family as it is ready. After `pip install .` the kernels "
                    "shipped in the package serve already, and this only loads them.")
    warm.add_argument("--cache-dir", help="the cache directory to fill (default: "
                                          "$FASTTRACK_CACHE_DIR, else the user cache dir)")
    warm.add_argument("--families", nargs="+", metavar="FAMILY",
                      help="some of: kalman unscented akkf smooth gating assign jpda mixture imm "
                           "resample particle (default: all)")
    warm.add_argument("--processes", type=int, default=None,
                      help="worker processes compiling at once (default: the cores)")
    args, extra = parser.parse_known_args(argv)
    if extra:
        commands.choices[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    if args.command == "demo":
        from .demo import run
        run(quick=args.quick, out=None if args.no_plots else args.out)
    elif args.command == "warmup":
        return _warmup(args)
    return 0


def _warmup(args):
    """Fill the cache in worker processes (which see ``--cache-dir``), a line a family."""
    import os
    import time
    from ._warmup import FAMILIES, warmup
    if args.cache_dir:
        os.environ["FASTTRACK_CACHE_DIR"] = os.path.abspath(args.cache_dir)
    families = args.families or list(FAMILIES)
    unknown = sorted(set(families) - set(FAMILIES))
    if unknown:
        print(f"unknown families {unknown}; valid: {', '.join(FAMILIES)}", file=sys.stderr)
        return 2
    from ._jit import cache
    start = time.perf_counter()
    if cache.shipped()[0] is not None:
        print("the kernels shipped with fasttrack serve these families: loading them, and "
              "compiling only what they lack", flush=True)
    print(f"compiling {len(families)} kernel families into "
          f"{os.environ.get('FASTTRACK_CACHE_DIR') or 'the user cache directory'}", flush=True)

    def report(name, seconds):
        print(f"  {name:<16} ready after {time.perf_counter() - start:6.1f} s "
              f"({seconds:.1f} s in its worker)", flush=True)

    warmup(families, processes=args.processes or os.cpu_count() or 1, report=report,
           load=False)
    print(f"done in {time.perf_counter() - start:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
