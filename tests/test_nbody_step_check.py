"""WHFast warns about a step too long for the orbits (visviva.nbody.step_check)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import visviva as vv
from visviva.nbody.step_check import MAX_STEP_FRACTION, shortest_period


def two_planets(integrator="whfast", dt=None, coordinates="jacobi"):
    sim = vv.Simulation(integrator, dt=dt, coordinates=coordinates)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, e=0.1, primary=0)
    sim.add(1e-3, a=1.6, e=0.05, primary=0)
    return sim


def test_a_step_of_a_third_of_the_period_is_warned_about_and_is_wrong():
    # dt = P/3 ran without a word: positions 0.5 off (the orbits' size) after 100 time units,
    # with a relative energy error of only 1.7e-3
    P = 2 * math.pi
    ref = two_planets("ias15")
    ref.integrate(100.0)
    sim = two_planets(dt=P / 3)
    with pytest.warns(UserWarning, match=r"step dt = .* 0\.33 of the shortest orbital period"):
        sim.integrate(100.0)
    assert np.abs(sim.positions - ref.positions).max() > 0.1  # what the warning is about
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.integrate(110.0)  # checked once for these particles and this dt
        good = two_planets(dt=P / 20)
        good.integrate(10.0)


def test_two_bodies_are_exact_in_jacobi_coordinates_at_any_step_but_not_in_dh():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = vv.Simulation("whfast", dt=5.0)  # 0.8 of the period: exact for two bodies
        sim.add(1.0)
        sim.add(1e-3, a=1.0, e=0.3, primary=0)
        sim.integrate(50.0)
    sim = vv.Simulation("whfast", dt=5.0, coordinates="democratic_heliocentric")
    sim.add(1.0)
    sim.add(1e-3, a=1.0, e=0.3, primary=0)
    with pytest.warns(UserWarning, match="democratic_heliocentric coordinates"):
        sim.integrate(50.0)


def test_shortest_period_is_the_two_body_period_and_skips_unbound_orbits():
    sim = two_planets()
    sim.add(0.0, r=[5.0, 0.0, 0.0], v=[0.0, 2.0, 0.0])  # hyperbolic: no period
    x, v, m = sim.positions, sim.velocities, sim.masses
    inner = 2 * math.pi * math.sqrt(1.0 / 1.001)  # placed at a = 1 about particle 0, G (m0 + m1)
    for jacobi in (True, False):
        assert shortest_period(x, v, m, sim.G, jacobi) == pytest.approx(inner, rel=1e-12)
    assert shortest_period(x[[0, 3]], v[[0, 3]], m[[0, 3]], 1.0) == math.inf
    assert 0 < MAX_STEP_FRACTION < 0.5
