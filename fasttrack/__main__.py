"""Command line: ``python -m fasttrack demo [--out DIR] [--quick]``."""
import argparse
import sys


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m fasttrack")
    commands = parser.add_subparsers(dest="command", required=True)
    demo = commands.add_parser("demo", help="run the tutorial scenarios and time them")
    demo.add_argument("--quick", action="store_true",
                      help="smaller sizes and fewer repeats (under a minute)")
    demo.add_argument("--out", default="fasttrack-demo",
                      help="folder for the PNG plots (default: ./fasttrack-demo)")
    warm = commands.add_parser(
        "warmup", help="compile every kernel family into the cache now (for a container "
                       "image or a CI cache)",
        description="Compile the kernels of each family into fasttrack's on-disk cache, a "
                    "line per family as it is ready.")
    warm.add_argument("--cache-dir", help="the cache directory to fill (default: "
                                          "$FASTTRACK_CACHE_DIR, else the user cache dir)")
    warm.add_argument("--families", nargs="+", metavar="FAMILY",
                      help="some of: resamplers particle_filter kalman batch adaptive_kernel")
    warm.add_argument("--processes", type=int, default=None,
                      help="worker processes compiling at once (default: the cores)")
    args = parser.parse_args(argv)
    if args.command == "demo":
        from .demo import run
        run(quick=args.quick, out=args.out)
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
    start = time.perf_counter()
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
