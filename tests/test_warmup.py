"""``visviva warmup``: runs every task, names each, reports failures, silences the compile notice."""

import io

import pytest

from visviva import cli, warmup
from visviva.core import _jit


def test_warmup_reports_each_task_and_failures():
    seen = []

    def ok():
        seen.append(_jit.notices["enabled"])

    def broken():
        raise ValueError("no such kernel")

    stream = io.StringIO()
    results = warmup.warmup((("fine", ok), ("broken", broken)), progress=False, stream=stream)
    assert [r[0] for r in results] == ["fine", "broken"]
    assert results[0][2] is None and results[1][2] == "ValueError: no such kernel"
    assert seen == [False] and _jit.notices["enabled"] is True  # notice off only meanwhile
    lines = stream.getvalue().splitlines()
    assert lines[0].split()[0] == "fine" and "FAILED: ValueError: no such kernel" in lines[1]


def test_warmup_compiles_instead_of_interpreting(monkeypatch):
    # the interpreter tier (core/tier.py) is off while the tasks run: their small calls must
    # compile and fill the cache; it is back as it was afterwards
    from visviva.core import tier

    monkeypatch.setitem(tier.spent, "off", False)
    seen = []
    warmup.warmup((("task", lambda: seen.append(tier.spent["off"])),), progress=False,
                  stream=io.StringIO())
    assert seen == [True] and tier.spent["off"] is False


def test_warmup_progress_bar_names_the_running_task():
    stream = io.StringIO()
    warmup.warmup((("first task", lambda: None),), progress=True, stream=stream)
    assert "visviva warmup" in stream.getvalue() and "first task" in stream.getvalue()


def test_warmup_is_a_cli_command(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["warmup", "--help"])
    assert exc.value.code == 0
    assert "compile" in capsys.readouterr().out.lower()


@pytest.mark.slow
def test_warmup_compiles_every_task(capsys):
    assert cli.main(["warmup", "--quiet"]) == 0
    out = capsys.readouterr()
    assert f"{len(warmup.TASKS)} of {len(warmup.TASKS)} kernel families compiled" in out.out
