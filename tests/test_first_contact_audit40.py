"""First contact, fourth pass (audit40): the command line refuses an option given twice, runs as
``python -m visviva``, and ``visviva warmup`` covers the kernels of this and last session's
features (MEGNO's tangent maps, the ensemble kernel)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from visviva import cli

ISS_TLE = ("ISS (ZARYA)\n"
           "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927\n"
           "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537\n")


@pytest.mark.parametrize("twice", [["--hours", "5", "--hours", "2"], ["--lat", "10"],
                                   ["--mask", "m.txt", "--mask", "m.txt"]])
def test_an_option_given_twice_is_refused_with_exit_code_2(tmp_path, capsys, twice):
    # was: argparse kept the last value silently (`--hours 5 --hours 2` searched 2 hours,
    # `--lat 52 ... --lat 10` a site at 10 deg north), exit code 0
    tle = tmp_path / "iss.tle"
    tle.write_text(ISS_TLE)
    argv = ["passes", str(tle), "--lat", "40", "--lon", "-75", "--start", "2008-09-20T12:00",
            *twice]
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    name = twice[0]
    assert f"argument {name}: given twice" in err and "give it once" in err
    assert "Traceback" not in err


def test_options_that_collect_stay_repeatable(capsys):
    # `visviva od --station A=... --station B=...` appends: not refused by the check above
    with pytest.raises(SystemExit) as exc:
        cli.main(["od", "--station", "A=1,2", "--station", "B=3,4", "--help"])
    assert exc.value.code == 0
    with pytest.raises(SystemExit) as exc:
        cli.main(["validate", "--jobs", "1", "-j", "2"])
    assert exc.value.code == 2
    assert "--jobs/-j: given twice" in capsys.readouterr().err


def test_python_dash_m_visviva_runs_the_command_line():
    # was: "No module named visviva.__main__; 'visviva' is a package and cannot be directly
    # executed"
    out = subprocess.run([sys.executable, "-m", "visviva", "passes", "--help"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "--mask FILE" in out.stdout


def test_a_command_shows_each_warning_once(capsys):
    # was: `visviva passes ... --start 2030-01-01` printed 21 warning lines: ERFA's "dubious
    # year" 15 times (one per ERFA function and count) and astropy's polar-motion warning 3 times
    import types
    import warnings

    from erfa import ErfaWarning

    def run(args):
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            for fn, n, note in (("dtf2d", 1, 6), ("utctai", 1, 3), ("taiutc", 5, 4)):
                warnings.warn(f'ERFA function "{fn}" yielded {n} of "dubious year (Note {note})"',
                              ErfaWarning, stacklevel=1)
            for _ in range(3):
                warnings.warn("Tried to get polar motions for times after IERS data is valid.",
                              stacklevel=1)
            warnings.warn('ERFA function "utcut1" yielded 1 of "other reason"', ErfaWarning,
                          stacklevel=1)
        return 0

    module = types.SimpleNamespace(run=run)
    assert cli._run_command(module, types.SimpleNamespace(command="passes")) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3, err
    assert sum("dubious year" in line for line in err) == 1
    assert sum("polar motions" in line for line in err) == 1
    # a second command shows them again
    assert cli._run_command(module, types.SimpleNamespace(command="passes")) == 0
    assert len(capsys.readouterr().err.splitlines()) == 3
