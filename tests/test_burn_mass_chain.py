"""A spacecraft's mass through several burns (audit38): the burns' masses must follow each other.

A finite burn's thrust acceleration F / m(t) starts from its ``mass`` at ignition. Two burns
built from one engine's settings (``mass=1000 * u.kg`` twice) flew the second from 1000 kg
again, silently: its Δv and the final mass were those of a full spacecraft. The rocket equation
with the mass the first burn left is the reference (Tsiolkovsky; Curtis 2014, sec. 11.3).
"""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from visviva.errors import InvalidInputError, UnitsError
from visviva.satellites import FiniteBurn, ImpulsiveBurn, propagate_cowell
from visviva.satellites.burns import STANDARD_GRAVITY_M_S2

KMS = u.km / u.s
G0 = 9.80665  # m/s^2, exact (CGPM 1901)
ISP, F, M0, DT = 300.0, 400.0, 1000.0, 600.0  # s, N, kg, s


def free_space():
    """A state far from any attractor's pull on a burn's time scale (GM of 1 km^3/s^2 at 1e6
    km): the velocity change is the rocket equation's to 1e-11."""
    return vv.StateVectors([1e6, 0.0, 0.0] * u.km, [0.0, 1.0, 0.0] * KMS,
                           1.0 * u.km**3 / u.s**2)


def engine(start_s, mass_kg):
    return FiniteBurn(start_s * u.s, DT * u.s, [0.0, 1.0, 0.0], "GCRS", thrust=F * u.N,
                      mass=mass_kg * u.kg, isp=ISP * u.s)


def rocket(m0_kg):
    mdot = F / (ISP * G0)
    return ISP * G0 * np.log(m0_kg / (m0_kg - mdot * DT))  # m/s


def test_g0_is_the_standard_gravity():
    assert STANDARD_GRAVITY_M_S2 == G0


def test_a_second_burn_given_the_first_burns_mass_at_ignition_is_refused():
    """Before: the second burn gave 250.36 m/s and a final mass of 918.42 kg (a full
    spacecraft again) instead of 273.66 m/s and 836.85 kg."""
    with pytest.raises(InvalidInputError, match=r"starts with 1000 kg but .* left 918\.42"):
        propagate_cowell(free_space(), 3000 * u.s, [], maneuvers=[engine(0.0, M0),
                                                                  engine(1200.0, M0)])


def test_burns_whose_masses_follow_each_other_give_the_rocket_equation_twice():
    first = engine(0.0, M0)
    second = engine(1200.0, first.final_mass.to_value(u.kg))
    state = free_space()
    out = propagate_cowell(state, 3000 * u.s, [], maneuvers=[first, second])
    dv = [r.delta_v.to_value(u.m / u.s) for r in out.burns]
    assert dv == pytest.approx([rocket(M0), rocket(first.final_mass.to_value(u.kg))], rel=1e-12)
    assert dv[1] == pytest.approx(273.66, abs=0.01)
    mdot = F / (ISP * G0)
    assert out.final_mass.to_value(u.kg) == pytest.approx(M0 - 2 * mdot * DT, rel=1e-12)
    # in (nearly) free space the speed gained is the sum of the two rocket equations
    gained = (out.v - state.v).to_value(u.m / u.s)
    assert np.linalg.norm(gained) == pytest.approx(sum(dv), rel=1e-9)


def test_a_mass_dropped_between_burns_is_an_impulse_of_no_delta_v():
    first = engine(0.0, M0)
    left = first.final_mass.to_value(u.kg)
    drop = ImpulsiveBurn(900 * u.s, [0.0, 0.0, 0.0] * KMS, mass=left * u.kg,
                         delta_mass=-300 * u.kg)
    second = engine(1200.0, left - 300.0)
    out = propagate_cowell(free_space(), 3000 * u.s, [], maneuvers=[first, drop, second])
    assert out.burns[2].delta_v.to_value(u.m / u.s) == pytest.approx(rocket(left - 300.0),
                                                                      rel=1e-12)
    with pytest.raises(InvalidInputError, match="a stage, a probe"):
        propagate_cowell(free_space(), 3000 * u.s, [], maneuvers=[first, engine(1200.0,
                                                                                left - 300.0)])


def test_impulses_whose_masses_contradict_each_other_are_refused():
    """Before: two impulses of 10 kg each from 1000 kg reported a final mass of 990 kg."""
    burns = [ImpulsiveBurn(t * u.s, [0.0, 0.01, 0.0] * KMS, mass=M0 * u.kg,
                           delta_mass=-10 * u.kg) for t in (100.0, 200.0)]
    with pytest.raises(InvalidInputError, match="left 990 kg"):
        propagate_cowell(free_space(), 300 * u.s, [], maneuvers=burns)


def test_an_isp_given_as_an_exhaust_speed_says_how_to_convert_it():
    """An effective exhaust speed (m/s) for isp was refused with 'Pass e.g. isp=90 * u.min'."""
    with pytest.raises(UnitsError, match=r"specific impulse in seconds.*300\.001 s"):
        FiniteBurn(0 * u.s, DT * u.s, [1, 0, 0], "VNB", thrust=F * u.N, mass=M0 * u.kg,
                   isp=2942 * u.m / u.s)
    # the conversion it names gives the rocket equation's speed back: c ln(m0 / m1)
    c = 2942.0 * u.m / u.s
    burn = FiniteBurn(0 * u.s, DT * u.s, [1, 0, 0], "VNB", thrust=F * u.N, mass=M0 * u.kg,
                      isp=c / (G0 * u.m / u.s**2))
    m1 = burn.final_mass.to_value(u.kg)
    assert burn.ideal_delta_v.to_value(u.m / u.s) == pytest.approx(2942.0 * np.log(M0 / m1),
                                                                   rel=1e-12)
