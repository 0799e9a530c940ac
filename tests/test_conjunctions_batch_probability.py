"""vv.collision_probabilities: K conjunctions at once, bit for bit K scalar calls.

The reference is ``collision_probability`` itself, row by row (the batch shares its encounter
plane, CARA clip, repair rule and accuracy checks, and runs the same compiled integral); the
cases are random LEO geometries, NASA CARA's Omitron cases (PcCircle and Pc3D_Hall unit tests)
and Alfano's (2009) cases 1-11.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from test_conjunctions_alfano import CASES
from test_conjunctions_probability import (
    NPD_CASE,
    OM_C1,
    OM_C2,
    OM_PC,
    OM_R1,
    OM_R2,
    OM_V1,
    OM_V2,
)
from visviva.conjunctions import CovarianceRepairWarning, collision_probabilities
from visviva.errors import ChanAccuracyWarning, InvalidInputError, Pc2dAccuracyWarning, ShapeError
from visviva.validation.checks_conjunctions import om8_args


def _random(k, seed=1, at_tca=True, six=False):
    """K LEO-like conjunctions (m, m/s, m^2): miss ~300 m, sigmas ~100 m, HBR 5-50 m."""
    rng = np.random.default_rng(seed)
    r1 = np.array([7.0e6, 0.0, 0.0]) + rng.normal(0.0, 1e3, (k, 3))
    v1 = np.array([0.0, 7.5e3, 0.0]) + rng.normal(0.0, 10.0, (k, 3))
    v2 = np.array([0.0, 0.0, 7.5e3]) + rng.normal(0.0, 500.0, (k, 3))
    d = rng.normal(0.0, 300.0, (k, 3))
    rel = v1 - v2
    if at_tca:  # r1 - r2 normal to the relative velocity
        d -= (np.sum(d * rel, 1) / np.sum(rel * rel, 1))[:, None] * rel
    a = rng.normal(0.0, 100.0, (2, k, 3, 3))
    covs = a @ np.swapaxes(a, -1, -2) + np.eye(3) * 1e-2
    if six:  # 6x6 with exact velocities (a velocity spread would call 3D-Nc, 0.1-60 s a row)
        covs = np.pad(covs, ((0, 0), (0, 0), (0, 3), (0, 3)))
    hbr = rng.uniform(5.0, 50.0, k)
    return r1, v1, covs[0], r1 - d, v2, covs[1], hbr


def _scalar(args, method="foster", log=False, **kw):
    """The K scalar values and the warnings they raised."""
    k = len(args[0])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = [vv.collision_probability(*(a[i] for a in args), method=method, log=log, **kw)
               for i in range(k)]
    return np.array(out), caught


@pytest.mark.parametrize("method", ["foster", "chan"])
@pytest.mark.parametrize("six", [False, True])
def test_random_rows_equal_the_scalar_calls_bit_for_bit(method, six):
    args = _random(40, seed=2 if six else 3, six=six)
    ref, _ = _scalar(args, method=method)
    lref, _ = _scalar(args, method=method, log=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = collision_probabilities(*args, method=method)
        lgot = collision_probabilities(*args, method=method, log=True)
    assert got.shape == lgot.shape == (40,)
    assert np.array_equal(got, ref)
    assert np.array_equal(lgot, lref)
    assert np.all((ref > 1e-12) & (ref < 1))  # the geometry makes all Pc non-trivial


def test_broadcast_covariance_and_radius_and_hbr_zero_and_inf():
    r1, v1, c1, r2, v2, c2, _ = _random(6, seed=4)
    hbr = np.array([0.0, 10.0, math.inf, 30.0, 0.0, 20.0])
    got = collision_probabilities(r1, v1, c1[0], r2, v2, c2, hbr)
    for i in range(6):
        assert got[i] == vv.collision_probability(r1[i], v1[i], c1[0], r2[i], v2[i], c2[i],
                                                  hbr[i])
    assert got[0] == got[4] == 0.0 and got[2] == 1.0
    one = collision_probabilities(r1, v1, c1, r2, v2, c2, 15.0)  # one HBR for all rows
    assert one[3] == vv.collision_probability(r1[3], v1[3], c1[3], r2[3], v2[3], c2[3], 15.0)


def test_cara_omitron_cases_with_quantities_and_in_a_stack():
    # PcCircle Omitron case 1 (km, km^2, HBR 20 m) and the Pc3D_Hall Omitron Test08 case, whose
    # 2-D value 2.3e-20 the velocity-spread check flags against 3D-Nc's 1.9e-5
    om8 = om8_args()
    r1 = np.stack([OM_R1 * 1e3, om8[0]]) * u.m
    v1 = np.stack([OM_V1 * 1e3, om8[1]]) * u.m / u.s
    r2 = np.stack([OM_R2 * 1e3, om8[3]]) * u.m
    v2 = np.stack([OM_V2 * 1e3, om8[4]]) * u.m / u.s

    def six(c):
        out = np.zeros((6, 6))
        out[:3, :3] = c * 1e6
        return out

    c1 = np.stack([six(OM_C1), om8[2]]) * u.m**2
    c2 = np.stack([six(OM_C2), om8[5]]) * u.m**2
    with pytest.warns(Pc2dAccuracyWarning, match=r"1 of 2 conjunctions \(row 1\)") as rec:
        got = collision_probabilities(r1, v1, c1, r2, v2, c2, 20 * u.m)
    assert len([w for w in rec if w.category is Pc2dAccuracyWarning]) == 1
    assert got[0] == pytest.approx(OM_PC, rel=1e-10)
    assert got[1] == pytest.approx(2.2660816e-20, rel=1e-5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert got[1] == vv.collision_probability(*om8)
    assert got[0] == vv.collision_probability(
        OM_R1 * u.km, OM_V1 * u.km / u.s, OM_C1 * u.km**2, OM_R2 * u.km, OM_V2 * u.km / u.s,
        OM_C2 * u.km**2, 20 * u.m)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["foster", "chan"])
def test_alfano_cases_1_to_11_equal_the_scalar_calls(method):
    # case 12 has no relative velocity (refused: test_bad_rows_are_named); cases 1, 2, 4 and
    # 10 are flagged by CARA's usage indicators and checked against 3D-Nc (1-3 s in all)
    cases = [CASES[i] for i in range(1, 12)]
    args = [np.stack([c[key] for c in cases]) for key in ("r1", "v1", "c1", "r2", "v2", "c2",
                                                          "hbr")]
    ref, caught = _scalar(args, method=method)
    with warnings.catch_warnings(record=True) as got_w:
        warnings.simplefilter("always")
        got = collision_probabilities(*args, method=method)
    assert np.array_equal(got, ref)
    kinds = {w.category for w in caught}
    assert sorted(k.__name__ for k in kinds) == sorted(w.category.__name__ for w in got_w)
    assert len(got_w) == len(kinds)  # one warning per kind
    flagged = [w for w in got_w if w.category is Pc2dAccuracyWarning][0]
    n = sum(w.category is Pc2dAccuracyWarning for w in caught)  # the flagged cases 1, 2, 4 ...
    assert n >= 4 and f"{n} of 11 conjunctions (rows 0, 1, 3, " in str(flagged.message)


def test_warnings_are_gathered_one_per_kind():
    # 30 rows off TCA (0.05 s at ~10 km/s): one Pc2dAccuracyWarning naming 30 rows, not 30
    args = _random(30, seed=5, at_tca=False)
    ref, caught = _scalar(args)
    assert sum(w.category is Pc2dAccuracyWarning for w in caught) >= 20
    n = sum(w.category is Pc2dAccuracyWarning for w in caught)
    with warnings.catch_warnings(record=True) as got_w:
        warnings.simplefilter("always")
        got = collision_probabilities(*args)
    assert np.array_equal(got, ref)
    assert len(got_w) == 1 and got_w[0].category is Pc2dAccuracyWarning
    assert f"{n} of 30 conjunctions (rows " in str(got_w[0].message)
    assert ", ...)" in str(got_w[0].message)


def test_repair_and_chan_warnings_name_their_rows():
    r1, v1, c1, r2, v2, c2 = NPD_CASE  # CARA's non-positive-definite case, as row 2 of 4
    good = _random(4, seed=6)
    stack = [np.stack([g[0], g[1], x, g[3]]) for g, x in zip(
        [good[0], good[1], good[2], good[3], good[4], good[5]], [r1, v1, c1, r2, v2, c2],
        strict=True)]
    with pytest.warns(CovarianceRepairWarning, match=r"1 of 4 conjunctions \(row 2\)"):
        got = collision_probabilities(*stack, 10.0)
    with pytest.warns(CovarianceRepairWarning):
        assert got[2] == vv.collision_probability(r1, v1, c1, r2, v2, c2, 10.0)
    # Chan off by more than 10 % (a thin covariance, HBR beside the minor sigma)
    thin = np.diag([1e6, 1e6, 1.0])
    with pytest.warns(ChanAccuracyWarning, match=r"of 3 conjunctions"):
        collision_probabilities(good[0][:3], [0.0, 7.5e3, 0.0], thin, good[0][:3]
                                + [0.0, 0.0, 5.0], [7.5e3, 0.0, 0.0], thin, 20.0,
                                method="chan")


def test_bad_rows_are_named():
    args = list(_random(8, seed=7))
    bad = [a.copy() for a in args]
    bad[0][5, 1] = np.nan
    with pytest.raises(InvalidInputError, match=r"r1: row 5 "):
        collision_probabilities(*bad)
    bad = [a.copy() for a in args]
    bad[2][3, 0, 0] = np.inf
    bad[2][6, 1, 1] = np.nan
    with pytest.raises(InvalidInputError, match=r"cov1: rows 3, 6 "):
        collision_probabilities(*bad)
    bad = [a.copy() for a in args]
    bad[6][4] = -1.0
    with pytest.raises(InvalidInputError, match=r"hard_body_radius: row 4 .*negative"):
        collision_probabilities(*bad)
    bad[6][4] = np.nan
    with pytest.raises(InvalidInputError, match=r"hard_body_radius: row 4 are NaN|row 4"):
        collision_probabilities(*bad)
    bad = [a.copy() for a in args]
    bad[4][7] = bad[1][7]  # no relative velocity (Alfano's case 12)
    with pytest.raises(InvalidInputError, match=r"row 7: the relative velocity is zero"):
        collision_probabilities(*bad)
    with pytest.raises(ShapeError, match="one length K"):
        collision_probabilities(*args[:3], args[3][:5], *args[4:])
    with pytest.raises(ShapeError, match=r"\(K, 3\)"):
        collision_probabilities(args[0][:, :2], *args[1:])
    with pytest.raises(InvalidInputError, match="loop over"):
        collision_probabilities(*args, method="pc3d_hall")


def test_exported_and_compiled_by_warmup():
    import visviva.conjunctions as conj
    from visviva.core import collision as kern

    assert vv.collision_probabilities is conj.collision_probabilities
    x = np.array([10.0, 300.0])
    out = np.empty(2)
    kern.log_pc_chan_many(x, x, np.array([100.0, 50.0]), np.array([60.0, 40.0]),
                          np.array([5.0, 20.0]), out)
    for i in range(2):
        assert out[i] == kern.log_pc_chan(x[i], x[i], [100.0, 50.0][i], [60.0, 40.0][i],
                                          [5.0, 20.0][i])


def test_rtn_labelled_covariances_are_refused_like_the_scalar_function():
    # propagate_covariance(..., output_frame="RTN") labels its matrix; taken for inertial it
    # gives a wrong Pc (audit52 refused it in collision_probability; the batch must too)
    from visviva._covariance import km_covariance

    c = km_covariance(np.diag([1e-4, 1e-2, 1e-4, 1e-8, 1e-8, 1e-8]), "RTN")
    r1 = np.array([7000e3, 0.0, 0.0])
    v1 = np.array([0.0, 7.5e3, 0.0])
    with pytest.raises(vv.errors.InvalidInputError, match="RTN axes"):
        vv.collision_probabilities(r1, v1, c, r1 + 100.0, [0.0, 0.0, 7.5e3], c, 20.0)


def _gate_rows(k, seed):
    """K conjunctions that straddle check_2d's gate: LEO and GEO-slow rows, 6x6 covariances
    with velocity terms from zero to large, states at and off TCA (m, m/s, m^2)."""
    rng = np.random.default_rng(seed)
    r1, v1, c1, r2, v2, c2, hbr = _random(k, seed=seed, six=True)
    slow = rng.random(k) < 0.3  # GEO pairs drifting at cm/s .. m/s
    r1[slow] = [4.2164e7, 0.0, 0.0]
    v1[slow] = [0.0, 3074.7, 0.0]
    v2[slow] = v1[slow] + rng.normal(0.0, 1.0, (int(slow.sum()), 3)) * 10.0 ** rng.uniform(
        -2, 0.5, (int(slow.sum()), 1))
    r2[slow] = r1[slow] + rng.normal(0.0, 300.0, (int(slow.sum()), 3))
    for c in (c1, c2):
        scale = 10.0 ** rng.uniform(-8, 0, k)
        b = rng.normal(0.0, 1.0, (k, 3, 3))
        c[:, 3:, 3:] = (b @ np.swapaxes(b, 1, 2)) * scale[:, None, None]
        c[:, :3, 3:] = c[:, 3:, :3] = 0.0
    return r1, v1, c1, r2, v2, c2, hbr


def test_only_the_rows_the_stacked_gates_keep_run_the_scalar_checks(monkeypatch):
    # audit54: every row ran the scalar accuracy checks (Coppola bounds, velocity spread, TCA
    # and unit checks: ~0.3 ms a row in numpy calls on 3-vectors, 3.5 of the 5.9 s at K =
    # 10,000 LEO rows at TCA); now stacked gates keep the rows that may warn, and only those
    # run the scalar checks. Silent rows never reach them.
    from visviva.conjunctions import batch_probability as bp

    calls = {"check_2d": 0, "check_tca": 0, "warn_km_as_metres": 0}
    for name in calls:
        real = getattr(bp, name)

        def counted(*a, _real=real, _name=name, **kw):
            calls[_name] += 1
            return _real(*a, **kw)

        monkeypatch.setattr(bp, name, counted)
    args = _random(300, seed=11, six=True)
    ref, caught = _scalar(args)
    assert not caught
    got = collision_probabilities(*args)
    assert np.array_equal(got, ref)
    assert calls == {"check_2d": 0, "check_tca": 0, "warn_km_as_metres": 0}


@pytest.mark.parametrize("seed", [21, 22])
def test_the_stacked_gates_keep_every_row_the_scalar_checks_flag(seed):
    # the gates must never drop a row whose scalar check goes on to 3D-Nc or warns: each
    # indicator of check_2d, computed by the scalar functions, against the stacked mask
    from visviva.conjunctions.accuracy import (
        EXTENDED_LIMIT,
        OFFSET_LIMIT,
        SPREAD_LIMIT,
        linear_encounter_bounds,
        velocity_spread,
    )
    from visviva.conjunctions.batch_checks import short_encounter_rows

    r1, v1, c1, r2, v2, c2, hbr = _gate_rows(400, seed)
    gm = 3.986004418e14
    mask = short_encounter_rows(r1, v1, c1, r2, v2, c2, hbr, gm)
    flagged = []
    for i in range(len(hbr)):
        b = linear_encounter_bounds(r1[i], v1[i], c1[i], r2[i], v2[i], c2[i], hbr[i], gm)
        if b is None:
            continue
        drop = velocity_spread(r1[i], v1[i], c1[i], r2[i], v2[i], c2[i], hbr[i], b[2], b[3])
        flagged.append(b[0] > EXTENDED_LIMIT or b[1] > OFFSET_LIMIT or drop > SPREAD_LIMIT)
        assert mask[i] or not flagged[-1], i
    flagged = np.array(flagged)
    assert 40 < flagged.sum() < len(flagged) - 40  # both sides of the gate are exercised
    assert mask.sum() <= flagged.sum() + 2  # and the gate keeps little more


@pytest.mark.slow
def test_gated_rows_give_the_scalar_warnings_bit_for_bit():
    # GEO-slow rows with velocity covariances (3D-Nc compared) beside silent LEO rows and
    # rows off TCA: values and the gathered warnings are the scalar calls'
    args = list(_gate_rows(12, 23))
    args[3][::5] += (args[1][::5] - args[4][::5]) * 0.05  # 0.05 s off TCA
    ref, caught = _scalar(args)
    with warnings.catch_warnings(record=True) as got_w:
        warnings.simplefilter("always")
        got = collision_probabilities(*args)
    assert np.array_equal(got, ref)
    assert sorted({w.category.__name__ for w in caught}) == sorted(
        w.category.__name__ for w in got_w)
    rows = []
    for i in range(12):
        _, one = _scalar([a[i:i + 1] for a in args])
        if any(w.category is Pc2dAccuracyWarning for w in one):
            rows.append(str(i))
    flagged = [w for w in got_w if w.category is Pc2dAccuracyWarning]
    assert len(rows) >= 2
    assert f"{len(rows)} of 12 conjunctions (rows {', '.join(rows[:5])}" in str(
        flagged[0].message)
