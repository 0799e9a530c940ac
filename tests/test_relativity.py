"""vv.Relativity: the post-Newtonian correction of Cowell's force model (IERS Conventions 2010,
eq. 10.12), checked against the formula written with numpy, its analytic partials against
central differences, and the relativistic precessions it must produce: the Schwarzschild
perigee advance 6 pi GM / (c^2 a (1 - e^2)) per revolution and the Lense-Thirring node and
perigee drifts 2 GM J / (c^2 a^3 (1 - e^2)^(3/2)) and -3 cos(i) times that."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.constants import C_KM_S
from visviva.core.relativity import accel_relativity, add_relativity_partials

KMS = u.km / u.s
MU = vv.EARTH.gm_km3_s2
J_EARTH = 980.0  # km^2/s (9.8e8 m^2/s, IERS Conventions 2010 sec. 10.3)


def formula(r, v, gm, j):
    """Eq. 10.12 of the IERS Conventions (beta = gamma = 1), Schwarzschild + Lense-Thirring."""
    rn = np.linalg.norm(r)
    f = gm / (C_KM_S**2 * rn**3)
    a = f * ((4 * gm / rn - v @ v) * r + 4 * (r @ v) * v)
    jv = np.array([0.0, 0.0, j])
    return a + 2 * f * (3 / rn**2 * np.cross(r, v) * (r @ jv) + np.cross(v, jv))


states = st.tuples(
    st.floats(6500.0, 50000.0), st.floats(-1.0, 1.0), st.floats(0.0, 2 * np.pi),
    st.floats(0.2, 1.4), st.floats(0.0, np.pi), st.floats(0.0, 2 * np.pi),
)


def _state(s):
    r_km, cz, lon, speed_frac, vth, vph = s
    sz = np.sqrt(1 - cz * cz)
    r = r_km * np.array([sz * np.cos(lon), sz * np.sin(lon), cz])
    speed = speed_frac * np.sqrt(MU / r_km)
    v = speed * np.array([np.sin(vth) * np.cos(vph), np.sin(vth) * np.sin(vph), np.cos(vth)])
    return r, v


@settings(max_examples=200, deadline=None)
@given(states, st.sampled_from([0.0, J_EARTH]))
def test_acceleration_is_the_iers_formula(s, j):
    r, v = _state(s)
    out = np.zeros(3)
    accel_relativity(*r, *v, MU, j, 0.0, 0.0, out)
    want = formula(r, v, MU, j)
    assert np.abs(out - want).max() <= 1e-12 * np.abs(want).max()


@settings(max_examples=60, deadline=None)
@given(states, st.sampled_from([0.0, J_EARTH]))
def test_partials_match_central_differences(s, j):
    r, v = _state(s)
    dadr, dadv = np.zeros((3, 3)), np.zeros((3, 3))
    add_relativity_partials(*r, *v, MU, j, 0.0, 0.0, dadr, dadv)
    fdr, fdv = np.zeros((3, 3)), np.zeros((3, 3))
    for k in range(3):
        dr = np.zeros(3)
        dr[k] = 1e-3 * np.linalg.norm(r)
        fdr[:, k] = (formula(r + dr, v, MU, j) - formula(r - dr, v, MU, j)) / (2 * dr[k])
        dv = np.zeros(3)
        dv[k] = 1e-3 * np.linalg.norm(v)
        fdv[:, k] = (formula(r, v + dv, MU, j) - formula(r, v - dv, MU, j)) / (2 * dv[k])
    # central differences of 1e-3 relative: truncation ~1e-6 of the entries
    assert np.abs(dadr - fdr).max() <= 1e-5 * np.abs(fdr).max()
    assert np.abs(dadv - fdv).max() <= 1e-5 * np.abs(fdv).max()


def test_force_model_rhs_and_stm_partials_carry_the_term():
    # through the force block: cowell_rhs with Relativity minus without is the formula, and
    # acceleration_partials adds the analytic partials (what the STM of fit_orbit and
    # propagate_covariance integrates)
    from visviva.core.perturbations import cowell_rhs
    from visviva.core.variational import acceleration_partials
    from visviva.satellites.cowell import ForceModel

    with_rel = ForceModel(MU, [vv.Relativity()])
    without = ForceModel(MU, [])
    y = np.array([7000.0, 300.0, -1200.0, 0.5, 7.4, 1.1])
    a, b = np.zeros(6), np.zeros(6)
    cowell_rhs(0.0, y, *with_rel.arrays(), a)
    cowell_rhs(0.0, y, *without.arrays(), b)
    want = formula(y[:3], y[3:], MU, J_EARTH)
    assert np.abs((a - b)[3:] - want).max() <= 1e-6 * np.abs(want).max()  # round-off of a
    assert 1.5e-11 < np.linalg.norm(want) < 2.5e-11  # km/s^2: ~2e-8 m/s^2 in LEO
    p = [np.zeros((3, 3)) for _ in range(4)]
    acceleration_partials(0.0, y, *with_rel.arrays(), p[0], p[1])
    acceleration_partials(0.0, y, *without.arrays(), p[2], p[3])
    dadr, dadv = np.zeros((3, 3)), np.zeros((3, 3))
    add_relativity_partials(*y[:3], *y[3:], MU, J_EARTH, 0.0, 0.0, dadr, dadv)
    assert np.abs((p[0] - p[2]) - dadr).max() <= 1e-6 * np.abs(dadr).max()
    assert np.array_equal(p[1] - p[3], dadv)


def _final_angles(perturbations, a, e, inc, n_orbits):
    state = vv.KeplerianElements.from_semi_major_axis(
        a * u.km, e, inc * u.deg, 30 * u.deg, 40 * u.deg, 10 * u.deg, vv.EARTH).to_state()
    period = 2 * np.pi * np.sqrt(a**3 / MU)
    out = vv.propagate_cowell(state, [n_orbits * period] * u.s, perturbations, rtol=1e-13,
                              atol=1e-15)
    el = vv.StateVectors(out.r[-1], out.v[-1], vv.EARTH).to_elements()
    return (el.argument_of_periapsis.to_value(u.rad),
            el.longitude_of_ascending_node.to_value(u.rad), n_orbits * period)


def test_perigee_advance_and_lense_thirring_drifts_are_the_textbook_rates():
    a, e, inc, n = 12000.0, 0.3, 50.0, 100
    w0, node0, _ = _final_angles([], a, e, inc, n)
    w1, node1, _ = _final_angles([vv.Relativity(lense_thirring=False)], a, e, inc, n)
    w2, node2, span = _final_angles([vv.Relativity()], a, e, inc, n)
    # Schwarzschild: 6 pi GM / (c^2 a (1 - e^2)) per revolution (5.6e-9 rad here); no node
    advance = n * 6 * np.pi * MU / (C_KM_S**2 * a * (1 - e * e))
    assert abs((w1 - w0) / advance - 1) < 1e-4  # measured 8.7e-8
    assert abs(node1 - node0) < 1e-3 * advance
    # Lense-Thirring: the node drifts by 2 GM J / (c^2 a^3 (1 - e^2)^1.5) (7.6e-9 rad over the
    # 15 days here; LAGEOS's 31 mas/yr), the perigee by -3 cos(i) times that
    drift = 2 * MU * J_EARTH / (C_KM_S**2 * a**3 * (1 - e * e) ** 1.5) * span
    assert abs((node2 - node1) / drift - 1) < 1e-3  # measured 7.7e-7
    assert abs((w2 - w1) / (-3 * np.cos(np.radians(inc)) * drift) - 1) < 1e-2


def test_refusals():
    with pytest.raises(vv.InvalidInputError, match="Lense-Thirring"):
        vv.Relativity(vv.MOON)
    vv.Relativity(vv.MOON, lense_thirring=False)  # the Schwarzschild term of any body
    with pytest.raises(vv.InvalidInputError, match="True or False"):
        vv.Relativity(lense_thirring="no")
    with pytest.raises(vv.InvalidInputError, match="at most one Relativity"):
        vv.propagate_cowell(vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * KMS, vv.EARTH),
                            [60] * u.s, [vv.Relativity(), vv.Relativity()])
    with pytest.raises(vv.InvalidInputError):  # a Moon term on an Earth orbit
        vv.propagate_cowell(vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * KMS, vv.EARTH),
                            [60] * u.s, [vv.Relativity(vv.MOON, lense_thirring=False)])


def test_od_command_reads_relativity_in_its_force_list():
    from visviva.od.cli_inputs import parse_forces

    forces = parse_forces(["j2,relativity"])
    assert [type(f).__name__ for f in forces] == ["J2", "Relativity"]
    assert forces[1].lense_thirring
    with pytest.raises(vv.InvalidInputError, match="not a force model"):
        parse_forces(["relativity:2"])
