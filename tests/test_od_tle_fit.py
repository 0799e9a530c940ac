"""fit_tle: SGP4 recovers itself to metres, a precise ephemeris beats the naive TLE, every input
kind (StateVectors GCRS/TEME, CowellResult, OEM), bad input; the fit-tle command."""

import math

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from visviva.cli import main
from visviva.od.tle_elements import naive_fields
from visviva.satellites.frames import transform_matrices

ONE_METER = 1e-3  # km
ISS = ("1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")
# a Molniya orbit (deep space, SDP4), as in tests/test_frames.py
MOLNIYA = ("1 08195U 75081A   24176.33215444  .00000099  00000-0  11873-3 0   813",
           "2 08195  64.1586 279.0717 6877146 264.7651  20.2257  2.00491383225656")


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(*ISS, "ISS (ZARYA)")


def _rms_km(sat, states):
    d = sat.gcrs(states.epoch).r.to_value(u.km) - states.r.to_value(u.km)
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def test_recovers_sgp4_generated_states(iss):
    states = iss.gcrs(np.linspace(0, 1, 60) * u.day).to_state_vectors()
    fit = vv.fit_tle(states, satnum=25544, name="ISS")
    assert isinstance(fit, vv.Satellite)
    assert fit.fit.max_position_km < ONE_METER
    assert _rms_km(fit, states) < ONE_METER
    # the elements themselves come back (B* to 1e-6 relative, mean motion to 1e-12 rad/min)
    assert fit.satrec.bstar == pytest.approx(iss.satrec.bstar, rel=1e-6)
    assert fit.satrec.no_kozai == pytest.approx(iss.satrec.no_kozai, abs=1e-12)
    assert fit.satrec.ecco == pytest.approx(iss.satrec.ecco, abs=1e-10)
    assert fit.satnum == 25544 and fit.epoch.utc.isot == iss.epoch.utc.isot
    line1, line2 = fit.to_tle()
    assert line2[8:63] == ISS[1][8:63]  # same elements in the TLE's columns


def test_deep_space_sdp4_is_recovered():
    sat = vv.Satellite.from_tle(*MOLNIYA)
    states = sat.teme(np.linspace(0, 2, 97) * u.day)
    from visviva.states import StateVectors

    sv = StateVectors(states.r, states.v, vv.EARTH, epoch=states.t)
    fit = vv.fit_tle(sv, frame="teme", satnum=8195)
    assert fit.fit.max_position_km < 10 * ONE_METER


def test_fixed_bstar_is_held(iss):
    states = iss.gcrs(np.linspace(0, 0.5, 40) * u.day).to_state_vectors()
    fit = vv.fit_tle(states, fit_bstar=False, bstar=2e-4)
    assert fit.satrec.bstar == 2e-4
    # the wrong drag costs metres only over half a day
    assert fit.fit.rms_position_km < 0.2


def test_bstar_held_with_an_initial_set_is_that_sets_not_zero(iss, tmp_path, capsys):
    # audit49: improving a set with new states while holding B* (fit_bstar=False, initial=old)
    # held it at bstar's old default 0, not at the old set's 1.027e-4: a day of the set's own
    # states came back 1.3 km RMS instead of under a millimetre, without a word
    states = iss.gcrs((1 + np.linspace(0, 1, 40)) * u.day).to_state_vectors()
    fit = vv.fit_tle(states, initial=iss, fit_bstar=False)
    assert fit.satrec.bstar == iss.satrec.bstar
    assert fit.fit.rms_position_km < ONE_METER and fit.fit.sigma_bstar is None
    assert vv.fit_tle(states, fit_bstar=False).satrec.bstar == 0.0  # no initial: 0 as before
    assert vv.fit_tle(states, initial=iss, fit_bstar=False, bstar=0.0).satrec.bstar == 0.0
    # the command line: --initial with --no-bstar holds the initial set's B*
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris

    seg = OEMSegment.from_states(states.epoch, states.r.to_value(u.km),
                                 states.v.to_value(u.km / u.s), object_name="ISS (ZARYA)")
    vv.write_oem(Ephemeris([seg]), tmp_path / "iss.oem")
    # a history of the object's sets (refused before without --satnum): the nearest is taken
    older = vv.Satellite.from_omm({**iss.to_omm(), "EPOCH": "2023-12-20T00:00:00", "BSTAR": 5e-4})
    (tmp_path / "old.tle").write_text("\n".join([*older.to_tle(), *ISS]) + "\n")
    assert main(["fit-tle", str(tmp_path / "iss.oem"), "--initial", str(tmp_path / "old.tle"),
                 "--no-bstar"]) == 0
    out = capsys.readouterr()
    assert out.out.splitlines()[1][53:61] == ISS[0][53:61] and "B* 1.02700e-04 (held)" in out.err


def test_beats_the_naive_tle_on_a_cowell_ephemeris(iss):
    s0 = iss.gcrs(0 * u.s).to_state_vectors()
    s0 = vv.StateVectors(s0.r, s0.v, vv.EARTH, epoch=iss.epoch)
    forces = [vv.Zonal(vv.EARTH, 6), vv.AtmosphericDrag(0.01 * u.m**2 / u.kg),
              vv.ThirdBody(vv.MOON), vv.ThirdBody(vv.SUN)]
    res = vv.propagate_cowell(s0, np.linspace(0, 1, 97) * u.day, forces)
    fit = vv.fit_tle(res)
    states = res.to_states()
    m = transform_matrices(states.epoch[:1], "gcrs", "teme")[0]
    y = m @ np.r_[states.r[0].to_value(u.km), states.v[0].to_value(u.km / u.s)]
    naive = vv.Satellite.from_omm(naive_fields(y[:3], y[3:], states.epoch[0].utc.isot))
    fitted_rms, naive_rms = _rms_km(fit, states), _rms_km(naive, states)
    # SGP4's theory limits the fit to a few hundred metres over a day; the osculating
    # elements taken as mean elements drift by hundreds of kilometres
    assert fitted_rms < 1.0
    assert naive_rms > 100 * fitted_rms


def test_oem_ephemeris_input(iss, tmp_path):
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris

    st = iss.gcrs(np.linspace(0, 1, 49) * u.day)
    seg = OEMSegment.from_states(st.t, st.r.to_value(u.km), st.v.to_value(u.km / u.s),
                                 object_name="ISS")
    path = tmp_path / "iss.oem"
    vv.write_oem(Ephemeris([seg]), path)
    fit = vv.fit_tle(vv.read_oem(path), satnum=25544)
    assert fit.fit.max_position_km < ONE_METER


def test_bad_input(iss):
    states = iss.gcrs(np.linspace(0, 1, 10) * u.day).to_state_vectors()
    with pytest.raises(vv.InvalidInputError, match="at least 7"):
        vv.fit_tle(states[:5])
    with pytest.raises(vv.InvalidInputError, match="increase strictly"):
        vv.fit_tle(states[[0, 2, 1, 3, 4, 5, 6, 7]])
    with pytest.raises(vv.InvalidInputError, match="times"):
        vv.fit_tle(vv.StateVectors(states.r, states.v, vv.EARTH))
    with pytest.raises(vv.InvalidInputError, match="satnum"):
        vv.fit_tle(states, satnum=0)
    with pytest.raises(vv.InvalidInputError, match="frame"):
        vv.fit_tle(states, frame="itrs")
    for bad in (np.nan, np.inf, "x"):  # was: 'SGP4 cannot propagate the first guess'
        with pytest.raises(vv.InvalidInputError, match="bstar must be a finite number"):
            vv.fit_tle(states, fit_bstar=False, bstar=bad)
    with pytest.raises(vv.InvalidInputError):
        vv.fit_tle([1, 2, 3])
    escaping = vv.StateVectors(states.r, states.v * 1.6, vv.EARTH, epoch=states.epoch)
    with pytest.raises(vv.InvalidInputError, match="bound orbit"):
        vv.fit_tle(escaping)


def test_fit_tle_command(iss, tmp_path, capsys):
    st = iss.gcrs(np.linspace(0, 1, 49) * u.day)
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris

    seg = OEMSegment.from_states(st.t, st.r.to_value(u.km), st.v.to_value(u.km / u.s),
                                 object_name="ISS (ZARYA)", object_id="1998-067A")
    path = tmp_path / "iss.oem"
    vv.write_oem(Ephemeris([seg]), path)
    assert main(["fit-tle", str(path), "--satnum", "25544"]) == 0
    out = capsys.readouterr()
    lines = out.out.strip().splitlines()
    assert lines[0] == "ISS (ZARYA)"
    sat = vv.Satellite.from_tle(lines[1], lines[2])  # valid lines, checksums included
    assert sat.satnum == 25544 and "98067A" in lines[1]
    assert "position RMS" in out.err
    omm = tmp_path / "fit.omm"
    assert main(["fit-tle", str(path), "--to", "omm", "-o", str(omm), "--no-bstar"]) == 0
    back = vv.Satellite.from_omm(vv.read_omm(omm))
    assert back.satrec.bstar == 0.0
    assert main(["fit-tle", str(tmp_path / "missing.oem")]) == 2
    assert "fit-tle" in capsys.readouterr().err


def test_fit_tle_batch_serial_and_on_dask(iss):
    distributed = pytest.importorskip("distributed")
    days = [iss.gcrs(np.linspace(k, k + 1, 25) * u.day).to_state_vectors() for k in range(4)]
    serial = vv.od.fit_tle_batch(days, satnums=[25544] * 4)
    assert all(s.fit.max_position_km < ONE_METER for s in serial)
    with distributed.LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        remote = vv.od.fit_tle_batch(days, satnums=[25544] * 4, client=client, chunks=2)
    for a, b in zip(serial, remote, strict=True):
        assert a.fit.fields == b.fit.fields  # the same fit wherever it runs
    with pytest.raises(vv.InvalidInputError, match="satnums"):
        vv.od.fit_tle_batch(days, satnums=[1, 2])


def test_fit_tle_batch_refuses_satnums_that_are_not_integers(iss):
    # audit20: int() truncated 25544.7 to 25544 (a real object's number) and read "25544"
    days = [iss.gcrs(np.linspace(0, 1, 25) * u.day).to_state_vectors()]
    for bad in (25544.7, "25544", True):
        with pytest.raises(vv.InvalidInputError, match=r"satnums\[0\]"):
            vv.od.fit_tle_batch(days, satnums=[bad])
    sat, = vv.od.fit_tle_batch(days, satnums=np.array([25544]))
    assert sat.satnum == 25544


def test_fit_tle_batch_packs_each_kind_of_history_exactly(iss, tmp_path):
    """What travels to a Dask worker (a few flat arrays) gives bit for bit the serial fits."""
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris
    from visviva.od.tle_batch import _fit_chunk, _fit_packed, _pack

    st = iss.itrs(np.linspace(0, 1, 25) * u.day)
    seg = OEMSegment.from_states(st.t, st.r.to_value(u.km), st.v.to_value(u.km / u.s),
                                 object_name="ISS", frame="ITRF", time_system="TAI")
    histories = [iss.gcrs(np.linspace(0, 1, 25) * u.day).to_state_vectors(),
                 vv.read_oem(vv.write_oem(Ephemeris([seg])))]
    items = list(zip(histories, [25544, 25545], [None, iss], strict=True))
    packed = _pack(items, "gcrs")
    assert packed["frame"] == ["gcrs", "itrs"] and packed["r"].shape == (50, 3)
    assert [r[0] for r in _fit_packed(packed, {})] == [r[0] for r in _fit_chunk(items, {})]
    assert _fit_chunk(items, {})[1][0]["REV_AT_EPOCH"] == iss.satrec.revnum  # carried


def test_fit_tle_and_convert_commands_read_mission_elapsed_time(iss, tmp_path, capsys):
    from astropy.time import Time

    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris

    launch = Time("2023-12-31T06:00:00", scale="utc")
    st = iss.gcrs(np.linspace(0, 1, 49) * u.day)
    seg = OEMSegment.from_states(st.t, st.r.to_value(u.km), st.v.to_value(u.km / u.s),
                                 object_name="ISS", time_system="MET", mission_epoch=launch)
    path = tmp_path / "met.oem"
    vv.write_oem(Ephemeris([seg]), path)
    assert main(["fit-tle", str(path)]) == 2
    assert "--mission-epoch" in capsys.readouterr().err
    assert main(["fit-tle", str(path), "--mission-epoch", "2023-12-31T06:00:00"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    direct = vv.fit_tle(st.to_state_vectors())
    assert lines[-2:] == list(direct.to_tle())  # the same element set as from UTC states
    xml = tmp_path / "met.xml"
    assert main(["convert", str(path), str(xml), "--to", "oem",
                 "--mission-epoch", "2023-12-31T06:00:00"]) == 0
    back = vv.read_oem(xml, mission_epoch=launch).segments[0]
    assert back.epochs == seg.epochs and back.time_system == "MET"
    assert main(["convert", str(path), str(xml), "--to", "oem", "--mission-epoch", "x",
                 "--overwrite"]) == 2
    assert "is not an ISO date-time" in capsys.readouterr().err


@pytest.mark.parametrize("frame, center, words", [
    # a true-of-date frame was taken as GCRS (precession since 2000: ~40 km at the ISS), a
    # Mars-centred ephemeris was fitted with SGP4: both silently
    ("TOD", "EARTH", "REF_FRAME = TOD"),
    ("EME2000", "MARS", "CENTER_NAME = MARS"),
])
def test_oem_input_in_a_frame_or_centre_sgp4_cannot_use_is_refused(iss, frame, center, words):
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris

    st = iss.gcrs(np.linspace(0, 1, 49) * u.day)
    seg = OEMSegment.from_states(st.t, st.r.to_value(u.km), st.v.to_value(u.km / u.s),
                                 object_name="ISS", frame=frame, center=center)
    with pytest.raises(vv.InvalidInputError, match=words):
        vv.fit_tle(vv.read_oem(vv.write_oem(Ephemeris([seg]))), satnum=25544)


def test_states_sgp4_cannot_reproduce_raise_instead_of_a_bad_fit(iss):
    # the first half of a day from the ISS, the second from a Molniya orbit: the fit stopped
    # where no step helped and returned a satellite 8,000 km RMS off as if it had converged
    # (likewise on a Cowell ephemeris that decays through the ground)
    molniya = vv.Satellite.from_tle(*MOLNIYA)
    t = iss.epoch + np.linspace(0, 1, 40) * u.day
    a, b = iss.gcrs(t[:20]).to_state_vectors(), molniya.gcrs(t[20:]).to_state_vectors()
    spliced = vv.StateVectors(np.concatenate([a.r, b.r]), np.concatenate([a.v, b.v]), vv.EARTH,
                              epoch=t)
    with pytest.raises(vv.ConvergenceError, match="SGP4 cannot reproduce these states"):
        vv.fit_tle(spliced)


def test_a_bstar_the_arc_cannot_determine_is_reported(iss):
    # ten minutes of states with 10 m noise: B* came back 30 times the truth (0.0031 for
    # 0.0001) with nothing said; it is now given with its formal sigma and a warning
    st = iss.gcrs(np.linspace(0, 10, 11) * u.min).to_state_vectors()
    rng = np.random.default_rng(0)
    noisy = vv.StateVectors(st.r + rng.normal(0, 0.01, st.r.shape) * u.km,
                            st.v + rng.normal(0, 1e-5, st.v.shape) * u.km / u.s, vv.EARTH,
                            epoch=st.epoch)
    with pytest.warns(RuntimeWarning, match="B\\* is not determined"):
        sat = vv.fit_tle(noisy)
    assert abs(sat.satrec.bstar - iss.satrec.bstar) < 2 * sat.fit.sigma_bstar
    # a day of the same noise determines it (sigma ~5e-7) and warns of nothing
    day = iss.gcrs(np.linspace(0, 1, 60) * u.day).to_state_vectors()
    noisy = vv.StateVectors(day.r + rng.normal(0, 0.01, day.r.shape) * u.km,
                            day.v + rng.normal(0, 1e-5, day.v.shape) * u.km / u.s, vv.EARTH,
                            epoch=day.epoch)
    sat = vv.fit_tle(noisy)
    assert sat.fit.sigma_bstar < 2e-6
    assert abs(sat.satrec.bstar - iss.satrec.bstar) < 4 * sat.fit.sigma_bstar
    assert vv.fit_tle(noisy, fit_bstar=False).fit.sigma_bstar is None


@pytest.mark.parametrize("frame", ["teme", "itrs"])
def test_satellite_states_are_fitted_in_their_own_frame(iss, frame):
    # sat.teme(t) knows it is TEME: it was taken as GCRS, a TLE 40 km off with no error
    # (ITRS: "SGP4 cannot propagate the first guess")
    t = iss.epoch + np.arange(0, 3 * 3600, 60) * u.s
    states = getattr(iss, frame)(t)
    fit = vv.fit_tle(states, satnum=25544)
    miss = np.linalg.norm((fit.teme(t).r - iss.teme(t).r).to_value(u.km), axis=-1)
    assert miss.max() < ONE_METER
    if frame == "teme":  # saying the frame the states already say is fine
        assert vv.fit_tle(states, satnum=25544, frame="teme").to_tle() == fit.to_tle()
    with pytest.raises(vv.InvalidInputError, match=f"{frame.upper()}.*frame='gcrs'"):
        vv.fit_tle(states, frame="gcrs")


def _fixed(line):
    return line[:68] + str(sum(int(c) if c.isdigit() else c == "-" for c in line[:68]) % 10)


def test_fit_across_a_leap_second_recovers_the_tle_and_its_epoch():
    """States spanning 2016-12-31T23:59:60 fit back to the TLE; epoch given inside the leap
    second (was ValueError 'second must be in 0..59') and to the microsecond (was rounded to
    the millisecond)."""
    from astropy.time import Time

    line1 = _fixed("1 25544U 98067A   16366.50000000  .00016717  00000-0  10270-3 0  9009")
    sat = vv.Satellite.from_tle(line1, ISS[1])
    times = Time("2016-12-31T12:00:00", scale="utc") + np.linspace(0, 1, 60) * u.day
    states = sat.gcrs(times).to_state_vectors()
    fit = vv.fit_tle(states, satnum=25544, fit_bstar=False, bstar=sat.satrec.bstar)
    assert fit.fit.max_position_km < ONE_METER
    assert abs((fit.epoch - sat.epoch).to_value(u.s)) < 1e-6
    ep = Time("2016-12-31T23:59:60.5", scale="utc")
    fit2 = vv.fit_tle(states, epoch=ep, satnum=25544, fit_bstar=False, bstar=sat.satrec.bstar)
    assert _rms_km(fit2, states) < ONE_METER
    assert fit2.epoch.isot == "2017-01-01T00:00:00.500"  # sgp4's clock has no 23:59:60
    ep = Time("2016-12-31T18:00:00.123456", scale="utc")
    fit3 = vv.fit_tle(states, epoch=ep, satnum=25544, fit_bstar=False, bstar=sat.satrec.bstar)
    assert abs((fit3.epoch - ep).to_value(u.s)) < 1e-6


def test_fit_tle_refuses_times_that_contradict_the_states_own(iss):
    # audit20: states with their own epoch array and times= an hour later were fitted at the
    # later times without a word (an element set an hour off); the same times are accepted
    t = iss.epoch + np.linspace(0, 1, 25) * u.day
    states = iss.gcrs(t).to_state_vectors()
    with pytest.raises(vv.InvalidInputError, match="by up to 3600 s"):
        vv.fit_tle(states, times=t + 1 * u.h, satnum=25544)
    with pytest.raises(vv.InvalidInputError, match="differs from them"):
        vv.fit_tle(states, times=t[:-1], satnum=25544)
    assert vv.fit_tle(states, times=t, satnum=25544).fit.max_position_km < ONE_METER
    bare = vv.StateVectors(states.r, states.v, vv.EARTH)  # no times of its own: times= gives them
    assert vv.fit_tle(bare, times=t, satnum=25544).fit.max_position_km < ONE_METER


#: a GPS-like element set (SDP4) without drag, B* = 0 (checksums not kept)
GPS_LIKE = ("1 99995U 24001A   24100.50000000  .00000000  00000-0  00000+0 0  9990",
            "2 99995  55.0000 100.0000 0050000  30.0000  10.0000  2.00560000  1000")


#: a geostationary set 5 deg inclined, B* = 0 (SDP4; checksum not kept)
GEO_5DEG = ("1 99990U 24001A   24100.50000000 -.00000100  00000-0  00000+0 0  9990",
            "2 99990   5.0000  85.1000 0001200 200.0000 120.0000  1.00270000  1000")


@pytest.mark.parametrize("lines, days", [(GPS_LIKE, 0.5), (GEO_5DEG, 1.0)])
def test_bstar_the_states_do_not_see_is_reported_not_the_whole_fit(lines, days):
    # half a day of a high orbit: B* moved no position by a rounding step, its column of the
    # normal matrix was zero, and the singular solve ended the fit at its first guess
    # "converged": the naive TLE came back 16-20 km off the states SGP4 itself made, sigma_bstar
    # 0, no warning (audit31). The other elements are now fitted and B* reported undetermined
    # (a GEO's B* moves nothing at all: held, sigma inf)
    truth = vv.Satellite.from_tle(*lines, verify_checksum=False)
    states = truth.gcrs(np.linspace(0, days, 40) * u.day).to_state_vectors()
    with pytest.warns(RuntimeWarning, match="B\\* is not determined") as said:
        fit = vv.fit_tle(states)
    assert fit.fit.max_position_km < ONE_METER
    assert _rms_km(fit, states) < ONE_METER
    assert fit.fit.sigma_bstar > 1e-4
    # a B* held because nothing sees it is said to be held, not "fitted 0 +- inf" (audit33)
    text = " ".join(str(w.message) for w in said if "B*" in str(w.message))
    if math.isinf(fit.fit.sigma_bstar):
        assert "held at its first guess, 0 1/earth radii (sigma_bstar = inf)" in text
        assert "fitted" not in text and fit.satrec.bstar == 0.0
    else:
        assert f"fitted {fit.satrec.bstar:.3g} +- " in text
    assert fit.satrec.inclo == pytest.approx(truth.satrec.inclo, abs=1e-10)
    assert fit.satrec.ecco == pytest.approx(truth.satrec.ecco, abs=1e-10)


def test_a_weak_deep_space_bstar_is_stepped_above_rounding():
    # a 3300 km perigee HEO (SDP4): B*'s finite-difference step (1e-9) moved the states by
    # 3e-11 km, SGP4's rounding, and the fit followed that noise column for 48 iterations to
    # B* = -6e-4 (truth 0) with a formal sigma of 5e-19 from a pseudo-inverse that had cut
    # B*'s direction off (audit31). The step now grows until B* moves the states by 1 mm
    line1 = "1 99995U 24001A   24100.50000000  .00000000  00000-0  00000+0 0  9990"
    line2 = "2 99995  63.0000 100.0000 6000000 270.0000  10.0000  2.30000000  1000"
    truth = vv.Satellite.from_tle(line1, line2, verify_checksum=False)
    states = truth.gcrs(np.linspace(0, 0.25, 40) * u.day).to_state_vectors()
    fit = vv.fit_tle(states)
    assert fit.fit.iterations <= 10
    assert fit.fit.max_position_km < 1e-4  # 0.1 mm
    assert abs(fit.satrec.bstar) < 1e-4  # moves these states by < 1 mm
    assert fit.fit.sigma_bstar > 1e-7


@pytest.mark.parametrize("lines", [
    ("1 99990U 24001A   24100.50000000 -.00000100  00000-0  00000+0 0  9990",
     "2 99990   0.0150  85.1000 0001200 200.0000 120.0000  1.00270000  1000"),
    ("1 99993U 24001A   24100.50000000  .00001000  00000-0  50000-4 0  9990",
     "2 99993  98.7000 300.0000 0012000  90.0000 120.0000 14.30000000  1000")])
def test_near_equatorial_and_retrograde_sets_fitted_in_equinoctial_elements(lines):
    # the unknowns i and the node are singular at i = 0; equinoctial elements are not (the
    # retrograde form, tan((pi - i)/2), for i > 90 deg): a geostationary set 0.015 deg
    # inclined comes back in 19 iterations (was ConvergenceError after 50 at 23 m RMS), a
    # sun-synchronous one as before
    truth = vv.Satellite.from_tle(*lines, verify_checksum=False)
    states = truth.gcrs(np.linspace(0, 2, 40) * u.day).to_state_vectors()
    fit = vv.fit_tle(states, fit_bstar=truth.satrec.bstar != 0)
    assert fit.fit.max_position_km < ONE_METER
    assert fit.fit.iterations <= 30
    assert fit.satrec.inclo == pytest.approx(truth.satrec.inclo, abs=1e-9)
    assert fit.satrec.nodeo == pytest.approx(truth.satrec.nodeo, abs=1e-5)


def test_a_slow_near_equatorial_geo_fit_is_told_to_iterate_longer_not_to_shorten_the_arc():
    # half a day of a GEO 0.015 deg inclined needs 58 iterations (2 days: 19): SDP4's lunisolar
    # inclination periodics are as large as the inclination there, a curved valley the fit
    # crawls along while B* is held (unseen). The ConvergenceError at the default 50 told the
    # user to "fit a shorter arc", which converges slower still
    truth = vv.Satellite.from_tle(
        "1 99990U 24001A   24100.50000000 -.00000100  00000-0  00000+0 0  9990",
        "2 99990   0.0150  85.1000 0001200 200.0000 120.0000  1.00270000  1000",
        verify_checksum=False)
    states = truth.gcrs(np.linspace(0, 0.5, 40) * u.day).to_state_vectors()
    with pytest.raises(vv.ConvergenceError) as info:
        vv.fit_tle(states, fit_bstar=False)
    text = str(info.value)
    assert "still falling" in text and "max_iterations=100" in text and "longer arc" in text
    assert "near-equatorial (i = 0.015" in text and "shorter arc" not in text
    assert info.value.history[-1]["rms_position_km"] < 0.1 * info.value.history[1][
        "rms_position_km"]
    fit = vv.fit_tle(states, fit_bstar=False, max_iterations=100)  # as the message says
    assert fit.fit.max_position_km < ONE_METER
    assert fit.satrec.inclo == pytest.approx(truth.satrec.inclo, abs=1e-9)


def test_a_fit_with_no_downhill_step_left_far_from_its_minimum_is_not_converged(iss, monkeypatch):
    # SGP4 refusing every trial step (here forced) left the fit at its first guess, the naive
    # TLE kilometres off, reported converged ("no downhill step left: at the minimum"); it is
    # converged only when Gauss-Newton's step promised under 0.1 % of the misfit (audit31)
    import visviva.od.tle_fit as tle_fit

    states = iss.gcrs(np.linspace(0, 30, 20) * u.min).to_state_vectors()
    calls = []
    real = tle_fit.sgp4_states

    def failing_trials(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs) if len(calls) <= 8 else None  # guess + 7 columns

    monkeypatch.setattr(tle_fit, "sgp4_states", failing_trials)
    with pytest.raises(vv.ConvergenceError, match="no step lowers the misfit"):
        vv.fit_tle(states)


#: SGP4-VER set 20413 (sgp4's verification file): e = 0.786, i = 12.35 deg, 5.8-day orbit (SDP4)
HEO_20413 = ("1 20413U 83020D   05363.79166667  .00000000  00000-0  00000+0 0  7041",
             "2 20413  12.3514 187.4253 7864447 196.3027 356.5478  0.24690082  7978")


def test_a_fit_across_sgp4s_own_jump_at_0_2_rad_inclination_recovers_the_set():
    # SDP4 applies its lunisolar periodics directly while the perturbed inclination is at least
    # 0.2 rad and in Lyddane's form below: 20413 crosses it between minutes 1843 and 1844, where
    # SGP4's own position jumps 1,655 km at apogee. The fit's set crossed elsewhere, missed the
    # two states in between by 1,500 km and settled 351 km RMS off, inside the 1 %-of-the-radius
    # check, without a word (audit33). Refitted without them it finds the set, and they fit it
    truth = vv.Satellite.from_tle(*HEO_20413)
    jump = truth.teme(np.array([1843.0, 1844.0]) * u.min)
    step = np.linalg.norm(np.diff(jump.r.to_value(u.km), axis=0))
    assert step > 1000.0  # km in one minute, 60x the speed there: SGP4's jump, not the orbit
    states = truth.teme(np.linspace(0, 2, 40) * u.day)
    with pytest.warns(RuntimeWarning) as said:
        fit = vv.fit_tle(states)
    assert all("B* is not determined" in str(w.message) for w in said)  # nothing else
    assert fit.fit.max_position_km < ONE_METER
    assert fit.fit.excluded.size == 0
    assert fit.satrec.inclo == pytest.approx(truth.satrec.inclo, abs=1e-9)
    assert fit.satrec.no_kozai == pytest.approx(truth.satrec.no_kozai, rel=1e-10)


def test_states_far_off_the_set_that_fits_the_others_are_left_out_and_named(iss):
    # one state 30 km off (a bad state, a manoeuvre or SGP4's own jump in a precise
    # ephemeris): the fit bent every element towards it and came back km off everywhere,
    # silently. It is now left out, named with its time, and the others fit to the metre
    states = iss.teme(np.linspace(0, 0.5, 30) * u.day)
    from visviva.states import StateVectors

    r = states.r.to_value(u.km).copy()
    r[11, 0] += 30.0
    sv = StateVectors(r * u.km, states.v, vv.EARTH, epoch=states.t)
    with pytest.warns(RuntimeWarning, match="far off") as said:
        fit = vv.fit_tle(sv, frame="teme", fit_bstar=False, bstar=iss.satrec.bstar)
    text = " ".join(str(w.message) for w in said)
    assert "1 of the 30 states is far off" in text and "state 11 (minute 273.103, 30 km)" in text
    assert "Left out of the fit (fit.excluded" in text and "split the arc" in text
    assert [h["iteration"] for h in fit.fit.history] == list(range(1, fit.fit.iterations + 1))
    assert list(fit.fit.excluded) == [11]
    assert fit.fit.max_position_km == pytest.approx(30.0, rel=1e-6)  # it counts them
    others = np.delete(np.arange(30), 11)
    d = fit.teme(states.t[others]).r.to_value(u.km) - r[others]
    assert np.max(np.linalg.norm(d, axis=1)) < ONE_METER


def test_fit_tle_batch_shows_each_fits_warnings_naming_the_history(iss):
    """A fit's warnings on a Dask worker process stayed in the worker's log (left item): each
    fit's warnings are recorded where it runs and shown by the caller, naming the history."""
    import warnings

    from visviva.od.tle_batch import _fit_packed, _pack

    good = iss.gcrs(np.linspace(0, 1, 25) * u.day).to_state_vectors()
    r = good.r.to_value(u.km).copy()
    r[7] += 200.0  # one bad state: the fit leaves it out and says so
    bad = vv.StateVectors(r * u.km, good.v, good.gm, epoch=good.epoch)
    items = list(zip([good, bad], [25544, 25544], [None, None], strict=True))
    said = [w for _, _, w in _fit_packed(_pack(items, "gcrs", 10), {})]  # what a worker returns
    assert said[0] == [] and len(said[1]) == 1 and said[1][0][0] is RuntimeWarning
    assert "state 7" in said[1][0][1]
    with pytest.warns(RuntimeWarning, match=r"histories\[1\]: 1 of the 25 states is far"):
        sats = vv.od.fit_tle_batch([good, bad], satnums=[25544] * 2)
    assert sats[1].fit.excluded.tolist() == [7]
    short = vv.StateVectors(r[:2] * u.km, good.v[:2], good.gm[:2], epoch=good.epoch[:2])
    with pytest.raises(vv.InvalidInputError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        vv.od.fit_tle_batch([good, short], satnums=[25544] * 2)
    assert err.value.__notes__ == ["(fitting histories[1] of fit_tle_batch)"]


def _sgp4_ver(number):
    """The SGP4-VER set ``number`` (sgp4's verification file, read as tests/test_catalog.py)."""
    import importlib.resources

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] if ln.startswith("2 ") else ln for ln in text.splitlines()
             if not ln.startswith("#")]
    for one, two in zip(lines, lines[1:], strict=False):
        if one.startswith(f"1 {number:05d}") and two.startswith("2 "):
            return vv.Satellite.from_tle(one, two, verify_checksum=False)
    raise LookupError(number)


def _sgp4_states(sat, days, count=40):
    """TEME states of ``sat`` from its epoch over ``days``, straight from its satrec."""
    from astropy.time import Time

    s = sat.satrec
    jd = np.full(count, s.jdsatepoch)
    fr = s.jdsatepochF + np.linspace(0.0, days, count)
    err, r, v = s.sgp4_array(jd, fr)
    assert not err.any()
    return r, v, Time(jd, fr, format="jd", scale="utc")


@pytest.mark.parametrize("number", [16925, 28623])
def test_a_low_perigee_heo_with_strong_drag_is_recovered_over_two_days(number):
    # 40 SGP4 states over 2 days of SGP4-VER 16925 (e = 0.56, B* 1.9e-4) and 28623 (e = 0.62,
    # B* 9.6e-4): from the osculating guess with B* = 0 the correction crept and ended
    # 315 km RMS (ConvergenceError "cannot reproduce") and 15 km off (out of iterations).
    # Drag over days is far from linear in B* there (held at the truth, both converge in
    # 5-7 iterations); fitted over widening windows about the epoch they come back
    from visviva.od.tle_fit import fit_tle_arrays

    truth = _sgp4_ver(number)
    r, v, t = _sgp4_states(truth, 2.0)
    fit = fit_tle_arrays(r, v, t, "teme", number)
    assert fit.fit.max_position_km < ONE_METER
    assert fit.satrec.bstar == pytest.approx(truth.satrec.bstar, rel=1e-6)
    assert fit.satrec.no_kozai == pytest.approx(truth.satrec.no_kozai, rel=1e-10)
    assert fit.satrec.ecco == pytest.approx(truth.satrec.ecco, abs=1e-9)


def test_a_24_hour_resonant_set_converges_over_two_days():
    # SGP4-VER 14128 (n = 0.989 rev/day, SDP4's 24-hour resonance terms): the finite-difference
    # steps of 1e-7 missed the curvature and the fit crept 1 cm off for 400 iterations
    # (ConvergenceError); with steps of 1e-8 it converges in a few
    from visviva.od.tle_fit import fit_tle_arrays

    truth = _sgp4_ver(14128)
    r, v, t = _sgp4_states(truth, 2.0)
    with pytest.warns(RuntimeWarning, match="B\\* is not determined"):
        fit = fit_tle_arrays(r, v, t, "teme", 14128)
    assert fit.fit.max_position_km < 1e-3 * ONE_METER
    assert fit.fit.iterations < 10
    assert fit.satrec.no_kozai == pytest.approx(truth.satrec.no_kozai, rel=1e-10)


def test_a_near_equatorial_deep_space_false_minimum_is_warned_about():
    # SGP4-VER 28626 (GEO, i = 0.0019 deg), half a day of its own states: the fit settles on
    # i = 0.023 deg, 28 m RMS and 77 m at worst off, and called itself converged without a
    # word (SDP4's mean inclination vector is ill-determined below 0.1 deg). It now says so
    from visviva.od.tle_fit import fit_tle_arrays

    truth = _sgp4_ver(28626)
    r, v, t = _sgp4_states(truth, 0.5)
    with pytest.warns(RuntimeWarning) as said:
        fit = fit_tle_arrays(r, v, t, "teme", 28626)
    text = " ".join(str(w.message) for w in said)
    assert "near-equatorial" in text and "false minimum" in text
    assert fit.fit.rms_position_km > 1e-3  # the false minimum it names (m-level, not 0)
    # a near-equatorial set that is fitted to the micrometre is not warned about
    other = _sgp4_ver(26900)
    r, v, t = _sgp4_states(other, 0.5)
    with pytest.warns(RuntimeWarning) as said:
        fit_tle_arrays(r, v, t, "teme", 26900)
    assert not any("false minimum" in str(w.message) for w in said)


def test_28626_over_two_days_is_a_crawl_not_a_false_minimum():
    """SGP4-VER 28626 (GEO, i = 0.0019 deg) over 2 days raised ConvergenceError at the default
    50 iterations a stage (16 m RMS, still falling), unexplained: it is no false minimum (half a
    day's is one, 28 m off): the correction crawls along SDP4's curved near-equatorial valley
    and, allowed 200 iterations a stage as the error's advice says, recovers the set to 1e-7
    km in 175 in all. The advice no longer promises "about 20 iterations" over 2 days."""
    from visviva.od.tle_fit import fit_tle_arrays

    truth = _sgp4_ver(28626)
    r, v, t = _sgp4_states(truth, 2.0)
    with pytest.raises(vv.ConvergenceError, match=r"still falling.*raise max_iterations.*"
                       r"near-equatorial.*28626 over 2 days: 175") as info:
        fit_tle_arrays(r, v, t, "teme", 28626)
    assert "about 20 iterations" not in str(info.value)
    with pytest.warns(RuntimeWarning, match="B\\* is not determined"):
        fit = fit_tle_arrays(r, v, t, "teme", 28626, max_iterations=200)
    assert fit.fit.max_position_km < 1e-3 * ONE_METER
    assert fit.satrec.inclo == pytest.approx(truth.satrec.inclo, abs=1e-9)
    assert fit.satrec.nodeo == pytest.approx(truth.satrec.nodeo, abs=1e-5)


#: SGP4-VER sets left out of the table: SGP4 fails on them within 2 days (decay, e >= 1)
_VER_UNFITTABLE = {22312, 28350, 28872, 29141, 33333, 33334, 33335}


@pytest.mark.slow
@pytest.mark.parametrize("days", [0.5, 2.0])
def test_every_sgp4_ver_set_is_recovered_or_refused(days):
    # 40 of each set's own SGP4 states over half a day and 2 days (the table in
    # docs/orbit_determination.md): each comes back to under a millimetre (23333 over half a
    # day too, since leftfix6: its first guess retried at a lower e), except the
    # near-equatorial GEO 28626 (i = 0.0019 deg: a false minimum, warned about; 2 days: a
    # ConvergenceError) and 20413 over 2 days, a local minimum 0.37 km off near SGP4's own
    # 1,655 km jump at the 0.2 rad crossing (not understood: an open limitation)
    import importlib.resources
    import warnings

    from visviva.od.tle_fit import fit_tle_arrays

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    numbers = sorted({int(ln[2:7]) for ln in text.splitlines() if ln.startswith("1 ")})
    worst = {}
    for number in numbers:
        truth = _sgp4_ver(number)
        s = truth.satrec
        jd = np.full(40, s.jdsatepoch)
        fr = s.jdsatepochF + np.linspace(0.0, days, 40)
        err, r, v = s.sgp4_array(jd, fr)
        if number in _VER_UNFITTABLE or err.any():
            continue
        from astropy.time import Time

        t = Time(jd, fr, format="jd", scale="utc")
        if number == 28626 and days == 2.0:  # the crawl of test_28626_over_two_days_...
            with pytest.raises(vv.ConvergenceError, match="near-equatorial"):
                fit_tle_arrays(r, v, t, "teme", number)
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_tle_arrays(r, v, t, "teme", number)
        worst[number] = fit.fit.max_position_km
    assert len(worst) >= 22
    known = {28626: 0.1, 20413: 0.5 if days == 2.0 else 1e-6}
    for number, miss in worst.items():
        assert miss < known.get(number, 1e-6), (number, miss)


def test_a_first_guess_past_sgp4s_eccentricity_limit_starts_inside_it():
    # SGP4-VER 23333 (mean e = 0.973, a 13.7-day orbit): the osculating e at its epoch, near
    # perigee, is 0.9905, past SGP4's 0.99, and the fit refused with "SGP4 cannot propagate the
    # first guess". Started at e = 0.975 it recovers the set over 2 days
    from visviva.od.tle_fit import fit_tle_arrays

    truth = _sgp4_ver(23333)
    r, v, t = _sgp4_states(truth, 2.0)
    fit = fit_tle_arrays(r, v, t, "teme", 23333)
    assert fit.fit.max_position_km < ONE_METER
    assert fit.satrec.ecco == pytest.approx(truth.satrec.ecco, abs=1e-9)
    # half a day: that start (and one at e = 0.96) was refused, "SGP4 cannot propagate the
    # first guess": SDP4's lunisolar periodics in e (~1e-2) move the perigee of a 241,600 km
    # orbit by thousands of km, and SGP4 called the start decayed (error 6) near perigee.
    # Started again at e = 0.95 the fit recovers the set
    r, v, t = _sgp4_states(truth, 0.5)
    fit = fit_tle_arrays(r, v, t, "teme", 23333)
    assert fit.fit.max_position_km < 1e-3 * ONE_METER
    assert fit.satrec.ecco == pytest.approx(truth.satrec.ecco, abs=1e-9)
    # a start SGP4 cannot propagate at any of the retried eccentricities is still refused,
    # saying so: an arc that decays
    with pytest.raises(vv.InvalidInputError, match=r"first guess \(e = 0\.975.*nor at e = "
                       r"0\.95 \.\.\. 0\.6\).*e < 0\.99.*epoch="):
        fit_tle_arrays(r * 0.05, v * 0.05 ** -0.5, t, "teme", 23333)


def test_sgp4_positions_beyond_any_earth_orbit_are_no_fit():
    """The fit took SGP4's states as they came: SGP4-VER 29141 (decayed at 0.3 days) comes
    back without an error code 1.4e6 to 2.2e6 km away 2.0 to 2.1 days past its epoch, and its
    element vector's states there were a residual like any other, where Satellite.teme and the
    SGP4 batch refuse them (more than 1e6 km: no Earth orbit). sgp4_states now treats them as an
    SGP4 failure, and states that far given to fit_tle_arrays are refused, saying why."""
    from astropy.time import Time

    from visviva.od.tle_elements import epoch_days, sgp4_states
    from visviva.od.tle_fit import fit_tle_arrays

    truth = _sgp4_ver(29141)
    s = truth.satrec
    jd = np.full(40, s.jdsatepoch)
    fr = s.jdsatepochF + np.linspace(2.0, 2.1, 40)
    err, r, v = s.sgp4_array(jd, fr)
    assert not err.any() and np.linalg.norm(r, axis=1).min() > 1.4e6  # sgp4 itself: code 0
    varpi, q = s.argpo + s.nodeo, math.tan(s.inclo / 2)  # the set's own element vector
    p = np.array([s.no_kozai, s.ecco * math.cos(varpi), s.ecco * math.sin(varpi),
                  q * math.cos(s.nodeo), q * math.sin(s.nodeo), s.mo + varpi, s.bstar])
    days = epoch_days(truth.to_omm()["EPOCH"])
    assert sgp4_states(p, days, 29141, jd[:1], np.array([s.jdsatepochF])) is not None
    assert sgp4_states(p, days, 29141, jd, fr) is None
    t = Time(jd, fr, format="jd", scale="utc")
    with pytest.raises(vv.InvalidInputError, match=r"state 0 lies 1\.44e\+06 km from the "
                       r"geocentre, beyond 1e\+06 km: no Earth orbit"):
        fit_tle_arrays(r, v, t, "teme", 29141)


def test_an_initial_set_of_another_object_is_warned(iss, recwarn):
    # the new set takes initial's catalogue number, name, designator and B*; with another
    # object's set (a Molniya set for ISS states) only the revolution number's disagreement was
    # mentioned, the ISS fit came out named and numbered as the Molniya satellite
    import warnings

    states = iss.gcrs(np.linspace(0, 1, 40) * u.day).to_state_vectors()
    molniya = vv.Satellite.from_tle(*MOLNIYA, "MOLNIYA 1-29")
    with pytest.warns(RuntimeWarning, match=r"initial \(MOLNIYA 1-29, catalogue number 8195\) "
                      r"looks like another object.*inclination 64\.159 vs 51\.6"):
        fit = vv.fit_tle(states, initial=molniya, fit_bstar=False)
    assert fit.fit.rms_position_km < 0.1  # the fit itself is still ISS's
    # the same object's set a month older: no warning of that kind
    older = vv.Satellite.from_omm({**iss.to_omm(), "EPOCH": "2023-12-01T00:00:00"})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vv.fit_tle(states, initial=older, fit_bstar=False)
    assert not [w for w in caught if "another object" in str(w.message)]
    # an OEM of another designator than initial's
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.oem_io import Ephemeris

    seg = OEMSegment.from_states(states.epoch, states.r.to_value(u.km),
                                 states.v.to_value(u.km / u.s), object_name="ISS (ZARYA)",
                                 object_id="1998-067A")
    with pytest.warns(RuntimeWarning, match="OBJECT_ID 1998-067A but initial is 1975-081A"):
        vv.fit_tle(Ephemeris([seg]), initial=molniya, fit_bstar=False)
