"""Ephemerides too coarse for the screening's cubic Hermite interpolation are flagged (audit 36).

The screening interpolates each ephemeris with the cubic Hermite polynomial of the two samples
around a time; its error grows as the fourth power of the spacing. An OEM or a Cowell run with
outputs every 300 s in LEO (common in exchanged ephemerides, which name a higher-order
interpolation) was screened with ~200 m errors in the miss distances while the docs promise
1 m, without a word. The truth here is independent: exact two-body (Kepler) propagation of the
same initial states, the minimum found by a bounded scalar search.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from astropy import units as u
from scipy.optimize import minimize_scalar

import visviva as vv
from visviva.conjunctions.sources import interpolation_error_km
from visviva.conjunctions.synthetic import synthetic_catalog
from visviva.core.universal import propagate_one

SPAN = 7200.0
GM = vv.EARTH.gm.to_value(u.km ** 3 / u.s ** 2)


@pytest.fixture(scope="module")
def pair():
    """Two objects built to cross (TEME states at the epoch: inertial, two-body motion)."""
    cat = synthetic_catalog(0, seed=3, crossing_pairs=1)
    t0 = cat.epochs[0]
    teme = [s.teme(t0) for s in cat]
    r = np.array([x.r.to_value(u.km) for x in teme])
    v = np.array([x.v.to_value(u.km / u.s) for x in teme])
    return t0, r, v


def _ephemeris(t0, r, v, step, offset=0.0):
    """Cowell (two-body) outputs every ``step`` s from ``t0 - offset``."""
    if offset:
        moved = [], []
        for r0, v0 in zip(r, v, strict=True):
            rr, vv_ = np.empty(3), np.empty(3)
            propagate_one(r0, v0, GM, -offset, rr, vv_)
            moved[0].append(rr)
            moved[1].append(vv_)
        r, v = np.array(moved[0]), np.array(moved[1])
    state = vv.StateVectors(r * u.km, v * u.km / u.s, vv.EARTH.gm, epoch=t0 - offset * u.s)
    return vv.propagate_cowell(state, np.arange(0.0, SPAN + 2 * step + 1, step) * u.s, [],
                               rtol=1e-12)


def _kepler(r0, v0, t):
    rr, vv_ = np.empty(3), np.empty(3)
    propagate_one(r0, v0, GM, float(t), rr, vv_)
    return rr


def _true_minimum(r, v, t_guess):
    def dist(t):
        return float(np.linalg.norm(_kepler(r[1], v[1], t) - _kepler(r[0], v[0], t)))

    res = minimize_scalar(dist, bounds=(t_guess - 30.0, t_guess + 30.0), method="bounded",
                          options={"xatol": 1e-6})
    return float(res.x), float(res.fun)


def _screen(t0, primaries, secondaries):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        tab = vv.screen_conjunctions(primaries, secondaries, t0, t0 + SPAN * u.s,
                                     threshold=50 * u.km)
    coarse = [w for w in record if "too coarsely" in str(w.message)]
    return tab, coarse


def _worst_miss_error(tab, t0, r, v):
    worst = 0.0
    for row in tab:
        t = float((row["tca"] - t0).to_value(u.s))
        t_true, d_true = _true_minimum(r, v, t)
        assert abs(t - t_true) < 0.05
        worst = max(worst, abs(row["miss_distance"].to_value(u.km) - d_true))
    return worst


def test_fine_ephemerides_give_tca_and_miss_of_exact_two_body_motion(pair):
    # two ephemerides on different time grids (30 s, the second shifted by 15 s)
    t0, r, v = pair
    tab, coarse = _screen(t0, _ephemeris(t0, r[:1], v[:1], 30.0),
                          _ephemeris(t0, r[1:], v[1:], 30.0, offset=15.0))
    assert not coarse and len(tab) == 2
    for row in tab:
        t = float((row["tca"] - t0).to_value(u.s))
        t_true, d_true = _true_minimum(r, v, t)
        assert abs(t - t_true) < 1e-3  # s
        assert abs(row["miss_distance"].to_value(u.km) - d_true) < 1e-3  # 1 m


def test_coarse_ephemerides_are_flagged_with_their_error(pair):
    # 300 s outputs, the second file's grid shifted by 150 s: the miss distance of the
    # 6.68 km approach came out 6.72 km (38.5 m off; 1.7 km off at 600 s) without a word
    t0, r, v = pair
    tab, coarse = _screen(t0, _ephemeris(t0, r[:1], v[:1], 300.0),
                          _ephemeris(t0, r[1:], v[1:], 300.0, offset=150.0))
    assert len(coarse) == 2  # primaries and secondaries
    text = str(coarse[0].message)
    assert "every 300 s" in text and "primaries[0]" in text
    assert coarse[0].filename == __file__  # at the user's line
    assert _worst_miss_error(tab, t0, r, v) > 0.02  # km: what the warning is about


@pytest.mark.parametrize("step, true_m", [(60.0, 0.353), (180.0, 28.6), (300.0, 220.0)])
def test_error_estimate_against_the_measured_interpolation_error(step, true_m):
    # a circular-ish LEO orbit: the skip-one estimate against the largest error of the
    # interpolant measured on a 2,001-point grid against Kepler's propagation
    from visviva.conjunctions.sources import SampledSource

    r0, v0 = np.array([6878.0, 0.0, 0.0]), np.array([0.0, 7.6126, 0.5])
    tau = np.arange(0.0, SPAN + step, step)
    rs = np.array([_kepler(r0, v0, t) for t in tau])
    vs = np.array([(_kepler(r0, v0, t + 1e-3) - _kepler(r0, v0, t - 1e-3)) / 2e-3
                   for t in tau])
    ts = np.linspace(0.0, SPAN, 2001)
    got, _ = SampledSource([tau], [rs], [vs], ["a"])._interp(0, ts)
    measured = max(np.linalg.norm(got[k] - _kepler(r0, v0, t)) for k, t in enumerate(ts))
    assert measured * 1e3 == pytest.approx(true_m, rel=0.05)
    est = interpolation_error_km(tau, rs, vs, SPAN)
    assert est == pytest.approx(measured, rel=0.1)


def test_oem_useable_span_must_cover_the_window(pair):
    # USEABLE_START_TIME / USEABLE_STOP_TIME: the states outside serve the interpolation at
    # the ends only (CCSDS 502.0-B-3); they were screened as the ephemeris without a word
    from visviva.ccsds.oem import OEMSegment
    from visviva.errors import InvalidInputError

    t0, r, v = pair
    oems = []
    for k in range(2):
        eph = _ephemeris(t0, r[k:k + 1], v[k:k + 1], 30.0)
        t = t0 + eph.t
        seg = OEMSegment.from_states(t, eph.r.to_value(u.km), eph.v.to_value(u.km / u.s),
                                     object_name=f"OBJ{k}", frame="GCRF")
        text = vv.write_oem(seg)
        start = (t0 + 600 * u.s).utc.isot
        stop = (t0 + 7000 * u.s).utc.isot
        lines = text.splitlines()
        at = next(i for i, line in enumerate(lines) if line.startswith("START_TIME"))
        lines[at + 1:at + 1] = [f"USEABLE_START_TIME = {start}", f"USEABLE_STOP_TIME = {stop}"]
        oems.append(vv.read_oem("\n".join(lines) + "\n"))
    with pytest.raises(InvalidInputError, match="useable from .* does not cover"):
        vv.screen_conjunctions(oems[0], oems[1], t0, t0 + SPAN * u.s, threshold=50 * u.km)
    # inside the useable span: screened as before (both approaches, exact two-body misses)
    tab = vv.screen_conjunctions(oems[0], oems[1], t0 + 600 * u.s, t0 + 7000 * u.s,
                                 threshold=50 * u.km)
    assert len(tab) == 2
    assert _worst_miss_error(tab, t0, r, v) < 1e-3
