"""``visviva od``: tracking data (TDM) in, an orbit with its covariance out (OPM, OEM, CSV).

The command must give exactly what the library gives (``fit_orbit`` / ``filter_orbit`` on the
same observations), write an OPM and an OEM that read back to the estimate and its covariance,
and refuse bad input with one line and exit code 2 (1 for a fit that fails).
"""

from __future__ import annotations

import csv
import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva import cli

ONE_MM = 1e-6  # km
SIGMA = {"range": 0.010 * u.km, "range_rate": 1e-5 * u.km / u.s, "azel": 0.01 * u.deg}
SIGMA_ARG = ["--sigma", "range=10m,range_rate=1cm/s", "--sigma", "angle=0.01deg"]
SITES = {"COLORADO": (40.0, -105.0, 1600.0), "KAROO": (-30.0, 20.0, 300.0),
         "PACIFIC": (15.0, 150.0, 0.0)}
STATION_ARGS = [a for name, (lat, lon, h) in SITES.items()
                for a in ("--station", f"{name}={lat},{lon},{h}")]


def _stations():
    return {name: vv.GroundStation(lat * u.deg, lon * u.deg, h * u.m, name=name)
            for name, (lat, lon, h) in SITES.items()}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Six hours of simulated range, range rate and az/el from three stations (J2 truth),
    written as a TDM."""
    folder = tmp_path_factory.mktemp("od")
    epoch = Time("2024-03-01T00:00:00", scale="utc")
    truth = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.05, 5.75] * u.km / u.s,
                            vv.EARTH, epoch=epoch)
    grid = epoch + np.arange(0, 6 * 3600, 30) * u.s
    obs = vv.od.simulate_tracking(truth, list(_stations().values()), grid, [vv.J2(vv.EARTH)],
                                  seed=42)
    tdm = folder / "passes.tdm"
    vv.write_tdm(obs, tdm, participant="SAT-1")
    back = vv.read_tdm(tdm).to_observations(_stations(), SIGMA)
    return {"folder": folder, "truth": truth, "tdm": str(tdm), "obs": back}


def _run(capsys, *argv):
    code = cli.main(["od", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def _truth_at(campaign, t):
    res = vv.propagate_cowell(campaign["truth"], t, [vv.J2(vv.EARTH)])
    return res.r.to_value(u.km).reshape(3)


def test_batch_equals_fit_orbit_and_products_read_back(campaign, tmp_path, capsys):
    opm, oem, res = tmp_path / "o.opm", tmp_path / "o.oem", tmp_path / "r.csv"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--opm", str(opm), "--oem", str(oem), "--span", "2h", "--step",
                          "10min", "--residuals", str(res))
    assert code == 0, err
    fit = vv.fit_orbit(campaign["obs"], None, [vv.J2(vv.EARTH)])  # IOD, as the command
    msg = vv.read_opm(opm)
    # the OPM holds the fit's state and covariance (km-based, the OPM's units) exactly
    assert abs((msg.epoch - fit.state.epoch).to_value(u.s)) < 1e-6
    np.testing.assert_allclose(msg.state.r.to_value(u.km), fit.state.r.to_value(u.km),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(msg.state.v.to_value(u.km / u.s),
                               fit.state.v.to_value(u.km / u.s), rtol=0, atol=1e-12)
    np.testing.assert_allclose(msg.covariance, fit.covariance, rtol=1e-14, atol=0)
    # and the estimate is the truth within its own 1-sigma scale (a few metres)
    err_km = msg.state.r.to_value(u.km) - _truth_at(campaign, fit.state.epoch)
    assert np.linalg.norm(err_km) < 0.05
    # the summary names what a flight-dynamics engineer checks
    assert "batch least squares" in out and "0 rejected" in out
    assert f"{fit.rms:.3f}" in out and f"{fit.iterations} iterations" in out
    sig_m = np.sqrt(np.diag(fit.covariance)[:3]) * 1e3
    assert " ".join(f"{x:16.3f}" for x in sig_m) in out
    # the OEM: 13 states over 2 h at 10 min, a covariance at each, equal to fit.propagate
    seg = vv.read_oem(oem).segments[0]
    assert len(seg.times) == 13 and len(seg.covariances) == 13
    pred = fit.propagate(seg.times)
    np.testing.assert_allclose(seg.states.r.to_value(u.km), pred.r.to_value(u.km), rtol=0,
                               atol=ONE_MM)
    np.testing.assert_allclose(seg.covariances[0].matrix, fit.covariance, rtol=1e-12)
    last = np.asarray(pred.covariance[-1])
    np.testing.assert_allclose(seg.covariances[-1].matrix, last, rtol=1e-9,
                               atol=1e-12 * np.abs(last).max())
    # the residual report: one row per observation, in m, m/s, arcsec
    rows = list(csv.DictReader(res.open()))
    assert len(rows) == len(campaign["obs"])
    for i in (0, 1, 2):
        f = 1e3 if rows[i]["unit"] in ("m", "m/s") else np.degrees(1) * 3600
        assert float(rows[i]["residual_1"]) == pytest.approx(fit.residuals[i, 0] * f, rel=1e-5)
        assert rows[i]["rejected"] == "no"


def test_initial_opm_with_covariance_and_xml_output(campaign, tmp_path, capsys):
    first = tmp_path / "first.opm"
    code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                        "--opm", str(first))
    assert code == 0, err
    out_xml = tmp_path / "second.opm.xml"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--initial", str(first), "--opm", str(out_xml))
    assert code == 0, err
    assert "with covariance (combined with the data as an a priori" in out
    prior = vv.read_opm(first)
    fit = vv.fit_orbit(campaign["obs"], prior.state, [vv.J2(vv.EARTH)],
                       apriori_covariance=prior.covariance)
    assert fit.apriori_covariance is not None
    back = vv.read_opm(out_xml)
    np.testing.assert_allclose(back.state.r.to_value(u.km), fit.state.r.to_value(u.km),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.covariance, fit.covariance, rtol=1e-12)
    # the same data counted twice (prior and data): the covariance halves
    np.testing.assert_allclose(np.diag(back.covariance), np.diag(prior.covariance) / 2,
                               rtol=0.02)
    # --no-apriori: the data alone, as before
    alone = tmp_path / "alone.opm"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--initial", str(first), "--opm", str(alone), "--no-apriori")
    assert code == 0, err
    assert "its covariance ignored: --no-apriori" in out
    fit = vv.fit_orbit(campaign["obs"], prior.state, [vv.J2(vv.EARTH)])
    np.testing.assert_allclose(vv.read_opm(alone).covariance, fit.covariance, rtol=1e-12)
    np.testing.assert_allclose(vv.read_opm(alone).covariance, prior.covariance, rtol=1e-4)


def test_an_opm_covariance_with_a_zero_variance_needs_no_apriori(campaign, tmp_path, capsys):
    from visviva.ccsds.covariance import values_from_matrix
    from visviva.ccsds.grammar import Record

    first = tmp_path / "first.opm"
    code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                        "--opm", str(first))
    assert code == 0, err
    msg = vv.read_opm(first)
    cov = np.array(msg.covariance)
    cov[5, :] = cov[:, 5] = 0.0
    msg.sections["covariance"] = Record(values=values_from_matrix(cov))
    vv.write_opm(msg, first)
    code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                        "--initial", str(first))
    assert code == 2 and "zero variance" in err and "--no-apriori" in err
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--initial", str(first), "--no-apriori")
    assert code == 0, err


def test_initial_tle_and_estimated_drag(campaign, tmp_path, capsys):
    """A TLE first guess (its SGP4 state at the first observation, in the GCRS) and drag's B
    estimated (truth B = 0.02 m^2/kg, start 0.015): the command gives what fit_orbit gives."""
    forces = [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.02 * u.m**2 / u.kg)]
    truth = campaign["truth"]
    obs = vv.od.simulate_tracking(truth, list(_stations().values()),
                                  truth.epoch + np.arange(0, 6 * 3600, 30) * u.s, forces,
                                  seed=7)
    tdm = tmp_path / "drag.tdm"
    vv.write_tdm(obs, tdm, participant="SAT-1")
    t = truth.epoch + np.arange(0, 3 * 3600, 300) * u.s
    sat = vv.fit_tle(vv.propagate_cowell(truth, t, forces), name="SAT-1")
    tle = tmp_path / "first.tle"
    tle.write_text("SAT-1\n" + "\n".join(sat.to_tle()) + "\n")
    opm = tmp_path / "o.opm"
    code, out, err = _run(capsys, str(tdm), *STATION_ARGS, *SIGMA_ARG, "--initial", str(tle),
                          "--force", "j2,drag:0.015", "--estimate", "drag:0.01", "--opm",
                          str(opm))
    assert code == 0, err
    obs = vv.read_tdm(tdm).to_observations(_stations(), SIGMA)
    first = vv.read_catalog_file(tle)[0].gcrs(obs.times[0])
    fit = vv.fit_orbit(obs, first, [forces[0], vv.AtmosphericDrag(0.015 * u.m**2 / u.kg)],
                       estimate=["drag"], parameter_sigma={"drag": 0.01 * u.m**2 / u.kg})
    back = vv.read_opm(opm)
    np.testing.assert_allclose(back.state.r.to_value(u.km), fit.state.r.to_value(u.km),
                               rtol=0, atol=1e-9)
    assert abs((back.epoch - obs.times[0]).to_value(u.s)) < 1e-6
    b = fit.parameters["drag"].to_value(u.m**2 / u.kg)
    sb = fit.parameter_sigma["drag"].to_value(u.m**2 / u.kg)
    assert abs(b - 0.02) < 4 * sb
    assert f"drag B      {b:.6g} +- {sb:.2g} m^2/kg" in out
    assert "object      SAT-1" in out


def _drag_tracking(campaign, tmp_path, hours, step_s, seed):
    """The campaign's truth flown with J2 and drag (B 0.02 m^2/kg), tracked by the stations every
    ``step_s`` s for ``hours``: (forces, truth, observations, its TDM file, the truth as an OPM
    file for --initial)."""
    from visviva.ccsds.opm import OPM

    forces = [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.02 * u.m**2 / u.kg)]
    truth = campaign["truth"]
    obs = vv.od.simulate_tracking(truth, list(_stations().values()),
                                  truth.epoch + np.arange(0, hours * 3600, step_s) * u.s, forces,
                                  seed=seed)
    tdm, first = tmp_path / "drag.tdm", tmp_path / "first.opm"
    vv.write_tdm(obs, tdm, participant="SAT-1")
    vv.write_opm(OPM.from_state(truth, object_name="SAT-1"), first)
    return forces, truth, obs, tdm, first


def test_ukf_estimates_drag_from_the_command_line(campaign, tmp_path, capsys):
    """--filter ukf --estimate drag:SIGMA (refused before this session): the unscented filter
    with B in its state, from B = 0.015 +- 0.01 (truth 0.02 m^2/kg), ends within 4 sigma of
    the truth, and the command reports it as filter_orbit(method="ukf") gives it."""

    forces, truth, obs, tdm, first = _drag_tracking(campaign, tmp_path, 6, 30, seed=7)
    code, out, err = _run(capsys, str(tdm), *STATION_ARGS, *SIGMA_ARG, "--initial", str(first),
                          "--force", "j2,drag:0.015", "--estimate", "drag:0.01", "--filter",
                          "ukf", "--apriori", "100m,10cm/s")
    assert code == 0, err
    obs = vv.read_tdm(tdm).to_observations(_stations(), SIGMA)
    p0 = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    f = vv.filter_orbit(obs, vv.read_opm(first).state, p0,
                        [forces[0], vv.AtmosphericDrag(0.015 * u.m**2 / u.kg)], method="ukf",
                        estimate="drag", parameter_sigma={"drag": 0.01 * u.m**2 / u.kg})
    b = f.parameters["drag"].to_value(u.m**2 / u.kg)[-1]
    sb = f.parameter_sigma["drag"].to_value(u.m**2 / u.kg)[-1]
    assert abs(b - 0.02) < 4 * sb
    assert "UKF" in out and f"drag B      {b:.6g} +- {sb:.2g} m^2/kg" in out


def test_opm_manoeuvre_is_flown_and_written_back(campaign, tmp_path, capsys):
    """An OPM first guess with an impulse (1 m/s along track, 2 h into the data): the fit
    flies it as fit_orbit(maneuvers=opm.burns()) does, and the OPM written keeps it."""
    from visviva.ccsds.opm import OPM, Maneuver

    truth = campaign["truth"]
    burn = Maneuver(truth.epoch + 2 * u.h, 0 * u.s, 0 * u.kg, "RTN", [0, 1e-3, 0] * u.km / u.s)
    start = OPM.from_state(truth, object_name="SAT-1", maneuvers=[burn])
    obs = vv.od.simulate_tracking(truth, list(_stations().values()),
                                  truth.epoch + np.arange(0, 6 * 3600, 30) * u.s,
                                  [vv.J2(vv.EARTH)], maneuvers=start.burns(), seed=11)
    tdm, first, out = tmp_path / "b.tdm", tmp_path / "first.opm", tmp_path / "out.opm"
    vv.write_tdm(obs, tdm, participant="SAT-1")
    vv.write_opm(start, first)
    code, text, err = _run(capsys, str(tdm), *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                           "--initial", str(first), "--opm", str(out))
    assert code == 0, err
    assert "0 rejected" in text
    opm0 = vv.read_opm(first)
    fit = vv.fit_orbit(vv.read_tdm(tdm).to_observations(_stations(), SIGMA), opm0.state,
                       [vv.J2(vv.EARTH)], maneuvers=opm0.burns())
    back = vv.read_opm(out)
    np.testing.assert_allclose(back.state.r.to_value(u.km), fit.state.r.to_value(u.km),
                               rtol=0, atol=1e-9)
    assert np.linalg.norm(back.state.r.to_value(u.km) - truth.r.to_value(u.km)) < 0.05
    (m,) = back.maneuvers
    assert abs((m.epoch - burn.epoch).to_value(u.s)) < 1e-6 and m.frame == "RTN"
    np.testing.assert_allclose(m.delta_v.to_value(u.km / u.s), [0, 1e-3, 0], atol=1e-15)


def test_two_tdm_files_kvn_and_xml_are_one_data_set(campaign, tmp_path, capsys):
    tdm = vv.read_tdm(campaign["tdm"])
    half = len(tdm.segments) // 2
    kvn, xml = tmp_path / "a.tdm", tmp_path / "b.xml"
    vv.write_tdm(type(tdm)(tdm.header, tdm.segments[:half]), kvn)
    vv.write_tdm(type(tdm)(tdm.header, tdm.segments[half:]), xml)
    assert xml.read_text().lstrip().startswith("<")
    one, two = tmp_path / "one.opm", tmp_path / "two.opm"
    args = [*STATION_ARGS, *SIGMA_ARG, "--force", "j2", "--opm"]
    assert _run(capsys, campaign["tdm"], *args, str(one))[0] == 0
    code, out, err = _run(capsys, str(kvn), str(xml), *args, str(two))
    assert code == 0, err
    assert f"{len(campaign['obs'])} observations" in out
    np.testing.assert_array_equal(vv.read_opm(one).state.r.value, vv.read_opm(two).state.r.value)


def test_initial_oem_is_interpolated_at_the_first_observation(campaign, tmp_path, capsys):
    from visviva.ccsds.oem import OEMSegment

    truth, obs = campaign["truth"], campaign["obs"]
    t = truth.epoch + np.arange(0, 7 * 3600, 120) * u.s
    run = vv.propagate_cowell(truth, t, [vv.J2(vv.EARTH)])
    seg = OEMSegment.from_states(t, run.r.to_value(u.km) + 0.5, run.v.to_value(u.km / u.s),
                                 object_name="SAT-1")  # 0.5 km off on each axis
    oem = tmp_path / "guess.oem"
    vv.write_oem(seg, oem)
    opm = tmp_path / "o.opm"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--initial", str(oem), "--opm", str(opm))
    assert code == 0, err
    first = vv.read_oem(oem).interpolate(obs.times[0])
    fit = vv.fit_orbit(obs, first, [vv.J2(vv.EARTH)])
    np.testing.assert_allclose(vv.read_opm(opm).state.r.to_value(u.km),
                               fit.state.r.to_value(u.km), rtol=0, atol=1e-9)
    # an ephemeris that does not reach the data is refused, naming the first observation
    late = OEMSegment.from_states(t[60:], run.r.to_value(u.km)[60:],
                                  run.v.to_value(u.km / u.s)[60:], object_name="SAT-1")
    vv.write_oem(late, tmp_path / "late.oem")
    code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--initial",
                        str(tmp_path / "late.oem"))
    assert code == 2 and "does not cover the first observation" in err


def test_opm_covariance_in_rtn_is_rotated_to_inertial(campaign, tmp_path, capsys):
    """An a priori covariance given in RTN (COV_REF_FRAME = RTN) is the same uncertainty as
    its GCRF rotation: the filter started from either gives the same estimate."""
    from visviva._covariance import to_local
    from visviva.ccsds.covariance import values_from_matrix
    from visviva.ccsds.grammar import Record
    from visviva.core.local_frames import FRAME_CODES

    gcrf = tmp_path / "gcrf.opm"
    code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                        "--opm", str(gcrf))
    assert code == 0, err
    msg = vv.read_opm(gcrf)
    inflated = msg.covariance * 1e4  # (a looser a priori than the fit's own)
    msg.sections["covariance"] = Record(values=values_from_matrix(inflated))
    vv.write_opm(msg, gcrf)
    r, v = msg.state.r.to_value(u.km), msg.state.v.to_value(u.km / u.s)
    rtn = vv.read_opm(gcrf)
    rtn.sections["covariance"] = Record(values={
        "COV_REF_FRAME": "RTN",
        **values_from_matrix(to_local(np.asarray(inflated), r, v, FRAME_CODES["RTN"]))})
    vv.write_opm(rtn, tmp_path / "rtn.opm")
    assert "COV_REF_FRAME" in (tmp_path / "rtn.opm").read_text()
    states = []
    for name in ("gcrf", "rtn"):
        out = tmp_path / f"{name}_out.opm"
        code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                            "--initial", str(tmp_path / f"{name}.opm"), "--filter", "ekf",
                            "--opm", str(out))
        assert code == 0, err
        states.append(vv.read_opm(out))
    np.testing.assert_allclose(states[0].state.r.to_value(u.km),
                               states[1].state.r.to_value(u.km), rtol=0, atol=1e-6)
    np.testing.assert_allclose(states[0].covariance, states[1].covariance, rtol=1e-6)


def test_filter_ekf_ends_at_the_last_observation(campaign, tmp_path, capsys):
    opm = tmp_path / "f.opm"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--filter", "ekf", "--opm", str(opm))
    assert code == 0, err
    assert "EKF" in out
    msg = vv.read_opm(opm)
    last = campaign["obs"].times[-1]
    assert abs((msg.epoch - last).to_value(u.s)) < 1e-6
    err_km = msg.state.r.to_value(u.km) - _truth_at(campaign, last)
    sigma_km = np.sqrt(np.trace(msg.covariance[:3, :3]))
    assert np.linalg.norm(err_km) < max(5 * sigma_km, 0.02)


def test_smoothed_ukf_from_a_later_opm_with_an_ephemeris(campaign, tmp_path, capsys):
    """An OPM after the first observation is carried back to it (state and covariance); the
    smoothed estimate is there, and the OEM starts from it with its covariance."""
    first = tmp_path / "first.opm"
    code, _, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                        "--opm", str(first))
    assert code == 0, err
    t_first = campaign["obs"].times[0]
    assert (vv.read_opm(first).epoch - t_first).to_value(u.s) > 0
    opm, oem = tmp_path / "s.opm", tmp_path / "s.oem"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--initial", str(first), "--filter", "ukf", "--smooth", "--opm",
                          str(opm), "--oem", str(oem), "--span", "1h", "--step", "30min")
    assert code == 0, err
    assert "UKF + RTS smoother" in out and "carried back to the first observation" in out
    msg = vv.read_opm(opm)
    assert abs((msg.epoch - t_first).to_value(u.s)) < 1e-6
    err_km = msg.state.r.to_value(u.km) - _truth_at(campaign, t_first)
    sigma_km = np.sqrt(np.trace(msg.covariance[:3, :3]))
    assert np.linalg.norm(err_km) < max(5 * sigma_km, 0.02)
    seg = vv.read_oem(oem).segments[0]
    assert len(seg.times) == 3 and len(seg.covariances) == 3
    np.testing.assert_allclose(seg.states.r.to_value(u.km)[0], msg.state.r.to_value(u.km),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(seg.covariances[0].matrix, msg.covariance, rtol=1e-12)
    # the propagated covariance stays positive definite
    assert np.all(np.linalg.eigvalsh(seg.covariances[-1].matrix) > 0)


@settings(max_examples=40, deadline=None)
@given(value=st.floats(1e-6, 1e6), unit=st.sampled_from(["m", "km", "cm", "mm"]))
def test_sigma_parsing_keeps_the_unit(value, unit):
    from visviva.od.cli_inputs import parse_sigmas

    got = parse_sigmas([f"range={value!r}{unit}"])["range"]
    assert got.to_value(u.km) == pytest.approx((value * u.Unit(unit)).to_value(u.km), rel=1e-15)


def test_refusals_are_one_line_with_exit_code_2(campaign, tmp_path, capsys):
    tdm = campaign["tdm"]
    base = [*STATION_ARGS, *SIGMA_ARG]
    cases = [
        ([str(tmp_path / "nope.tdm"), *base], "nope.tdm"),
        ([tdm, *STATION_ARGS, "--sigma", "range=5"], "has no unit"),
        ([tdm, *STATION_ARGS, "--sigma", "range=5m/s"], "is not a length"),
        ([tdm, *STATION_ARGS, "--sigma", "range=five m"], "not a number with a unit"),
        ([tdm, *STATION_ARGS, "--sigma", "rnage=5m"], "KIND=VALUE"),
        ([tdm, *STATION_ARGS, "--sigma", "range=-5m"], "> 0"),
        ([tdm, *STATION_ARGS, "--sigma", "range=10m,angle=0.01deg"], "range_rate=1mm/s"),
        ([tdm, *STATION_ARGS, "--sigma", "range=10m,doppler=1cm/s"], "ANGLE_TYPE = AZEL"),
        ([tdm, *SIGMA_ARG], "--station"),
        ([tdm, "--station", "COLORADO=40", *SIGMA_ARG], "NAME=LAT,LON"),
        ([tdm, "--station", "ELSEWHERE=1,2,3", *SIGMA_ARG], "--station COLORADO="),
        ([tdm, *base, "--force", "j3"], "not a force model"),
        ([tdm, *base, "--estimate", "drag"], "--force drag:"),
        ([tdm, *base, "--smooth"], "--filter"),
        ([tdm, *base, "--force", "drag:0.01", "--estimate", "drag", "--filter", "ekf"],
         "a priori"),
        ([tdm, *base, "--force", "drag:0.01", "--estimate", "drag:-1"], "> 0"),
        ([tdm, *base, "--oem", str(tmp_path / "x.oem"), "--span", "2"], "--span"),
        ([tdm, *base, "--opm", tdm], "is the input file"),
        ([tdm, *base, "--opm", str(tmp_path / "a"), "--oem", str(tmp_path / "a")],
         "given as two outputs"),
        ([tdm, *base, "--oem", str(tmp_path / "x.oem"), "--span", "1h", "--step", "2h"],
         "longer than --span"),
        ([tdm, *base, "--initial", str(tmp_path / "missing.opm")], "missing.opm"),
    ]
    for argv, text in cases:
        code, out, err = _run(capsys, *argv)
        assert code == 2, (argv, err)
        assert text in err, (argv, err)
        assert err.startswith("visviva od: ") and err.count("\n") == 1, err
        assert out == ""


def test_an_initial_state_about_another_body_is_bad_input(campaign, tmp_path, capsys):
    # audit20: a Moon-centred OPM as --initial exited 1 ("the orbit determination failed"),
    # as a fit that did not converge; it is bad input (exit 2) naming the file
    from visviva.ccsds.opm import OPM

    moon = vv.StateVectors([2000.0, 0, 0] * u.km, [0, 1.5, 0] * u.km / u.s, vv.MOON,
                           epoch=Time("2024-03-01T00:10:00", scale="utc"))
    path = tmp_path / "moon.opm"
    vv.write_opm(OPM.from_state(moon, object_name="LRO", center="MOON", frame="EME2000"), path)
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--initial",
                          str(path))
    assert code == 2 and "moon.opm: the state is centred on the Moon" in err and out == ""


def test_existing_output_needs_overwrite(campaign, tmp_path, capsys):
    opm = tmp_path / "o.opm"
    opm.write_text("keep me")
    argv = [campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2", "--opm", str(opm)]
    code, _, err = _run(capsys, *argv)
    assert code == 2 and "--overwrite" in err
    assert opm.read_text() == "keep me"
    code, _, err = _run(capsys, *argv, "--overwrite")
    assert code == 0, err
    assert vv.read_opm(opm).covariance is not None


def test_no_usable_rows(tmp_path, capsys):
    text = "\n".join([
        "CCSDS_TDM_VERS = 2.0", "CREATION_DATE = 2024-03-01T00:00:00", "ORIGINATOR = TEST", "",
        "META_START", "TIME_SYSTEM = UTC", "PARTICIPANT_1 = COLORADO", "PARTICIPANT_2 = SAT-1",
        "MODE = SEQUENTIAL", "PATH = 1,2,1", "META_STOP", "DATA_START",
        "RECEIVE_FREQ_1 = 2024-03-01T00:13:00 2.2e9", "DATA_STOP", ""])
    tdm = tmp_path / "freq.tdm"
    tdm.write_text(text)
    code, _, err = _run(capsys, str(tdm), *STATION_ARGS, *SIGMA_ARG)
    assert code == 2
    assert "no measurement" in err and "RECEIVE_FREQ_1" in err


def test_a_fit_that_does_not_converge_exits_1(campaign, monkeypatch, capsys):
    from visviva.errors import ConvergenceError
    from visviva.od import batch

    def diverge(*args, **kwargs):
        raise ConvergenceError("the orbit fit did not converge in 2 iterations (RMS by "
                               "iteration: 1: rms 1e6; 2: rms 1e9)")

    monkeypatch.setattr(batch, "fit_orbit", diverge)
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG)
    assert code == 1 and out == ""
    assert err.startswith("visviva od: the orbit fit did not converge") and err.count("\n") == 1


def test_filter_with_process_and_gauss_markov_noise(campaign, tmp_path, capsys):
    """--process-noise Q,FRAME and --parameter-noise drag:SIGMA,TAU reach filter_orbit: the
    command reports the B that filter_orbit(process_noise=, parameter_noise=) gives, which is
    not the B of the filter without them."""

    forces, truth, obs, tdm, first = _drag_tracking(campaign, tmp_path, 3, 60, seed=8)
    opm = tmp_path / "out.opm"
    code, out, err = _run(capsys, str(tdm), *STATION_ARGS, *SIGMA_ARG, "--initial", str(first),
                          "--force", "j2,drag:0.015", "--estimate", "drag:0.01", "--filter",
                          "ekf", "--apriori", "100m,10cm/s", "--process-noise", "1e-13,TNW",
                          "--parameter-noise", "drag:0.004,2h", "--opm", str(opm))
    assert code == 0, err
    obs = vv.read_tdm(tdm).to_observations(_stations(), SIGMA)
    p0 = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    kw = {"estimate": "drag", "parameter_sigma": {"drag": 0.01 * u.m**2 / u.kg}}
    start = [forces[0], vv.AtmosphericDrag(0.015 * u.m**2 / u.kg)]
    f = vv.filter_orbit(obs, vv.read_opm(first).state, p0, start, process_noise=1e-13,
                        process_noise_frame="TNW", **kw,
                        parameter_noise={"drag": (0.004 * u.m**2 / u.kg, 2 * u.hour)})
    plain = vv.filter_orbit(obs, vv.read_opm(first).state, p0, start, **kw)
    b = f.parameters["drag"].to_value(u.m**2 / u.kg)[-1]
    sb = f.parameter_sigma["drag"].to_value(u.m**2 / u.kg)[-1]
    assert f"drag B      {b:.6g} +- {sb:.2g} m^2/kg" in out
    assert ("EKF, process noise 1e-13 km^2/s^3 TNW, drag Gauss-Markov sigma 0.004 m^2/kg "
            "tau 7200 s") in out
    assert abs(b - 0.02) < 4 * sb
    # the noise left the coefficient less certain than the constant-B filter
    assert sb > 1.2 * plain.parameter_sigma["drag"].to_value(u.m**2 / u.kg)[-1]
    np.testing.assert_allclose(vv.read_opm(opm).state.r.to_value(u.km),
                               f.state.r.to_value(u.km), rtol=0, atol=1e-6)


def test_noise_options_are_refused_with_exit_code_2(campaign, capsys):
    base = [campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2,drag:0.01"]
    ekf = ["--filter", "ekf"]
    cases = [
        (["--process-noise", "1e-12"], "goes with --filter"),
        (["--estimate", "drag:0.01", "--parameter-noise", "drag:0.001,3h"], "goes with --filter"),
        ([*ekf, "--process-noise", "lots"], "spectral density"),
        ([*ekf, "--process-noise=-1e-12"], "spectral density"),
        ([*ekf, "--process-noise", "0"], "not all zero"),
        ([*ekf, "--process-noise", "1e-12:1e-12"], "three joined by ':'"),
        ([*ekf, "--process-noise", "1e-12,XYZ"], "frame must be RTN"),
        ([*ekf, "--parameter-noise", "drag:0.001,3h"], "'drag' is not estimated"),
        ([*ekf, "--estimate", "drag:0.01", "--parameter-noise", "drag:0.001"],
         "NAME:SIGMA,TAU"),
        ([*ekf, "--estimate", "drag:0.01", "--parameter-noise", "drag:0.001,3"], "has no unit"),
        ([*ekf, "--estimate", "drag:0.01", "--parameter-noise", "drag:-1,3h"], ">= 0"),
        ([*ekf, "--estimate", "drag:0.01", "--parameter-noise", "drag:0.001,3m"],
         "is not a time"),
        ([*ekf, "--estimate", "drag:0.01", "--parameter-noise", "drag:0.001,1h",
          "--parameter-noise", "drag:0.002,1h"], "twice"),
    ]
    for argv, text in cases:
        code, out, err = _run(capsys, *base, *argv)
        assert code == 2, (argv, err)
        assert text in err, (argv, err)
        assert err.startswith("visviva od: ") and err.count("\n") == 1, err


def test_troposphere_flag_fits_as_the_library_does(campaign, tmp_path, capsys):
    # --troposphere: the observations modelled with the standard atmosphere at each station,
    # the same estimate as fit_orbit on to_observations(..., troposphere=True)
    opm = tmp_path / "t.opm"
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--troposphere", "--opm", str(opm))
    assert code == 0, err
    obs = vv.read_tdm(campaign["tdm"]).to_observations(_stations(), SIGMA, troposphere=True)
    assert obs.troposphere is not None
    fit = vv.fit_orbit(obs, None, [vv.J2(vv.EARTH)])
    np.testing.assert_allclose(vv.read_opm(opm).state.r.to_value(u.km),
                               fit.state.r.to_value(u.km), rtol=0, atol=1e-9)
    # the data hold no delay: modelling one moves the orbit by metres, not kilometres
    plain = vv.fit_orbit(campaign["obs"], None, [vv.J2(vv.EARTH)])
    shift = np.linalg.norm((fit.state.r - plain.state.r).to_value(u.km))
    assert 1e-4 < shift < 0.1
    # --refraction radio: the AZEL rows bent by the radio model, as troposphere={"refraction":
    # "radio"} in the library; without --troposphere it is refused
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG, "--force", "j2",
                          "--troposphere", "--refraction", "radio", "--opm", str(opm),
                          "--overwrite")
    assert code == 0, err
    obs = vv.read_tdm(campaign["tdm"]).to_observations(_stations(), SIGMA,
                                                       troposphere={"refraction": "radio"})
    assert obs.troposphere.refraction == "radio"
    radio = vv.fit_orbit(obs, None, [vv.J2(vv.EARTH)])
    np.testing.assert_allclose(vv.read_opm(opm).state.r.to_value(u.km),
                               radio.state.r.to_value(u.km), rtol=0, atol=1e-9)
    moved = np.linalg.norm((radio.state.r - fit.state.r).to_value(u.km))
    assert moved > 1e-6  # 2.8 mm: the metre-level range rows dominate the 36-arcsec angles
    code, out, err = _run(capsys, campaign["tdm"], *STATION_ARGS, *SIGMA_ARG,
                          "--refraction", "radio")
    assert code == 2 and "add --troposphere" in err


def test_initial_file_of_one_objects_history_starts_from_the_set_nearest_the_data(tmp_path):
    # audit49: a space-track history file (several sets of the one object) was refused
    # ("holds 3 element sets; give a file with the one object tracked"); the first guess is now
    # the set nearest the first observation, and sets of two objects are still refused
    from visviva.od.cli_inputs import read_initial

    iss = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", "ISS")
    sets = [vv.Satellite.from_omm({**iss.to_omm(), "EPOCH": f"2024-01-0{d}T12:00:00",
                                   "OBJECT_ID": "1998-067A"}) for d in (1, 3, 5)]
    path = tmp_path / "history.tle"
    path.write_text("".join(f"ISS\n{a}\n{b}\n" for a, b in (s.to_tle() for s in sets)))
    first = Time("2024-01-03T18:00:00", scale="utc")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (not "screening pairs such an object with itself")
        guess = read_initial(path, first)
    want = sets[1].gcrs(first).r.to_value(u.km)
    assert np.abs(guess["state"].r.to_value(u.km) - want).max() < ONE_MM
    assert guess["object_id"] == "1998-067A" and guess["name"] == "ISS"
    other = vv.Satellite.from_omm({**sets[0].to_omm(), "NORAD_CAT_ID": 25545})
    path.write_text("".join(f"X\n{a}\n{b}\n" for a, b in (s.to_tle() for s in (iss, other))))
    with pytest.raises(vv.InvalidInputError, match="element sets of 2 objects"):
        read_initial(path, first)


def test_star_reduced_radec_is_fitted_as_such_with_radec_reference(tmp_path, capsys):
    # audit59: visviva od had no way to read a TDM's RADEC as astrometry reduced against
    # catalogue stars (radec_reference="stars"): such 2-arcsec LEO data were fitted as the
    # natural GCRS direction, ~80 m from the truth at a formal 4 m, without a word. Now
    # --radec-reference stars fits them as read_tdm(...).to_observations(radec_reference=
    # "stars") does, and RADEC data without the option get a warning naming it
    epoch = Time("2024-03-01T00:00:00", scale="utc")
    truth = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.05, 5.75] * u.km / u.s,
                            vv.EARTH, epoch=epoch)
    stations = _stations()
    grid = epoch + np.arange(0, 6 * 3600, 60) * u.s
    obs = vv.od.simulate_tracking(truth, list(stations.values()), grid,
                                  measurements={"radec": 2.0 * u.arcsec}, seed=3,
                                  radec_reference="stars")
    assert obs.radec_reference == "stars"
    tdm = tmp_path / "optical.tdm"
    vv.write_tdm(obs, tdm, participant="SAT-1")
    argv = [str(tdm), *STATION_ARGS, "--sigma", "angle=2arcsec", "--opm"]
    code, _, err = _run(capsys, *argv, str(tmp_path / "gcrs.opm"))
    assert code == 0 and "--radec-reference stars" in err
    code, _, err = _run(capsys, *argv, str(tmp_path / "stars.opm"), "--radec-reference", "stars")
    assert code == 0 and "radec-reference" not in err
    errors = {}
    for name in ("gcrs", "stars"):
        opm = vv.read_opm(tmp_path / f"{name}.opm")
        true_r = vv.propagate_cowell(truth, opm.state.epoch, []).r.to_value(u.km).reshape(3)
        errors[name] = np.linalg.norm(opm.state.r.to_value(u.km) - true_r)
    assert errors["gcrs"] > 0.03  # km: the 20 arcsec the natural direction leaves out
    assert errors["stars"] < 0.015  # km: a few formal sigmas (4 m)
    want = vv.fit_orbit(vv.read_tdm(tdm).to_observations(
        stations, {"radec": 2.0 * u.arcsec}, radec_reference="stars"),
        vv.read_opm(tmp_path / "stars.opm").state)
    assert np.linalg.norm((want.state.r - vv.read_opm(tmp_path / "stars.opm").state.r)
                          .to_value(u.km)) < 1e-3
