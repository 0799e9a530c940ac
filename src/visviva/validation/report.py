"""The Markdown report of ``visviva validate`` with its plots (matplotlib, Agg backend).

``write_report(outcome, folder)`` writes ``report.md``, ``results.json`` and one PNG per plot.
Plots are drawn from each :class:`~visviva.validation.base.Check`'s ``details``:

Explicit plots
    ``details["plot"]`` is a dict (or a list of dicts) with keys

    - ``kind``: ``"hist"`` (histogram of ``log10 |y|``, with the tolerance as a vertical line),
      ``"line"``, ``"semilogy"``, ``"loglog"`` (of ``|y|`` against ``x``);
    - ``x``: the key of the abscissa array (line kinds), ``y``: a key or a list of keys;
    - optional ``labels`` (one per ``y``), ``xlabel``, ``ylabel``, ``title``,
      ``guide_slope`` (draws a power law ``x**slope`` through the first curve's median,
      e.g. 0.5 for Brouwer's law), ``tolerance_line`` (default true for ``hist``).

Automatic plots (when there is no ``plot`` key)
    - a time array (``t``, ``time``, ``times``, ``t_s``, ``t_days``, ``t_years``, ``times_yr``,
      ..., or any key starting with ``t_``/``time``) plus other 1-D arrays of the same length:
      ``|series|`` against time on a log scale (log-log with a ``t**0.5`` guide when the check
      name mentions Brouwer); series of reference libraries (keys starting with or containing
      ``rebound``, ``reference``, ``skyfield``, ...) are drawn dashed, beside visviva's; energy
      histories of different checks share one figure ("energy error against time");
    - otherwise every 1-D numeric array whose key mentions ``err``, ``diff``, ``delta``,
      ``residual``, ``dr`` or ``dv`` with at least 8 values: a histogram of ``log10 |x|``.

Grouping
    Checks with the same ``details["plot_group"]`` share one figure, one panel per check
    (e.g. the energy error of every integrator, each beside REBOUND's).

Tolerance reasons and hints
    ``details["why"]`` (or ``tolerance_reason``, ``rationale``): one sentence on why the tolerance
    is what it is; listed in the report's "Why these tolerances" section. ``details["hint"]``:
    the likely cause of a failure, printed under a FAIL line and in the "Failures" section.
"""

from __future__ import annotations

import datetime as _dt
import io
import json
import math
import re
from pathlib import Path

import numpy as np

from .._text import replace_binary_file, replace_text_file
from .base import Check
from .results import environment, fmt_value, short_name, status_of, to_json

__all__ = ["write_report", "plot_specs", "markdown_escape"]

TIME_KEYS = ("t", "time", "times", "t_s", "t_days", "t_years", "t_orbits", "orbits", "t_yr",
             "times_yr", "times_s", "times_days", "time_yr", "time_s", "time_days")
ERROR_HINTS = ("err", "diff", "delta", "residual", "dr", "dv")
REFERENCE_PREFIXES = ("rebound", "reference", "ref_", "skyfield", "astropy", "sgp4")

_MD_SPECIAL = re.compile(r"([\\`*_\[\]<>|$#])")


def markdown_escape(text) -> str:
    """Escape Markdown (and MyST dollar-math) specials so text renders literally in a table."""
    return _MD_SPECIAL.sub(r"\\\1", str(text)).replace("\n", " ")


def _array(value):
    """A 1-D float array from ``value``, or ``None`` if it is not numeric 1-D data."""
    if isinstance(value, (str, bytes, dict)) or value is None:
        return None
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None
    if arr.ndim != 1 or arr.size < 2:
        return None
    return arr


def plot_specs(check: Check) -> list[dict]:
    """The plots one check asks for (explicit ``details["plot"]`` or the automatic rules)."""
    details = check.details if isinstance(check.details, dict) else {}
    explicit = details.get("plot")
    if explicit:
        specs = explicit if isinstance(explicit, list) else [explicit]
        return [dict(s) for s in specs if isinstance(s, dict)]
    arrays = {k: a for k, a in ((k, _array(v)) for k, v in details.items()) if a is not None}
    time_key = _time_key(arrays)
    if time_key is not None:
        n = arrays[time_key].size
        series = [k for k, a in arrays.items() if k != time_key and a.size == n]
        if series:
            brouwer = "brouwer" in check.name.lower() or bool(details.get("brouwer"))
            spec = {"kind": "loglog" if brouwer else "semilogy", "x": time_key, "y": series,
                    "guide_slope": 0.5 if brouwer else None}
            if all("energy" in k.lower() for k in series):
                spec["ylabel"] = "|relative energy error|"
                if not brouwer:
                    spec["group"] = "energy error against time"
            return [spec]
    specs = []
    for k, a in arrays.items():
        if a.size >= 8 and any(h in k.lower() for h in ERROR_HINTS):
            specs.append({"kind": "hist", "y": k})
    return specs


def _is_reference(key: str) -> bool:
    key = key.lower()
    return key.startswith(REFERENCE_PREFIXES) or any(
        f"_{name}" in key for name in ("rebound", "reference", "skyfield", "astropy", "sgp4"))


def _time_key(arrays: dict) -> str | None:
    """The abscissa among the arrays: a known time key, else one starting with t_/time."""
    key = next((k for k in TIME_KEYS if k in arrays), None)
    if key is None:
        key = next((k for k in arrays if k.lower().startswith(("t_", "time"))), None)
    return key


def _draw(ax, check: Check, spec: dict) -> bool:
    """Draw one spec on ``ax``; return whether anything was drawn."""
    details = check.details
    kind = spec.get("kind", "line")
    ys = spec.get("y", [])
    ys = [ys] if isinstance(ys, str) else list(ys)
    labels = spec.get("labels") or ys
    drawn = False
    if kind == "hist":
        for key, label in zip(ys, labels, strict=False):
            a = _array(details.get(key))
            if a is None:
                continue
            a = np.abs(a[np.isfinite(a)])
            if a.size == 0:
                continue
            floor = max(np.min(a[a > 0]) if np.any(a > 0) else 1e-300, 1e-300)
            ax.hist(np.log10(np.maximum(a, floor)), bins=min(50, max(10, a.size // 20)),
                    alpha=0.7, label=_short(label, 40))
            drawn = True
        tol = _finite(check.tolerance)
        if drawn and spec.get("tolerance_line", True) and tol is not None and tol > 0:
            ax.axvline(math.log10(tol), color="crimson", linestyle="--", label="tolerance")
        ax.set_xlabel(_short(spec.get("xlabel") or f"log10 of {check.metric or ', '.join(ys)}",
                             55))
        ax.set_ylabel(_short(spec.get("ylabel") or "count"))
    else:
        x = _array(details.get(spec.get("x"))) if spec.get("x") else None
        first = None
        for key, label in zip(ys, labels, strict=False):
            y = _array(details.get(key))
            if y is None:
                continue
            xx = x if (x is not None and x.size == y.size) else np.arange(y.size, dtype=float)
            yy = np.abs(y) if kind in ("semilogy", "loglog") else y
            mask = np.isfinite(yy) & np.isfinite(xx)
            if kind in ("semilogy", "loglog"):
                mask &= yy > 0
            if kind == "loglog":
                mask &= xx > 0
            if not np.any(mask):
                continue
            style = "--" if _is_reference(str(key)) else "-"
            ax.plot(xx[mask], yy[mask], style, lw=1.2, label=_short(label, 40))
            if first is None:
                first = (xx[mask], yy[mask])
            drawn = True
        if kind in ("semilogy", "loglog"):
            ax.set_yscale("log")
        if kind == "loglog":
            ax.set_xscale("log")
        slope = spec.get("guide_slope")
        if drawn and slope and first is not None and kind == "loglog":
            xg, yg = first
            x0, y0 = float(np.median(xg)), float(np.median(yg))
            xs = np.geomspace(xg.min(), xg.max(), 50)
            ax.plot(xs, y0 * (xs / x0) ** slope, ":", color="gray",
                    label=f"t^{slope:g} (Brouwer)" if slope == 0.5 else f"x^{slope:g}")
        ax.set_xlabel(_short(spec.get("xlabel") or (spec.get("x") or "index")))
        ax.set_ylabel(_short(spec.get("ylabel") or (check.metric or "")))
    if drawn:
        ax.set_title(_short(spec.get("title") or check.name), fontsize=8)
        ax.legend(fontsize=6)
        ax.grid(True, alpha=0.3)
    return drawn


def _short(text: str, n: int = 70) -> str:
    """Shortened text, safe for matplotlib (no mathtext from stray dollar signs)."""
    text = str(text).replace("$", r"\$")
    return text if len(text) <= n else text[: n - 1] + "…"


def _finite(x):
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _slug(text: str) -> str:
    s = re.sub(r"[^a-zA-Z0-9]+", "_", text).strip("_").lower()
    return s[:60] or "plot"


def _figures(outcome) -> list[tuple[str, list[tuple[Check, dict]]]]:
    """Group (check, spec) pairs into figures: one per ``plot_group``, else one per check."""
    groups: dict[str, list[tuple[Check, dict]]] = {}
    order: list[str] = []
    for module, check in outcome.checks:
        details = check.details if isinstance(check.details, dict) else {}
        try:
            specs = plot_specs(check)
        except Exception:  # noqa: BLE001 - a malformed details dict must not stop the report
            specs = []
        for spec in specs:
            topic = short_name(module)
            default = check.name if check.name.lower().startswith(topic) else (
                f"{topic}: {check.name}")
            key = details.get("plot_group") or spec.get("group") or default
            if key not in groups:
                groups[key] = []
                order.append(key)
            groups[key].append((check, spec))
    return [(k, groups[k]) for k in order]


def _render(title: str, panels: list[tuple[Check, dict]], path: Path) -> bool:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = len(panels)
    ncols = min(3, n)
    nrows = math.ceil(n / ncols)
    fig = Figure(figsize=(4.2 * ncols, 3.2 * nrows), layout="constrained")
    FigureCanvasAgg(fig)
    drawn_any = False
    for i, (check, spec) in enumerate(panels):
        ax = fig.add_subplot(nrows, ncols, i + 1)
        try:
            drawn = _draw(ax, check, spec)
        except Exception as exc:  # noqa: BLE001
            ax.text(0.5, 0.5, f"plot failed: {exc!r:.60}", ha="center", va="center", fontsize=7)
            drawn = False
        if not drawn:
            ax.set_axis_off()
        drawn_any |= drawn
    if not drawn_any:
        return False
    if n > 1:
        fig.suptitle(_short(title, 100), fontsize=10)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90)
    replace_binary_file(path, buffer.getvalue())  # whole or not at all
    return True


#: keys of ``details`` that explain a tolerance; shown in the report's "Why these tolerances"
REASON_KEYS = ("why", "tolerance_reason", "rationale")


def _reason(check: Check) -> str | None:
    details = check.details if isinstance(check.details, dict) else {}
    for key in REASON_KEYS:
        if isinstance(details.get(key), str) and details[key].strip():
            return details[key].strip()
    return None


def write_report(outcome, folder) -> Path:
    """Write ``report.md``, ``results.json`` and the plots into ``folder``; return the report path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    counts = outcome.counts()
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    env = environment()
    verdict = "all checks pass" if outcome.exit_code == 0 else "SOME CHECKS FAIL"
    if not outcome.checks:
        verdict = "no checks ran"
    lines = [
        "# visviva validation report",
        "",
        f"Generated {now} by `visviva validate{' --full' if outcome.full else ''}"
        f"{f' --only {outcome.only}' if outcome.only else ''}` in {outcome.elapsed_s:.0f} s: "
        f"**{counts['PASS']} passed, {counts['FAIL']} failed, {counts['SKIP']} skipped** "
        f"({verdict}).",
        "",
        "A check passes when the measured difference is at most its tolerance.",
        "",
        "## Environment",
        "",
        "| | |",
        "|---|---|",
    ]
    lines += [f"| {k} | {markdown_escape(v)} |" for k, v in env.items()]
    lines += ["", "## Modules", "", "| module | passed | failed | skipped | time (s) |",
              "|---|---|---|---|---|"]
    for m in outcome.modules:
        st = [status_of(c) for c in m.checks]
        lines.append(f"| {markdown_escape(short_name(m.module))} | {st.count('PASS')} | "
                     f"{st.count('FAIL')} | {st.count('SKIP')} | {m.elapsed_s:.1f} |")
    lines += ["", "## Checks", "",
              "| status | check | measured | tolerance | metric | reference |",
              "|---|---|---|---|---|---|"]
    for _module, c in outcome.checks:
        status = status_of(c)
        shown = f"**{status}**" if status == "FAIL" else status
        measured = fmt_value(c.measured) if status != "SKIP" else markdown_escape(
            c.details.get("skipped"))
        lines.append(f"| {shown} | {markdown_escape(c.name)} | {measured} | {fmt_value(c.tolerance)} "
                     f"| {markdown_escape(c.metric)} | {markdown_escape(c.reference)} |")
    reasons = [(c, _reason(c)) for _m, c in outcome.checks if _reason(c)]
    if reasons:
        lines += ["", "## Why these tolerances", ""]
        lines += [f"- {markdown_escape(c.name)} (tolerance {fmt_value(c.tolerance)}): "
                  f"{markdown_escape(why)}" for c, why in reasons]
    failures = [(m, c) for m, c in outcome.checks if status_of(c) == "FAIL"]
    if failures:
        lines += ["", "## Failures", ""]
        for module, c in failures:
            lines += [f"- {markdown_escape(short_name(module))}: {markdown_escape(c.name)}: "
                      f"measured {fmt_value(c.measured)}, tolerance {fmt_value(c.tolerance)}"]
            hint = c.details.get("hint") if isinstance(c.details, dict) else None
            if hint:
                lines += [f"  hint: {markdown_escape(hint)}"]
            err = c.details.get("traceback") if isinstance(c.details, dict) else None
            if err:
                tail = "\n".join(str(err).strip().splitlines()[-12:]).replace("```", "'''")
                lines += ["", "  ```text", *["  " + t for t in tail.splitlines()], "  ```", ""]
    warned = [m for m in outcome.modules if m.warnings]
    if warned:
        lines += ["", "## Warnings raised during the checks", ""]
        for m in warned:
            lines += [f"- {markdown_escape(short_name(m.module))}: {markdown_escape(w)}"
                      for w in m.warnings[:20]]
    plot_lines: list[str] = []
    plots = set()
    for i, (title, panels) in enumerate(_figures(outcome), 1):
        name = f"plot_{i:02d}_{_slug(title)}.png"
        try:
            ok = _render(title, panels, folder / name)
        except Exception:  # noqa: BLE001 - a broken plot must not lose the report
            ok = False
        if ok:
            plot_lines += [f"![{markdown_escape(title)}]({name})", ""]
            plots.add(name)
    if plot_lines:
        lines += ["", "## Plots", "", *plot_lines]
    lines.append("")
    path = folder / "report.md"
    # each file whole or not at all: a crash or a full disk keeps the previous run's file
    replace_text_file(path, "\n".join(lines))
    replace_text_file(folder / "results.json",
                      json.dumps(to_json(outcome), indent=1, allow_nan=False))
    for old in folder.glob("plot_*.png"):  # the earlier run's plots, once the report is new
        if old.name not in plots:
            old.unlink()
    return path
