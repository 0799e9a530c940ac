"""A TDM's own frequencies for the ionosphere's delay (``TDM.to_observations(ionosphere=...)``):
TRANSMIT_FREQ_n / RECEIVE_FREQ_n (+ FREQ_OFFSET), the turnaround ratio, the last line at or
before each row, the two-way delay (uplink and downlink each at its frequency), KVN and XML,
and the refusals (frequency_hz more than 1 % off, a Doppler shift without its offset, half a
turnaround ratio, no frequency at all)."""

import re
import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.ccsds.grammar import CCSDSFormatError
from visviva.errors import TrackingDataWarning
from visviva.od import simulate_observations, simulate_tracking
from visviva.od.ionosphere import K_GROUP, TECU, two_way_frequency_hz, vtec_mapping

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
Y0 = np.array([6878.0, 0.0, 0.0, 0.0, 4.7, 5.9])  # 500 km, i = 51.5 deg
TRUTH = vv.StateVectors(Y0[:3] * u.km, Y0[3:] * KMS, vv.EARTH, epoch=EPOCH)
SITE = vv.GroundStation(40 * u.deg, -10 * u.deg, 100 * u.m, name="SITE")
IONO = {"vtec_tecu": 30.0}
SIGMA = {"range": 2 * u.m, "range_rate": 1 * u.mm / u.s}
F_UP = 2_110_243_000.0  # an S-band uplink, Hz
F_DOWN = F_UP * 240 / 221  # its coherent downlink (2291.6 MHz)


@pytest.fixture(scope="module")
def plan():
    """A pass of range and range rate from SITE (exact, no ionosphere)."""
    grid = EPOCH + np.arange(0, 86400, 30.0) * u.s
    return simulate_tracking(TRUTH, [SITE], grid, seed=False, min_elevation=5 * u.deg,
                             measurements={"range": 0.002, "range_rate": 1e-6})


def _kvn(obs, data, meta=(), frequency_hz=None):
    """KVN of ``obs`` (written with the ionosphere at the rows' frequency_hz) with extra data
    lines ``data`` [(keyword, Time, value)] and metadata lines ``meta``."""
    delayed = simulate_observations(TRUTH, obs.times, list(obs.kinds), list(obs.sigmas),
                                    obs.stations, seed=False, ionosphere=IONO,
                                    frequency_hz=frequency_hz)
    text = vv.write_tdm(delayed)
    head, rest = text.split("DATA_START\n")
    body, tail = rest.split("DATA_STOP")
    lines = body.strip("\n").split("\n")
    lines += [f"{k:<21} = {t.utc.isot}000000 {v!r}" for k, t, v in data]
    lines.sort(key=lambda ln: ln.split("=")[1].split()[0])  # by epoch, stable
    head = head.replace("META_STOP", "".join(f"{m}\n" for m in meta) + "META_STOP")
    return head + "DATA_START\n" + "\n".join(lines) + "\nDATA_STOP" + tail


def _line_of(text, start):
    return next(i for i, ln in enumerate(text.split("\n"), 1) if ln.startswith(start))


def test_two_way_delay_is_the_mean_of_the_legs(plan):
    # the two-way range's delay = 0.5 * 40.3 TEC (1/f_up^2 + 1/f_down^2) m(E), by hand
    rng = plan.kinds == "range"
    t, st = plan.times[rng], [s for s, k in zip(plan.stations, plan.kinds, strict=True)
                              if k == "range"]
    n = len(t)
    f = two_way_frequency_hz(F_UP, F_DOWN)
    assert F_UP < f < F_DOWN
    with_iono = simulate_observations(TRUTH, t, "range", 0.001, st, seed=False,
                                      ionosphere=IONO, frequency_hz=[f] * n)
    plain = simulate_observations(TRUTH, t, "range", 0.001, st, seed=False)
    el = simulate_observations(TRUTH, t, "azel", 1e-9, st, seed=False).values[:, 1]
    m, _ = vtec_mapping(el)
    hand = 0.5 * K_GROUP * 30 * TECU * (1 / F_UP**2 + 1 / F_DOWN**2) * m  # m
    np.testing.assert_allclose((with_iono.values[:, 0] - plain.values[:, 0]) * 1e3, hand,
                               rtol=2e-4)


def test_kvn_transmit_freq_with_the_turnaround_ratio(plan):
    # uplink lines at the pass's start and middle (the uplink retuned by 1 MHz), the ratio
    # 240/221: every range/Doppler row is delayed at the two-way frequency of the line at or
    # before it, and the table equals the data written with those frequencies
    t0, tm = plan.times[0], plan.times[len(plan) // 2]
    f2 = F_UP + 1e6
    row_up = np.where((plan.times - tm).sec >= 0, f2, F_UP)
    want = two_way_frequency_hz(row_up, row_up * 240 / 221)
    text = _kvn(plan, [("TRANSMIT_FREQ_1", t0, F_UP), ("TRANSMIT_FREQ_1", tm, f2)],
                ["TURNAROUND_NUMERATOR = 240", "TURNAROUND_DENOMINATOR = 221"], want)
    tdm = vv.read_tdm(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the frequency lines are used: nothing unread
        read = tdm.to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)
    np.testing.assert_allclose(read.ionosphere.frequency_hz, want, rtol=1e-15)
    np.testing.assert_allclose(read.values, simulate_observations(
        TRUTH, read.times, list(read.kinds), list(read.sigmas), read.stations, seed=False,
        ionosphere=IONO, frequency_hz=read.ionosphere.frequency_hz).values, rtol=0, atol=1e-8)  # km: 10 um (times round-tripped through text)
    # without the ionosphere the lines are read but not used, as before
    with pytest.warns(TrackingDataWarning, match=r"TRANSMIT_FREQ_1 \(2\)"):
        plain = tdm.to_observations({"SITE": SITE}, SIGMA)
    assert plain.ionosphere is None
    # frequency_hz agreeing within 1 % (the downlink, or the two-way value) is accepted...
    for hz in (F_DOWN, float(want[0]), 2.29 * u.GHz):
        ok = tdm.to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO, frequency_hz=hz)
        np.testing.assert_allclose(ok.ionosphere.frequency_hz, want, rtol=1e-15)
    # ...one 5 % off is refused, naming the frequency line used
    n = _line_of(text, "TRANSMIT_FREQ_1")
    with pytest.raises(CCSDSFormatError, match=rf"line {n}: TRANSMIT_FREQ_1 .* more than 1%"):
        tdm.to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO, frequency_hz=2.4e9)


def test_kvn_receive_freq_is_freq_offset_plus_the_value(plan):
    # RECEIVE_FREQ_1 written as offsets from FREQ_OFFSET = 2.2 GHz (a Doppler-like residual
    # of +57 kHz and -48 kHz); no uplink lines and no ratio: the link is at that frequency
    # both ways. Rows before the first line take the first.
    t1, t2 = plan.times[3], plan.times[len(plan) // 3]
    offset = 2.2e9
    sec = (plan.times - t2).sec
    want = np.where(sec >= 0, offset - 48_000.5, offset + 57_000.25)
    text = _kvn(plan, [("RECEIVE_FREQ_1", t1, 57_000.25), ("RECEIVE_FREQ_1", t2, -48_000.5)],
                [f"FREQ_OFFSET = {offset!r}"], want)
    read = vv.read_tdm(text).to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)
    np.testing.assert_allclose(read.ionosphere.frequency_hz, want, rtol=1e-15)
    # the same lines without FREQ_OFFSET read as 57 kHz: not a carrier, refused naming it
    bare = _kvn(plan, [("RECEIVE_FREQ_1", t1, 57_000.25)], [], want)
    with pytest.raises(CCSDSFormatError, match=r"FREQ_OFFSET") as e:
        vv.read_tdm(bare).to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)
    assert f"line {_line_of(bare, 'RECEIVE_FREQ_1')}" in str(e.value)


def test_xml_frequencies_and_refusals(plan, tmp_path):
    t0 = plan.times[0]
    want = np.full(len(plan), two_way_frequency_hz(F_UP, F_DOWN))
    delayed = simulate_observations(TRUTH, plan.times, list(plan.kinds), list(plan.sigmas),
                                    plan.stations, seed=False, ionosphere=IONO,
                                    frequency_hz=want)
    xml = vv.write_tdm(delayed, format="xml")
    obs = (f"<observation><EPOCH>{t0.utc.isot}000000</EPOCH>"
           f"<TRANSMIT_FREQ_1>{F_UP!r}</TRANSMIT_FREQ_1></observation>"
           f"<observation><EPOCH>{t0.utc.isot}000000</EPOCH>"
           f"<RECEIVE_FREQ_1>{F_DOWN - 2.0e9!r}</RECEIVE_FREQ_1></observation>")
    xml = xml.replace("<data>", "<data>" + obs, 1).replace(
        "</metadata>", "<FREQ_OFFSET>2.0e9</FREQ_OFFSET></metadata>", 1)
    path = tmp_path / "link.xml"
    path.write_text(xml)
    read = vv.read_tdm(path).to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)
    np.testing.assert_allclose(read.ionosphere.frequency_hz, want, rtol=1e-12)
    np.testing.assert_allclose(read.values, simulate_observations(
        TRUTH, read.times, list(read.kinds), list(read.sigmas), read.stations, seed=False,
        ionosphere=IONO, frequency_hz=want).values, rtol=0, atol=1e-8)  # km: 10 um (times round-tripped through text)
    # half a turnaround ratio is refused
    half = xml.replace("</metadata>", "<TURNAROUND_NUMERATOR>240</TURNAROUND_NUMERATOR>"
                       "</metadata>", 1)
    with pytest.raises(CCSDSFormatError, match="TURNAROUND_DENOMINATOR"):
        vv.read_tdm(half).to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)


def test_no_frequency_anywhere_is_refused_and_frequency_hz_still_serves(plan):
    text = vv.write_tdm(plan)
    tdm = vv.read_tdm(text)
    with pytest.raises(vv.InvalidInputError, match=re.escape("give frequency_hz")):
        tdm.to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)
    read = tdm.to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO, frequency_hz=2.2e9)
    assert read.ionosphere.frequency_hz == 2.2e9  # one number, as before


def test_the_cli_takes_the_tdm_frequencies_without_frequency(plan, tmp_path, capsys):
    # visviva od --ionosphere without --frequency: the TDM's lines give it, and the fit is
    # fit_orbit's on to_observations(ionosphere=); a TDM without lines still needs --frequency
    from visviva import cli
    from visviva.ccsds.opm import OPM

    want = np.full(len(plan), two_way_frequency_hz(F_UP, F_DOWN))
    text = _kvn(plan, [("TRANSMIT_FREQ_1", plan.times[0], F_UP)],
                ["TURNAROUND_NUMERATOR = 240", "TURNAROUND_DENOMINATOR = 221"], want)
    tdm = tmp_path / "link.tdm"
    tdm.write_text(text)
    guess = vv.StateVectors((Y0[:3] + [0.2, -0.1, 0.1]) * u.km, (Y0[3:] + 2e-4) * KMS,
                            vv.EARTH, epoch=EPOCH)
    first = tmp_path / "guess.opm"
    vv.write_opm(OPM.from_state(guess, object_name="SAT-1"), first)
    read = vv.read_tdm(tdm).to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO)
    fit = vv.fit_orbit(read, vv.read_opm(first).state)
    opm = tmp_path / "fit.opm"
    args = ["od", str(tdm), "--station", "SITE=40,-10,100", "--sigma",
            "range=2m,range_rate=1mm/s", "--initial", str(first), "--ionosphere", "vtec=30"]
    code = cli.main([*args, "--opm", str(opm)])
    assert code == 0, capsys.readouterr().err
    np.testing.assert_allclose(vv.read_opm(opm).state.r.to_value(u.km),
                               fit.state.r.to_value(u.km), rtol=0, atol=1e-9)
    plain = tmp_path / "plain.tdm"
    vv.write_tdm(plan, plain)
    capsys.readouterr()
    code = cli.main(["od", str(plain), *args[2:], "--opm", str(tmp_path / "x.opm")])
    assert code == 2 and "--frequency" in capsys.readouterr().err


def test_a_segment_without_lines_takes_frequency_hz(plan):
    # segment 1 with an uplink line, segment 2 without: its rows are at frequency_hz
    half = len(plan) // 2
    a, b = [vv.Observations(time=plan.times[s], kind=list(plan.kinds[s]),
                            value=[plan.values[i, :1] for i in range(len(plan))[s]],
                            sigma=list(plan.sigmas[s]), station=plan.stations[s])
            for s in (slice(0, half), slice(half, None))]
    f_a = two_way_frequency_hz(F_UP, F_DOWN)
    text = _kvn(a, [("TRANSMIT_FREQ_1", a.times[0], F_UP)],
                ["TURNAROUND_NUMERATOR = 240", "TURNAROUND_DENOMINATOR = 221"],
                np.full(len(a), f_a))
    text += "\n" + _kvn(b, [], [], F_DOWN).split("\n\n", 1)[1]  # its segment only
    read = vv.read_tdm(text).to_observations({"SITE": SITE}, SIGMA, ionosphere=IONO,
                                             frequency_hz=F_DOWN)
    expected = np.where((read.times - b.times[0]).sec >= 0, F_DOWN, f_a)
    np.testing.assert_allclose(read.ionosphere.frequency_hz, expected, rtol=1e-15)


@settings(max_examples=200, deadline=None)
@given(st.floats(1e8, 4e10), st.floats(0.5, 2.0))
def test_two_way_frequency_lies_between_the_legs(f_up, ratio):
    f_down = f_up * ratio
    f = two_way_frequency_hz(f_up, f_down)
    assert min(f_up, f_down) * (1 - 1e-12) <= f <= max(f_up, f_down) * (1 + 1e-12)
    assert 1 / f**2 == pytest.approx(0.5 / f_up**2 + 0.5 / f_down**2, rel=1e-12)
    assert two_way_frequency_hz(f_up, f_up) == pytest.approx(f_up, rel=1e-15)


def test_a_filter_s_rows_keep_their_own_frequencies(plan):
    # light_time.model on a subset of rows (as the filters call it) uses those rows'
    # frequencies: equal to the whole table's prediction at those rows
    from visviva.od.light_time import model

    f = np.linspace(2.0e9, 8.4e9, len(plan))
    obs = simulate_observations(TRUTH, plan.times, list(plan.kinds), list(plan.sigmas),
                                plan.stations, seed=False, ionosphere=IONO, frequency_hz=f)
    sec = (plan.times - EPOCH).sec
    once, back = np.unique(sec, return_inverse=True)
    sv = vv.propagate_cowell(TRUTH, EPOCH + once * u.s, [])
    r, v = sv.r.to_value(u.km), sv.v.to_value(KMS)
    y = (np.c_[r.T, v.T] if r.shape[0] == 3 and r.shape[1] != 3 else np.c_[r, v])[back]
    gm = vv.EARTH.gm_km3_s2
    whole, _ = model(obs, y, gm)
    rows = np.arange(len(obs))[5::7]
    part, _ = model(obs, y[rows], gm, rows=rows)
    np.testing.assert_allclose(part, whole[rows], rtol=0, atol=1e-12)
    # and the rows differ as 1/f^2: the high-frequency rows carry less delay
    assert not np.allclose(whole, model(simulate_observations(
        TRUTH, plan.times, list(plan.kinds), list(plan.sigmas), plan.stations, seed=False,
        ionosphere=IONO, frequency_hz=2.0e9), y, gm)[0], rtol=0, atol=1e-6)


def test_uplink_ramp_transmit_freq_rate_moves_the_frequency():
    # 503.0-B-2 3.5.2: TRANSMIT_FREQ_RATE_n is the linear rate of change of TRANSMIT_FREQ_n
    # from its epoch to the next rate line. Uplink at t: the line's value + the integrated rate.
    from visviva.od.link_frequencies import link_frequencies

    text = ("CCSDS_TDM_VERS = 2.0\nCREATION_DATE = 2024-045T12:00:00\nORIGINATOR = TESTS\n"
            "META_START\nTIME_SYSTEM = UTC\nPARTICIPANT_1 = SITE\nPARTICIPANT_2 = SAT\n"
            "MODE = SEQUENTIAL\nPATH = 1,2,1\nTURNAROUND_NUMERATOR = 240\n"
            "TURNAROUND_DENOMINATOR = 221\nMETA_STOP\nDATA_START\n"
            f"TRANSMIT_FREQ_1 = 2024-03-01T00:00:00 {F_UP!r}\n"
            "TRANSMIT_FREQ_RATE_1 = 2024-03-01T00:00:00 100.0\n"
            "RANGE = 2024-03-01T00:00:30 1000.0\n"
            "TRANSMIT_FREQ_RATE_1 = 2024-03-01T00:01:00 -50.0\n"
            "RANGE = 2024-03-01T00:01:30 1000.0\n"
            f"TRANSMIT_FREQ_1 = 2024-03-01T00:02:00 {F_UP + 1e6!r}\n"
            "RANGE = 2024-03-01T00:02:10 1000.0\nDATA_STOP\n")
    seg = vv.read_tdm(text).segments[0]
    rows = np.flatnonzero(np.array(seg.keywords) == "RANGE")
    f, used = link_frequencies(seg, 1, 2, rows, None, "test")
    up = np.array([F_UP + 100 * 30, F_UP + 100 * 60 - 50 * 30, F_UP + 1e6 - 50 * 10])
    np.testing.assert_allclose(f, two_way_frequency_hz(up, up * 240 / 221), rtol=1e-15)
    assert "TRANSMIT_FREQ_RATE_1" in used  # read, so not in the unused warning
    # ignored: the frequency lines as written
    f0, used0 = link_frequencies(seg, 1, 2, rows, None, "test", ignore=("TRANSMIT_FREQ_RATE_1",))
    up0 = np.array([F_UP, F_UP, F_UP + 1e6])
    np.testing.assert_allclose(f0, two_way_frequency_hz(up0, up0 * 240 / 221), rtol=1e-15)
    assert "TRANSMIT_FREQ_RATE_1" not in used0
