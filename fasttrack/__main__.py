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
    args = parser.parse_args(argv)
    if args.command == "demo":
        from .demo import run
        run(quick=args.quick, out=args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
