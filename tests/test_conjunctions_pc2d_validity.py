"""The 2-D Pc methods checked where their short-encounter assumption fails (audit 36).

The encounter-plane methods (``"foster"``, ``"chan"``) take the relative motion as a straight
line through TCA. On slow encounters (GEO pairs drifting past each other at cm/s, formation
flight) that fails and, before, they returned 0.40x to 0.80x the two-body Monte Carlo value
without a word (Alfano's (2009) cases 1, 2, 4, 10; CARA's 1e8-trial Monte Carlo in
``tests/data/alfano2009_cara.csv``). NASA CARA's ``UsageViolationPc2D`` flags such encounters
with Coppola's (2012) straight-line time bounds: "Extended" (2 dtau / P) and "Offset"
(max(|t_a|, |t_b|) / P) above 0.01; flagged ones are now checked against Hall's 3D-Nc.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from scipy.special import erfc

import visviva as vv
from test_conjunctions_alfano import CASES, _args
from visviva.conjunctions import collision_probability
from visviva.conjunctions.accuracy import linear_encounter_bounds

GM_M = 3.986004418e14


def _pc_and_warnings(args, **kw):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        pc = collision_probability(*args, **kw)
    return pc, [w for w in record if issubclass(w.category, vv.Pc2dAccuracyWarning)]


@pytest.mark.parametrize("n", [1, 2, 4, 10])
def test_slow_encounter_2d_pc_warns_with_the_3d_nc_value(n):
    # before: no warning at all; the 2-D values are 0.68, 0.40, 0.67, 0.80 of CARA's MC
    c = CASES[n]
    pc, record = _pc_and_warnings(_args(c))
    assert pc == pytest.approx(c["cara_pc2d"], rel=1e-10)  # the value itself is unchanged
    assert abs(pc / c["cara_pc_mc"] - 1) > 0.15
    assert len(record) == 1
    text = str(record[0].message)
    assert "pc3d_hall" in text and "Extended" in text
    # the 3D-Nc value the message gives lies with CARA's two-body Monte Carlo (whole encounter)
    hall = float(re.search(r"of this conjunction gives ([0-9.e+-]+)", text).group(1))
    assert hall == pytest.approx(c["cara_pc_mc"], rel=2e-3)


def test_cara_omitron_case_where_velocity_uncertainty_spreads_the_encounter():
    # CARA's Pc3D_Hall_UnitTest Omitron case (tests/test_conjunctions_alfano.py): not slow
    # (Extended 5.6e-4, Offset 4.7e-3), but the velocity covariance lowers the smallest squared
    # Mahalanobis distance from 82 to 9.8; before: 2.27e-20 without a word, 3D-Nc 1.93e-5
    from visviva.conjunctions.accuracy import velocity_spread
    from visviva.validation.checks_conjunctions import om8_args

    args = om8_args()
    pc, record = _pc_and_warnings(args)
    assert pc == pytest.approx(2.2660816e-20, rel=1e-5)
    assert len(record) == 1
    text = str(record[0].message)
    hall = float(re.search(r"of this conjunction gives ([0-9.e+-]+)", text).group(1))
    assert hall == pytest.approx(1.9271201e-05, rel=2e-3)  # CARA's Pc3D_Hall
    ext, off, ta, tb = linear_encounter_bounds(*args, GM_M)
    assert ext < 0.01 and off < 0.01
    assert velocity_spread(*args, ta, tb) == pytest.approx(72.2, abs=0.5)


def test_slow_encounter_chan_warns_too():
    c = CASES[2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vv.ChanAccuracyWarning)
        _, record = _pc_and_warnings(_args(c), method="chan")
    assert len(record) == 1 and "method='chan'" in str(record[0].message)


def test_slow_encounter_monte_carlo_warns_too():
    # the plane it samples is the 2-D one: its estimate 0.0062 beside CARA's MC 0.0156
    c = CASES[2]
    pc, record = _pc_and_warnings(_args(c), method="monte_carlo", samples=100_000, seed=1)
    assert pc == pytest.approx(c["cara_pc2d"], rel=0.15)
    assert len(record) == 1 and "method='monte_carlo' samples" in str(record[0].message)


@pytest.mark.parametrize("n", [2, 4])
def test_position_only_covariances_are_compared_at_exact_velocities(n):
    # the 2-D values of these cases miss the velocity uncertainty that spreads the slow
    # encounter; without it (3x3 covariances: exact velocities) 3D-Nc agrees with them to 6 %
    c = CASES[n]
    args = (c["r1"], c["v1"], c["c1"][:3, :3], c["r2"], c["v2"], c["c2"][:3, :3], c["hbr"])
    pc, record = _pc_and_warnings(args)
    assert not record
    assert pc == pytest.approx(c["cara_pc2d"], rel=1e-10)


@pytest.mark.parametrize("n", [3, 5, 6, 7, 8])
def test_2d_pc_close_to_3d_nc_does_not_warn(n):
    # 3, 5: short encounters (not flagged); 6, 7, 8: flagged by the indicators, but the 2-D
    # value is within 5 % of the 3D-Nc one (and of CARA's MC)
    c = CASES[n]
    pc, record = _pc_and_warnings(_args(c))
    assert not record
    assert pc == pytest.approx(c["cara_pc_mc"], rel=0.05)


def test_fast_leo_encounter_pays_nothing(monkeypatch):
    # CARA's Omitron case (docs/conjunctions.md): 14.5 km/s, Extended ~ 1e-4: no 3D-Nc call
    from visviva.conjunctions import nc3d

    def boom(*a, **k):
        raise AssertionError("3D-Nc computed for a short encounter")

    monkeypatch.setattr(nc3d, "log_pc3d_hall", boom)
    from visviva.validation.checks_conjunctions import om1_args

    args = om1_args()
    pc, record = _pc_and_warnings(args)
    assert pc == pytest.approx(2.706023476569e-05, rel=1e-10) and not record
    ext, off, _, _ = linear_encounter_bounds(*args, GM_M)
    assert ext < 1e-3 and off < 1e-3


@pytest.mark.parametrize("n", [2, 4, 7])
def test_linear_bounds_against_a_brute_force_mahalanobis_scan(n):
    # independent: the squared Mahalanobis distance of the straight-line relative position,
    # scanned on a fine grid; its minimum is at T, and at T -+ dtau it has grown by q^2 with
    # erfc(q / sqrt 2) = 1e-16 (Coppola's gamma)
    c = CASES[n]
    r1, v1, c1, r2, v2, c2, hbr = _args(c)
    ext, off, ta, tb = linear_encounter_bounds(r1, v1, c1, r2, v2, c2, hbr, GM_M)
    a_inv = np.linalg.inv(c1[:3, :3] + c2[:3, :3])
    r, u = r2 - r1, v2 - v1

    def md2(t):
        x = r[None, :] + np.atleast_1d(t)[:, None] * u[None, :]
        return np.einsum("ij,jk,ik->i", x, a_inv, x)

    t_mid = 0.5 * (ta + tb)
    grid = np.linspace(ta, tb, 200_001)
    t_min = grid[np.argmin(md2(grid))]
    assert abs(t_min - t_mid) <= 2 * (tb - ta) / 200_000
    q2 = float(md2(tb)[0] - md2(t_mid)[0])
    assert erfc(math.sqrt(q2) / math.sqrt(2.0)) == pytest.approx(1e-16, rel=1e-6)
    a = 1.0 / (2.0 / np.linalg.norm(r1) - v1 @ v1 / GM_M)
    b = 1.0 / (2.0 / np.linalg.norm(r2) - v2 @ v2 / GM_M)
    period = 2 * math.pi * math.sqrt(min(a, b) ** 3 / GM_M)
    assert ext == pytest.approx((tb - ta) / period, rel=1e-12)
    assert off == pytest.approx(max(abs(ta), abs(tb)) / period, rel=1e-12)


def test_zero_relative_velocity_has_no_bounds():
    c = CASES[12]
    assert linear_encounter_bounds(*_args(c), GM_M) is None


def test_relative_states_at_the_origin_are_not_checked():
    # the 2-D methods need only the relative state: object 1 at the origin at rest has no
    # orbital period (before this guard the check divided by |r1| = 0)
    cov = np.diag([1e4, 1e4, 1e4])
    args = ([0, 0, 0], [0, 0, 0], cov, [100, 0, 0], [0, 0, 7500], cov, 10)
    assert linear_encounter_bounds(*(np.asarray(a, float) for a in args[:-1]), 10.0,
                                   GM_M) is None
    pc, record = _pc_and_warnings(args)
    assert 0 < pc < 1 and not record
