"""Timing helpers shared by every ``benchmarks/bench_<topic>.py``.

The conventions, so that every row of ``docs/performance.md`` means the same thing:

* **Compile time is measured separately.** :func:`compile_time` times the first call (numba
  compiles or loads from its on-disk cache) and is reported in ``notes``, never in ``visviva_s``.
* **Warm up, then take the median of repeats.** :func:`time_call` calls the function ``warmup``
  times untimed, then ``repeat`` timed rounds of ``number`` calls each and reports the median
  per-call time (the minimum is kept too). ``number`` is chosen automatically so that one round
  lasts at least ``min_round_s``.
* **Threads are explicit.** :func:`threads` is a context manager around
  ``numba.set_num_threads`` so that a benchmark states how many cores it used.
* **ratio = visviva_s / reference_s** (a time ratio: below 1 visviva is faster). ``target`` is
  the largest acceptable ratio; ``met`` is ``ratio <= target``. Use :func:`result` to build a row.

Example
-------
>>> from benchmarks.common import time_call, result
>>> t = time_call(sum, range(100), repeat=3)
>>> row = result("sum", t.median, "builtins", t.median, target=1.5)
>>> row["met"]
True
"""

from __future__ import annotations

import contextlib
import math
import os
import statistics
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

__all__ = [
    "Timing",
    "time_call",
    "interleaved",
    "compile_time",
    "threads",
    "result",
    "skipped",
    "failed",
    "SKIP_REASONS",
    "n_threads",
    "fmt_seconds",
    "ROW_KEYS",
]

#: The keys of one benchmark row, in table order.
ROW_KEYS = ("name", "visviva_s", "reference", "reference_s", "ratio", "target", "met", "notes")


@dataclass
class Timing:
    """Per-call timings of one function (seconds)."""

    median: float
    best: float
    repeat: int
    number: int
    samples: list[float] = field(default_factory=list)

    def __float__(self) -> float:
        return self.median

    def __str__(self) -> str:
        return (f"{fmt_seconds(self.median)} median of {self.repeat} x {self.number} "
                f"(best {fmt_seconds(self.best)})")


def fmt_seconds(seconds: float) -> str:
    """Format a duration with a sensible unit (``1.23 ms``)."""
    if seconds is None or not math.isfinite(seconds):
        return "n/a"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)):
        if abs(seconds) >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds / 1e-9:.3g} ns"


def compile_time(fn: Callable, *args, **kwargs) -> float:
    """Time the first call of ``fn`` (compilation or cache load plus one run), in seconds.

    Call this before :func:`time_call`; report the value in the row's ``notes``.
    """
    t0 = time.perf_counter()
    fn(*args, **kwargs)
    return time.perf_counter() - t0


def time_call(fn: Callable, *args, repeat: int = 7, number: int | None = None,
              warmup: int = 1, min_round_s: float = 0.05, max_total_s: float = 20.0,
              **kwargs) -> Timing:
    """Median per-call wall time of ``fn(*args, **kwargs)`` after ``warmup`` untimed calls.

    Parameters
    ----------
    fn : callable
        The function to time.
    repeat : int
        Number of timed rounds; the median over rounds is reported.
    number : int, optional
        Calls per round. By default chosen so that a round lasts at least ``min_round_s`` s.
    warmup : int
        Untimed calls first (compilation, caches, lazy imports).
    min_round_s : float
        Target minimum duration of one round when ``number`` is automatic (s).
    max_total_s : float
        Fewer rounds (at least 3) are run when the estimate exceeds this budget (s).

    Returns
    -------
    Timing
        ``median`` and ``best`` per-call times in seconds.
    """
    for _ in range(max(warmup, 0)):
        fn(*args, **kwargs)
    if number is None:
        number = 1
        while True:
            t0 = time.perf_counter()
            for _ in range(number):
                fn(*args, **kwargs)
            elapsed = time.perf_counter() - t0
            if elapsed >= min_round_s or number >= 1_000_000:
                break
            number *= 10 if elapsed < min_round_s / 10 else 2
        per_call = elapsed / number
    else:
        per_call = None
    if per_call is not None and per_call * number * repeat > max_total_s:
        repeat = max(3, int(max_total_s / max(per_call * number, 1e-12)))
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn(*args, **kwargs)
        samples.append((time.perf_counter() - t0) / number)
    return Timing(median=statistics.median(samples), best=min(samples), repeat=repeat,
                  number=number, samples=samples)


def n_threads() -> int:
    """The number of threads numba currently uses (1 when numba is missing)."""
    try:
        import numba

        return int(numba.get_num_threads())
    except Exception:  # pragma: no cover - numba is a hard dependency
        return 1


@contextlib.contextmanager
def threads(n: int | None) -> Iterator[int]:
    """Run the body with ``numba.set_num_threads(n)``; restore the previous count afterwards.

    ``n=None`` uses every core numba was configured with. Yields the thread count in effect.
    """
    import numba

    previous = numba.get_num_threads()
    wanted = numba.config.NUMBA_NUM_THREADS if n is None else max(1, min(int(n),
                                                                         numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(wanted)
    try:
        yield wanted
    finally:
        numba.set_num_threads(previous)


def interleaved(fns, rounds: int = 5) -> list[Timing]:
    """Per-call times of ``fns`` timed in alternation, one call each per round.

    Each function is called once untimed first (compilation, caches). Alternating round by
    round makes a change of machine load (other processes taking a core for a while) hit every
    function alike; the ``best`` of the rounds is the least disturbed figure, the ``median`` the
    typical one. Returns one :class:`Timing` per function.
    """
    samples = [[] for _ in fns]
    for fn in fns:
        fn()
    for _ in range(rounds):
        for k, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            samples[k].append(time.perf_counter() - t0)
    return [Timing(median=statistics.median(x), best=min(x), repeat=rounds, number=1, samples=x)
            for x in samples]


def result(name: str, visviva_s: float | None, reference: str, reference_s: float | None,
           target: float | None = None, notes: str = "", *,
           compile_s: float | None = None) -> dict:
    """Build one benchmark row with the keys of :data:`ROW_KEYS`.

    Parameters
    ----------
    name : str
        What is timed, with the problem size (``"solve_kepler, 1e6 anomalies"``).
    visviva_s, reference_s : float or Timing
        Per-call times in seconds (``None`` when not measured).
    reference : str
        The reference library and what was called (``"rebound 4.4 ias15"``).
    target : float, optional
        Largest acceptable ``visviva_s / reference_s``; ``None`` means no target.
    notes : str
        Threads, compile time, accuracy settings.
    compile_s : float, optional
        First-call time; appended to ``notes``.
    """
    v = None if visviva_s is None else float(visviva_s)
    r = None if reference_s is None else float(reference_s)
    ratio = v / r if (v is not None and r) else None
    met = None if (target is None or ratio is None) else bool(ratio <= target)
    extra = []
    if compile_s is not None:
        extra.append(f"first call {fmt_seconds(compile_s)}")
    if "thread" not in notes:
        extra.append(f"{n_threads()} thread(s)")
    full_notes = "; ".join([s for s in [notes, *extra] if s])
    return {"name": name, "visviva_s": v, "reference": reference, "reference_s": r,
            "ratio": ratio, "target": target, "met": met, "notes": full_notes}


def skipped(name: str, reason: str, reference: str = "") -> dict:
    """A row for a benchmark that could not run because a reference library or a GPU is absent
    (``reason`` says which, with one of :data:`SKIP_REASONS`); a failure is :func:`failed`."""
    return {"name": name, "visviva_s": None, "reference": reference, "reference_s": None,
            "ratio": None, "target": None, "met": None, "notes": f"skipped: {reason}"}


#: The only acceptable reasons for a skipped row (its ``notes`` after ``skipped:``): a
#: reference library or a GPU absent on this machine. Anything else that stops a row is a
#: :func:`failed` row (``tests/test_benchmarks.py`` holds every module to this).
SKIP_REASONS = ("not installed", "no GPU")


def failed(name: str, exc: BaseException, reference: str = "") -> dict:
    """A row for a benchmark that raised: named ``"<name>: failed"`` with the error in its notes,
    so that ``python -m benchmarks`` exits with status 1 (the other rows of the module stay)."""
    import traceback

    last = traceback.format_exception_only(type(exc), exc)[-1].strip()
    return {"name": f"{name}: failed", "visviva_s": None, "reference": reference,
            "reference_s": None, "ratio": None, "target": None, "met": False,
            "notes": f"error: {last}"}


def quick_from_env(default: bool = False) -> bool:
    """``True`` when ``VISVIVA_BENCH_QUICK`` is set to a true value."""
    value = os.environ.get("VISVIVA_BENCH_QUICK", "")
    return value.lower() in {"1", "true", "yes"} if value else default


def interleaved_medians(fa: Callable, fb: Callable, rounds: int = 7) -> tuple[float, float]:
    """Median per-call seconds of ``fa()`` and ``fb()`` timed in alternation (A B A B ...), after
    one untimed call of each: :func:`interleaved` for two functions, as plain numbers.

    A change of machine load hits both alike, so their ratio is steadier than two separate
    :func:`time_call` runs.
    """
    ta, tb = interleaved([fa, fb], rounds)
    return ta.median, tb.median
