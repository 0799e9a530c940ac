"""Run every ``benchmarks/bench_*.py`` and write ``docs/performance.md``.

Usage (from the repository root)::

    python -m benchmarks [--quick] [--only STR] [--output docs/performance.md] [--no-write]
                         [--json rows.json]

or ``visviva bench`` with the same options. A benchmark module that fails to import or raises is
reported as a row with its error; it never stops the others. The exit status is 1 when a row
failed (a module, or one row of it: its name ends in ``": failed"``); ``--json`` writes the rows
(a list of dicts with the keys of ``benchmarks.common.ROW_KEYS`` and ``module``) for a test
(``tests/test_benchmarks.py``, ``pytest -m slow``).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib
import json
import os
import pkgutil
import platform
import sys
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUTPUT = ROOT / "docs" / "performance.md"

_VERSIONED = ("visviva", "numpy", "numba", "rebound", "skyfield", "sgp4", "astropy", "scipy")


def discover() -> list[str]:
    """Names of the benchmark modules (``bench_*``), sorted."""
    here = Path(__file__).resolve().parent
    return sorted(m.name for m in pkgutil.iter_modules([str(here)]) if m.name.startswith("bench_"))


def cpu_model() -> str:
    """The CPU model name (from /proc/cpuinfo on Linux, else :func:`platform.processor`)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def versions() -> dict[str, str]:
    """Installed versions of visviva and the libraries the benchmarks compare against."""
    from importlib import metadata

    out = {}
    for name in _VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def machine() -> dict[str, str]:
    """A description of the machine the numbers were measured on."""
    try:
        import numba

        threads = str(numba.get_num_threads())
    except Exception:  # pragma: no cover
        threads = "n/a"
    try:
        cores = str(len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        cores = str(os.cpu_count())
    return {
        "cpu": cpu_model(),
        "cores": cores,
        "numba threads": threads,
        "python": platform.python_version(),
        "platform": platform.platform(),
    }


def run_module(name: str, quick: bool) -> tuple[list[dict], float]:
    """Import ``benchmarks.<name>`` and call its ``run(quick)``; errors become a row."""
    t0 = time.perf_counter()
    try:
        module = importlib.import_module(f"benchmarks.{name}")
        rows = list(module.run(quick=quick))
    except Exception as exc:  # a module in progress must not stop the others
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        rows = [{"name": f"{name}: failed", "visviva_s": None, "reference": "",
                 "reference_s": None, "ratio": None, "target": None, "met": False,
                 "notes": f"error: {last}"}]
    for row in rows:
        row.setdefault("module", name)
        for key in ("name", "visviva_s", "reference", "reference_s", "ratio", "target", "met",
                    "notes"):
            row.setdefault(key, None)
    return rows, time.perf_counter() - t0


def _fmt_s(x) -> str:
    from benchmarks.common import fmt_seconds

    return "" if x is None else fmt_seconds(float(x))


def _fmt_ratio(x) -> str:
    if x is None:
        return ""
    x = float(x)
    return f"{x:.3g}"


def _fmt_target(x) -> str:
    return "" if x is None else f"<= {float(x):.3g}"


def _fmt_met(x) -> str:
    return {True: "met", False: "NOT met", None: ""}[None if x is None else bool(x)]


def _cell(text) -> str:
    return str("" if text is None else text).replace("|", "\\|").replace("\n", " ")


def markdown(rows: list[dict], quick: bool, elapsed_s: float, output=None) -> str:
    """The performance page: machine, versions, one table row per benchmark, and the
    hand-written sections of the page at ``output`` (:func:`kept_sections`)."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    mach = machine()
    vers = versions()
    met = sum(1 for r in rows if r.get("met") is True)
    with_target = sum(1 for r in rows if r.get("met") is not None)
    lines = [
        "# Performance",
        "",
        "visviva timed side by side with the reference libraries in one process "
        "(`python -m benchmarks`, also `visviva bench`). Each time is the median per-call wall "
        "time of several repeats after a warm-up call; the first call (numba compilation or "
        "loading from the on-disk cache) is excluded and given in the notes. "
        "**ratio = visviva time / reference time** (below 1: visviva is faster); the target is "
        "the largest acceptable ratio.",
        "",
        f"Measured {now}{' (quick mode: small problem sizes)' if quick else ''}; "
        f"{met} of {with_target} targets met; the whole run took {elapsed_s:.0f} s.",
        "",
        "## Machine",
        "",
        "| | |",
        "|---|---|",
    ]
    lines += [f"| {k} | {_cell(v)} |" for k, v in mach.items()]
    lines += ["", "## Versions", "", "| package | version |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in vers.items()]
    lines += [
        "",
        "## Results",
        "",
        "| benchmark | visviva | reference | reference time | ratio | target | met | notes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {_cell(r['name'])} | {_fmt_s(r['visviva_s'])} | {_cell(r['reference'])} | "
            f"{_fmt_s(r['reference_s'])} | {_fmt_ratio(r['ratio'])} | {_fmt_target(r['target'])} "
            f"| {_fmt_met(r['met'])} | {_cell(r['notes'])} |")
    if not rows:
        lines.append("| (no benchmark modules found) | | | | | | | |")
    lines.append("")
    # the hand-measured sections (cold start, GPU, scale-out: figures measured by hand, on a lent
    # GPU, or before/after a change) stay on the page: those of the page being replaced, or,
    # for a new page, the cold-start section
    kept = kept_sections(Path(output)) if output is not None else ""
    cold = Path(__file__).with_name("cold_start.md")
    if not kept and cold.is_file():
        kept = cold.read_text(encoding="utf-8").rstrip()
    if kept:
        lines += ["", kept, ""]
    return "\n".join(lines)


def kept_sections(page: Path) -> str:
    """The hand-written sections of an existing performance page: everything from the first
    ``## `` heading after its ``## Results`` table ("" when there is none)."""
    if not page.is_file():
        return ""
    text = page.read_text(encoding="utf-8").splitlines()
    try:
        start = text.index("## Results")
    except ValueError:
        return ""
    for i in range(start + 1, len(text)):
        if text[i].startswith("## "):
            return "\n".join(text[i:]).rstrip()
    return ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="small problem sizes (a smoke run)")
    parser.add_argument("--only", default=None, help="run only modules whose name contains this")
    parser.add_argument("--output", default=str(DEFAULT_OUTPUT), help="the Markdown page to write")
    parser.add_argument("--no-write", action="store_true", help="print only; write no page")
    parser.add_argument("--json", default=None, help="also write the rows to this JSON file")
    parser.add_argument("--threads", type=int, default=None,
                        help="numba threads for the whole run (default: every core)")
    args = parser.parse_args(argv)
    if args.threads:
        import numba

        numba.set_num_threads(max(1, min(args.threads, numba.config.NUMBA_NUM_THREADS)))

    names = [n for n in discover() if args.only is None or args.only in n]
    t_start = time.perf_counter()
    rows: list[dict] = []
    for i, name in enumerate(names, 1):
        print(f"[{i}/{len(names)}] {name} ...", file=sys.stderr, flush=True)
        mod_rows, dt = run_module(name, args.quick)
        rows += mod_rows
        for r in mod_rows:
            print(f"  {r['name']:<50s} visviva {_fmt_s(r['visviva_s']):>10s}  "
                  f"{_cell(r['reference'])[:24]:<24s} {_fmt_s(r['reference_s']):>10s}  "
                  f"ratio {_fmt_ratio(r['ratio']):>7s} {_fmt_target(r['target']):>8s} "
                  f"{_fmt_met(r['met'])}", flush=True)
        print(f"  ({dt:.1f} s)", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - t_start
    with_target = [r for r in rows if r.get("met") is not None]
    print(f"{sum(1 for r in with_target if r['met'])} of {len(with_target)} targets met "
          f"in {elapsed:.0f} s", flush=True)
    # each file whole or not at all: a crash or a full disk keeps the earlier page
    from visviva._text import replace_text_file

    if not args.no_write:
        out = Path(args.output)
        out.parent.mkdir(parents=True, exist_ok=True)
        replace_text_file(out, markdown(rows, args.quick, elapsed, out))
        print(f"wrote {out}", file=sys.stderr)
    if args.json:
        replace_text_file(args.json, json.dumps(rows, indent=1, default=float))
    failed = [r for r in rows if r["name"].endswith(": failed")]
    return 1 if failed else 0



if __name__ == "__main__":
    sys.exit(main())
