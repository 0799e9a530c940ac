"""A Hohmann transfer combined with a change of inclination (audit53)."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from scipy.optimize import minimize_scalar

import visviva as vv
from visviva.errors import InvalidInputError, InvalidStateError
from visviva.satellites import Maneuver, hohmann_plane_change_delta_v

KMS = u.km / u.s
MU = vv.EARTH.gm_km3_s2


def split_by_scipy(r1, r2, di):
    """The cheapest split, by scipy's bounded minimisation of the textbook cost (law of cosines
    in its plain form: independent of the module's)."""
    v1, v2 = np.sqrt(MU / r1), np.sqrt(MU / r2)
    vt1, vt2 = v1 * np.sqrt(2 * r2 / (r1 + r2)), v2 * np.sqrt(2 * r1 / (r1 + r2))

    def cost(a):
        return (np.sqrt(v1**2 + vt1**2 - 2 * v1 * vt1 * np.cos(a))
                + np.sqrt(v2**2 + vt2**2 - 2 * v2 * vt2 * np.cos(di - a)))

    res = minimize_scalar(cost, bounds=(0.0, di), method="bounded", options={"xatol": 1e-12})
    return res.x, res.fun, cost(0.0), cost(di)


@pytest.mark.parametrize(("r1", "r2", "di_deg"), [
    (6678.0, 42164.0, 28.5), (6678.0, 42164.0, 60.0), (6678.0, 42164.0, 120.0),
    (7000.0, 7100.0, 10.0), (42164.0, 6678.0, 28.5), (6678.0, 384400.0, 28.5)])
def test_split_is_the_minimum_found_by_scipy(r1, r2, di_deg):
    dv1, dv2, di1, di2, tof = hohmann_plane_change_delta_v(r1 * u.km, r2 * u.km,
                                                           di_deg * u.deg, vv.EARTH)
    x, best, at_second, at_first = split_by_scipy(r1, r2, np.deg2rad(di_deg))
    total = (dv1 + dv2).to_value(KMS)
    assert total == pytest.approx(best, abs=1e-12)  # km/s
    assert total < min(at_second, at_first) - 1e-4  # cheaper than the whole turn at one burn
    assert di1.to_value(u.rad) == pytest.approx(x, abs=1e-6)
    assert (di1 + di2).to_value(u.deg) == pytest.approx(di_deg, abs=1e-12)
    assert tof.to_value(u.s) == pytest.approx(np.pi * np.sqrt((r1 + r2) ** 3 / (8 * MU)))


def test_leo_to_geo_textbook_split_and_sign():
    # the classic case: about 2.2 deg of the 28.5 deg at the perigee burn
    dv1, dv2, di1, di2, _ = hohmann_plane_change_delta_v(6678 * u.km, 42164 * u.km,
                                                         -28.5 * u.deg, vv.EARTH)
    assert di1.to_value(u.deg) == pytest.approx(-2.200, abs=1e-3)
    assert di2.to_value(u.deg) == pytest.approx(-26.300, abs=1e-3)
    assert (dv1 + dv2).to_value(KMS) == pytest.approx(4.2314, abs=1e-4)
    # broadcasts
    d = hohmann_plane_change_delta_v([6678, 7000] * u.km, 42164 * u.km, [[10], [-20]] * u.deg,
                                     vv.EARTH)[2]
    assert d.shape == (2, 2) and np.all(d[0] > 0) and np.all(d[1] < 0)


def test_split_refuses_bad_input():
    with pytest.raises(InvalidInputError, match="degrees"):
        hohmann_plane_change_delta_v(6678 * u.km, 42164 * u.km, 28.5, vv.EARTH)
    with pytest.raises(InvalidInputError, match="inside"):
        hohmann_plane_change_delta_v(6678 * u.km, 500 * u.km, 0.1, vv.EARTH)


def node_state(inc_deg, u_deg, raan_deg=40.0, r=6678.0):
    return vv.KeplerianElements.from_semi_major_axis(
        r * u.km, 0.0, inc_deg * u.deg, raan_deg * u.deg, 0.0, u_deg * u.deg, vv.EARTH
    ).to_state()


@pytest.mark.parametrize(("inc", "u_deg", "di", "raan_after"), [
    (28.5, 0.0, -28.5, None), (28.5, 180.0, -28.5, None), (28.5, 180.0, -10.0, 40.0),
    (0.0, 37.0, 10.0, 77.0), (98.0, 180.0, 5.0, 40.0)])
def test_hohmann_with_delta_inc_arrives_circular_in_the_new_plane(inc, u_deg, di, raan_after):
    leo = node_state(inc, u_deg)
    man = Maneuver.hohmann(leo, 42164 * u.km, delta_inc=di * u.deg)
    el = man.apply(leo).to_elements()
    assert el.semi_major_axis.to_value(u.km) == pytest.approx(42164.0, abs=1e-6)
    assert el.eccentricity < 1e-12
    assert el.inclination.to_value(u.deg) == pytest.approx(inc + di, abs=1e-9)
    if raan_after is not None:
        assert el.longitude_of_ascending_node.to_value(u.deg) == pytest.approx(raan_after,
                                                                               abs=1e-9)
    dv1, dv2, *_ = hohmann_plane_change_delta_v(6678 * u.km, 42164 * u.km, di * u.deg, vv.EARTH)
    assert man.total_delta_v.to_value(KMS) == pytest.approx((dv1 + dv2).to_value(KMS),
                                                            abs=1e-12)
    # flown by Cowell without perturbations: the same orbit
    flown = vv.propagate_cowell(leo, man.duration, [], maneuvers=man.burns())
    h = np.cross(flown.r.to_value(u.km), flown.v.to_value(KMS))
    assert np.rad2deg(np.arccos(h[2] / np.linalg.norm(h))) == pytest.approx(inc + di, abs=1e-7)
    assert np.linalg.norm(flown.r.to_value(u.km)) == pytest.approx(42164.0, abs=1e-5)


def test_hohmann_with_delta_inc_refuses_a_state_off_the_nodes_and_through_the_equator():
    with pytest.raises(InvalidStateError, match="node"):
        Maneuver.hohmann(node_state(28.5, 10.0), 42164 * u.km, delta_inc=-28.5 * u.deg)
    with pytest.raises(InvalidInputError, match="outside 0-180"):
        Maneuver.hohmann(node_state(28.5, 0.0), 42164 * u.km, delta_inc=-30 * u.deg)
    # no transfer: one impulse, the turn at once
    man = Maneuver.hohmann(node_state(28.5, 0.0), 6678 * u.km, delta_inc=-10 * u.deg)
    assert len(man.impulses) == 1 and man.duration.value == 0.0
    v = np.sqrt(MU / 6678.0)
    assert man.total_delta_v.to_value(KMS) == pytest.approx(2 * v * np.sin(np.deg2rad(5)))
    # delta_inc = 0 is the plain Hohmann transfer, bit for bit
    a = Maneuver.hohmann(node_state(28.5, 10.0), 42164 * u.km)
    b = Maneuver.hohmann(node_state(28.5, 10.0), 42164 * u.km, delta_inc=0.0)
    assert [i.dv.value.tolist() for i in a.impulses] == [i.dv.value.tolist() for i in b.impulses]


def test_then_chains_a_phasing_and_a_hohmann_transfer():
    """audit53: a sequence (phasing into the slot, then a transfer) had to be assembled by hand,
    with the second plan's times shifted by the first's duration."""
    leo = node_state(51.6, 0.0, r=6878.0)
    phase = Maneuver.phasing(leo, 20 * u.deg, revolutions=2)
    after = phase.apply(leo)
    for coast in (0.0, 1234.5):
        transfer = Maneuver.hohmann(after.propagate(coast * u.s), 7200 * u.km)
        both = phase.then(transfer, coast * u.s)
        want = transfer.apply(after.propagate(coast * u.s))
        got = both.apply(leo)
        assert np.abs((got.r - want.r).to_value(u.km)).max() < 1e-6
        assert np.abs((got.v - want.v).to_value(KMS)).max() < 1e-9
        assert both.total_delta_v.to_value(KMS) == pytest.approx(
            (phase.total_delta_v + transfer.total_delta_v).to_value(KMS), rel=1e-14)
        assert both.duration.to_value(u.s) == pytest.approx(
            (phase.duration + transfer.duration).to_value(u.s) + coast, rel=1e-14)
    with pytest.raises(InvalidInputError, match=">= 0"):
        phase.then(transfer, -1 * u.s)
    with pytest.raises(InvalidInputError, match="takes a Maneuver"):
        phase.then([(0 * u.s, [0, 0, 0.1] * KMS)])
