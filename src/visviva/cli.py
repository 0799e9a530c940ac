"""Command line: ``visviva validate`` (the cross-validation report) and ``visviva bench``."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="visviva", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p_val = sub.add_parser("validate", help="run the cross-validation suite against REBOUND, "
                           "Skyfield, astropy and sgp4 and write a report")
    p_val.add_argument("--full", action="store_true", help="include the long runs")
    p_val.add_argument("--report", default="validation-report", help="folder for the report")
    p_val.add_argument("--only", default=None, help="run only checks whose name contains this")
    sub.add_parser("bench", help="time visviva side by side with the reference libraries")
    args = parser.parse_args(argv)
    if args.command == "validate":
        from .validation import run

        return run(full=args.full, report_dir=args.report, only=args.only)
    if args.command == "bench":
        import runpy

        runpy.run_module("benchmarks", run_name="__main__")
        return 0
    return 2


if __name__ == "__main__":
    sys.exit(main())
