"""Collision probability given inputs a user gets slightly wrong (audit48).

* States that are not at TCA: the 2-D methods take ``|r1 - r2|`` as the miss (NASA CARA's
  ``PcCircle`` convention); 0.1 s off at 10.6 km/s put 1.06 km along the relative velocity into
  a 100 m miss and Pc came out 7.7e-16 for 1.09e-3, silently. Now a ``Pc2dAccuracyWarning``
  gives the value at the straight-line TCA.
* ``method="monte_carlo"`` with no hit returned Pc = 0 (the plane's exact value 2.2e-14) without
  a word; with a handful of hits, an estimate uncertain by a factor of ten.
* ``max_collision_probability`` with one covariance added 1 m^2 for the other, so the answer
  depended on the given covariance's size, which is the unknown (7.5e-4 for 1.3e-5).
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from scipy import integrate

import visviva as vv
from visviva.conjunctions import (
    collision_probability,
    max_collision_probability,
    monte_carlo_probability,
)

# a LEO crossing at 90 deg: 10.6 km/s, 100 m radial miss at TCA (t = 0)
R1 = np.array([7000e3, 0.0, 0.0])
V1 = np.array([0.0, 7.5e3, 0.0])
R2 = R1 + np.array([100.0, 0.0, 0.0])
V2 = np.array([0.0, 0.0, 7.5e3])
COV = np.diag([100.0**2, 1000.0**2, 100.0**2])  # m^2, each object (radial, y, z)
HBR = 20.0


def _states(dt):
    """Both objects moved by ``dt`` s along their straight lines (covariances unchanged)."""
    return R1 + V1 * dt, V1, COV, R2 + V2 * dt, V2, COV


def _disc_integral(xm, zm, sx, sz, hbr):
    """Foster's integral by scipy's dblquad over the disc (independent of visviva)."""
    def f(z, x):
        return math.exp(-0.5 * ((x - xm) / sx) ** 2 - 0.5 * ((z - zm) / sz) ** 2) / (
            2 * math.pi * sx * sz)
    return integrate.dblquad(f, -hbr, hbr, lambda x: -math.sqrt(hbr * hbr - x * x),
                             lambda x: math.sqrt(hbr * hbr - x * x), epsabs=0,
                             epsrel=1e-10)[0]


def _record(fn, *args, **kw):
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        out = fn(*args, **kw)
    return out, rec


# encounter plane of the case: u = (0, 7.5, -7.5) km/s; x radial (sigma 100 sqrt 2), z along
# (0, 1, 1)/sqrt 2 (variance (1000^2 + 100^2) / 2 per object, summed)
SX, SZ = 100.0 * math.sqrt(2.0), math.sqrt(1000.0**2 + 100.0**2)
PC_TCA = _disc_integral(100.0, 0.0, SX, SZ, HBR)


def test_states_at_tca_agree_with_the_disc_integral_and_stay_silent():
    pc, rec = _record(collision_probability, *_states(0.0), HBR)
    assert pc == pytest.approx(PC_TCA, rel=1e-9)
    assert not [w for w in rec if issubclass(w.category, vv.Pc2dAccuracyWarning)]
    # rounding of states at TCA (a millimetre along the relative velocity): silent too
    r1, v1, c1, r2, v2, c2 = _states(1e-7)
    pc, rec = _record(collision_probability, r1, v1, c1, r2, v2, c2, HBR)
    assert pc == pytest.approx(PC_TCA, rel=1e-6)
    assert not rec


@pytest.mark.parametrize("dt", [0.01, -0.1, 1.0])
def test_states_off_tca_warn_with_the_value_at_the_straight_line_tca(dt):
    # before: 0.01 s -> 8.27e-4, 0.1 s -> 7.7e-16, 1 s -> 0, for 1.09e-3 at TCA, no warning
    pc, rec = _record(collision_probability, *_states(dt), HBR)
    d = math.hypot(100.0, 7.5e3 * math.sqrt(2.0) * dt)  # |r1 - r2| off TCA
    assert pc == pytest.approx(_disc_integral(d, 0.0, SX, SZ, HBR), rel=1e-6, abs=1e-300)
    (w,) = [w for w in rec if issubclass(w.category, vv.Pc2dAccuracyWarning)]
    text = str(w.message)
    assert "not at the time of closest approach" in text and "pc3d_hall" in text
    at_tca = float(re.search(r"straight-line TCA it is ([0-9.e+-]+)", text).group(1))
    assert at_tca == pytest.approx(PC_TCA, rel=1e-3)  # printed to 4 digits
    offset = float(re.search(r"straight-line TCA is ([0-9.e+-]+) s", text).group(1))
    assert offset == pytest.approx(-dt, rel=1e-3)
    assert w.filename == __file__  # points at the caller


@pytest.mark.parametrize("method", ["chan", "monte_carlo"])
def test_chan_and_monte_carlo_warn_off_tca_too(method):
    _, rec = _record(collision_probability, *_states(0.1), HBR, method=method,
                     samples=10_000, seed=1)
    assert [w for w in rec if issubclass(w.category, vv.Pc2dAccuracyWarning)
            and "not at the time of closest approach" in str(w.message)]
    _, rec = _record(monte_carlo_probability, *_states(0.1), HBR, samples=10_000, seed=1)
    (w,) = [w for w in rec if issubclass(w.category, vv.Pc2dAccuracyWarning)]
    assert w.filename == __file__


def test_pc3d_hall_off_tca_gives_the_value_at_tca():
    # what the warning advises: 3D-Nc follows the encounter in time (6x6, small velocity sigmas)
    c6 = np.zeros((6, 6))
    c6[:3, :3] = COV
    c6[3:, 3:] = np.eye(3) * 1e-4
    r1, v1, _, r2, v2, _ = _states(0.1)
    pc = collision_probability(r1, v1, c6, r2, v2, c6, HBR, method="pc3d_hall")
    assert pc == pytest.approx(PC_TCA, rel=1e-3)


def test_monte_carlo_without_hits_warns_with_the_upper_bound():
    r2 = R1 + np.array([1000.0, 0.0, 0.0])  # Foster: 2.2e-14
    exact = collision_probability(R1, V1, COV, r2, V2, COV, HBR)
    assert exact == pytest.approx(_disc_integral(1000.0, 0.0, SX, SZ, HBR), rel=1e-8)
    pc, rec = _record(collision_probability, R1, V1, COV, r2, V2, COV, HBR,
                      method="monte_carlo", samples=10_000, seed=1)
    assert pc == 0.0  # the estimate itself
    (w,) = [w for w in rec if "samples hit" in str(w.message)]
    bound = float(re.search(r"Pc < ([0-9.e+-]+)", str(w.message)).group(1))
    # Clopper-Pearson upper bound for 0 of n: 1 - (alpha/2)^(1/n)
    assert bound == pytest.approx(1 - 0.025 ** (1 / 10_000), rel=1e-2)
    assert bound > exact
    assert w.filename == __file__
    # HBR 0: Pc = 0 exactly, nothing to say
    pc, rec = _record(collision_probability, R1, V1, COV, r2, V2, COV, 0.0,
                      method="monte_carlo", samples=1_000, seed=1)
    assert pc == 0.0 and not rec


def test_monte_carlo_with_few_hits_warns_and_with_many_does_not():
    # Pc 1.09e-3: 2,000 samples give ~2 hits, 200,000 give ~220
    pc, rec = _record(collision_probability, *_states(0.0), HBR, method="monte_carlo",
                      samples=2_000, seed=3)
    res = monte_carlo_probability(*_states(0.0), HBR, samples=2_000, seed=3)
    assert 0 < res.hits < 10 and pc == res.pc
    (w,) = [w for w in rec if "samples hit" in str(w.message)]
    assert f"only {res.hits} of the 2000" in str(w.message)
    pc, rec = _record(collision_probability, *_states(0.0), HBR, method="monte_carlo",
                      samples=200_000, seed=3)
    assert pc == pytest.approx(PC_TCA, rel=0.25)
    assert not rec


def _brute_max(miss, s_major, s_minor, hbr):
    """The largest Pc over a fine grid of scales ``k`` of the plane's sigmas (the miss along the
    minor axis), independent of the optimiser and of the plane's construction."""
    from visviva.conjunctions.probability import log_pc_2d

    ks = np.exp(np.linspace(6.0, 14.0, 1601))
    return math.exp(max(log_pc_2d(0.0, miss, k * s_major, k * s_minor, hbr, "foster")
                        for k in ks))


def test_max_probability_with_one_covariance_takes_its_shape_whatever_its_size():
    # before: the missing covariance was 1 m^2, so a thin covariance (sigmas 1 cm, 1 m) gave
    # 7.5e-4 and the same one in other units (x 1e6) 1.3e-5
    r2 = R1 + np.array([200.0, 0.0, 0.0])
    thin = np.diag([0.01**2, 1.0**2, 0.01**2])
    # its plane: x radial (sigma 0.01 m, the miss), z along (0, 1, 1)/sqrt 2
    ref = _brute_max(200.0, math.sqrt((1.0 + 1e-4) / 2), 0.01, 10.0)
    for c in (thin, thin * 1e6, thin * 1e-6):
        assert max_collision_probability(R1, V1, r2, V2, 10.0, cov1=c) == pytest.approx(
            ref, rel=1e-4)
        assert max_collision_probability(R1, V1, r2, V2, 10.0, cov2=c) == pytest.approx(
            ref, rel=1e-4)
    both = max_collision_probability(R1, V1, r2, V2, 10.0, cov1=thin / 2, cov2=thin / 2)
    assert both == pytest.approx(ref, rel=1e-4)


@pytest.mark.parametrize("args", [(100.0, 0.0, 100.0, 0.0, 20.0), (100.0, 0.0, 100.0, -5.0, 20.0),
                                  (math.nan, 0.0, 100.0, 50.0, 20.0),
                                  (100.0, 0.0, 100.0, 50.0, math.nan),
                                  (100.0, 0.0, 100.0, 50.0, -1.0)])
def test_log_pc_2d_refuses_a_plane_it_cannot_integrate(args):
    # before: Chan's series gave NaN for a zero sigma (and looped for ever on a negative one);
    # Foster's integral -inf for a negative sigma, NaN or -inf for the rest
    from visviva.conjunctions.probability import log_pc_2d
    from visviva.errors import InvalidInputError

    for method in ("foster", "chan"):
        with pytest.raises(InvalidInputError, match="must be"):
            log_pc_2d(*args, method)
    assert log_pc_2d(100.0, 0.0, 100.0, 50.0, 0.0, "chan") == -math.inf


def test_pc3d_hall_refuses_a_hard_body_not_small_beside_the_orbit():
    # before: HBR 1,000 km in LEO gave Pc = 1.007 (> 1), 10,000 km inf with numpy overflows
    from visviva.errors import InvalidInputError

    c6 = np.zeros((6, 6))
    c6[:3, :3] = COV
    c6[3:, 3:] = np.eye(3) * 1e-4
    for hbr in (1e6, 1e7):
        with pytest.raises(InvalidInputError, match="small beside the orbits"):
            collision_probability(R1, V1, c6, R2, V2, c6, hbr, method="pc3d_hall")
    # 3 km (sigmas 0.14 and 1 km): the sphere holds the encounter, Pc equals Foster's < 1
    pc = collision_probability(R1, V1, c6, R2, V2, c6, 3e3, method="pc3d_hall")
    assert pc == pytest.approx(collision_probability(R1, V1, c6, R2, V2, c6, 3e3), rel=1e-6)
    assert pc <= 1.0


def test_3d_method_takes_an_object_on_a_hyperbola():
    # before: ValueError 'math domain error' (the window's quarter-period bound took the period
    # of any orbit); a fast encounter, so the flux integral equals Foster's plane value
    gm = 3.986004418e14
    v1 = np.array([0.0, 1.2 * math.sqrt(2 * gm / 7000e3), 0.0])  # 1.2 x escape speed
    c6 = np.zeros((6, 6))
    c6[:3, :3] = COV
    c6[3:, 3:] = np.eye(3) * 1e-4
    foster = collision_probability(R1, v1, COV, R2, V2, COV, HBR)
    pc = collision_probability(R1, v1, c6, R2, V2, c6, HBR, method="3d")
    assert pc == pytest.approx(foster, rel=1e-6)
    with pytest.raises(vv.errors.InvalidInputError, match="bound"):
        collision_probability(R1, v1, c6, R2, V2, c6, HBR, method="pc3d_hall")
