"""Hamiltonian mechanics: Legendre transform, symplectic orders, phase portraits, sections."""

import numpy as np
import pytest

sp = pytest.importorskip("sympy")
from sympy.physics.mechanics import dynamicsymbols  # noqa: E402

from visviva import errors as mech_errors  # noqa: E402
from visviva import mechanics as mech  # noqa: E402
from visviva.errors import InvalidInputError, ShapeError  # noqa: E402


def test_legendre_transform_textbook():
    x = dynamicsymbols("x")
    m, k = sp.symbols("m k", positive=True)
    H, (p,) = mech.legendre_transform(m * x.diff() ** 2 / 2 - k * x**2 / 2, [x])
    assert sp.simplify(H - (p**2 / (2 * m) + k * x**2 / 2)) == 0
    # polar coordinates: H = p_r^2/2m + p_phi^2/(2 m r^2) + V
    r, ph = dynamicsymbols("r phi")
    L = m * (r.diff() ** 2 + r**2 * ph.diff() ** 2) / 2 + k / r
    H, (pr, pphi) = mech.legendre_transform(L, [r, ph])
    assert sp.simplify(H - (pr**2 / (2 * m) + pphi**2 / (2 * m * r**2) - k / r)) == 0


def _oscillator():
    q, p = sp.symbols("q p")
    return mech.HamiltonianSystem(p**2 / 2 + 4 * q**2 / 2, [q], [p])


@pytest.mark.parametrize(("method", "order"), [("leapfrog", 2), ("yoshida4", 4)])
def test_symplectic_convergence_order(method, order):
    sys = _oscillator()
    assert sys.is_separable
    errors = []
    for dt in (0.02, 0.01):
        tr = sys.symplectic([1.0], [0.0], dt, int(round(5 / dt)), method=method)
        errors.append(np.max(np.abs(tr.q[:, 0] - np.cos(2 * tr.t))))
    assert np.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.15)


def test_symplectic_energy_bounded_no_drift():
    # pendulum H = p^2/2 - cos q, 20000 steps of yoshida4: energy error bounded, no trend
    dT = lambda p: p  # noqa: E731
    dV = lambda q: np.sin(q)  # noqa: E731
    tr = mech.symplectic_integrate(dT, dV, [2.0], [0.0], 0.05, 20000, save_every=10)
    E = tr.p[:, 0] ** 2 / 2 - np.cos(tr.q[:, 0])
    err = np.abs(E - E[0])
    assert err.max() < 1e-5
    first, last = err[: len(err) // 2].max(), err[len(err) // 2 :].max()
    assert last < 2 * first
    # forward then backward returns home
    back = mech.symplectic_integrate(dT, dV, tr.q[-1], tr.p[-1], -0.05, 20000)
    assert back.q[-1, 0] == pytest.approx(2.0, abs=1e-9)


def test_from_lagrangian_and_solve_ivp_agree():
    pend = mech.pendulum(length=1.0, g=9.81)
    hs = mech.HamiltonianSystem.from_lagrangian(pend.lagrangian, pend.coordinates, pend.parameters)
    t = np.linspace(0, 3, 31)
    a = hs.simulate([1.0], [0.0], t)
    b = pend.simulate([1.0], [0.0], t)
    np.testing.assert_allclose(a.q[:, 0], b.q[:, 0], atol=1e-9)
    sym = hs.symplectic([1.0], [0.0], 0.001, 3000, save_every=100)
    np.testing.assert_allclose(sym.q[:, 0], b.q[:, 0], atol=1e-9)


def test_phase_portrait_levels():
    pend = mech.pendulum(length=1.0, g=1.0)
    hs = mech.HamiltonianSystem.from_lagrangian(pend.lagrangian, pend.coordinates, pend.parameters)
    Q, P, E = mech.phase_portrait(hs, (-np.pi, np.pi), (-3, 3), (41, 31))
    assert E.shape == (31, 41)
    np.testing.assert_allclose(E, P**2 / 2 - np.cos(Q), atol=1e-14)
    Q, P, E = mech.phase_portrait(lambda q, p: p**2 + q**2, (-1, 1), (-1, 1), 5)
    assert E[2, 2] == 0.0
    two = mech.HamiltonianSystem(sp.Symbol("a") ** 2 + sp.Symbol("b") ** 2, ["x", "y"], ["a", "b"])
    with pytest.raises(ShapeError):
        mech.phase_portrait(two, (-1, 1), (-1, 1))
    # audit43: a sympy expression (as legendre_transform returns) gave a bare TypeError
    # "'Add' object is not callable"
    q, p = sp.symbols("q p")
    with pytest.raises(InvalidInputError, match="HamiltonianSystem"):
        mech.phase_portrait(p**2 / 2 - sp.cos(q), (-1, 1), (-1, 1), 3)


def test_poincare_section_integrable_and_henon_heiles():
    x, y, px, py = sp.symbols("x y p_x p_y")
    # uncoupled oscillators: every crossing of x = 0 upward has p_x = sqrt(2 E_x)
    sys = mech.HamiltonianSystem((px**2 + x**2) / 2 + (py**2 + 2 * y**2) / 2, [x, y], [px, py])
    t, pts = mech.poincare_section(sys, [0.5, 0.3, 0.0, 0.1], 60.0, 0)
    assert len(t) == 9
    np.testing.assert_allclose(pts[:, 2], 0.5, rtol=1e-9)
    np.testing.assert_allclose(np.diff(t), 2 * np.pi, rtol=1e-9)
    # Henon-Heiles: the crossings stay on the energy surface
    hh = mech.HamiltonianSystem(
        (px**2 + py**2) / 2 + (x**2 + y**2) / 2 + x**2 * y - y**3 / 3, [x, y], [px, py]
    )
    y0 = np.array([0.0, 0.1, 0.35, 0.0])
    t, pts = mech.poincare_section(hh, y0, 300.0, 0, max_points=30)
    assert len(t) == 30
    np.testing.assert_allclose(pts[:, 0], 0.0, atol=1e-10)
    E = hh.energy(pts[:, :2], pts[:, 2:])
    assert np.max(np.abs(E - hh.energy(y0[:2], y0[2:]))) < 1e-9


def test_bad_inputs():
    with pytest.raises(InvalidInputError):
        mech.symplectic_integrate(lambda p: p, lambda q: q, [1.0], [0.0], 0.1, 10, method="rk4")
    with pytest.raises(ShapeError):
        mech.symplectic_integrate(lambda p: p, lambda q: q, [1.0], [0.0, 1.0], 0.1, 10)
    q, p = sp.symbols("q p")
    nonsep = mech.HamiltonianSystem(p**2 * (1 + q**2) / 2, [q], [p])
    assert not nonsep.is_separable
    with pytest.raises(InvalidInputError, match="not separable"):
        nonsep.symplectic([1.0], [0.0], 0.1, 10)


def test_nan_equations_of_motion_raise_a_domain_error():
    # H = p^2/2 - sqrt(q) falls into q < 0, where dH/dq is NaN: solve_ivp used to hang there
    q, p = sp.symbols("q p")
    system = mech.HamiltonianSystem(p**2 / 2 - sp.sqrt(q), [q], [p])
    with np.errstate(invalid="ignore"), pytest.raises(mech_errors.DomainError, match="not finite"):
        system.simulate([0.5], [-3.0], np.linspace(0, 2, 5))
    with np.errstate(invalid="ignore"), pytest.raises(mech_errors.DomainError, match="not finite"):
        mech.poincare_section(system, [0.5, -3.0], 5.0, 0)


def test_symplectic_nan_gradient_raises_instead_of_returning_nan():
    # dV/dq = log q is NaN once the particle passes q = 0: the trajectory used to be NaN, silently
    with np.errstate(divide="ignore", invalid="ignore"), pytest.raises(
        mech_errors.DomainError, match="not finite"
    ):
        mech.symplectic_integrate(lambda p: p, lambda q: np.log(q), [2.0], [-3.0], 0.1, 50)


def test_hamiltonian_simulate_checks_its_inputs():
    q, p = sp.symbols("q p")
    osc = mech.HamiltonianSystem(p**2 / 2 + q**2 / 2, [q], [p])
    with pytest.raises(ShapeError, match=r"shape \(1,\)"):
        osc.simulate([1.0, 0.0], [0.0], [0.0, 1.0])  # was sympy's TypeError
    with pytest.raises(InvalidInputError, match="finite"):
        osc.simulate([np.nan], [0.0], [0.0, 1.0])  # was scipy's ValueError
    with pytest.raises(InvalidInputError, match="t_max"):
        mech.poincare_section(osc, [1.0, 0.0], -5.0, 0)  # was an empty result
    tr = osc.simulate([1.0], [0.0], np.linspace(0, np.pi, 5))  # q = cos t
    np.testing.assert_allclose(tr.q[:, 0], np.cos(np.linspace(0, np.pi, 5)), atol=1e-10)


def test_symplectic_gradient_of_the_wrong_shape_raises():
    # a (2,) dV/dq for a (1,) q silently broadcast the state to (2,)
    with pytest.raises(ShapeError, match="shaped like q0"):
        mech.symplectic_integrate(lambda p: p, lambda q: np.array([q[0], q[0]]), [1.0], [0.0],
                                  0.1, 10)


def test_poincare_section_checks_state_and_section():
    # a short y0 gave sympy's TypeError, a section index past the state numpy's IndexError
    x, y, px, py = sp.symbols("x y p_x p_y")
    system = mech.HamiltonianSystem((px**2 + py**2) / 2 + (x**2 + y**2) / 2, [x, y], [px, py])
    with pytest.raises(ShapeError, match="4 numbers"):
        mech.poincare_section(system, [0.5, 0.0, 0.0], 5.0, 0)
    with pytest.raises(InvalidInputError, match="section index 7"):
        mech.poincare_section(system, [0.5, 0.0, 0.0, 1.0], 5.0, 7)
    # isotropic oscillator: x = 0.5 cos t crosses x = 0 upwards at t = 3 pi / 2 + 2 pi k
    t_cross, _ = mech.poincare_section(system, [0.5, 0.0, 0.0, 1.0], 12.0, 0)
    np.testing.assert_allclose(t_cross, [1.5 * np.pi, 3.5 * np.pi], rtol=1e-9)


def test_kepler_orbit_from_hamiltons_equations():
    # L = (r'^2 + r^2 phi'^2)/2 + 1/r (GM = 1) -> H by the Legendre transform; from periapsis
    # of an a = 1, e = 0.5 ellipse, Hamilton's equations reach apoapsis a(1 + e) at phi = pi after
    # T/2 and close after T = 2 pi (Kepler's third law), with H = -1/(2a) and p_phi = h conserved
    r, ph = dynamicsymbols("r phi")
    kepler = mech.HamiltonianSystem.from_lagrangian(
        (r.diff() ** 2 + r**2 * ph.diff() ** 2) / 2 + 1 / r, [r, ph]
    )
    a, e = 1.0, 0.5
    h = np.sqrt(a * (1 - e**2))
    tr = kepler.simulate([a * (1 - e), 0.0], [0.0, h], [0.0, np.pi, 2 * np.pi])
    np.testing.assert_allclose(tr.q[1], [a * (1 + e), np.pi], rtol=1e-9)
    np.testing.assert_allclose(tr.q[2], [a * (1 - e), 2 * np.pi], rtol=1e-9)
    np.testing.assert_allclose(kepler.energy(tr.q, tr.p), -1 / (2 * a), rtol=1e-10)
    np.testing.assert_allclose(tr.p[:, 1], h, rtol=1e-12)


def test_quantities_are_converted_to_si_not_stripped():
    # audit26: np.asarray stripped units: 100 cm ran as 100 m, a step of 0.6 s / 60 as 0.6
    import astropy.units as u

    q, p, k = sp.symbols("q p k")
    osc = mech.HamiltonianSystem(p**2 / 2 + k * q**2 / 2, [q], [p], {k: 4.0 * u.N / u.m})
    si = osc.symplectic([1.0], [0.0], 0.01, 100)
    mixed = mech.symplectic_integrate(osc._grad_T, osc._grad_V, [100.0] * u.cm, [0.0],
                                      0.6 * u.s / 60, 100)
    np.testing.assert_allclose(mixed.q, si.q, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(mixed.t, si.t, rtol=1e-14)
    np.testing.assert_allclose(si.q[-1, 0], np.cos(2.0), atol=1e-8)  # omega = sqrt(k) = 2
    tr = osc.simulate([100.0] * u.cm, [0.0], [0.0, 1.0 / 60] * u.min)
    np.testing.assert_allclose(tr.q[-1, 0], np.cos(2.0), atol=1e-10)
    np.testing.assert_allclose(osc.energy([[100.0]] * u.cm, [[0.0]]), 2.0, rtol=1e-14)


def test_step_counts_are_not_truncated():
    # audit26: n_steps = int(n_steps) truncated 0.3 / 0.1 = 2.9999999999999996 to 2 steps, so the
    # integration silently stopped at t = 0.2 instead of 0.3
    grad = (lambda p: p, lambda q: q)
    with pytest.raises(InvalidInputError, match="round"):
        mech.symplectic_integrate(*grad, [1.0], [0.0], 0.1, 0.3 / 0.1)
    with pytest.raises(InvalidInputError, match="save_every"):
        mech.symplectic_integrate(*grad, [1.0], [0.0], 0.1, 4, save_every=1.5)
    with pytest.raises(InvalidInputError, match="n_steps"):
        mech.symplectic_integrate(*grad, [1.0], [0.0], 0.1, -1)
    tr = mech.symplectic_integrate(*grad, [1.0], [0.0], 0.1, round(0.3 / 0.1))
    np.testing.assert_allclose(tr.t, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(tr.q[-1, 0], np.cos(0.3), atol=1e-6)
    assert mech.symplectic_integrate(*grad, [1.0], [0.0], 0.1, 3.0).t.size == 4


def test_grid_and_crossing_counts_are_not_truncated():
    # audit26: int() truncated phase_portrait's n = 5.5 to 5 and max_points = 2.5 to 2
    with pytest.raises(InvalidInputError, match="whole number"):
        mech.phase_portrait(lambda q, p: q * q + p * p, (-1, 1), (-1, 1), n=5.5)
    with pytest.raises(InvalidInputError, match="max_points"):
        mech.poincare_section(lambda t, y: [y[1], -y[0]], [1.0, 0.0], 20.0, 1, max_points=2.5)
    t_cross, _ = mech.poincare_section(lambda t, y: [y[1], -y[0]], [1.0, 0.0], 20.0, 1,
                                       max_points=2)
    np.testing.assert_allclose(t_cross, [np.pi, 3 * np.pi], rtol=1e-9)
    assert mech.phase_portrait(lambda q, p: q * q + p * p, (-1, 1), (-1, 1), n=(5, 7))[2].shape == (7, 5)


def test_direction_and_method_are_checked():
    # audit26: direction=5 was taken as 1 silently; method="euler" gave scipy's raw ValueError
    q, p = sp.symbols("q p")
    osc = mech.HamiltonianSystem(p**2 / 2 + q**2 / 2, [q], [p])
    with pytest.raises(InvalidInputError, match="direction"):
        mech.poincare_section(osc, [1.0, 0.0], 10.0, 0, direction=5)
    with pytest.raises(InvalidInputError, match="method"):
        osc.simulate([1.0], [0.0], [0.0, 1.0], method="euler")
    with pytest.raises(InvalidInputError, match="method"):
        mech.pendulum().simulate([1.0], [0.0], [0.0, 1.0], method="euler")


def test_energy_of_nan_states_raises():
    # audit26: HamiltonianSystem.energy and LagrangianSystem.energy returned NaN for NaN input
    q, p = sp.symbols("q p")
    osc = mech.HamiltonianSystem(p**2 / 2 + q**2 / 2, [q], [p])
    with pytest.raises(InvalidInputError, match="q contains NaN"):
        osc.energy([[np.nan]], [[0.0]])
    with pytest.raises(InvalidInputError, match="qdot contains NaN"):
        mech.pendulum().energy([[0.1]], [[np.nan]])
    assert osc.energy([[1.0]], [[1.0]])[0] == 1.0


def test_legendre_transform_keeps_the_real_branch():
    """audit57: L = cosh(q') - q^2/2 is strictly convex (p = sinh q' inverts uniquely over the
    reals), but sympy returns a complex branch too and the transform was refused ("found 2").
    H = p asinh(p) - sqrt(1 + p^2) + q^2/2 (the real branch)."""
    import math

    q = dynamicsymbols("q")
    H, (p,) = mech.legendre_transform(sp.cosh(q.diff()) - q**2 / 2, [q])
    for pv, qv in ((0.7, 0.3), (-1.9, 1.1)):
        got = complex(H.subs({q: qv, p: pv}).evalf())
        want = pv * math.asinh(pv) - math.sqrt(1 + pv * pv) + qv * qv / 2
        assert abs(got.imag) < 1e-14 and got.real == pytest.approx(want, rel=1e-13)
    # not convex: p = q'^2 has two real inverses; q'^4/4: the real inverse is piecewise
    for L in (q.diff() ** 3 / 3, q.diff() ** 4 / 4 - q**2 / 2):
        with pytest.raises(InvalidInputError, match="strictly convex"):
            mech.legendre_transform(L, [q])
