"""What one ``visviva validate`` run produced, and its plain-data forms.

The result containers (:class:`ModuleResult`, :class:`Outcome`) and the helpers that turn them
into text and JSON, shared by the runner (:mod:`visviva.validation.runner`, which fills them)
and the report (:mod:`visviva.validation.report`, which reads them). Neither of those is
imported here, so the dependency goes one way: runner -> report -> results.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

from .base import Check

__all__ = ["ModuleResult", "Outcome", "environment", "short_name", "status_of", "to_json"]

#: prefix of the check modules' names (``visviva.validation.checks_<topic>``)
PREFIX = "checks_"


@dataclass
class ModuleResult:
    """The checks of one ``checks_<topic>`` module and how long they took."""

    module: str
    checks: list[Check]
    elapsed_s: float
    error: str | None = None
    warnings: list[str] = field(default_factory=list)


@dataclass
class Outcome:
    """Everything one run produced (what the report and the JSON output are made of)."""

    modules: list[ModuleResult] = field(default_factory=list)
    full: bool = False
    only: str | None = None
    elapsed_s: float = 0.0
    strict: bool = False

    @property
    def checks(self) -> list[tuple[str, Check]]:
        return [(m.module, c) for m in self.modules for c in m.checks]

    def counts(self) -> dict[str, int]:
        out = {"PASS": 0, "FAIL": 0, "SKIP": 0}
        for _, c in self.checks:
            out[status_of(c)] += 1
        return out

    @property
    def exit_code(self) -> int:
        counts = self.counts()
        if counts["FAIL"] or (self.strict and counts["SKIP"]):
            return 1
        if not self.checks:
            return 1  # nothing was checked: never report success for an empty run
        return 0


def status_of(check: Check) -> str:
    """``"PASS"``, ``"FAIL"`` or ``"SKIP"`` for one check."""
    details = check.details if isinstance(check.details, dict) else {}
    if details.get("skipped"):
        return "SKIP"
    try:
        return "PASS" if check.passed else "FAIL"
    except Exception:  # a measured value that cannot be compared
        return "FAIL"


def short_name(module: str) -> str:
    """``visviva.validation.checks_nbody`` -> ``nbody``."""
    leaf = module.rsplit(".", 1)[-1]
    return leaf[len(PREFIX):] if leaf.startswith(PREFIX) else leaf


def fmt_value(x) -> str:
    """A measured value or tolerance for the report: 3 significant digits, nan/inf spelled out."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(x):
        return "nan"
    if x == 0:
        return "0"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.3g}" if 1e-3 <= abs(x) < 1e4 else f"{x:.2e}"


def jsonable(value, max_len: int = 20000):
    """Convert ``details`` values for JSON: arrays become lists (long ones are summarised)."""
    try:
        import numpy as np
    except ImportError:  # pragma: no cover
        np = None
    if np is not None and isinstance(value, np.ndarray | np.generic):
        arr = np.asarray(value)
        if arr.dtype.kind in "fc" and arr.size > max_len:
            finite = arr[np.isfinite(arr)]
            return {"size": int(arr.size), "min": float(finite.min()) if finite.size else None,
                    "max": float(finite.max()) if finite.size else None}
        if arr.dtype.kind in "fiub":
            return [jsonable(v) for v in arr.tolist()] if arr.ndim else jsonable(arr.item())
        return str(arr.tolist())[:1000]
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, int | bool | str) or value is None:
        return value
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        if len(value) > max_len:
            return f"<{len(value)} items>"
        return [jsonable(v) for v in value]
    return str(value)[:1000]


def to_json(outcome: Outcome) -> dict:
    """The run as a JSON-ready dict."""
    counts = outcome.counts()
    return {
        "full": outcome.full,
        "only": outcome.only,
        "elapsed_s": outcome.elapsed_s,
        "counts": counts,
        "exit_code": outcome.exit_code,
        "environment": environment(),
        "modules": [{"module": m.module, "elapsed_s": m.elapsed_s, "error": m.error,
                     "warnings": m.warnings} for m in outcome.modules],
        "checks": [{"module": short_name(mod), "name": c.name, "status": status_of(c),
                    "metric": c.metric, "measured": jsonable(_as_float(c.measured)),
                    "tolerance": jsonable(_as_float(c.tolerance)), "reference": c.reference,
                    "details": jsonable(c.details)} for mod, c in outcome.checks],
    }


def _as_float(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


def environment() -> dict[str, str]:
    """Versions of visviva and of the reference libraries, and the machine."""
    import platform
    from importlib import metadata

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name in ("visviva", "numpy", "numba", "astropy", "scipy", "rebound", "skyfield", "sgp4"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    try:
        out["cores"] = str(len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        out["cores"] = str(os.cpu_count())
    return out
