"""Screening of numerically propagated ephemerides (Cowell) against brute-force sampling."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from test_conjunctions_screening import brute_force_minima
from visviva.conjunctions.synthetic import synthetic_catalog
from visviva.errors import InvalidInputError

HOURS = 2.0
THRESHOLD = 20.0  # km


def _cowell_runs(cat):
    """The catalogue's TEME states at its first epoch run by Cowell (J2): 30 s and 1 s outputs."""
    t0 = cat.epochs[0]
    teme = [s.teme(t0) for s in cat]
    r = np.array([x.r.to_value(u.km) for x in teme])
    v = np.array([x.v.to_value(u.km / u.s) for x in teme])
    state = vv.StateVectors(r * u.km, v * u.km / u.s, vv.EARTH.gm, epoch=t0)
    span = HOURS * 3600.0
    # the ephemerides screened: 30 s outputs; the brute force: 1 s outputs of the same run
    coarse = vv.propagate_cowell(state, np.arange(0.0, span + 1, 30.0) * u.s, [vv.J2()])
    fine = vv.propagate_cowell(state, np.arange(0.0, span + 1, 1.0) * u.s, [vv.J2()])
    return t0, coarse, fine


@pytest.fixture(scope="module")
def setup():
    return _cowell_runs(synthetic_catalog(14, seed=5, crossing_pairs=4))


def _brute(fine):
    return brute_force_minima(fine.r.to_value(u.km), fine.t.to_value(u.s), THRESHOLD)


def test_cowell_screen_misses_nothing_one_second_sampling_finds(setup):
    t0, coarse, fine = setup
    tab = vv.screen_conjunctions(coarse, None, t0, t0 + HOURS * u.hour,
                                 threshold=THRESHOLD * u.km)
    brute = _brute(fine)
    assert len(brute) >= 4  # the crossing pairs meet
    tca_s = (tab["tca"] - t0).to_value(u.s)
    miss = tab["miss_distance"].to_value(u.km)
    for i, j, t, dmin in brute:
        sel = (tab["index1"] == i) & (tab["index2"] == j) & (np.abs(tca_s - t) <= 1.0)
        assert sel.sum() == 1, (i, j, t, dmin)
        # the refined minimum (on the Hermite interpolant of 30 s outputs) is never above a
        # sampled distance by more than the interpolation error (~1 m at 30 s in LEO)
        assert miss[sel][0] <= dmin + 2e-3
    assert len(tab) == len(brute)
    assert list(tab["object1"][:1]) == [f"primaries[{int(tab['index1'][0])}]"]


def test_tca_and_miss_agree_with_the_dense_ephemeris(setup):
    t0, coarse, fine = setup
    tab = vv.screen_conjunctions(coarse, None, t0, t0 + HOURS * u.hour,
                                 threshold=THRESHOLD * u.km)
    r = fine.r.to_value(u.km)
    v = fine.v.to_value(u.km / u.s)
    for row in tab:
        i, j = int(row["index1"]), int(row["index2"])
        t = float((row["tca"] - t0).to_value(u.s))
        k = int(round(t))
        # the range rate of the dense (1 s) ephemeris changes sign within 1 s of the TCA
        g = [float(np.dot(r[j, m] - r[i, m], v[j, m] - v[i, m])) for m in (k - 1, k + 1)]
        assert g[0] <= 0.0 <= g[1]
        d = np.linalg.norm(r[j, k] - r[i, k])
        assert row["miss_distance"].to_value(u.km) <= d + 2e-3


def test_lists_and_state_histories_are_accepted(setup):
    t0, coarse, _ = setup
    tab = vv.screen_conjunctions(coarse, None, t0, t0 + HOURS * u.hour,
                                 threshold=THRESHOLD * u.km)
    i, j = int(tab["index1"][0]), int(tab["index2"][0])
    # a StateVectors history per object (absolute epochs), primary against a list
    hist = [vv.StateVectors(coarse.r[n], coarse.v[n], vv.EARTH.gm, epoch=t0 + coarse.t)
            for n in (i, j)]
    one = vv.screen_conjunctions(hist[0], [hist[1]], t0, t0 + HOURS * u.hour,
                                 threshold=THRESHOLD * u.km)
    expect = tab[(tab["index1"] == i) & (tab["index2"] == j)]
    assert len(one) == len(expect)
    assert np.allclose(one["miss_distance"].to_value(u.km),
                       expect["miss_distance"].to_value(u.km), atol=1e-9)


def test_bad_ephemerides_are_refused(setup):
    t0, coarse, _ = setup
    with pytest.raises(InvalidInputError, match="does not cover"):
        vv.screen_conjunctions(coarse, None, t0, t0 + 3 * HOURS * u.hour)
    cat = synthetic_catalog(2, seed=1)
    with pytest.raises(InvalidInputError, match="different frames"):
        vv.screen_conjunctions(cat, coarse, t0, t0 + 1 * u.hour)
    with pytest.raises(InvalidInputError, match="CowellResult"):
        vv.screen_conjunctions(np.zeros(3), None, t0, t0 + 1 * u.hour)


def test_satellite_state_histories_are_screened_in_one_frame():
    # sat1.teme(t) against sat2.gcrs(t) compared positions 40 km apart by frame alone: a 3.4 km
    # approach was missed with no error
    cat = synthetic_catalog(4, seed=2, crossing_pairs=1)
    t0 = cat.epochs[0]
    t = t0 + np.arange(0, 7201, 30) * u.s
    a, b = cat[4], cat[5]
    sgp4 = vv.screen_conjunctions(a, b, t0, t0 + 2 * u.hour, threshold=20 * u.km)
    assert len(sgp4) == 1
    for frame in ("gcrs", "teme"):
        tab = vv.screen_conjunctions(getattr(a, frame)(t), getattr(b, frame)(t), t0,
                                     t0 + 2 * u.hour, threshold=20 * u.km)
        assert len(tab) == 1
        assert abs(tab["tca"][0] - sgp4["tca"][0]) < 0.01 * u.s
        assert abs(tab["miss_distance"][0] - sgp4["miss_distance"][0]) < 1 * u.m
    with pytest.raises(InvalidInputError, match="TEME.*GCRS"):
        vv.screen_conjunctions(a.teme(t), b.gcrs(t), t0, t0 + 2 * u.hour)
    with pytest.raises(InvalidInputError, match="GCRS and TEME are mixed"):
        vv.screen_conjunctions([a.teme(t), b.gcrs(t)], None, t0, t0 + 2 * u.hour)
    with pytest.raises(InvalidInputError, match="ITRS"):
        vv.screen_conjunctions(a.itrs(t), b.itrs(t), t0, t0 + 2 * u.hour)


def test_oem_ephemerides_are_screened(tmp_path):
    # an OEM (vv.read_oem) was refused ("must be a Satellite, a Catalog, a CowellResult, ...")
    from visviva.ccsds.oem import OEMSegment

    cat = synthetic_catalog(4, seed=2, crossing_pairs=1)
    t0 = cat.epochs[0]
    t = t0 + np.arange(0, 7201, 30) * u.s
    a, b = cat[4], cat[5]
    oems = []
    for sat, frame in ((a, "GCRF"), (b, "EME2000")):
        # (GCRS states: written in EME2000 with the frame bias, read back on the GCRS axes)
        seg = OEMSegment.from_states(sat.gcrs(t), object_name=sat.name, frame=frame)
        oems.append(vv.read_oem(vv.write_oem(seg)))
    ref = vv.screen_conjunctions(a.gcrs(t), b.gcrs(t), t0, t0 + 2 * u.hour, threshold=20 * u.km)
    tab = vv.screen_conjunctions(oems[0], oems[1], t0, t0 + 2 * u.hour, threshold=20 * u.km)
    assert len(tab) == len(ref) == 1
    assert abs(tab["miss_distance"][0] - ref["miss_distance"][0]) < 1 * u.mm
    with pytest.raises(InvalidInputError, match="TEME.*GCRS|GCRS.*TEME"):
        vv.screen_conjunctions(oems[0], b.teme(t), t0, t0 + 2 * u.hour)


def test_tca_of_ephemerides_across_a_leap_second():
    """Ephemeris offsets are SI seconds from t0: a TCA after 2016-12-31T23:59:60 was put 1 s
    late (UTC Julian-day arithmetic) while miss distances stayed right."""
    t0, coarse, fine = _cowell_runs(
        synthetic_catalog(6, seed=0, crossing_pairs=3, epoch="2016-12-31T23:30:00"))
    tab = vv.screen_conjunctions(coarse, None, t0, t0 + HOURS * u.hour,
                                 threshold=THRESHOLD * u.km)
    rf, vf = fine.r.to_value(u.km), fine.v.to_value(u.km / u.s)
    after = 0
    for row in tab:
        i, j = int(row["index1"]), int(row["index2"])
        t = float((row["tca"] - t0).to_value(u.s))
        k = int(np.floor(t))
        # the range rate of the dense ephemeris is linear over a second: its zero is the TCA
        g = [float(np.dot(rf[j, m] - rf[i, m], vf[j, m] - vf[i, m])) for m in (k, k + 1)]
        t_dense = k + g[0] / (g[0] - g[1])
        assert abs(t - t_dense) < 0.01
        after += row["tca"] > Time("2016-12-31T23:59:60", scale="utc")
    assert after >= 1  # some approaches come after the leap second


def test_an_oem_against_a_tle_catalogue_is_refused_with_the_recipe_that_works(tmp_path):
    # audit54: an operator's OEM against a TLE catalogue (the usual owner/operator screening)
    # was refused as "different frames" naming no way to do it; the message now gives the
    # recipe (sample the SGP4 objects in the ephemeris frame), and the recipe finds the
    # approach the SGP4 screen finds (TCA to 10 ms, miss to 1 m)
    from visviva.ccsds.oem import OEMSegment

    cat = synthetic_catalog(4, seed=2, crossing_pairs=1)
    t0 = cat.epochs[0]
    t = t0 + np.arange(0, 7201, 30) * u.s
    a = cat[4]
    oem = vv.read_oem(vv.write_oem(OEMSegment.from_states(a.gcrs(t), object_name=a.name)))
    others = vv.Catalog([s for k, s in enumerate(cat) if k != 4])
    with pytest.raises(InvalidInputError, match=r"sample them.*\[sat\.gcrs\(t\) for sat in"):
        vv.screen_conjunctions(oem, others, t0, t0 + 2 * u.hour, threshold=20 * u.km)
    with pytest.raises(InvalidInputError, match=r"as the primaries"):
        vv.screen_conjunctions(others, oem, t0, t0 + 2 * u.hour, threshold=20 * u.km)
    ref = vv.screen_conjunctions(a, others, t0, t0 + 2 * u.hour, threshold=20 * u.km)
    tab = vv.screen_conjunctions(oem, [sat.gcrs(t) for sat in others], t0, t0 + 2 * u.hour,
                                 threshold=20 * u.km)
    assert len(tab) == len(ref) == 1
    assert abs(tab["tca"][0] - ref["tca"][0]) < 0.01 * u.s
    assert abs(tab["miss_distance"][0] - ref["miss_distance"][0]) < 1 * u.m
