"""``visviva validate`` progress: names the running module, never garbles, ends with a table."""

import io
import sys
import time
import types

from visviva.core import _jit
from visviva.validation import runner
from visviva.validation.base import Check


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def _module(monkeypatch, name, checks):
    full = f"visviva.validation.checks_fake_{name}"
    module = types.ModuleType(full)
    module.checks = checks
    monkeypatch.setitem(sys.modules, full, module)
    return full


def _slow(full=False):
    time.sleep(1.2)  # long enough for the bar's clock to tick
    _jit.notices["write"]("visviva: compiling some_kernel for its first use\n")
    return [Check("slow: one", "abs", 0.1, 1.0), Check("slow: two", "abs", 2.0, 1.0)]


def _quick(full=False):
    return [Check("quick: skipped", "abs", float("nan"), 1.0, details={"skipped": "no lib"})]


def test_bar_names_running_module_and_lines_stay_whole(monkeypatch, tmp_path):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    out = _Terminal()  # stdout and stderr on one terminal, as a user sees them
    monkeypatch.setattr(sys, "stdout", out)
    names = [_module(monkeypatch, "slow", _slow), _module(monkeypatch, "quick", _quick)]
    code = runner.run(modules=names, report_dir=None, progress=True)
    assert code == 1
    bar = term.getvalue()
    assert "running: fake_slow (1 s)" in bar  # the clock ticks while the module runs
    lines = out.getvalue().splitlines()
    # every result line is whole: it starts with its status (tqdm.write clears the bar first)
    results = [ln for ln in lines if "slow: " in ln or "quick: " in ln]
    assert [ln.split()[0] for ln in results] == ["PASS", "FAIL", "SKIP"]
    # the compile notice came through the bar too, as a whole line
    assert any(ln.startswith("visviva: compiling some_kernel") for ln in bar.splitlines())
    assert "write" not in _jit.notices


def test_summary_table_one_row_per_module_and_total(monkeypatch):
    stream = io.StringIO()
    names = [_module(monkeypatch, "slow2", _slow), _module(monkeypatch, "quick2", _quick)]
    runner.run(modules=names, report_dir=None, progress=False, stream=stream)
    text = stream.getvalue()
    table = text[text.index("module "):].splitlines()
    assert table[0].split() == ["module", "checks", "pass", "fail", "skip", "time", "(s)"]
    rows = {ln.split()[0]: ln.split()[1:5] for ln in table[2:] if not ln.startswith("-")}
    assert rows["fake_slow2"] == ["2", "1", "1", "0"]
    assert rows["fake_quick2"] == ["1", "0", "0", "1"]
    assert rows["total"] == ["3", "1", "1", "1"]
