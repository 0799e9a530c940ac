"""The element-set fields SGP4 ignores, as fit_tle fills them: the mean-motion derivative (the
TLE's ndot/2) and the revolution number at epoch (visviva.satellites.tle_fields)."""

from __future__ import annotations

import math
import os
import warnings

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from visviva.satellites.tle_fields import mean_motion_dot, revolutions_between

_RAD_MIN2_TO_REV_DAY2 = 1440.0**2 / (2 * math.pi)

#: real ISS element sets (Space-Track, via the skyfield and sgp4 test suites and Vallado's
#: example 2008); revolution numbers 11345 and 12110 are 49.19 days apart
ISS_2008 = ("1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927",
            "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537")
ISS_2013 = ("1 25544U 98067A   13330.58127943  .00000814  00000-0  21834-4 0  1064",
            "2 25544  51.6484  23.7537 0001246  74.1647  18.7420 15.50540527859894")
ISS_2018A = ("1 25544U 98067A   18135.61844383  .00002728  00000-0  48567-4 0  9998",
             "2 25544  51.6402 181.0633 0004018  88.8954  22.2246 15.54059185113452")
ISS_2018B = ("1 25544U 98067A   18184.80969102  .00001614  00000-0  31745-4 0  9993",
             "2 25544  51.6414 295.8524 0003435 262.6267 204.2868 15.54005638121106")
ISS_2019 = ("1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
            "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")


def _sat(lines):
    return vv.Satellite.from_tle(*lines)


def _verification_sets():
    """{satnum: Satellite} of the SGP4 verification TLEs shipped with sgp4 (Vallado et al.
    2006, AIAA 2006-6753)."""
    import sgp4

    path = os.path.join(os.path.dirname(sgp4.__file__), "SGP4-VER.TLE")
    with open(path) as f:
        lines = [line.rstrip("\n")[:69] for line in f]
    out = {}
    for k, line in enumerate(lines[:-1]):
        if line.startswith("1 ") and lines[k + 1].startswith("2 "):
            sat = vv.Satellite.from_tle(line, lines[k + 1], verify_checksum=False)
            out.setdefault(sat.satnum, sat)
    return out


def _published_ndot(sat):
    return sat.satrec.ndot * _RAD_MIN2_TO_REV_DAY2  # the TLE's ndot/2, rev/day**2


#: drag-dominated sets of the verification file (near-Earth and deep-space): published ndot/2
#: against the rate of SGP4's own mean motion agree to 11 % at worst (88888: 8.10e-4 vs 7.31e-4)
DRAG_DOMINATED = [5, 6251, 16925, 23599, 28350, 28623, 28872, 29238, 88888]


def test_mean_motion_dot_matches_the_published_field_of_drag_dominated_sets():
    sets = _verification_sets()
    for satnum in DRAG_DOMINATED:
        sat = sets[satnum]
        published, estimate = _published_ndot(sat), mean_motion_dot(sat.satrec)
        assert estimate == pytest.approx(published, rel=0.12), satnum


@pytest.mark.parametrize("lines", [ISS_2008, ISS_2013, ISS_2018A, ISS_2018B, ISS_2019])
def test_mean_motion_dot_of_real_iss_sets_has_the_published_sign_and_magnitude(lines):
    # measured: estimate / published = 0.72 (2008), 1.56 (2013), 1.18, 1.30, 1.26
    sat = _sat(lines)
    ratio = mean_motion_dot(sat.satrec) / _published_ndot(sat)
    assert 0.5 < ratio < 2.0


def test_fit_carries_the_revolution_number_between_two_real_iss_sets():
    old, new = _sat(ISS_2018A), _sat(ISS_2018B)
    states = new.gcrs(np.linspace(0.0, 1.0, 40) * u.day).to_state_vectors()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # 49 days apart, no manoeuvre: no doubt about the count
        fit = vv.fit_tle(states, initial=old)
    assert fit.satrec.revnum == 12110 == new.satrec.revnum  # the published number
    assert fit.satnum == 25544
    assert fit.to_tle()[1][63:68] == "12110"
    # and backwards: an initial set after the states
    back = vv.fit_tle(old.teme(np.linspace(0.0, 1.0, 40) * u.day), initial=new)
    assert back.satrec.revnum == 11345 == old.satrec.revnum
    assert revolutions_between(old, new)[0] == 765 == -revolutions_between(new, old)[0]
    # the fitted ndot/2 is the one the fitted drag implies, of the published sign and size
    assert fit.to_omm()["MEAN_MOTION_DOT"] == pytest.approx(mean_motion_dot(new.satrec),
                                                           rel=1e-3)
    assert 0.5 < fit.to_omm()["MEAN_MOTION_DOT"] / _published_ndot(new) < 2.0


def _ascending_crossings(sat, days):
    """Equator crossings northward of SGP4's TEME positions sampled every 30 s from the epoch
    to ``days`` (signed: negative going back)."""
    t = np.linspace(0.0, days * 1440.0, int(abs(days) * 2880) + 1)
    z = sat.teme(t * u.min).r.to_value(u.km)[:, 2]
    if days > 0:
        return int(np.sum((z[:-1] < 0) & (z[1:] >= 0)))
    return -int(np.sum((z[:-1] >= 0) & (z[1:] < 0)))


@pytest.mark.parametrize("days", [365.0, -200.0])
def test_revolution_number_carried_across_a_year(days):
    iss = _sat(ISS_2018A)
    states = iss.teme((days + np.linspace(0.0, 0.5, 30)) * u.day)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = vv.fit_tle(states, initial=iss, fit_bstar=False, bstar=iss.satrec.bstar)
    expected = iss.satrec.revnum + _ascending_crossings(iss, days)
    assert fit.satrec.revnum == expected  # 17025 and 8236
    # a year of ISS drag (3.2e-5 rev/day**2 x 182.5**2 days**2 = 1.1 revolutions along track
    # over half the gap) is flagged as resting on SGP4's drag model; 200 days back (0.3) is not
    warned = any("revolution number" in str(w.message) for w in caught)
    assert warned == (days > 0)


@pytest.mark.parametrize("satnum", [8195, 21897, 26975, 28626])
def test_revolution_count_of_deep_space_sets(satnum):
    # Molniya-type (12 h, e ~ 0.7) and geostationary sets, 30 days on; their epochs are not
    # within 0.01 rad of the node, where mean and osculating crossings could differ
    sat = _verification_sets()[satnum]
    period_days = 2 * math.pi / sat.satrec.no_kozai / 1440.0
    states = sat.teme((30.0 + np.linspace(0.0, 2 * period_days, 30)) * u.day)
    fit = vv.fit_tle(states, initial=sat, fit_bstar=False, bstar=sat.satrec.bstar)
    assert fit.satrec.revnum - sat.satrec.revnum == _ascending_crossings(sat, 30.0)


def test_sets_far_apart_warn_that_the_count_may_be_off():
    # 524 days with reboosts between them: the sets disagree by 0.30 revolution at the midpoint
    with pytest.warns(RuntimeWarning, match="may be off: they disagree by 0.30 revolution"):
        revolutions_between(_sat(ISS_2018B), _sat(ISS_2019))


def test_fields_sgp4_ignores_do_not_change_propagation():
    iss = _sat(ISS_2018B)
    fit = vv.fit_tle(iss.teme(np.linspace(0.0, 0.5, 30) * u.day), initial=_sat(ISS_2018A))
    plain = vv.Satellite.from_omm({**fit.to_omm(), "MEAN_MOTION_DOT": 0.0, "REV_AT_EPOCH": 0})
    assert fit.to_omm()["MEAN_MOTION_DOT"] != 0.0
    t = np.linspace(-3.0, 3.0, 50) * u.day
    np.testing.assert_array_equal(fit.teme(t).r.value, plain.teme(t).r.value)
    np.testing.assert_array_equal(fit.teme(t).v.value, plain.teme(t).v.value)
    line1, line2 = fit.to_tle()
    again = vv.Satellite.from_tle(line1, line2)
    assert line1[33:43] == " .00002097"  # ndot/2 written (published for this set: .00001614)
    assert again.satrec.revnum == 12110


def test_initial_gives_number_name_and_designator_unless_given():
    iss = vv.Satellite.from_tle(*ISS_2018B, name="ISS (ZARYA)")
    states = iss.teme(np.linspace(0.0, 0.25, 20) * u.day)
    fit = vv.fit_tle(states, initial=iss, fit_bstar=False, bstar=iss.satrec.bstar)
    assert (fit.satnum, fit.name, fit.to_omm()["OBJECT_ID"]) == (25544, "ISS (ZARYA)",
                                                                 "1998-067A")
    own = vv.fit_tle(states, initial=iss, satnum=1234567, name="X", object_id="2024-001A",
                     fit_bstar=False, bstar=iss.satrec.bstar)
    assert (own.satnum, own.name, own.to_omm()["OBJECT_ID"]) == (1234567, "X", "2024-001A")
    with pytest.raises(vv.InvalidInputError, match="initial must be a vv.Satellite"):
        vv.fit_tle(states, initial=ISS_2018B)


def test_fit_tle_batch_carries_each_history_its_own_revolution_number():
    old, new = _sat(ISS_2018A), _sat(ISS_2018B)
    days = [new.teme(np.linspace(k, k + 0.5, 20) * u.day) for k in range(2)]
    sats = vv.od.fit_tle_batch(days, initials=[old, None])
    assert sats[0].satrec.revnum == 12110 and sats[0].satnum == 25544
    assert sats[1].satrec.revnum == 0 and sats[1].satnum == 99999  # no initial: unknown
    with pytest.raises(vv.InvalidInputError, match="initials=\\[...\\]"):
        vv.od.fit_tle_batch(days, initial=old)
    with pytest.raises(vv.InvalidInputError, match="1 initials for 2 histories"):
        vv.od.fit_tle_batch(days, initials=[old])


def test_an_initial_set_that_decays_before_the_midpoint_keeps_the_fit_and_warns():
    fields = vv.Satellite.from_tle(*ISS_2018A).to_omm()
    low = vv.Satellite.from_omm({**fields, "MEAN_MOTION": 16.2, "BSTAR": 0.01})  # decays in 2 d
    later = vv.Satellite.from_omm({**fields, "EPOCH": "2018-07-15T12:00:00.000000"})
    states = later.teme(np.linspace(0.0, 0.3, 20) * u.day)
    with pytest.warns(RuntimeWarning, match="revolution number was not carried .*SGP4 error 1"):
        fit = vv.fit_tle(states, initial=low, fit_bstar=False, bstar=later.satrec.bstar)
    assert fit.satrec.revnum == 0 and fit.fit.rms_position_km < 1e-3


def test_fit_tle_command_carries_the_revolution_number_from_an_initial_file(tmp_path, capsys):
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris
    from visviva.cli import main

    old, new = _sat(ISS_2018A), _sat(ISS_2018B)
    st = new.gcrs(np.linspace(0.0, 1.0, 40) * u.day)
    seg = OEMSegment.from_states(st.t, st.r.to_value(u.km), st.v.to_value(u.km / u.s),
                                 object_name="ISS (ZARYA)", object_id="1998-067A")
    oem = tmp_path / "iss.oem"
    vv.write_oem(Ephemeris([seg]), oem)
    tle = tmp_path / "old.tle"
    other = vv.Satellite.from_omm({**old.to_omm(), "NORAD_CAT_ID": 5})
    tle.write_text("\n".join([*old.to_tle(), *other.to_tle()]) + "\n")
    assert main(["fit-tle", str(oem), "--initial", str(tle), "--satnum", "25544"]) == 0
    line1, line2 = capsys.readouterr().out.strip().splitlines()[1:]
    assert line1[2:7] == "25544" and line2[63:68] == "12110"
    assert main(["fit-tle", str(oem), "--initial", str(tle)]) == 2  # two objects: which?
    assert "pick the object with --satnum" in capsys.readouterr().err
    assert main(["fit-tle", str(oem), "--initial", str(tmp_path / "none.tle")]) == 2
    assert "no such file" in capsys.readouterr().err


def test_a_set_of_another_orbit_as_initial_is_reported():
    iss = _sat(ISS_2018A)
    other = vv.Satellite.from_omm({**iss.to_omm(), "MEAN_MOTION": 14.2,
                                   "EPOCH": "2018-05-25T00:00:00.000000"})
    with pytest.warns(RuntimeWarning, match="may be off: their mean motions differ by 9"):
        revolutions_between(iss, other)


@pytest.mark.parametrize("lines", [ISS_2018A, ISS_2008])
def test_revolution_counts_add_up_and_change_sign(lines):
    # three sets of one SGP4 trajectory (fits 20 and 45 days on): A->B plus B->C is A->C,
    # and B->A is -(A->B)
    a = _sat(lines)
    kw = {"initial": a, "fit_bstar": False, "bstar": a.satrec.bstar}
    b = vv.fit_tle(a.teme((20.3 + np.linspace(0, 0.3, 20)) * u.day), **kw)
    c = vv.fit_tle(a.teme((45.7 + np.linspace(0, 0.3, 20)) * u.day), **kw)
    ab, bc, ac = (revolutions_between(x, y)[0] for x, y in ((a, b), (b, c), (a, c)))
    assert ab + bc == ac == c.satrec.revnum - a.satrec.revnum
    assert revolutions_between(b, a)[0] == -ab
    assert ac == _ascending_crossings(a, 45.7)
