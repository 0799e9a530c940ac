"""First-contact audit 35: what a Skyfield/Orekit/STK user meets in the first five minutes.

Each test fails on the code before its fix (named in the test's comment)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

import visviva as vv

SRC = Path(vv.__file__).parent


def _resolves(dotted: str) -> bool:
    """True when ``vv.a.b`` (``dotted`` without the ``vv``) names an attribute or module."""
    obj = vv
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if hasattr(obj, part):
            obj = getattr(obj, part)
            continue
        try:
            obj = importlib.import_module("visviva." + ".".join(parts[: i + 1]))
        except ImportError:
            return False
    return True


def test_every_vv_name_in_messages_and_docstrings_exists():
    # was: the TLE checksum error advised 'vv.parse_tle_text ... with verify_checksum=False',
    # which is not importable from visviva (AttributeError for whoever followed the advice)
    missing = []
    for path in SRC.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"(?<![\w.])vv((?:\.[A-Za-z_]\w*)+)", text):
            dotted = m.group(1)[1:]
            if dotted.split(".")[0] in {"copy"}:  # a local array named vv (conjunctions)
                continue
            if not _resolves(dotted):
                line = text[: m.start()].count("\n") + 1
                missing.append(f"{path.relative_to(SRC)}:{line}: vv.{dotted}")
    assert not missing, missing


def test_every_sphinx_cross_reference_to_visviva_resolves():
    # leftfix4: docstrings pointed at :mod:`visviva.core.tiers` (the module is core.tier),
    # :attr:`visviva.OPM.covariance` (OPM is visviva.ccsds.OPM) and
    # :func:`visviva.core.gravity.row_acceleration` (no such kernel): dead links in the API docs
    role = re.compile(r":(?:mod|attr|class|func|meth|data|exc):`~?visviva\.([\w.]+)`")
    missing = []
    for path in SRC.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for m in role.finditer(text):
            if not _resolves(m.group(1)):
                line = text[: m.start()].count("\n") + 1
                missing.append(f"{path.relative_to(SRC)}:{line}: visviva.{m.group(1)}")
    assert not missing, missing


def test_checksum_error_names_a_reader_that_exists():
    line1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9000"
    line2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"
    with pytest.raises(vv.TLEFormatError, match="checksum") as info:
        vv.Satellite.from_tle(line1, line2)
    named = re.findall(r"visviva\.satellites\.catalog\.(\w+)", str(info.value))
    assert named == ["parse_tle_text"]
    from visviva.satellites import catalog

    sat = getattr(catalog, named[0])(line1 + "\n" + line2, verify_checksum=False).satellites[0]
    assert sat.satnum == 25544


# --- a CDM whose states contradict its own MISS_DISTANCE / RELATIVE_SPEED -------------------

CDM_SAMPLE = Path(__file__).parent / "data" / "sample_cdm.kvn"
X1 = "X                                  = 2570.097065 [km]"


def _no_warning_read(text):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return vv.read_cdm(text)


def test_cdm_position_in_metres_without_unit_is_warned():
    # was: X = 2570097.065 (metres, no [km]) read as km put object 1 2.57 million km away; the
    # message said MISS_DISTANCE = 715 m and msg.probability(10 m) returned 0 without a word
    import numpy as np
    from astropy import units as u

    text = CDM_SAMPLE.read_text()
    assert X1 in text
    bad = text.replace(X1, "X                                  = 2570097.065", 1)
    with pytest.warns(UserWarning, match=r"line 8: MISS_DISTANCE = 715 m, but the two "
                                         r"objects' states at TCA give 2\.5675\de\+09 m"):
        msg = vv.read_cdm(bad)
    assert np.linalg.norm((msg.object1.r - msg.object2.r).to_value(u.km)) > 1e6
    # the XML encoding of the same message warns the same way
    xml = msg.to_xml()
    with pytest.warns(UserWarning, match="MISS_DISTANCE = 715 m"):
        vv.read_cdm(xml)
    # the genuine message, KVN and XML, is consistent (states 715.75 m apart): no warning
    good = _no_warning_read(text)
    _no_warning_read(good.to_xml())


def test_cdm_velocity_in_metres_per_second_is_warned():
    # X_DOT = 4418.769571 (m/s written as km/s numbers): the miss distance still matched, the
    # relative speed of the states was 4.4e3 km/s against RELATIVE_SPEED = 14762 m/s
    text = CDM_SAMPLE.read_text()
    old = "X_DOT                              = 4.418769571 [km/s]"
    assert old in text
    bad = text.replace(old, "X_DOT                              = 4418.769571", 1)
    with pytest.warns(UserWarning, match=r"line 9: RELATIVE_SPEED = 14762 m/s"):
        vv.read_cdm(bad)


def test_cdm_objects_on_different_frames_are_compared_on_gcrf():
    # object 2 on ITRF (rotated properly): its state as written is thousands of km from object
    # 1's, but on GCRF the miss is the message's 104 m; no false alarm
    import numpy as np
    from astropy import units as u
    from astropy.time import Time

    from visviva.conjunctions import rtn_to_inertial
    from visviva.satellites.frames import gcrs_to_itrs

    tca = Time("2024-05-01T12:00:00", scale="utc")
    r1, v1 = np.array([7000.0, 0.0, 0.0]), np.array([0.0, 7.5, 0.0])
    r2, v2 = r1 + np.array([0.1, 0.02, 0.02]), np.array([0.0, 0.0, 7.5])
    cov = np.diag([30.0, 200.0, 20.0, 0.2, 0.03, 0.02]) ** 2
    msg = vv.ConjunctionDataMessage.from_states(
        tca, r1 * u.km, v1 * u.km / u.s, rtn_to_inertial(cov, r1 * u.km, v1 * u.km / u.s),
        r2 * u.km, v2 * u.km / u.s, rtn_to_inertial(cov, r2 * u.km, v2 * u.km / u.s))
    sections = _no_warning_read(msg.to_kvn()).sections()
    state = sections["object2"]["state_vector"].values
    ri, vi = gcrs_to_itrs(r2, v2, tca)
    for k, axis in enumerate("XYZ"):
        state[axis], state[f"{axis}_DOT"] = float(ri[k]), float(vi[k])
    sections["object2"]["metadata"].values["REF_FRAME"] = "ITRF"
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vv.read_cdm(vv.ConjunctionDataMessage(sections).to_kvn())
    texts = [str(w.message) for w in caught]
    assert any("REF_FRAME = ITRF" in t for t in texts)  # the frames warning, as before
    assert not any("MISS_DISTANCE" in t or "RELATIVE_SPEED" in t for t in texts), texts
    # relabelled without rotating (the GCRF numbers called ITRF): 4742 km apart on GCRF
    sections["object2"]["state_vector"].values.update(
        {a: float(x) for a, x in zip(("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT"),
                                     (*r2, *v2), strict=True)})
    with pytest.warns(UserWarning, match=r"MISS_DISTANCE = 103\.923 m, but .* give 4\.74\d+e\+06 m"):
        vv.read_cdm(vv.ConjunctionDataMessage(sections).to_kvn())


# --- visviva od: --span / --step without --oem -----------------------------------------------

TDM = """CCSDS_TDM_VERS = 2.0
CREATION_DATE = 2024-045T12:00:00
ORIGINATOR = DOCS
META_START
TIME_SYSTEM = UTC
PARTICIPANT_1 = DSS-65
PARTICIPANT_2 = DOCSAT
MODE = SEQUENTIAL
PATH = 1,2,1
META_STOP
DATA_START
RANGE = 2024-02-14T10:00:00 1201.2500
RANGE = 2024-02-14T10:00:10 1176.2600
DATA_STOP
"""


@pytest.mark.parametrize(("extra", "named"), [
    (["--span", "2x"], "--span shapes the ephemeris of --oem OUT"),
    (["--step", "30s"], "--step shapes"),
    (["--span", "2d", "--step", "1min"], "--span and --step shape"),
])
def test_od_span_and_step_without_oem_are_refused(tmp_path, capsys, extra, named):
    # was: ignored in silence (a misspelt --span 2x ran the whole fit; a user asking for a
    # two-day ephemeris got none and no word of it)
    from visviva import cli

    tdm = tmp_path / "a.tdm"
    tdm.write_text(TDM)
    code = cli.main(["od", str(tdm), "--station", "DSS-65=40.43,-4.25,830", "--sigma",
                     "range=5m", *extra])
    out, err = capsys.readouterr()
    assert code == 2
    assert err.startswith("visviva od: ") and err.count("\n") == 1, err
    assert named in err and out == ""


# --- visviva convert: options the conversion would not read ---------------------------------

ISS_TLE = ("ISS (ZARYA)\n"
           "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009\n"
           "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340\n")


def test_convert_refuses_options_it_would_ignore(tmp_path, capsys):
    # was: `visviva convert in.oem out.oem --frame GCRF` wrote the input's ITRF with exit 0, and
    # --hours/--step/--start/--frame on a TLE -> OMM/TLE, --mission-epoch on a TLE, were dropped
    from visviva import cli

    tle = tmp_path / "iss.tle"
    tle.write_text(ISS_TLE)
    oem = tmp_path / "itrf.oem"
    assert cli.main(["convert", str(tle), str(oem), "--hours", "1", "--frame", "ITRF"]) == 0
    assert "REF_FRAME            = ITRF" in oem.read_text()
    capsys.readouterr()
    cases = [
        ([str(oem), str(tmp_path / "a.oem"), "--frame", "GCRF"],
         "--frame shapes an OEM sampled from a TLE or OMM; an OEM is re-encoded with its own "
         "frame"),
        ([str(tle), str(tmp_path / "b.omm"), "--hours", "48"], "an OMM output holds the mean"),
        ([str(tle), str(tmp_path / "c.tle"), "--step", "10", "--frame", "ITRF"],
         "--step and --frame shape an OEM"),
        ([str(tle), str(tmp_path / "d.omm"), "--mission-epoch", "2024-01-01"],
         "--mission-epoch reads an OEM input"),
    ]
    for argv, text in cases:
        assert cli.main(["convert", *argv]) == 2, argv
        out, err = capsys.readouterr()
        assert err.startswith("visviva convert: ") and err.count("\n") == 1, err
        assert text in err, err
        assert not Path(argv[1]).exists()
    # the defaults still apply where they are read: 24 h at 60 s in GCRF, and a plain re-encode
    assert cli.main(["convert", str(tle), str(tmp_path / "e.oem")]) == 0
    text = (tmp_path / "e.oem").read_text()
    assert "REF_FRAME            = GCRF" in text
    assert "STOP_TIME            = 2024-01-02T12:00:00" in text
    assert cli.main(["convert", str(oem), str(tmp_path / "f.oem")]) == 0
    assert "REF_FRAME            = ITRF" in (tmp_path / "f.oem").read_text()


def test_od_apriori_where_nothing_reads_it_is_refused(tmp_path, capsys):
    # was: --apriori without --filter (the batch fit has no such input) and --apriori beside an
    # --initial OPM covariance (the filter starts from the OPM's) were ignored in silence
    import numpy as np
    from astropy import units as u
    from astropy.time import Time

    from visviva import cli
    from visviva.ccsds.opm import OPM

    tdm = tmp_path / "a.tdm"
    tdm.write_text(TDM)
    base = ["od", str(tdm), "--station", "DSS-65=40.43,-4.25,830", "--sigma", "range=5m"]
    assert cli.main([*base, "--apriori", "100m,10cm/s"]) == 2
    out, err = capsys.readouterr()
    assert err.startswith("visviva od: --apriori is the starting uncertainty of --filter")
    assert err.count("\n") == 1 and out == ""

    state = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 0.0] * u.km / u.s, vv.EARTH,
                            epoch=Time("2024-02-14T09:59:00", scale="utc"))
    opm = tmp_path / "first.opm"
    cov = np.diag([1.0] * 3 + [1e-6] * 3)
    vv.write_opm(OPM.from_state(state, object_name="DOCSAT", covariance=cov), opm)
    assert cli.main([*base, "--initial", str(opm), "--filter", "ekf",
                     "--apriori", "100m,10cm/s"]) == 2
    out, err = capsys.readouterr()
    assert "has a covariance, which the filter starts from" in err and "--no-apriori" in err
    assert err.count("\n") == 1 and out == ""


# --- TDM.to_observations: range units as a Quantity, ignore= typos, quality= dropping all --

TDM_RU = TDM.replace("PATH = 1,2,1\n", "PATH = 1,2,1\nRANGE_UNITS = RU\n")


def _site():
    from astropy import units as u

    return {"DSS-65": vv.GroundStation(40.43 * u.deg, -4.25 * u.deg, 0.83 * u.km,
                                       name="DSS-65")}


def test_range_units_km_takes_a_length_quantity():
    # was: range_units_km=1 * u.m raised a bare TypeError ('only dimensionless scalar
    # quantities can be converted to Python scalars') from deep inside the reader
    from astropy import units as u

    tdm = vv.read_tdm(TDM_RU)
    sigma = {"range": 5 * u.m}
    plain = tdm.to_observations(_site(), sigma, range_units_km=0.001).values[:, 0]
    metres = tdm.to_observations(_site(), sigma, range_units_km=1 * u.m).values[:, 0]
    assert list(plain) == list(metres) == [1.20125, 1.17626]  # km: 1201.25 RU of 1 m
    with pytest.raises(vv.UnitsError, match="range_units_km"):
        tdm.to_observations(_site(), sigma, range_units_km=1 * u.s)
    with pytest.raises(vv.InvalidInputError, match="range_units_km must be > 0"):
        tdm.to_observations(_site(), sigma, range_units_km=-1.0)


def test_ignore_refuses_a_keyword_that_is_not_one():
    # was: ignore=("RANGEE",) or ignore=("range",) left the RANGE data in, without a word
    from astropy import units as u

    tdm = vv.read_tdm(TDM)
    for bad in ("RANGEE", "range"):
        with pytest.raises(vv.InvalidInputError, match=f"'{bad}' is not a TDM data or metadata"):
            tdm.to_observations(_site(), {"range": 5 * u.m}, ignore=(bad,))


def test_quality_that_leaves_out_every_segment_says_so():
    # was: 'the TDM holds no measurement visviva models (...); it has RANGE (2)', which blamed
    # the data for what the quality filter did (a segment without DATA_QUALITY counts as RAW)
    from astropy import units as u

    tdm = vv.read_tdm(TDM)
    with pytest.raises(vv.InvalidInputError, match=r"quality=\('VALIDATED',\) left out every "
                                                   r"segment \(1 segments with DATA_QUALITY"):
        tdm.to_observations(_site(), {"range": 5 * u.m}, quality="VALIDATED")
    assert len(tdm.to_observations(_site(), {"range": 5 * u.m}, quality=("RAW",))) == 2


def test_sigma_key_that_is_no_kind_is_named():
    # was: sigma={'range': ..., 'doppler': ...} said "the TDM has 'range_rate' data but sigma
    # has no 'range_rate'", and a stray key beside the right ones was dropped without a word
    from astropy import units as u

    tdm = vv.read_tdm(TDM)
    for key in ("doppler", "rangerate", "angle"):
        with pytest.raises(vv.InvalidInputError, match=f"sigma has the key '{key}', which is "
                                                       "no observation kind"):
            tdm.to_observations(_site(), {"range": 5 * u.m, key: 1 * u.mm / u.s})


def test_fit_tle_refuses_states_about_another_body():
    # was: StateVectors(..., vv.MOON) were fitted as geocentric without a word (an OEM about
    # the Moon and fit_orbit's Moon-centred first guess were already refused)
    import numpy as np
    from astropy import units as u
    from astropy.time import Time

    times = Time("2024-01-01T12:00:00", scale="utc") + np.arange(10) * 60 * u.s
    r = np.tile([2000.0, 0.0, 0.0], (10, 1)) * u.km
    v = np.tile([0.0, 1.6, 0.0], (10, 1)) * u.km / u.s
    with pytest.raises(vv.InvalidInputError, match="is the Moon's; SGP4 mean elements describe "
                                                   "Earth orbits"):
        vv.fit_tle(vv.StateVectors(r, v, vv.MOON, epoch=times))


def test_collision_probability_warns_on_km_given_as_plain_numbers():
    # was: r = [7000, 0, 0], v = [0, 7.5, 0] (km, km/s, the units of the rest of visviva) read
    # as m and m/s gave Pc = 0.0025 instead of 0.0019, silently
    import warnings

    import numpy as np
    from astropy import units as u

    cov = np.eye(3) * 1e4  # m^2
    r1, v1, r2, v2 = [7000, 0, 0], [0, 7.5, 0], [7000.1, 0, 0], [0, 0, 7.5]
    with pytest.warns(UserWarning, match=r"\|r1\| = 7000 m and \|v1\| = 7\.5 m/s .* look like "
                                         r"km and km/s"):
        wrong = vv.collision_probability(r1, v1, cov, r2, v2, cov, 10)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        right = vv.collision_probability(r1 * u.km, v1 * u.km / u.s, cov, r2 * u.km,
                                         v2 * u.km / u.s, cov, 10 * u.m)
        metres = vv.collision_probability(np.multiply(r1, 1e3), np.multiply(v1, 1e3), cov,
                                          np.multiply(r2, 1e3), np.multiply(v2, 1e3), cov, 10)
        # relative states (object 1 at the origin) and proximity operations stay quiet
        vv.collision_probability([0, 0, 0], [0, 0, 0], cov, [100, 0, 0], [0, 0, 7500], cov, 10)
    assert right == pytest.approx(metres, rel=1e-12)
    assert abs(wrong / right - 1) > 0.2


def test_a_perturbation_class_instead_of_an_instance_says_to_call_it():
    # was: "<class 'visviva.satellites.perturbations.J2'> is not a perturbation; use vv.J2,
    # ...", which named vv.J2 as the fix for passing vv.J2
    from astropy import units as u

    state = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH)
    with pytest.raises(vv.InvalidInputError, match=r"the class J2 was given, not a "
                                                   r"perturbation: call it \(e\.g\. vv\.J2"):
        vv.propagate_cowell(state, 60 * u.s, [vv.J2])


def test_from_omm_names_the_field_that_is_not_a_plain_number():
    # was: "OMM record '25544' has a bad value: only dimensionless scalar quantities can be
    # converted to Python scalars" (which field, and what to give, unsaid)
    from astropy import units as u

    line1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009"
    line2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"
    fields = vv.Satellite.from_tle(line1, line2).to_omm()
    with pytest.raises(vv.InvalidInputError, match=r"INCLINATION = <Quantity 51\.6416 deg> is "
                                                   r"a Quantity; .* give INCLINATION in deg"):
        vv.Satellite.from_omm({**fields, "INCLINATION": 51.6416 * u.deg})
    with pytest.raises(vv.InvalidInputError, match="MEAN_MOTION = 'fifteen' is not a number"):
        vv.Satellite.from_omm({**fields, "MEAN_MOTION": "fifteen"})
