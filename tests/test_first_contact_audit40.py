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


# A mistake in the arguments: one line on stderr, nothing on stdout, exit code 2 (left from
# audit40: argparse printed its usage block first, 5 to 21 lines, and a bad number said only
# "invalid float value: '500km'", not the unit).
_SITE = ["--lat", "52.2", "--lon", "0.12", "--start", "2024-05-01T18:00"]
_ARGUMENT_MISTAKES = [
    # a bad value: a numeric option says its unit and gives an example
    (["validate", "--jobs", "two"],
     "argument --jobs/-j: 'two' is not a whole number of processes, 1 or more; "
     "give e.g. --jobs 2"),
    (["validate", "--timeout", "10min"],
     "argument --timeout: '10min' is not a positive number of seconds; give e.g. --timeout 60"),
    (["bench", "--threads", "all"], "'all' is not a whole number of threads"),
    (["screen", "c.tle", "--start", "2024-01-01", "--hours", "1", "--threshold", "5km"],
     "argument --threshold: '5km' is not a positive number of km; give e.g. --threshold 5"),
    (["screen", "c.tle", "--start", "2024-01-01", "--hours", "1", "--step", "1min"],
     "argument --step: '1min' is not a positive number of seconds"),
    (["convert", "a.tle", "b.oem", "--hours", "1d"],
     "argument --hours: '1d' is not a positive number of hours; give e.g. --hours 24"),
    (["convert", "a.tle", "b.tle", "--satnum", "ISS"],
     "argument --satnum: 'ISS' is not a catalogue number"),
    (["passes", "c.tle", *_SITE, "--height", "500km"],
     "argument --height: '500km' is not a number of metres; give e.g. --height 500"),
    (["passes", "c.tle", *_SITE, "--height", "nan"], "'nan' is not a number of metres"),
    (["passes", "c.tle", "--lat", "52.2N", "--lon", "0.12", "--start", "2024-05-01"],
     "argument --lat: '52.2N' is not a number of degrees; give e.g. --lat 10"),
    (["passes", "c.tle", *_SITE, "--min-elevation", "10deg"], "is not a number of degrees"),
    (["fit-tle", "e.oem", "--bstar", "1e-4/er"],
     "argument --bstar: '1e-4/er' is not a number of 1/earth radii"),
    (["od", "p.tdm", "--filter", "kalman"], "argument --filter: invalid choice: 'kalman'"),
    (["warmup", "--quiet=yes"], "argument --quiet: ignored explicit argument 'yes'"),
    # a missing argument, or an option without its value
    (["validate", "--only"], "argument --only: expected one argument; give its value"),
    (["bench", "--only"], "argument --only: expected one argument"),
    (["screen", "c.tle", "--hours", "1"], "the following arguments are required: --start"),
    (["convert", "a.tle"], "the following arguments are required: output"),
    (["passes", "c.tle", "--lat", "1", "--lon", "2"],
     "the following arguments are required: --start; see visviva passes --help"),
    (["fit-tle"], "the following arguments are required: ephemeris"),
    (["od"], "the following arguments are required: TDM"),
    # an unknown argument is the command's, not the top parser's
    (["warmup", "--fast"], "visviva warmup: error: unrecognized arguments: --fast"),
    (["passes", "c.tle", *_SITE, "extra"], "unrecognized arguments: extra"),
    ([], "visviva: error: the following arguments are required: command"),
    (["pases"], "argument command: invalid choice: 'pases'"),
]


@pytest.mark.parametrize(("argv", "why"), _ARGUMENT_MISTAKES,
                         ids=[" ".join(a if len(a) < 4 else a[:1] + a[-2:]) or "none"
                              for a, _ in _ARGUMENT_MISTAKES])
def test_an_argument_mistake_is_one_line_and_exit_code_2(capsys, argv, why):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    prog = "visviva" + (f" {argv[0]}" if argv and argv[0] != "pases" else "")
    assert lines[0].startswith(f"{prog}: error: ") and why in lines[0], lines[0]


def test_every_numeric_option_says_its_unit():
    # a new option with type=float would be back to "invalid float value: '500km'"
    import argparse

    _, sub, _ = cli._build_parser()
    checked = 0
    for name, parser in sub.choices.items():
        for action in parser._actions:
            assert action.type not in (float, int), (name, action.option_strings)
            if isinstance(action.type, cli._Number):
                with pytest.raises(argparse.ArgumentTypeError) as exc:
                    action.type("1 lightyear")
                option = max(action.option_strings, key=len)
                message = str(exc.value)
                assert f"give e.g. {option} " in message
                assert any(unit in message for unit in ("metres", "degrees", " km", "hours",
                                                        "seconds", "earth radii", "processes",
                                                        "threads", "catalogue number"))
                checked += 1
    assert checked == 16  # validate 2, bench 1, screen 3, convert 3, passes 5, fit-tle 2


def test_a_negative_value_in_exponent_form(capsys):
    # argparse takes `--bstar -1.2e-4` for two options; the line says how to give it
    with pytest.raises(SystemExit) as exc:
        cli.main(["fit-tle", "e.oem", "--bstar", "-1.2e-4"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "write --bstar=VALUE when the value starts with '-'" in err
    parser, _, _ = cli._build_parser()
    args = parser.parse_args(["fit-tle", "e.oem", "--bstar=-1.2e-4", "--satnum", "25544"])
    assert args.bstar == -1.2e-4 and args.satnum == 25544
    args = parser.parse_args(["passes", "c.tle", "--lat", "-33.9", "--lon", "-70", "--start",
                              "2024-05-01", "--height", "-20"])
    assert (args.lat, args.lon, args.height) == (-33.9, -70.0, -20.0)


def test_help_keeps_its_usage(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["passes", "--help"])
    assert exc.value.code == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("usage: visviva passes [-h] --lat DEG --lon DEG [--height M]")
    assert "height above the WGS-84 ellipsoid, metres (default 0)" in captured.out
    assert captured.err == ""


def test_python_dash_m_visviva_refuses_a_bad_value_in_one_line():
    # the audit's case, through the real entry point
    out = subprocess.run([sys.executable, "-m", "visviva", "passes", "c.tle", *_SITE,
                          "--height", "500km"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr == ("visviva passes: error: argument --height: '500km' is not a number "
                          "of metres; give e.g. --height 500\n")
