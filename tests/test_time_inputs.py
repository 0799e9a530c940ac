"""Every form a time can take at the public functions: accepted the same way, or refused clearly.

Offsets (Quantity or TimeDelta, in any unit) and absolute astropy Times in any scale give the
same states as sgp4 itself; masked times (a missing date, whose hidden value every conversion
used silently: a state at the wrong date) and times in the 'local' scale are refused with a
message saying what to do; strings, datetimes and Julian-date floats are refused where a Time
is expected (solar_system alone takes a TDB Julian date, as documented).
"""

import datetime as dt
import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time, TimeDelta
from sgp4.api import Satrec

import visviva as vv

L1 = "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991"
L2 = "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482"


def _fix(line):
    s = sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68])
    return line[:68] + str(s % 10)


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(L1, L2, "ISS")


def _sgp4_km(line1, line2, t):
    """sgp4's own TEME positions at the UTC Julian dates of ``t`` (days of 86,400 s)."""
    sat = Satrec.twoline2rv(line1, line2)
    jd, fr = np.atleast_1d(t.utc.jd1), np.atleast_1d(t.utc.jd2)
    err, r, _ = sat.sgp4_array(jd, fr)
    assert not err.any()
    return r


def test_offsets_and_absolute_times_in_every_form_agree_with_sgp4(iss):
    t = iss.epoch + np.array([0.0, 3600.0, 86400.0]) * u.s
    ref = _sgp4_km(L1, L2, t)
    forms = {
        "seconds": np.array([0.0, 3600.0, 86400.0]) * u.s,
        "days": np.array([0.0, 1 / 24, 1.0]) * u.day,
        "TimeDelta sec": TimeDelta([0.0, 3600.0, 86400.0], format="sec"),
        "TimeDelta jd": TimeDelta([0.0, 1 / 24, 1.0], format="jd"),
        "utc": t.utc, "tai": t.tai, "tt": t.tt, "tdb": t.tdb, "tcb": t.tcb, "ut1": t.ut1,
        "gps format": Time(t.gps, format="gps"),
    }
    for name, form in forms.items():
        got = iss.teme(form).r.to_value(u.km)
        np.testing.assert_allclose(got, ref, rtol=0, atol=2e-6, err_msg=name)  # 2 mm


def test_masked_times_are_refused_not_computed_at_the_hidden_date(iss):
    """A masked entry gave the state at the value under the mask (the epoch here)."""
    e = iss.epoch
    masked = Time(np.ma.masked_array([e.jd, e.jd + 0.01], mask=[False, True]), format="jd")
    state = iss.gcrs(e).to_state_vectors()
    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    calls = {
        "teme": lambda: iss.teme(masked),
        "itrs": lambda: iss.itrs(masked),
        "look": lambda: site.look(iss, masked),
        "cowell": lambda: vv.propagate_cowell(state, masked),
        "find_passes": lambda: vv.find_passes(iss, site, e, masked[1]),
        "screen": lambda: vv.screen_conjunctions(iss, None, e, masked[1]),
        "epoch": lambda: vv.StateVectors(state.r, state.v, vv.EARTH, epoch=masked[1]),
        "burn": lambda: vv.ImpulsiveBurn(masked[1], [0, 1e-3, 0] * u.km / u.s),
        "frames": lambda: vv.satellites.frames.gcrs_to_itrs(state.r, state.v, masked),
    }
    for name, call in calls.items():
        with pytest.raises(vv.InvalidInputError, match="masked"):
            call()
            pytest.fail(name)
    # unmasked, the same Time class computes
    ok = Time(np.ma.masked_array([e.jd, e.jd + 0.01], mask=[False, False]), format="jd")
    np.testing.assert_allclose(iss.teme(ok).r.to_value(u.km), _sgp4_km(L1, L2, ok), atol=2e-6)


def test_local_scale_and_timedelta_epochs_are_refused():
    with pytest.raises(vv.InvalidInputError, match="'local'"):
        vv.Satellite.from_tle(L1, L2).teme(Time(2458827.5, format="jd", scale="local"))
    with pytest.raises(vv.InvalidInputError, match="TimeDelta"):
        vv.solar_system(TimeDelta(1.0, format="jd"))


@pytest.mark.parametrize("value", ["2019-12-10T00:00:00Z", dt.datetime(2019, 12, 10),
                                   dt.datetime(2019, 12, 10, tzinfo=dt.UTC),
                                   np.datetime64("2019-12-10T00:00:00"), 2458827.5],
                         ids=["str-Z", "datetime", "datetime-tz", "datetime64", "jd-float"])
def test_non_time_dates_are_refused_where_a_time_is_expected(iss, value):
    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    for call in (lambda: iss.teme(value), lambda: site.look(iss, value),
                 lambda: vv.find_passes(iss, site, value, iss.epoch),
                 lambda: vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s,
                                         vv.EARTH, epoch=value)):
        with pytest.raises(vv.InvalidInputError, match="Time"):
            call()


@pytest.mark.parametrize("yy, year", [("57", 1957), ("58", 1958), ("99", 1999), ("00", 2000),
                                      ("56", 2056)])
def test_two_digit_epoch_years_and_times_before_1960(yy, year):
    """TLE years 57-99 are 1957-1999, 00-56 are 2000-2056; a Vanguard-like orbit a year either
    side of its epoch (back to 1956, before UTC existed) equals sgp4 to the metre."""
    l1 = _fix(f"1 00005U 58002B   {yy}075.50000000  .00000023  00000-0  28098-4 0  9990")
    l2 = _fix("2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157 41300")
    sat = vv.Satellite.from_tle(l1, l2)
    assert sat.epoch.utc.datetime.year == year
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ERFA: "dubious year" before 1960 (no UTC then)
        t = sat.epoch + np.array([-365.0, 0.0, 365.0]) * u.day
        ref = _sgp4_km(l1, l2, t)
        got = sat.teme(t).r.to_value(u.km)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-3)


def test_timedelta_durations_are_accepted_like_quantities_everywhere():
    """propagate, propagate_kepler, propagate_cowell and burns took a TimeDelta; an N-body
    Simulation refused it ('t must be a number')."""
    st = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 1] * u.km / u.s, vv.EARTH,
                         epoch=Time("2024-01-01"))
    ref = st.propagate(3600 * u.s).r.to_value(u.km)
    day = TimeDelta(1 / 24, format="jd")
    np.testing.assert_allclose(st.propagate(day).r.to_value(u.km), ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(vv.propagate_kepler(st, day).r.to_value(u.km), ref, rtol=0,
                               atol=1e-9)
    assert vv.ImpulsiveBurn(day, [0, 1e-3, 0] * u.km / u.s).start == 3600.0
    a, b = vv.solar_system(), vv.solar_system()  # units au, yr (Julian), Msun
    a.integrate(TimeDelta(365.25, format="jd"))
    b.integrate(1 * u.yr)
    assert a.t == b.t == 1.0
    np.testing.assert_array_equal(np.asarray(a.positions), np.asarray(b.positions))
    with pytest.raises(vv.UnitsError, match="no units"):
        vv.Simulation().integrate(TimeDelta(1.0, format="jd"))


@pytest.mark.parametrize("scale", ["tdb", "tcb", "tcg", "ut1"])
def test_a_propagated_epoch_is_the_time_cowell_and_the_batch_reach(scale):
    """Elapsed times are TT seconds everywhere: the epoch label advances by them too.

    ``StateVectors.propagate(dt)`` labelled its states ``epoch + dt`` added in the epoch's own
    scale (TDB seconds for a TDB epoch), while ``propagate_cowell`` and the Kepler batch count
    ``t.tt - epoch.tt``: at the label of a 180-day Kepler state, the batch put the orbiter 74 m
    away (heliocentric, 30 km/s), and ``CowellResult.times`` were 2.7 ms off the asked ``t``.
    """
    from visviva.satellites.catalog import propagate_kepler_batch

    epoch = getattr(Time("2024-03-01T00:00:00", scale="tt"), scale)
    s = vv.StateVectors([1.0, 0.2, 0.0] * u.AU, [-5, 29.5, 0.3] * u.km / u.s, vv.SUN,
                        epoch=epoch)
    dt = [50.0, 180.0] * u.day
    moved = s.propagate(dt)
    assert moved.epoch.scale == scale
    assert s.propagate(0 * u.s).epoch == epoch  # no offset keeps the epoch's bits
    np.testing.assert_allclose((moved.epoch.tt - epoch.tt).to_value(u.day), dt.value,
                               rtol=0, atol=1e-9 / 86400)
    batch = propagate_kepler_batch(s, moved.epoch)
    gap_m = np.linalg.norm((batch.r[0] - moved.r).to_value(u.m), axis=-1)
    assert gap_m.max() < 1e-3  # was 74 m for TDB
    t = epoch + dt  # asked in the epoch's scale
    res = vv.propagate_cowell(s, t, [])
    np.testing.assert_allclose((res.times.tt - t.tt).to_value(u.s), 0.0, atol=1e-8)  # was 2.7 ms


def test_utc_epochs_advance_exactly_as_astropy_adds():
    epoch = Time("2016-12-31T23:59:30", scale="utc")
    s = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH, epoch=epoch)
    later = s.propagate([0.0, 60.0, 3600.0] * u.s)
    assert np.all(later.epoch == epoch + [0.0, 60.0, 3600.0] * u.s)  # across the leap second
    assert later.epoch.scale == "utc"


def test_masked_quantities_are_refused_not_computed_with_their_hidden_values():
    # a MaskedQuantity (a QTable column with missing entries, e.g. a pass table's duration)
    # or a numpy.ma array kept its hidden values and every two-body function used them: a
    # state 1e9 s later, a Lambert arc for the hidden tof, a speed at the hidden radius
    from astropy.utils.masked import Masked

    s = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH)
    dt = Masked([60.0, 1e9] * u.s, mask=[False, True])
    with pytest.raises(vv.InvalidInputError, match=r"dt has 1 masked .* index \(1,\)"):
        s.propagate(dt)
    with pytest.raises(vv.InvalidInputError, match="tof has 1 masked"):
        vv.lambert([7000, 0, 0] * u.km, [0, 8000, 0] * u.km, Masked([3e3, 4e3] * u.s, [0, 1]),
                   vv.EARTH)
    with pytest.raises(vv.InvalidInputError, match="r has 1 masked"):
        vv.vis_viva(Masked([7000.0, 8000.0] * u.km, [False, True]), 8000 * u.km, vv.EARTH)
    with pytest.raises(vv.InvalidInputError, match="M has 1 masked"):
        vv.solve_kepler(np.ma.masked_array([1.0, 2.0], [False, True]), 0.1)
    # nothing masked: the values are used as given
    np.testing.assert_array_equal(
        s.propagate(Masked([60.0, 120.0] * u.s, mask=False)).r.value,
        s.propagate([60.0, 120.0] * u.s).r.value)
    assert vv.solve_kepler(np.ma.masked_array([1.0], [False]), 0.1) == vv.solve_kepler([1.0], 0.1)
