"""Command line: ``visviva validate`` (the cross-validation report), ``visviva bench``, and the
commands registered in ``_COMMANDS``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _validate_parser(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="run the cross-validation suite against REBOUND, Skyfield, astropy and sgp4",
        description="Run every visviva.validation.checks_* module live against the installed "
        "reference libraries; print one line per check (status, name, measured, tolerance, "
        "metric); write a Markdown report with plots. Exit code 0 only when every check passes.")
    p.add_argument("--full", action="store_true", help="include the long runs")
    p.add_argument("--report", default="reference/report", metavar="DIR",
                   help="folder for report.md, results.json and the plots "
                        "(default: reference/report)")
    p.add_argument("--no-report", action="store_true", help="write no report")
    p.add_argument("--only", default=None, metavar="STR",
                   help="comma-separated terms: run the modules whose topic matches, or else "
                        "only the checks whose name matches (case-insensitive)")
    p.add_argument("--json", default=None, metavar="PATH", dest="json_path",
                   help="also write the results as JSON ('-' for stdout)")
    p.add_argument("--strict", action="store_true", help="count skipped checks as failures")
    p.add_argument("--timeout", type="seconds", default=None, metavar="SECONDS",
                   help="time budget per module (default 600 s; none with --full)")
    p.add_argument("--jobs", "-j", type="processes", default=None, metavar="N",
                   help="worker processes running check modules side by side "
                        "(default: the usable cores, at most 2; 1 runs everything in-process)")
    p.add_argument("--quiet", action="store_true", help="no progress display on stderr")
    p.add_argument("--list", action="store_true", help="list the check modules and exit")


def _bench_parser(sub) -> None:
    p = sub.add_parser("bench", help="time visviva side by side with the reference libraries "
                       "and write docs/performance.md (run from the repository root)")
    p.add_argument("--quick", action="store_true", help="small problem sizes")
    p.add_argument("--only", default=None, metavar="STR", help="modules whose name contains STR")
    p.add_argument("--output", default=None, metavar="PATH",
                   help="the page to write (default docs/performance.md)")
    p.add_argument("--no-write", action="store_true", help="print only")
    p.add_argument("--threads", type="threads", default=None, help="numba threads for the whole run")


def _import_benchmarks():
    """Import the ``benchmarks`` package of the repository (cwd first, then the source tree)."""
    candidates = [Path.cwd(), Path(__file__).resolve().parents[2]]
    for root in candidates:
        if (root / "benchmarks" / "__main__.py").is_file():
            if str(root) not in sys.path:
                sys.path.insert(0, str(root))
            import benchmarks.__main__ as bench_main

            return bench_main
    raise SystemExit("visviva bench: no benchmarks/ folder found; run it from the repository root")


#: More commands, one line each: command name -> module that defines ``add_parser(sub)`` (adds
#: the sub-parser named like the command) and ``run(args) -> int`` (the exit code). The module is
#: imported when the parser is built, so it must import nothing heavy at module level.
_COMMANDS: dict[str, str] = {
    "screen": "visviva.conjunctions.cli",
    "convert": "visviva.ccsds.convert",
    "passes": "visviva.ground.cli",
    "fit-tle": "visviva.od.cli",
    "od": "visviva.od.od_command",
    "warmup": "visviva.warmup",
}


class _GivenOnce(argparse._StoreAction):
    """An option with one value that refuses to be given twice: argparse keeps the last one
    silently, so ``--hours 5 ... --hours 2`` ran a 2-hour window (audit40)."""

    def __call__(self, parser, namespace, values, option_string=None):
        given = getattr(self, "given", None)
        if given is not None:
            raise argparse.ArgumentError(
                self, f"given twice ({given[0]} {given[1]!r}, then {option_string} {values!r}); "
                "give it once")
        self.given = (option_string, values)
        super().__call__(parser, namespace, values, option_string)


class _Number:
    """The type of a numeric option: its value as a number of one unit, refused in one line that
    names the unit and gives an example (argparse said ``invalid float value: '500km'``).

    Parameters
    ----------
    what : str
        What the value must be, with its unit (``"a number of metres"``).
    example : str
        A value to show (``"500"``).
    whole : bool
        A whole number, 0 or more (else a float).
    positive : bool
        Refuse zero and negative values (else only NaN and infinities are refused besides
        non-numbers: ``--height nan`` reached the station as a NaN).
    upper : int, optional
        The largest value accepted.
    option : str, optional
        The option it belongs to, shown in the example (:meth:`bound`).
    """

    def __init__(self, what: str, example: str, *, whole: bool = False, positive: bool = False,
                 upper: int | None = None, option: str | None = None):
        self.what, self.example, self.whole = what, example, whole
        self.positive, self.upper, self.option = positive, upper, option
        self.__name__ = what  # (argparse names a type by its __name__)

    def bound(self, option: str) -> _Number:
        """The same type for ``option``, so that the example reads ``--height 500``."""
        return _Number(self.what, self.example, whole=self.whole, positive=self.positive,
                       upper=self.upper, option=option)

    def __call__(self, text: str):
        import math

        try:
            value = int(text) if self.whole else float(text)
        except ValueError:
            value = None
        wrong = (value is None or not math.isfinite(value)
                 or (self.positive and value <= 0)
                 or (self.whole and value < 0)
                 or (self.upper is not None and value > self.upper))
        if wrong:
            example = f"{self.option} {self.example}" if self.option else self.example
            raise argparse.ArgumentTypeError(f"{text!r} is not {self.what}; give e.g. {example}")
        return value


#: The types of the numeric options, by name (``add_argument("--height", type="metres")``):
#: one table, so that every command says the unit of a bad value the same way.
_NUMBERS: dict[str, _Number] = {
    "metres": _Number("a number of metres", "500"),
    "degrees": _Number("a number of degrees", "10"),
    "km": _Number("a positive number of km", "5", positive=True),
    "hours": _Number("a positive number of hours", "24", positive=True),
    "seconds": _Number("a positive number of seconds", "60", positive=True),
    "per-earth-radius": _Number("a number of 1/earth radii", "1e-4"),
    "processes": _Number("a whole number of processes, 1 or more", "2", whole=True,
                         positive=True),
    "threads": _Number("a whole number of threads, 1 or more", "4", whole=True, positive=True),
    "satnum": _Number("a catalogue number (a whole number, 0 to 999999999)", "25544",
                      whole=True, upper=999_999_999),
}


class _Parser(argparse.ArgumentParser):
    """The parser of visviva and its commands.

    * Every option of one value is a :class:`_GivenOnce` (argparse's public ``register``;
      options that collect, ``action="append"``, stay repeatable).
    * A numeric option names its type in :data:`_NUMBERS` (``type="metres"``): a bad value is
      refused naming the unit, with an example for that option.
    * An argument error is one line on standard error, ``visviva passes: error: ...``, and exit
      code 2; argparse printed its usage block first (seven lines for ``passes``, 21 for
      ``od``) and the error came last (audit40). ``--help`` is unchanged.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.register("action", None, _GivenOnce)
        self.register("action", "store", _GivenOnce)
        for name, number in _NUMBERS.items():
            self.register("type", name, number)

    def add_argument(self, *args, **kwargs):
        """``ArgumentParser.add_argument``, with a type of :data:`_NUMBERS` bound to the option
        (the longest of its names) for the example of its error message."""
        kind = kwargs.get("type")
        if isinstance(kind, str) and kind in _NUMBERS:
            kwargs["type"] = _NUMBERS[kind].bound(max(args, key=len) if args else kind)
        return super().add_argument(*args, **kwargs)

    def error(self, message):
        """One line on standard error and exit code 2 (argparse's own printed the usage first).

        An option without its value gets the way to give one that starts with ``-``: argparse
        takes ``--bstar -1.2e-4`` for two options (a number in exponent form does not look
        negative to it). A message that gives no advice of its own (a missing or unknown
        argument) ends with where the usage is: ``see visviva passes --help``.
        """
        import re

        text = " ".join(str(message).split())
        lone = re.fullmatch(r"argument (\S+): expected one argument", text)
        if lone:
            option = max(lone.group(1).split("/"), key=len)
            text += (f"; give its value after it, or write {option}=VALUE when the value starts "
                     "with '-'")
        if not any(advice in text for advice in ("give ", "choose from")):
            text += f"; see {self.prog} --help"
        self.exit(2, f"{self.prog}: error: {text}\n")


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` while a command runs: one line per warning on stderr,
    ``visviva: warning: <message>`` (visviva's own: a category of visviva, or warned from its
    code), else ``visviva: warning: <Category>: <message>``, instead of Python's
    ``file:line: Category: message`` followed by the source line."""
    import os

    package = os.path.dirname(os.path.abspath(__file__))
    ours = (category.__module__.split(".")[0] == "visviva"
            or os.path.abspath(filename).startswith(package + os.sep))
    text = " ".join(str(message).split())  # (one line)
    kind = "" if ours else f"{category.__name__}: "
    key = _warning_key(category, text)
    if key in _SHOWN:
        return
    _SHOWN.add(key)
    print(f"visviva: warning: {kind}{text}", file=sys.stderr if file is None else file)


#: The warnings a command has shown (:func:`_warning_key`): each is shown once per command.
_SHOWN: set = set()


def _warning_key(category, text: str) -> tuple:
    """What makes two warnings the same for the one-line display: the text, and for ERFA's
    the reason alone (audit40: a pass search in 2030 printed 15 ``"dubious year"`` lines, one
    per ERFA function and count, and astropy's polar-motion warning three times)."""
    import re

    if category.__name__ == "ErfaWarning":
        reason = re.search(r'of "([^"(]+)', text)
        if reason:
            return (category.__name__, reason.group(1).strip())
    return (category.__name__, text)


def _run_command(module, args) -> int:
    """``module.run(args)`` with the warnings shown as :func:`_show_warning` does; Ctrl-C is
    one line on stderr and exit code 130 (128 + SIGINT, as shells report it), not a traceback
    from wherever the work was (every output file is written whole or not at all, so none is
    left half-written)."""
    import warnings

    saved = warnings.showwarning
    warnings.showwarning = _show_warning
    _SHOWN.clear()
    try:
        return int(module.run(args))
    except KeyboardInterrupt:
        print(f"visviva {args.command}: interrupted; each output file is either complete or "
              "was not written.", file=sys.stderr)
        return 130
    finally:
        warnings.showwarning = saved


def _build_parser():
    """The parser of the command line, the group of its commands' parsers (``.choices``: name ->
    parser) and the modules of the commands of :data:`_COMMANDS` (name -> module)."""
    import importlib

    parser = _Parser(
        prog="visviva",
        description="visviva: orbital mechanics cross-validated against REBOUND, Skyfield, "
                    "astropy and sgp4. Run `visviva warmup` once after installing, "
                    "`visviva validate` for the cross-validation report.",
        epilog="Each command has its own help: visviva COMMAND --help.",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _validate_parser(sub)
    _bench_parser(sub)
    commands = {name: importlib.import_module(module) for name, module in _COMMANDS.items()}
    for module in commands.values():
        module.add_parser(sub)
    return parser, sub, commands


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``visviva ARGV``; the exit code. A mistake in the arguments exits
    (``SystemExit``) with code 2 after one line on standard error; ``--help`` with code 0."""
    parser, sub, commands = _build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # (argparse blamed the top parser for a command's unknown argument)
        sub.choices.get(args.command, parser).error(
            f"unrecognized arguments: {' '.join(unknown)}")
    if args.command in commands:
        return _run_command(commands[args.command], args)
    if args.command == "validate":
        if args.list:
            from .validation.runner import discover, short_name

            for name in discover():
                print(short_name(name))
            return 0
        from .validation import run
        from .validation.runner import default_jobs

        return run(jobs=default_jobs() if args.jobs is None else args.jobs,full=args.full, report_dir=None if args.no_report else args.report,
                   only=args.only, json_path=args.json_path, strict=args.strict,
                   timeout_s=args.timeout, progress=not args.quiet)
    if args.command == "bench":
        bench_main = _import_benchmarks()
        bench_argv = ["--quick"] if args.quick else []
        if args.only:
            bench_argv += ["--only", args.only]
        if args.output:
            bench_argv += ["--output", args.output]
        if args.no_write:
            bench_argv += ["--no-write"]
        if args.threads:
            bench_argv += ["--threads", str(args.threads)]
        return bench_main.main(bench_argv)
    return 2


if __name__ == "__main__":
    sys.exit(main())
