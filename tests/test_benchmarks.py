"""The benchmarks cannot rot: every ``benchmarks/bench_*.py`` runs in quick mode and every row
runs (``pytest -m slow``).

A row broken for a whole session went unnoticed (bench_od's Dask ``fit_tle`` row raised
ValueError); so each module runs here as ``python -m benchmarks --only <module> --quick
--no-write --json rows.json`` in a fresh process (the way a user runs it, with its own numba
threads and Dask clusters), and its rows must all have run: no ``"...: failed"`` row, a measured
time on every row that is not skipped, and a skip only where a reference library or a GPU is
absent (:data:`benchmarks.common.SKIP_REASONS`), never for a visviva failure. The fast tests below
check the checker and the runner's failure rows.

Cost of the slow tests (2-core machine shared with other work, numba cache warm): see
docs/performance.md ("Benchmarks as tests").
"""

from __future__ import annotations

import importlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _bench():
    """The ``benchmarks`` package of this checkout (it is not installed)."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    main = importlib.import_module("benchmarks.__main__")
    common = importlib.import_module("benchmarks.common")
    return main, common


def _modules() -> list[str]:
    return _bench()[0].discover()


def row_problems(rows: list[dict], module: str) -> list[str]:
    """What is wrong with the rows one module returned (empty when every row ran)."""
    _, common = _bench()
    problems = []
    if not rows:
        problems.append(f"{module} returned no rows")
    for r in rows:
        name, notes = str(r.get("name")), str(r.get("notes") or "")
        if r.get("module") != module:
            problems.append(f"{name!r} comes from {r.get('module')!r}, not {module!r}")
        if name.endswith(": failed") or notes.startswith("error:"):
            problems.append(f"{name!r} failed: {notes}")
            continue
        if notes.startswith("skipped:"):
            if not any(reason in notes for reason in common.SKIP_REASONS):
                problems.append(f"{name!r} was skipped for a reason that is not a reference "
                                f"library or GPU absent: {notes}")
            continue
        for key in ("visviva_s", "reference_s"):
            value = r.get(key)
            if key == "visviva_s" and value is None:
                problems.append(f"{name!r} measured no visviva time")
            elif value is not None and not (math.isfinite(value) and value > 0):
                problems.append(f"{name!r} has {key} = {value!r}")
        if r.get("ratio") is not None and not math.isfinite(r["ratio"]):
            problems.append(f"{name!r} has ratio {r['ratio']!r}")
    return problems


@pytest.mark.slow
@pytest.mark.parametrize("module", _modules())
def test_every_row_of_the_module_runs_in_quick_mode(module, tmp_path):
    out = tmp_path / "rows.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--only", module, "--quick", "--no-write",
         "--json", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    assert out.is_file(), f"no rows written (exit {proc.returncode}): {proc.stderr[-3000:]}"
    rows = [r for r in json.loads(out.read_text()) if r.get("module") == module]
    problems = row_problems(rows, module)
    assert not problems, "\n".join(problems) + f"\n--- stderr:\n{proc.stderr[-3000:]}"
    assert proc.returncode == 0, proc.stderr[-3000:]


# ---- fast: the checker and the runner ------------------------------------------------------------
def test_row_checker_accepts_runs_and_absent_references_only():
    _, common = _bench()
    good = [dict(common.result("a", 1e-3, "ref", 2e-3, target=1.0), module="m"),
            dict(common.skipped("b", "rebound not installed"), module="m"),
            dict(common.skipped("c", "no GPU (no CUDA driver)"), module="m")]
    assert row_problems(good, "m") == []
    bad = [dict(common.skipped("d", "visviva not importable: boom"), module="m"),
           dict(common.skipped("e", "cluster failed: timeout"), module="m"),
           dict(common.failed("f", ValueError("initials")), module="m"),
           dict(common.result("g", float("nan"), "ref", 1.0), module="m"),
           dict(common.result("h", None, "ref", 1.0), module="m")]
    problems = row_problems(bad, "m")
    assert {p.split("'")[1][0] for p in problems} == set("defgh"), problems  # each bad row named
    assert row_problems([], "m") == ["m returned no rows"]


def test_a_broken_visviva_import_is_a_failed_row_not_a_skip(monkeypatch):
    # bench_kepler (and five other modules) turned any error importing visviva into a skipped
    # row "visviva not importable", which `python -m benchmarks` counted as fine
    main, _ = _bench()
    import visviva.core

    monkeypatch.setitem(sys.modules, "visviva.core.kepler_arrays", None)  # import fails
    # once imported (by an earlier test), the package's attribute would answer `from
    # visviva.core import kepler_arrays` without looking at sys.modules
    monkeypatch.delattr(visviva.core, "kepler_arrays", raising=False)
    monkeypatch.delitem(sys.modules, "benchmarks.bench_kepler", raising=False)
    rows, _ = main.run_module("bench_kepler", quick=True)
    assert [r["name"] for r in rows] == ["bench_kepler: failed"]
    assert "ImportError" in rows[0]["notes"] or "ModuleNotFoundError" in rows[0]["notes"]
    assert row_problems(rows, "bench_kepler")


def test_runner_exits_1_on_a_failed_row_and_writes_json(monkeypatch, tmp_path):
    main, common = _bench()
    fake = type(sys)("benchmarks.bench_zz_fake")
    fake.run = lambda quick=False: [common.result("ok", 1e-3, "ref", 1e-3),
                                    common.failed("dask row", RuntimeError("no workers"))]
    monkeypatch.setitem(sys.modules, "benchmarks.bench_zz_fake", fake)
    monkeypatch.setattr(main, "discover", lambda: ["bench_zz_fake"])
    out = tmp_path / "rows.json"
    assert main.main(["--quick", "--no-write", "--json", str(out)]) == 1
    rows = json.loads(out.read_text())
    assert [r["name"] for r in rows] == ["ok", "dask row: failed"]
    assert rows[1]["notes"] == "error: RuntimeError: no workers"
    assert rows[0]["module"] == "bench_zz_fake"


def test_runner_keeps_the_earlier_page_and_json_when_a_write_fails(monkeypatch, tmp_path,
                                                                   full_disk):
    # was: Path.write_text over docs/performance.md and --json: a full disk (or a crash)
    # mid-write left a truncated page in place of the earlier one
    main, common = _bench()
    fake = type(sys)("benchmarks.bench_zz_fake")
    fake.run = lambda quick=False: [common.result("ok", 1e-3, "ref", 1e-3)]
    monkeypatch.setitem(sys.modules, "benchmarks.bench_zz_fake", fake)
    monkeypatch.setattr(main, "discover", lambda: ["bench_zz_fake"])
    page, rows = tmp_path / "performance.md", tmp_path / "rows.json"
    args = ["--quick", "--output", str(page), "--json", str(rows)]
    assert main.main(args) == 0
    before = {p: p.read_bytes() for p in (page, rows)}
    assert b"ok" in before[page] and json.loads(before[rows])[0]["name"] == "ok"
    full_disk()
    with pytest.raises(OSError, match="No space left"):
        main.main(args)
    for p, data in before.items():
        assert p.read_bytes() == data, p
    assert not [p.name for p in tmp_path.iterdir() if p.suffix == ".tmp"]


def test_gpu_rows_file_keeps_whole_lines_when_a_write_fails(monkeypatch, tmp_path, full_disk):
    # was: appended with open(path, "a"): a run cut off mid-write left half a JSON line
    _bench()
    bench_gpu = importlib.import_module("benchmarks.bench_gpu")
    path = tmp_path / "rows.jsonl"
    monkeypatch.setenv("VISVIVA_BENCH_ROWS", str(path))
    rows = bench_gpu._Rows()
    rows.append({"name": "first", "visviva_s": 1.0})
    rows.append({"name": "second", "visviva_s": 2.0})
    before = path.read_bytes()
    full_disk()
    with pytest.raises(OSError, match="No space left"):
        rows.append({"name": "third", "visviva_s": 3.0})
    assert path.read_bytes() == before
    assert [json.loads(line)["name"] for line in before.decode().splitlines()] == ["first",
                                                                                 "second"]
