"""Times in UT1 everywhere a public function takes a Time: the installed IERS table, offline.

A UT1 time converted outside :func:`visviva.satellites.frames.offline_iers` goes through
astropy's own ``IERS_Auto`` table, which tries to download a new Bulletin A once its
predictions are more than 30 days old (and raises ValueError, "interpolating from IERS_Auto
using predictive values that are more than 30.0 days old", when it cannot). Each call below
did that before (angles-only IOD, Herrick-Gibbs, the first orbit of UT1 observations and their
repr, screening ephemerides in UT1 against a window in UTC, a burn starting at a UT1 epoch, an
OPM in UT1 with manoeuvres, the solar system at a UT1 epoch); each is compared with the same
instants given in TAI.
"""

import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.satellites.frames import offline_iers

pytestmark = pytest.mark.filterwarnings("ignore::visviva.EarthOrientationWarning",
                                        "ignore:ERFA function")

#: past the installed table (predictions end 2027-10-29): a UT1 time there needs the table
ISO = "2028-01-01T00:00:00"

OMM = {"OBJECT_NAME": "X", "NORAD_CAT_ID": 1, "EPOCH": "2027-12-31T23:00:00",
       "MEAN_MOTION": 15.5, "ECCENTRICITY": 0.001, "INCLINATION": 51.6,
       "RA_OF_ASC_NODE": 10.0, "ARG_OF_PERICENTER": 0.0, "MEAN_ANOMALY": 0.0, "BSTAR": 0.0001,
       "MEAN_MOTION_DOT": 0.0, "MEAN_MOTION_DDOT": 0.0}


@pytest.fixture
def no_download(monkeypatch):
    """Any download is an error, and astropy's own table would want one (its predictions are
    a year old)."""
    import astropy.utils.data
    from astropy.utils import iers

    def refuse(*args, **kwargs):
        raise AssertionError(f"a download was attempted: {args!r}")

    with offline_iers():
        last = Time(iers.earth_orientation_table.get().meta["predictive_mjd"], format="mjd")
    monkeypatch.setattr(astropy.utils.data, "download_file", refuse)
    monkeypatch.setattr(iers.iers, "download_file", refuse)
    monkeypatch.setattr(iers.IERS_Auto, "time_now", property(lambda self: last + 365 * u.day))
    monkeypatch.setattr(iers.conf, "auto_max_age", 30.0)


def ut1(offsets_s=None):
    """A fresh UT1 Time (nothing cached on it) at ISO (+ offsets, s)."""
    t = Time(ISO, scale="ut1")
    if offsets_s is None:
        return t
    return Time((t + np.asarray(offsets_s) * u.s).isot, scale="ut1")


def tai(offsets_s=None):
    """The same instants in TAI (converted with the installed table)."""
    t = ut1(offsets_s)
    with offline_iers():
        return t.tai


def test_initial_orbit_determination_takes_ut1_times(no_download):
    sat = vv.Satellite.from_omm(OMM)
    offsets = [0.0, 120.0, 240.0]
    r = sat.gcrs(tai(offsets)).r
    v_ut1 = vv.herrick_gibbs(r[0], r[1], r[2], *ut1(offsets), vv.EARTH)
    v_s = vv.herrick_gibbs(r[0], r[1], r[2], *(np.array(offsets) * u.s), vv.EARTH)
    np.testing.assert_allclose(v_ut1.to_value(u.km / u.s), v_s.to_value(u.km / u.s), atol=1e-9)
    site = np.array([[6000.0, 1000.0, 2000.0]] * 3)
    rho = r.to_value(u.km) - site
    ra = np.arctan2(rho[:, 1], rho[:, 0]) * u.rad
    dec = np.arcsin(rho[:, 2] / np.linalg.norm(rho, axis=1)) * u.rad
    for solve in (vv.gauss_angles, vv.od.double_r):
        got = solve(ra, dec, ut1(offsets), site * u.km, vv.EARTH)
        ref = solve(ra, dec, np.array(offsets) * u.s, site * u.km, vv.EARTH)
        got = got[0] if isinstance(got, list) else got
        ref = ref[0] if isinstance(ref, list) else ref
        np.testing.assert_allclose(got.r.to_value(u.km), ref.r.to_value(u.km), atol=1e-6)
        assert got.epoch.scale == "ut1"
    obs = vv.Observations(time=ut1([0.0, 60.0, 120.0, 180.0]), kind=["position"] * 4,
                          value=sat.gcrs(tai([0.0, 60.0, 120.0, 180.0])).r.to_value(u.km),
                          sigma=[0.01] * 4, station=[None] * 4)
    assert "span 180.0 s" in repr(obs)
    from visviva.od.first_orbit import initial_orbit

    first = initial_orbit(obs, vv.EARTH)
    truth = sat.gcrs(first.epoch)  # the middle fix's time, in UT1
    assert first.epoch.scale == "ut1"
    assert np.linalg.norm((first.r - truth.r).to_value(u.km)) < 1e-6


def test_screening_ephemerides_in_ut1_against_a_window_in_utc(no_download):
    a, b = vv.Satellite.from_omm(OMM), vv.Satellite.from_omm({**OMM, "NORAD_CAT_ID": 2,
                                                              "MEAN_ANOMALY": 0.01})
    grid = np.arange(0.0, 3660.0, 60.0)
    ga, gb = a.gcrs(tai(grid)), b.gcrs(tai(grid))
    with offline_iers():
        w0 = Time(tai().utc.isot, scale="utc")
    ref0 = tai()
    hist_ut1 = [vv.StateVectors(g.r, g.v, vv.EARTH, epoch=ut1(grid)) for g in (ga, gb)]
    hist_tai = [vv.StateVectors(g.r, g.v, vv.EARTH, epoch=tai(grid)) for g in (ga, gb)]
    got = vv.screen_conjunctions(*hist_ut1, w0 + 1 * u.s, w0 + 3599 * u.s)
    ref = vv.screen_conjunctions(*hist_tai, ref0 + 1 * u.s, ref0 + 3599 * u.s)
    assert len(got) == len(ref) >= 1
    np.testing.assert_allclose(got["miss_distance"].to_value(u.km),
                               ref["miss_distance"].to_value(u.km), rtol=1e-9)
    assert np.all(np.abs((got["tca"] - ref["tca"]).to_value(u.s)) < 1e-3)
    state = vv.StateVectors(ga.r[0], ga.v[0], vv.EARTH, epoch=ut1())
    cow = vv.propagate_cowell(state, grid * u.s)
    vv.screen_conjunctions(cow, hist_ut1[1], w0 + 1 * u.s, w0 + 3599 * u.s)


def test_burns_and_opm_manoeuvres_at_ut1_epochs(no_download, tmp_path):
    state = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH,
                            epoch=ut1())
    state_tai = vv.StateVectors(state.r, state.v, vv.EARTH, epoch=tai())
    dv = [0, 0.001, 0] * u.km / u.s
    got = vv.propagate_cowell(state, 600 * u.s, maneuvers=[vv.ImpulsiveBurn(ut1(300.0), dv)])
    ref = vv.propagate_cowell(state_tai, 600 * u.s,
                              maneuvers=[vv.ImpulsiveBurn(tai(300.0), dv)])
    np.testing.assert_allclose(got.r.to_value(u.km), ref.r.to_value(u.km), atol=1e-6)
    man = ("MAN_EPOCH_IGNITION = {t}\nMAN_DURATION = 0.0\nMAN_DELTA_MASS = 0.0\n"
           "MAN_REF_FRAME = RTN\nMAN_DV_1 = 0.0\nMAN_DV_2 = 0.001\nMAN_DV_3 = 0.0\n")
    text = ("CCSDS_OPM_VERS = 2.0\nCREATION_DATE = 2024-01-01T00:00:00\nORIGINATOR = X\n"
            "OBJECT_NAME = X\nOBJECT_ID = 2000-001A\nCENTER_NAME = EARTH\nREF_FRAME = GCRF\n"
            f"TIME_SYSTEM = UT1\nEPOCH = {ISO}\nX = 7000.0\nY = 0.0\nZ = 0.0\nX_DOT = 0.0\n"
            "Y_DOT = 7.5\nZ_DOT = 0.0\n" + man.format(t="2028-01-01T00:10:00")
            + man.format(t="2028-01-01T00:05:00"))
    path = tmp_path / "ut1.opm"
    path.write_text(text)
    opm = vv.read_opm(path)
    burns = opm.burns()
    assert [round(b.start_offset_s(state.epoch), 6) for b in burns] == [300.0, 600.0]
    out = vv.propagate_cowell(opm.state, 900 * u.s, maneuvers=burns)
    assert np.isfinite(out.r.to_value(u.km)).all()


def test_solar_system_at_a_ut1_epoch(no_download):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = vv.solar_system(ut1())
        with offline_iers():
            ref = vv.solar_system(tai().tdb)
    np.testing.assert_allclose(np.asarray(got.positions), np.asarray(ref.positions), rtol=0,
                               atol=1e-12)  # au: the same instant, to 0.15 m
    np.testing.assert_allclose(np.asarray(got.velocities), np.asarray(ref.velocities), rtol=0,
                               atol=1e-12)


def test_threads_share_the_offline_table(no_download):
    """Each visviva call restored astropy's settings on leaving, even while another thread was
    mid-conversion: that thread got astropy's own table (no 1962-1972 rows: 0.36 km of ITRS in
    1968) or downloads on (a download attempt, then TypeError)."""
    import threading

    from visviva.satellites.frames import gcrs_to_itrs

    r, v = [7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 0.0] * u.km / u.s

    def times(k):
        if k % 2:
            return Time("1968-01-01T00:00:00", scale="utc") + np.arange(50) * u.s
        return ut1(np.arange(50.0))

    ref = {k: gcrs_to_itrs(r, v, times(k))[0].to_value(u.km) for k in (0, 1)}
    bad = []

    def work(k):
        for _ in range(40):
            try:
                got = gcrs_to_itrs(r, v, times(k))[0].to_value(u.km)
                if np.abs(got - ref[k % 2]).max() > 1e-9:
                    bad.append(("mismatch", k, float(np.abs(got - ref[k % 2]).max())))
            except Exception as exc:  # noqa: BLE001 (collected, reported below)
                bad.append(repr(exc))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not bad, bad[:3]
    from astropy.utils import iers

    assert iers.conf.auto_download and iers.earth_orientation_table._value is None  # restored
