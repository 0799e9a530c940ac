"""The first minutes with the command line and the file readers (audit14): an empty element-set
file, an output in a folder that does not exist, and outputs written whole or not at all."""

from __future__ import annotations

import os
import stat

import pytest

import visviva as vv
from visviva import cli
from visviva.cli_window import write_output

ISS_TLE = ("ISS (ZARYA)\n"
           "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927\n"
           "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537\n")
WINDOW = ["--start", "2008-09-20T12:00", "--hours", "1"]
SITE = ["--lat", "40", "--lon", "-75"]


@pytest.mark.parametrize("content", ["", "\n\n", "  \r\n", "\ufeff\n"])
@pytest.mark.parametrize("reader", [vv.read_catalog_file, vv.read_tle_file])
def test_an_empty_element_set_file_is_refused_naming_it(tmp_path, reader, content):
    # was: Catalog(0 satellites), silently; `visviva passes` then said "the catalogue is empty;
    # pass at least one Satellite" (the Python API's words, no file named) and `visviva
    # convert` "holds 0 satellites (); pick one with --satnum"
    path = tmp_path / "active.txt"
    path.write_text(content, encoding="utf-8")
    with pytest.raises(vv.InvalidInputError, match=r"active\.txt: the file is empty"):
        reader(path)


def test_the_commands_name_an_empty_file(tmp_path, capsys):
    path = tmp_path / "gp.tle"
    path.write_text("")
    for argv in (["passes", str(path), *SITE, *WINDOW],
                 ["screen", str(path), *WINDOW, "--quiet"],
                 ["convert", str(path), str(tmp_path / "x.omm")]):
        assert cli.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "gp.tle: the file is empty" in err, (argv, err)
        assert "Traceback" not in err


def test_an_output_in_a_missing_folder_or_a_folder_is_refused_before_the_work(
        tmp_path, capsys, monkeypatch):
    # was: the passes were searched (minutes for a catalogue), printed, and only then "cannot
    # write ...: No such file or directory"
    import visviva.ground.passes as passes

    def no_work(*args, **kwargs):
        raise AssertionError("the search ran before the output path was checked")

    monkeypatch.setattr(passes, "find_passes", no_work)
    tle = tmp_path / "a.tle"
    tle.write_text(ISS_TLE)
    missing = tmp_path / "no" / "such" / "p.csv"
    assert cli.main(["passes", str(tle), *SITE, *WINDOW, "--csv", str(missing)]) == 2
    err = capsys.readouterr().err
    assert f"the folder {missing.parent} does not exist" in err
    assert cli.main(["passes", str(tle), *SITE, *WINDOW, "--ecsv", str(tmp_path)]) == 2
    assert "cannot write" in (err := capsys.readouterr().err) and "is a folder; name a file" in err
    assert cli.main(["convert", str(tle), str(missing.with_suffix(".omm"))]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not missing.parent.exists()


def test_a_failed_write_leaves_the_old_file_and_no_partial_one(tmp_path):
    # was: open(path, "w") emptied the file first, so a write that failed half-way (a full
    # disk, Ctrl-C; here a character that UTF-8 cannot encode) destroyed the file that
    # --overwrite was about to replace and left a truncated one
    path = tmp_path / "orbit.oem"
    path.write_text("precious\n")
    with pytest.raises(vv.InvalidInputError, match="line 1001 .* cannot encode"):
        write_output("convert", str(path), "CCSDS_OEM_VERS = 3.0\n" * 1000 + "\ud800")
    assert path.read_text() == "precious\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["orbit.oem"]


def test_a_replaced_output_keeps_its_permissions_and_a_new_one_gets_the_usual(tmp_path):
    path = tmp_path / "shared.omm"
    path.write_text("old\n")
    os.chmod(path, 0o640)
    assert write_output("convert", str(path), "new\n") == 0
    assert path.read_text() == "new\n"
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o640
    fresh = tmp_path / "fresh.omm"
    assert write_output("convert", str(fresh), "x\n") == 0
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(os.stat(fresh).st_mode) == 0o666 & ~umask


def test_pass_and_screen_tables_are_written_whole(tmp_path):
    # the tables go through the same whole-or-nothing write; the CSV reads back row for row
    from astropy.table import Table

    tle = tmp_path / "a.tle"
    tle.write_text(ISS_TLE)
    csv = tmp_path / "p.csv"
    ecsv = tmp_path / "p.ecsv"
    argv = ["passes", str(tle), *SITE, "--start", "2008-09-20T00:00", "--hours", "24",
            "--csv", str(csv), "--ecsv", str(ecsv)]
    assert cli.main(argv) == 0
    rows = Table.read(csv, format="ascii.csv")
    back = Table.read(ecsv, format="ascii.ecsv")
    assert len(rows) == len(back) > 0
    assert list(rows["satnum"]) == [25544] * len(rows)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.tle", "p.csv", "p.ecsv"]


def _checksum(line: str) -> str:
    return str(sum(int(c) if c.isdigit() else c == "-" for c in line[:68]) % 10)


def _pair_file(tmp_path):
    """The ISS and a copy 0.5 deg of mean anomaly behind it (about 59 km apart all along)."""
    lines = ISS_TLE.splitlines()
    other = [line.replace("25544", "25545").replace("325.0288", "325.5288")
             for line in lines[1:]]
    other = [line[:68] + _checksum(line) for line in other]
    path = tmp_path / "pair.tle"
    path.write_text(ISS_TLE + "OTHER\n" + "\n".join(other) + "\n")
    return path


def test_a_screening_step_too_long_to_bracket_every_minimum_is_refused(tmp_path, capsys):
    # was: `--step 3600` (or any step of an orbit's length) printed "1 close approaches"
    # where the 60 s default finds 2 (the one at 12:47 fell between the two samples), exit 0
    from astropy import units as u
    from astropy.time import Time

    path = _pair_file(tmp_path)
    cat = vv.read_catalog_file(path)
    t0 = Time("2008-09-20T12:00:00", scale="utc")
    found = vv.screen_conjunctions(cat, None, t0, t0 + 1 * u.h, 5000 * u.km)
    for step in (60, 600):
        again = vv.screen_conjunctions(cat, None, t0, t0 + 1 * u.h, 5000 * u.km,
                                       step=step * u.s)
        assert len(again) == len(found) >= 2
        assert abs(again["tca"] - found["tca"]).max().to_value(u.ms) < 1.0
    for step in (1800, 3600, 1e9):
        with pytest.raises(vv.InvalidInputError, match=r"1/8 of the shortest orbital period"):
            vv.screen_conjunctions(cat, None, t0, t0 + 1 * u.h, 5000 * u.km, step=step * u.s)
    argv = ["screen", str(path), "--start", "2008-09-20T12:00", "--hours", "1", "--threshold",
            "5000", "--quiet"]
    assert cli.main([*argv, "--step", "3600"]) == 2
    err = capsys.readouterr().err
    assert "step = 3600 s is longer than" in err and "at most 6" in err
    assert cli.main(argv) == 0
    assert f"{len(found)} close approaches" in capsys.readouterr().out


def test_a_checksum_error_gives_advice_that_the_reader_and_the_commands_can_follow(tmp_path,
                                                                                    capsys):
    # was: "(or pass verify_checksum=False for hand-made element sets)", from
    # read_catalog_file and `visviva passes`/`screen`/`convert`, none of which takes it
    lines = ISS_TLE.splitlines()
    bad = lines[1][:68] + str((int(lines[1][68]) + 1) % 10)
    path = tmp_path / "bad.tle"
    path.write_text("\n".join([lines[0], bad, lines[2]]) + "\n")
    with pytest.raises(vv.TLEFormatError, match="download the element set again") as exc:
        vv.read_catalog_file(path)
    assert "line 2 of" in str(exc.value) and "vv.read_tle_file" in str(exc.value)
    assert len(vv.read_tle_file(path, verify_checksum=False)) == 1  # the advice works
    assert cli.main(["passes", str(path), *SITE, *WINDOW]) == 2
    err = capsys.readouterr().err
    assert "bad.tle: checksum mismatch" in err and "download the element set again" in err


def test_a_missing_input_gets_advice_for_the_shell(tmp_path, capsys, monkeypatch):
    # was: "'x.oem': no such file ...; check the name, or pass the message text itself (a
    # string with its newlines, or bytes)": the readers' advice for Python callers
    monkeypatch.chdir(tmp_path)
    for argv in (["convert", "missing.oem", "x.omm"], ["fit-tle", "missing.oem"]):
        assert cli.main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err == (f"visviva {argv[0]}: 'missing.oem': no such file (relative to "
                       f"{str(tmp_path)!r}); check the name."), err


def test_ctrl_c_is_one_line_and_exit_code_130(tmp_path, capsys, monkeypatch):
    # was: a KeyboardInterrupt traceback from inside sgp4's wrapper (a long `visviva screen`)
    import visviva.conjunctions.screening as screening

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(screening, "screen_conjunctions", interrupted)
    tle = tmp_path / "a.tle"
    tle.write_text(ISS_TLE)
    csv = tmp_path / "s.csv"
    assert cli.main(["screen", str(tle), *WINDOW, "--quiet", "--csv", str(csv)]) == 130
    err = capsys.readouterr().err.strip()
    assert err.startswith("visviva screen: interrupted") and "\n" not in err
    assert not csv.exists()


def test_an_output_behind_a_symbolic_link_is_written_where_the_link_points(tmp_path):
    target = tmp_path / "real.omm"
    target.write_text("old\n")
    link = tmp_path / "link.omm"
    link.symlink_to(target)
    assert write_output("convert", str(link), "new\n") == 0
    assert link.is_symlink() and target.read_text() == "new\n"


def test_write_passes_writes_a_file_whole_or_into_an_open_text_file(tmp_path):
    import io

    from astropy import units as u
    from astropy.table import Table
    from astropy.time import Time

    from visviva.ground import write_passes

    lines = ISS_TLE.splitlines()
    iss = vv.Satellite.from_tle(lines[1], lines[2], name=lines[0])
    site = vv.GroundStation(40 * u.deg, -75 * u.deg, 0 * u.m)
    t0 = Time("2008-09-20T00:00:00", scale="utc")
    table = vv.find_passes(iss, site, t0, t0 + 1 * u.day)
    buffer = io.StringIO()
    write_passes(table, buffer, format="csv")
    path = tmp_path / "p.csv"
    write_passes(table, path)
    assert path.read_text() == buffer.getvalue()
    assert len(Table.read(path, format="ascii.csv")) == len(table) > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]


def test_convert_never_converts_another_object_than_satnum_asks_for(tmp_path, capsys):
    # was: a file with one OMM ignored --satnum and converted the object it held, exit 0
    tle = tmp_path / "a.tle"
    tle.write_text(ISS_TLE)
    omm = tmp_path / "a.omm"
    assert cli.main(["convert", str(tle), str(omm)]) == 0
    for source in (omm, tle):
        assert cli.main(["convert", str(source), "-", "--to", "tle", "--satnum", "99999"]) == 2
        captured = capsys.readouterr()
        assert captured.out == ""
        assert f"no satellite 99999 in {source} (it holds 25544)" in captured.err
        assert cli.main(["convert", str(source), "-", "--to", "tle", "--satnum", "25544"]) == 0
        assert capsys.readouterr().out.splitlines()[1:] == ISS_TLE.splitlines()[1:]
