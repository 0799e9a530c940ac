"""The cross-validation runner behind ``visviva validate``.

It finds every module ``visviva.validation.checks_<topic>`` and calls its
``checks(full: bool = False) -> list[Check]``, which compares visviva LIVE against the installed
reference libraries (REBOUND, Skyfield, astropy, sgp4). It prints one line per check
(status, name, measured value, tolerance, metric), shows a progress counter on stderr, writes a
Markdown report with plots (:mod:`visviva.validation.report`) and returns the exit code:
0 only when every check passes.

Robustness rules:

* a module that fails to import, raises, or returns something other than a list of
  :class:`~visviva.validation.base.Check` becomes one FAILED check carrying the error; the run
  goes on with the other modules;
* a check whose ``details`` holds ``{"skipped": "<reason>"}`` is reported as SKIP and does not
  change the exit code (``--strict`` makes skips fail);
* ``measured`` NaN fails (see :attr:`Check.passed`).
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import math
import os
import pkgutil
import signal
import sys
import time
import traceback
import warnings
from contextlib import contextmanager
from pathlib import Path

from .._text import replace_text_file
from .base import Check
from .results import (
    PREFIX,
    ModuleResult,
    Outcome,
    fmt_value,
    jsonable,
    short_name,
    status_of,
    to_json,
)

__all__ = ["Outcome", "ModuleResult", "discover", "run_module", "run", "status_of"]

PACKAGE = "visviva.validation"

#: Per-module time budget (s) of the default run, against hangs (a cold numba cache can make
#: a module take minutes); ``--full`` has none.
DEFAULT_MODULE_TIMEOUT_S = 600.0


def discover() -> list[str]:
    """Full names of every ``visviva.validation.checks_*`` module, sorted."""
    package = importlib.import_module(PACKAGE)
    names = [m.name for m in pkgutil.iter_modules(package.__path__) if m.name.startswith(PREFIX)]
    return [f"{PACKAGE}.{n}" for n in sorted(names)]


def _error_check(module: str, stage: str, exc: BaseException) -> Check:
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    last = traceback.format_exception_only(type(exc), exc)[-1].strip()
    return Check(
        name=f"{short_name(module)}: {stage} failed ({last[:120]})",
        metric="module error",
        measured=math.nan,
        tolerance=0.0,
        reference="",
        details={"error": last, "traceback": tb[-4000:]},
    )


class _ModuleTimeout(Exception):
    pass


@contextmanager
def _time_limit(seconds: float | None):
    """Raise :class:`_ModuleTimeout` after ``seconds`` (main thread on POSIX only)."""
    usable = (seconds is not None and seconds > 0 and hasattr(signal, "SIGALRM")
              and _in_main_thread())
    if not usable:
        yield
        return

    def _handler(signum, frame):
        raise _ModuleTimeout(f"exceeded the time budget of {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, _handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _in_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def run_module(module: str, full: bool = False, timeout_s: float | None = None) -> ModuleResult:
    """Import ``module`` and call its ``checks(full)``; every failure becomes a failed check.

    Python warnings raised meanwhile are recorded in :attr:`ModuleResult.warnings` (and listed in
    the report) instead of being printed between the result lines.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        result = _run_module(module, full, timeout_s)
    seen: dict[str, int] = {}
    for w in caught:
        text = f"{w.category.__name__}: {str(w.message).splitlines()[0][:200]}"
        seen[text] = seen.get(text, 0) + 1
    result.warnings = [f"{t} (x{n})" if n > 1 else t for t, n in seen.items()]
    return result


def _run_module(module: str, full: bool, timeout_s: float | None) -> ModuleResult:
    t0 = time.perf_counter()
    try:
        mod = importlib.import_module(module)
    except BaseException as exc:  # noqa: BLE001 - a module in progress must not crash the run
        if isinstance(exc, KeyboardInterrupt):
            raise
        return ModuleResult(module, [_error_check(module, "import", exc)],
                            time.perf_counter() - t0, error=str(exc))
    fn = getattr(mod, "checks", None)
    if not callable(fn):
        exc = AttributeError(f"{module} defines no checks(full) function")
        return ModuleResult(module, [_error_check(module, "import", exc)],
                            time.perf_counter() - t0, error=str(exc))
    try:
        with _time_limit(timeout_s):
            produced = fn(full=full)
    except BaseException as exc:  # noqa: BLE001
        if isinstance(exc, KeyboardInterrupt):
            raise
        return ModuleResult(module, [_error_check(module, "checks()", exc)],
                            time.perf_counter() - t0, error=str(exc))
    checks: list[Check] = []
    try:
        items = list(produced)
    except TypeError as exc:
        items = []
        checks.append(_error_check(module, "checks() return value", exc))
    for item in items:
        if isinstance(item, Check):
            checks.append(item)
        else:
            checks.append(_error_check(module, "checks() return value", TypeError(
                f"expected a Check, got {type(item).__name__}: {item!r:.80}")))
    if not checks:
        checks.append(_error_check(module, "checks()", ValueError("returned no checks")))
    return ModuleResult(module, checks, time.perf_counter() - t0)


def _matches(text: str, only: str | None) -> bool:
    if not only:
        return True
    terms = [t.strip().lower() for t in only.split(",") if t.strip()]
    return any(t in text.lower() for t in terms)


def select_topics(only: str | None, names: list[str]) -> list[str]:
    """The modules whose topic ``only`` names: a term equal to a topic selects that topic
    alone, any other term every topic it is a piece of (``od`` is the orbit-determination
    module, not also ``nbody``; ``body`` is ``nbody``)."""
    terms = [t.strip().lower() for t in (only or "").split(",") if t.strip()]
    topics = [short_name(n).lower() for n in names]
    chosen = []
    for name, topic in zip(names, topics, strict=True):
        for term in terms:
            if (topic == term) if term in topics else (term in topic):
                chosen.append(name)
                break
    return chosen


def _module_source(module: str) -> str | None:
    """The source text of ``module`` without importing it (None when it cannot be read)."""
    try:
        spec = importlib.util.find_spec(module)
        origin = spec.origin if spec is not None else None
        return Path(origin).read_text(encoding="utf-8") if origin else None
    except (ImportError, ValueError, OSError, UnicodeDecodeError):
        return None


def unmatched_only(only: str | None, names: list[str]) -> str | None:
    """The error message when no term of ``only`` can match a module topic or a check name.

    Checked before anything runs, so a typo costs no run: a term can match a check name only
    if it occurs (case-insensitively) in the source text of a check module, where the names
    are written. A module whose source cannot be read counts as a possible match (no
    refusal then: the run filters the check names as before).
    """
    terms = [t.strip().lower() for t in (only or "").split(",") if t.strip()]
    if not terms or not names:
        return None
    for name in names:
        source = _module_source(name)
        if source is None:
            return None
        text = short_name(name).lower() + "\n" + source.lower()
        if any(t in text for t in terms):
            return None
    topics = ", ".join(short_name(n) for n in names)
    return (f"visviva validate: --only {only!r} matches no check module ({topics}) and no "
            "check name; use one of these topics or a piece of a check name")


def format_line(check: Check, width: int = 64) -> str:
    """One printed line: status, name, measured, tolerance, metric."""
    status = status_of(check)
    name = check.name if len(check.name) <= width else check.name[: width - 1] + "…"
    if status == "SKIP":
        return f"SKIP  {name:<{width}s}  ({check.details.get('skipped')})"
    line = (f"{status}  {name:<{width}s}  {fmt_value(check.measured):>10s} <= "
            f"{fmt_value(check.tolerance):<9s}  {check.metric}")
    details = check.details if isinstance(check.details, dict) else {}
    if status == "FAIL":
        for key in ("error", "hint"):
            if details.get(key):
                line += f"\n      {key}: {str(details[key])[:300]}"
    return line


class _Progress:
    """Progress on stderr that never garbles the result lines.

    On a terminal: a tqdm bar over the modules whose description names the module(s) running
    now and for how long, refreshed every half second by a small thread (a module that compiles
    for a minute shows its clock ticking instead of a frozen bar). Result lines go through
    :meth:`write` (``tqdm.write``: the bar is cleared, the line printed, the bar redrawn).
    Elsewhere (a pipe, CI): one ``[i/n] module ...`` line per module on stderr.
    """

    def __init__(self, total: int, enabled: bool):
        self.total = total
        self.enabled = enabled
        self.bar = None
        self.running: dict[str, float] = {}
        self._stop = None
        if enabled and sys.stderr.isatty():
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit="module", file=sys.stderr, leave=False,
                                bar_format="{n_fmt}/{total_fmt} |{bar:20}| {elapsed} {desc}")
            except Exception:  # pragma: no cover - tqdm is a dependency
                self.bar = None
        if self.bar is not None:
            import threading

            self._stop = threading.Event()
            threading.Thread(target=self._tick, daemon=True).start()

    def _describe(self) -> str:
        now = time.perf_counter()
        items = [f"{short_name(m)} ({now - t0:.0f} s)" for m, t0 in list(self.running.items())]
        return "running: " + ", ".join(items) if items else ""

    def _tick(self) -> None:
        while not self._stop.wait(0.5):
            self.bar.set_description_str(self._describe(), refresh=True)

    def start(self, i: int, module: str) -> None:
        """``module`` (the i-th of ``total``) has started."""
        if not self.enabled:
            return
        self.running.setdefault(module, time.perf_counter())
        if self.bar is not None:
            self.bar.set_description_str(self._describe(), refresh=True)
        else:
            print(f"[{i}/{self.total}] {short_name(module)} ...", file=sys.stderr, flush=True)

    def done(self, result: ModuleResult) -> None:
        """``result.module`` has finished."""
        self.running.pop(result.module, None)
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(1)
        else:
            print(f"      {short_name(result.module)}: {len(result.checks)} checks in "
                  f"{result.elapsed_s:.1f} s",
                  file=sys.stderr, flush=True)

    def write(self, line: str, file) -> None:
        """Print ``line`` to ``file`` without breaking the bar."""
        if self.bar is not None:
            self.bar.write(line, file=file)
            file.flush()
        else:
            print(line, file=file, flush=True)

    def close(self) -> None:
        if self._stop is not None:
            self._stop.set()
        if self.bar is not None:
            self.bar.close()


def summary_table(outcome: Outcome) -> str:
    """The end-of-run table: one row per module (checks passed, failed, skipped, time)."""
    rows = [("module", "checks", "pass", "fail", "skip", "time (s)")]
    for m in outcome.modules:
        st = [status_of(c) for c in m.checks]
        rows.append((short_name(m.module), str(len(st)), str(st.count("PASS")),
                     str(st.count("FAIL")), str(st.count("SKIP")), f"{m.elapsed_s:.1f}"))
    counts = outcome.counts()
    rows.append(("total", str(sum(counts.values())), str(counts["PASS"]), str(counts["FAIL"]),
                 str(counts["SKIP"]), f"{outcome.elapsed_s:.1f}"))
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]

    def fmt(row):
        return "  ".join(c.ljust(w) if k == 0 else c.rjust(w)
                         for k, (c, w) in enumerate(zip(row, widths, strict=True)))

    rule = "  ".join("-" * w for w in widths)
    return "\n".join([fmt(rows[0]), rule, *map(fmt, rows[1:-1]), rule, fmt(rows[-1])])


def _child_main(name: str, full: bool, timeout_s: float | None, conn) -> None:
    """Entry point of a worker process: run one module, send back its (picklable) result."""
    import pickle

    from ..core import _jit

    _jit.notices["enabled"] = False  # the parent's bar names the running module
    result = run_module(name, full=full, timeout_s=timeout_s)
    try:
        pickle.dumps(result)
    except Exception:  # noqa: BLE001 - details holding something unpicklable
        for check in result.checks:
            check.details = jsonable(check.details)
    conn.send(result)
    conn.close()


def _iter_results(names: list[str], full: bool, timeout_s: float | None, jobs: int, bar):
    """Yield one :class:`ModuleResult` per name, in order; ``jobs > 1`` runs worker processes.

    Each worker is a fresh (spawned) process, so a module that crashes the interpreter
    (a segfault) becomes a failed check too. Numba compilation, the bulk of a cold run,
    proceeds in parallel.
    """
    if jobs <= 1 or len(names) <= 1:
        for i, name in enumerate(names, 1):
            bar.start(i, name)
            yield run_module(name, full=full, timeout_s=timeout_s)
        return
    import multiprocessing as mp
    from multiprocessing.connection import wait

    ctx = mp.get_context("spawn")
    pending = list(enumerate(names))
    running: dict = {}  # sentinel -> (index, name, process, connection, start time)
    done: dict[int, ModuleResult] = {}
    next_out = 0
    try:
        while next_out < len(names):
            while pending and len(running) < jobs:
                index, name = pending.pop(0)
                parent, child = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_child_main, args=(name, full, timeout_s, child),
                                   daemon=True)
                proc.start()
                child.close()
                running[proc.sentinel] = (index, name, proc, parent, time.perf_counter())
                bar.start(index + 1, name)
            ready_conns = wait([r[3] for r in running.values()] + list(running), timeout=1.0)
            for key, (index, name, proc, conn, t0) in list(running.items()):
                if conn not in ready_conns and key not in ready_conns:
                    continue
                result = None
                try:
                    if conn.poll():
                        result = conn.recv()
                except (EOFError, OSError):
                    result = None
                if result is None and proc.is_alive():
                    continue  # sentinel not ready and nothing sent yet
                proc.join(timeout=5)
                if result is None:
                    exc = RuntimeError(f"worker process died (exit code {proc.exitcode})")
                    result = ModuleResult(name, [_error_check(name, "worker", exc)],
                                          time.perf_counter() - t0, error=str(exc))
                conn.close()
                del running[key]
                done[index] = result
            while next_out in done:
                yield done.pop(next_out)
                next_out += 1
    finally:
        for _index, _name, proc, conn, _t0 in running.values():
            proc.kill()
            conn.close()


def default_jobs() -> int:
    """Worker processes for ``visviva validate``: the usable cores, at most 2."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        cores = os.cpu_count() or 1
    return max(1, min(2, cores))


def run(full: bool = False, report_dir: str | os.PathLike | None = "reference/report",
        only: str | None = None, json_path: str | os.PathLike | None = None,
        progress: bool = True, strict: bool = False, timeout_s: float | None = None,
        stream=None, modules: list[str] | None = None, jobs: int = 1) -> int:
    """Run the suite, print one line per check, write the report; return the exit code.

    Parameters
    ----------
    full : bool
        Include the long runs (passed on to every ``checks(full)``).
    report_dir : path or None
        Folder for ``report.md`` and its plots; ``None`` writes no report.
    only : str, optional
        Comma-separated, case-insensitive terms. Modules whose topic matches a term run whole
        (a term equal to a topic selects that topic only, else every topic containing it: see
        :func:`select_topics`); when no topic matches, every module runs and only the checks
        whose name matches are kept.
        A term found in no topic and nowhere in the check modules' source (so in no check
        name) returns 2 at once, with a one-line message on stderr listing the topics.
    json_path : path, optional
        Also write the results as JSON (``-`` for stdout; the per-check lines then go to
        stderr).
    progress : bool
        Show the progress counter on stderr.
    strict : bool
        Count skipped checks as failures.
    timeout_s : float, optional
        Time budget per module (s); default :data:`DEFAULT_MODULE_TIMEOUT_S`, none with ``full``.
    stream : file, optional
        Where the per-check lines go (default stdout).
    modules : list of str, optional
        Module names to run instead of :func:`discover` (used by the tests).
    jobs : int
        Number of worker processes (1: in this process, in order).

    Returns
    -------
    int
        0 when every check passed (and at least one ran), 2 when ``only`` can match nothing
        (nothing ran), 1 otherwise.
    """
    out = stream if stream is not None else sys.stdout
    json_out = out
    if json_path is not None and str(json_path) == "-" and stream is None:
        out = sys.stderr  # keep stdout valid JSON
    t_start = time.perf_counter()
    names = discover() if modules is None else list(modules)
    filter_checks = False
    refusal = unmatched_only(only, names)
    if refusal is not None:
        print(refusal, file=sys.stderr, flush=True)
        return 2
    if only:
        by_topic = select_topics(only, names)
        if by_topic:
            names = by_topic
        else:
            filter_checks = True
    if timeout_s is None and not full:
        timeout_s = DEFAULT_MODULE_TIMEOUT_S
    outcome = Outcome(full=full, only=only, strict=strict)
    bar = _Progress(len(names), progress)
    from ..core import _jit

    # a compile notice (a cold numba cache) goes through the bar too, not across it
    _jit.notices["write"] = lambda text: bar.write(text.rstrip("\n"), file=sys.stderr)
    print(f"visviva validate: {len(names)} check modules"
          f"{' (full)' if full else ''}{f', only {only!r}' if only else ''}", file=out, flush=True)
    try:
        for result in _iter_results(names, full, timeout_s, jobs, bar):
            if filter_checks:
                result.checks = [c for c in result.checks
                                 if _matches(c.name, only) or result.error is not None]
            outcome.modules.append(result)
            bar.done(result)
            for check in result.checks:
                bar.write(format_line(check), file=out)
    finally:
        bar.close()
        _jit.notices.pop("write", None)
    outcome.elapsed_s = time.perf_counter() - t_start
    counts = outcome.counts()
    print("\n" + summary_table(outcome), file=out, flush=True)
    print(f"{counts['PASS']} passed, {counts['FAIL']} failed, {counts['SKIP']} skipped "
          f"in {outcome.elapsed_s:.1f} s", file=out, flush=True)
    if not outcome.checks:
        print("no checks ran (nothing matched --only?)", file=out, flush=True)
    if report_dir is not None:
        try:
            from .report import write_report

            path = write_report(outcome, report_dir)
            print(f"report: {path}", file=out, flush=True)
        except Exception as exc:  # the verdict must survive a broken plot
            print(f"report could not be written: {exc!r}", file=sys.stderr, flush=True)
            traceback.print_exc()
    if json_path is not None:
        payload = json.dumps(to_json(outcome), indent=1, allow_nan=False)
        if str(json_path) == "-":
            print(payload, file=json_out, flush=True)
        else:
            Path(json_path).parent.mkdir(parents=True, exist_ok=True)
            replace_text_file(json_path, payload)  # whole or not at all
    return outcome.exit_code
