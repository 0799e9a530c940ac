"""The command line: ``visviva validate`` end to end and its exit codes; ``visviva bench``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from visviva import cli
from visviva.validation import runner
from visviva.validation.base import Check
from visviva.validation.report import markdown_escape, plot_specs
from visviva.validation.results import short_name

ROOT = Path(__file__).resolve().parent.parent


def _fake_module(monkeypatch, name: str, fn) -> str:
    """Register a fake ``checks_<name>`` module in sys.modules; return its full name."""
    full = f"visviva.validation.checks_fake_{name}"
    module = types.ModuleType(full)
    if fn is not None:
        module.checks = fn
    monkeypatch.setitem(sys.modules, full, module)
    return full


def _passing(full=False):
    t = np.linspace(1.0, 100.0, 50)
    return [
        Check("fake: round trip", "max |dr| (km)", 1e-9, 1e-6, "fake 1.0",
              {"dr_km": np.abs(np.random.default_rng(0).normal(0, 1e-10, 100))}),
        Check("fake: energy", "max |dE/E|", 1e-14, 1e-12, "fake 1.0",
              {"t": t, "energy_error": 1e-16 * np.sqrt(t), "rebound_energy_error": 2e-16 * t,
               "plot_group": "energy"}),
    ]


def _failing(full=False):
    return [Check("fake: too far", "max |dr| (km)", 2.0, 1.0, "fake")]


def _raising(full=False):
    raise RuntimeError("half-written capability")


def _skipping(full=False):
    return [Check("fake: later", "x", math.nan, 1.0, details={"skipped": "not there yet"})]


def test_cli_validate_units_end_to_end(tmp_path):
    """The real command in a subprocess: runs the cheap units checks and writes the report."""
    report = tmp_path / "report"
    out_json = tmp_path / "out.json"
    proc = subprocess.run(
        [sys.executable, "-m", "visviva.cli", "validate", "--only", "units", "--report",
         str(report), "--json", str(out_json), "--quiet"],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert "units: _units.to_array vs astropy" in proc.stdout, proc.stdout + proc.stderr
    data = json.loads(out_json.read_text())
    statuses = {c["status"] for c in data["checks"]}
    assert statuses <= {"PASS", "SKIP", "FAIL"}
    assert proc.returncode == (1 if "FAIL" in statuses else 0), proc.stdout
    text = (report / "report.md").read_text()
    assert "# visviva validation report" in text
    assert "units: \\_units.to\\_array vs astropy" in text
    assert (report / "results.json").is_file()
    for line in proc.stdout.splitlines():
        if line.startswith(("PASS", "FAIL")):
            assert "<=" in line, line  # measured <= tolerance on every line


def test_passing_module_exit_zero_and_report_with_plots(monkeypatch, tmp_path, capsys):
    name = _fake_module(monkeypatch, "pass", _passing)
    code = runner.run(modules=[name], report_dir=tmp_path, progress=False)
    out = capsys.readouterr().out
    assert code == 0
    assert "PASS  fake: round trip" in out and "2 passed, 0 failed" in out
    pngs = sorted(p.name for p in tmp_path.glob("plot_*.png"))
    assert len(pngs) == 2, pngs  # the histogram and the energy group
    report = (tmp_path / "report.md").read_text()
    for png in pngs:
        assert f"]({png})" in report


def test_failing_check_gives_nonzero_exit(monkeypatch, tmp_path, capsys):
    good = _fake_module(monkeypatch, "pass", _passing)
    bad = _fake_module(monkeypatch, "fail", _failing)
    assert runner.run(modules=[good, bad], report_dir=tmp_path, progress=False) == 1
    out = capsys.readouterr().out
    assert "FAIL  fake: too far" in out
    assert "**FAIL**" in (tmp_path / "report.md").read_text()


def test_broken_modules_become_failed_checks_not_crashes(monkeypatch, tmp_path, capsys):
    raising = _fake_module(monkeypatch, "raise", _raising)
    no_fn = _fake_module(monkeypatch, "nofn", None)
    wrong = _fake_module(monkeypatch, "wrong", lambda full=False: [42])
    missing = "visviva.validation.checks_does_not_exist_xyz"
    good = _fake_module(monkeypatch, "pass", _passing)
    code = runner.run(modules=[raising, no_fn, wrong, missing, good], report_dir=tmp_path,
                      progress=False)
    out = capsys.readouterr().out
    assert code == 1
    assert "half-written capability" in out
    assert "defines no checks(full)" in out
    assert "expected a Check" in out
    assert "import failed" in out
    assert "2 passed, 4 failed" in out  # the good module still ran


def test_skips_do_not_fail_unless_strict(monkeypatch, tmp_path):
    good = _fake_module(monkeypatch, "pass", _passing)
    skip = _fake_module(monkeypatch, "skip", _skipping)
    assert runner.run(modules=[good, skip], report_dir=None, progress=False) == 0
    assert runner.run(modules=[good, skip], report_dir=None, progress=False, strict=True) == 1


def test_empty_run_is_not_a_success(tmp_path):
    assert runner.run(modules=[], report_dir=tmp_path, progress=False) == 1


def test_only_selects_modules_then_check_names(monkeypatch, capsys):
    good = _fake_module(monkeypatch, "pass", _passing)
    bad = _fake_module(monkeypatch, "fail", _failing)
    # a topic match runs the whole module
    assert runner.run(modules=[good, bad], report_dir=None, progress=False, only="fake_pass") == 0
    # no topic matches: filter by check name ("energy" is a check of the passing module)
    assert runner.run(modules=[good, bad], report_dir=None, progress=False, only="ENERGY") == 0
    out = capsys.readouterr().out
    assert "too far" not in out and "fake: energy" in out


def test_full_flag_reaches_the_module(monkeypatch):
    seen = []

    def record(full=False):
        seen.append(full)
        return _passing(full)

    name = _fake_module(monkeypatch, "record", record)
    runner.run(modules=[name], report_dir=None, progress=False, full=True)
    assert seen == [True]


def test_timeout_turns_into_failed_check(monkeypatch):
    import time

    def slow(full=False):
        time.sleep(5)
        return _passing()

    name = _fake_module(monkeypatch, "slow", slow)
    result = runner.run_module(name, timeout_s=0.2)
    assert len(result.checks) == 1 and not result.checks[0].passed
    assert "time budget" in result.checks[0].name


def test_json_output_is_strict_json(monkeypatch, tmp_path):
    good = _fake_module(monkeypatch, "pass", _passing)
    raising = _fake_module(monkeypatch, "raise", _raising)
    path = tmp_path / "r.json"
    runner.run(modules=[good, raising], report_dir=None, progress=False, json_path=path)
    data = json.loads(path.read_text())  # NaN would make this invalid JSON
    assert data["counts"] == {"PASS": 2, "FAIL": 1, "SKIP": 0}
    assert data["exit_code"] == 1
    assert data["environment"]["numpy"] == np.__version__
    assert isinstance(data["checks"][0]["details"]["dr_km"], list)


def test_cli_main_in_process(monkeypatch, tmp_path, capsys):
    bad = _fake_module(monkeypatch, "fail", _failing)
    monkeypatch.setattr(runner, "discover", lambda: [bad])
    assert cli.main(["validate", "--report", str(tmp_path), "--quiet"]) == 1
    assert cli.main(["validate", "--list"]) == 0
    assert "fake_fail" in capsys.readouterr().out


def test_plot_specs_conventions():
    t = np.arange(1.0, 11.0)
    brouwer = Check("Brouwer's law, ias15", "rel energy error", 1.0, 2.0,
                    details={"t": t, "energy_error": t**0.5})
    assert plot_specs(brouwer)[0]["kind"] == "loglog"
    hist = Check("x", "m", 0.0, 1.0, details={"dv_error": np.ones(10), "names": ["a"] * 10})
    assert plot_specs(hist) == [{"kind": "hist", "y": "dv_error"}]
    explicit = Check("x", "m", 0.0, 1.0, details={"plot": {"kind": "line", "x": "a", "y": "b"}})
    assert plot_specs(explicit)[0]["x"] == "a"
    assert plot_specs(Check("x", "m", 0.0, 1.0)) == []


def test_markdown_escape():
    assert markdown_escape("a|b *c* $x$ <y>") == "a\\|b \\*c\\* \\$x\\$ \\<y\\>"


def test_bench_from_repo_root(tmp_path):
    """``visviva bench`` finds the benchmarks package from the repository root."""
    out = tmp_path / "perf.md"
    proc = subprocess.run(
        [sys.executable, "-m", "visviva.cli", "bench", "--only", "no_such_benchmark_xyz",
         "--output", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    assert "# Performance" in text and "| numba |" in text and "| cpu |" in text


def test_bench_page_marks_targets(tmp_path, monkeypatch):
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks import __main__ as bench_main
        from benchmarks.common import result
    finally:
        sys.path.remove(str(ROOT))
    rows = [result("fast", 1.0, "ref", 2.0, target=1.0), result("slow", 3.0, "ref", 1.0, target=2.0)]
    text = bench_main.markdown(rows, quick=True, elapsed_s=1.0)
    assert "| fast |" in text and "| met |" in text and "| NOT met |" in text
    assert "1 of 2 targets met" in text
    # a page being replaced keeps its hand-written sections (GPU figures measured on a lent
    # machine, before/after comparisons): a rerun on another machine must not erase them
    page = tmp_path / "performance.md"
    page.write_text(text + "\n## Measured on a GPU by hand\n\n| row | 1 ns |\n")
    again = bench_main.markdown(rows[:1], quick=False, elapsed_s=2.0, output=page)
    assert "## Measured on a GPU by hand" in again and "| row | 1 ns |" in again
    assert "| slow |" not in again and again.count("## Results") == 1


def test_warnings_are_recorded_not_printed(monkeypatch, tmp_path, capsys):
    import warnings

    def noisy(full=False):
        warnings.warn("IERS table is old", UserWarning, stacklevel=1)
        return _passing()

    name = _fake_module(monkeypatch, "noisy", noisy)
    assert runner.run(modules=[name], report_dir=tmp_path, progress=False) == 0
    captured = capsys.readouterr()
    assert "IERS table is old" not in captured.out + captured.err
    assert "UserWarning: IERS table is old" in (tmp_path / "report.md").read_text()


def test_worker_processes_keep_order_and_survive_a_crash(monkeypatch, tmp_path, capsys):
    """--jobs 2: modules run in spawned workers; a hard crash (os._exit) is a failed check."""
    (tmp_path / "vvfake_ok.py").write_text(
        "from visviva.validation.base import Check\n"
        "def checks(full=False):\n"
        "    return [Check('worker ok', 'x', 0.0, 1.0)]\n")
    (tmp_path / "vvfake_crash.py").write_text(
        "import os\n"
        "def checks(full=False):\n"
        "    os._exit(3)\n")
    (tmp_path / "vvfake_fail.py").write_text(
        "from visviva.validation.base import Check\n"
        "def checks(full=False):\n"
        "    return [Check('worker fail', 'x', 2.0, 1.0)]\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    code = runner.run(modules=["vvfake_ok", "vvfake_crash", "vvfake_fail"], report_dir=None,
                      progress=False, jobs=2)
    out = capsys.readouterr().out
    assert code == 1
    lines = [ln for ln in out.splitlines() if ln.startswith(("PASS", "FAIL"))]
    assert lines[0].startswith("PASS  worker ok")
    assert "worker failed" in lines[1] and "exit code 3" in out
    assert lines[2].startswith("FAIL  worker fail")


def test_energy_histories_share_one_figure_and_reference_is_dashed():
    from visviva.validation.report import _is_reference

    t = np.linspace(1, 100, 20)
    a = Check("nbody whfast vs rebound", "m", 0.0, 1.0,
              details={"times_yr": t, "energy_error_visviva": t * 1e-16,
                       "energy_error_rebound": t * 2e-16})
    (spec,) = plot_specs(a)
    assert spec["x"] == "times_yr" and spec["group"] == "energy error against time"
    assert _is_reference("energy_error_rebound") and not _is_reference("energy_error_visviva")


@pytest.mark.slow  # the section's CPU baseline: 49 s of CI's two cores
def test_bench_gpu_sections_return_their_rows(monkeypatch):
    # run() must hand its rows to the page writer (it printed them and returned None, so
    # `python -m benchmarks --only gpu` reported "bench_gpu: failed")
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks import bench_gpu
    finally:
        sys.path.remove(str(ROOT))
    monkeypatch.setattr(bench_gpu, "_gpu", lambda: ("no GPU here", ""))
    rows = bench_gpu.run(quick=True, sections=("whfast",))
    assert isinstance(rows, list) and len(rows) == 1
    assert rows[0]["name"].startswith("WHFast on the GPU") and "skipped" in rows[0]["notes"]


def test_top_level_help_speaks_to_users(capsys):
    # `visviva --help` printed the module docstring: RST markup and the developers' _COMMANDS
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "_COMMANDS" not in out and "``" not in out
    assert "visviva COMMAND --help" in out


ISS_TLE = ("ISS (ZARYA)\n"
           "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927\n"
           "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537\n")


def test_no_command_writes_over_its_input_or_an_existing_file_silently(tmp_path, capsys):
    # `visviva convert a.tle a.tle --to omm`, `visviva passes a.tle ... --csv a.tle` and
    # `visviva screen a.tle ... --csv a.tle` replaced the element sets they had just read, and
    # every command replaced an existing output without a word (audit10)
    tle = tmp_path / "a.tle"
    tle.write_text(ISS_TLE)
    window = ["--start", "2008-09-20T12:00", "--hours", "1"]
    site = ["--lat", "40", "--lon", "-75"]
    for argv in (["convert", str(tle), str(tle), "--to", "omm"],
                 ["convert", str(tle), str(tmp_path / "." / "a.tle"), "--to", "omm",
                  "--overwrite"],
                 ["passes", str(tle), *site, *window, "--csv", str(tle)],
                 ["passes", str(tle), *site, *window, "--ecsv", str(tle), "--overwrite"],
                 ["screen", str(tle), *window, "--csv", str(tle), "--quiet"]):
        assert cli.main(argv) == 2, argv
        assert "is the input file" in capsys.readouterr().err
        assert tle.read_text() == ISS_TLE
    # an existing output: refused, untouched; replaced with --overwrite
    oem = tmp_path / "iss.oem"
    assert cli.main(["convert", str(tle), str(oem), "--to", "oem", "--hours", "1"]) == 0
    for out, argv in ((oem, ["convert", str(tle), str(oem), "--to", "oem", "--hours", "2"]),
                      (tmp_path / "p.csv", ["passes", str(tle), *site, *window, "--csv"]),
                      (tmp_path / "s.csv", ["screen", str(tle), *window, "--quiet", "--csv"])):
        if not out.exists():
            out.write_text("precious\n")
        before = out.read_text()
        full = argv + ([str(out)] if argv[-1] == "--csv" else [])
        assert cli.main(full) == 2, argv
        assert "exists; pass --overwrite" in capsys.readouterr().err
        assert out.read_text() == before
        assert cli.main([*full, "--overwrite"]) == 0, argv
        assert out.read_text() != before
    # fit-tle: the ephemeris is never its output; one file is not two outputs
    assert cli.main(["fit-tle", str(oem), "-o", str(oem), "--overwrite"]) == 2
    assert "is the input file" in capsys.readouterr().err
    # a bad --epoch is bad input (2), not a failed fit (1, with astropy's list of formats)
    assert cli.main(["fit-tle", str(oem), "--epoch", "2024-13-01"]) == 2
    assert "--epoch '2024-13-01' is not an ISO time" in capsys.readouterr().err
    assert cli.main(["passes", str(tle), *site, *window, "--csv", str(tmp_path / "x"),
                     "--ecsv", str(tmp_path / "x")]) == 2
    assert "given as two outputs" in capsys.readouterr().err


def test_only_matching_nothing_is_refused_before_running(monkeypatch, capsys):
    """Regression: ``--only <typo>`` ran every module (95 s) before saying nothing matched."""
    ran = []

    def record(module, full=False, timeout_s=None):
        ran.append(module)
        raise AssertionError("no module may run")

    monkeypatch.setattr(runner, "run_module", record)
    code = runner.run(report_dir=None, progress=False, only="no_such_check_xyz")
    err = capsys.readouterr().err
    assert code == 2 and ran == []
    line = err.strip()
    assert "\n" not in line and "no_such_check_xyz" in line
    for topic in ("units", "nbody", "anomalies"):
        assert topic in line
    # a term naming a real check (not a topic) is not refused: it is written in a module
    assert runner.unmatched_only("vs mpmath", runner.discover()) is None
    assert runner.unmatched_only("UNITS", runner.discover()) is None


def test_the_satellite_rooms_have_check_modules():
    # ground, conjunctions and od had no checks before the twentieth session: discovered by
    # name, listed by --list, and reachable by --only topic or by a piece of a check name
    topics = {short_name(n) for n in runner.discover()}
    assert {"ground", "conjunctions", "od", "ccsds", "satellites"} <= topics
    for term in ("ground", "conjunctions", "od", "find_events", "Pc3D_Hall", "Herrick-Gibbs"):
        assert runner.unmatched_only(term, runner.discover()) is None


def test_only_a_whole_topic_name_selects_that_topic_alone():
    # "od" is also a piece of "nbody": --only od ran the N-body module too (11 s more)
    names = runner.discover()
    assert [short_name(n) for n in runner.select_topics("od", names)] == ["od"]
    assert [short_name(n) for n in runner.select_topics("OD, ground", names)] == ["ground", "od"]
    assert [short_name(n) for n in runner.select_topics("body", names)] == ["nbody"]
    assert [short_name(n) for n in runner.select_topics("s", ["a.checks_units", "a.checks_x"])
            ] == ["units"]


def test_cli_only_matching_nothing_exits_2_at_once():
    proc = subprocess.run(
        [sys.executable, "-m", "visviva.cli", "validate", "--only", "no_such_check_xyz",
         "--no-report", "--quiet"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "matches no check module" in proc.stderr and "check modules" not in proc.stdout


def test_validate_keeps_the_earlier_report_and_json_when_a_write_fails(monkeypatch, tmp_path,
                                                                        capsys, full_disk):
    # was: Path.write_text over the old files: a full disk (or a crash) mid-write left a
    # truncated report.md / results.json / --json file in place of the previous run's
    good = _fake_module(monkeypatch, "pass", _passing)
    bad = _fake_module(monkeypatch, "fail", _failing)
    out_json = tmp_path / "out.json"
    report = tmp_path / "report"
    assert runner.run(modules=[good], report_dir=report, progress=False,
                      json_path=out_json) == 0
    files = [report / "report.md", report / "results.json", out_json,
             *sorted(report.glob("plot_*.png"))]
    before = {p: p.read_bytes() for p in files}
    assert len(before) == 5 and json.loads(before[out_json])["exit_code"] == 0
    full_disk()
    with pytest.raises(OSError, match="No space left"):
        runner.run(modules=[good, bad], report_dir=report, progress=False, json_path=out_json)
    assert "report could not be written" in capsys.readouterr().err
    for p, data in before.items():
        assert p.read_bytes() == data, p  # the earlier run's file, whole
    leftovers = [p.name for p in (*tmp_path.iterdir(), *report.iterdir()) if p.suffix == ".tmp"]
    assert not leftovers
