"""Lagrangian mechanics via sympy's LagrangesMethod: equations, compiled rhs, conservation."""

import numpy as np
import pytest

sp = pytest.importorskip("sympy")
from sympy.physics.mechanics import dynamicsymbols  # noqa: E402

from visviva import mechanics as mech  # noqa: E402
from visviva.errors import InvalidInputError  # noqa: E402

G = 9.81


def test_pendulum_equation_is_textbook():
    sys = mech.pendulum(m=2.0, length=1.5)
    th = sys.coordinates[0]
    m, ell, g = sp.symbols("m l g", positive=True)
    expected = m * ell**2 * th.diff(dynamicsymbols._t, 2) + m * g * ell * sp.sin(th)
    assert sp.simplify(sys.equations[0] - expected) == 0


def test_pendulum_period_exact():
    from scipy.special import ellipk

    theta0, ell = 2.5, 0.7
    sys = mech.pendulum(length=ell, g=G)
    period = 4 * np.sqrt(ell / G) * ellipk(np.sin(theta0 / 2) ** 2)
    tr = sys.simulate([theta0], [0.0], [0.0, period / 2, period])
    np.testing.assert_allclose(tr.q[:, 0], [theta0, -theta0, theta0], atol=1e-9)


def test_double_pendulum_matches_closed_form_equations():
    m1, m2, l1, l2 = 1.3, 0.7, 1.1, 0.9
    sys = mech.double_pendulum(m1, m2, l1, l2, G)
    rng = np.random.default_rng(5)
    for _ in range(10):
        t1, t2, w1, w2 = rng.uniform(-3, 3, 4)
        d = t1 - t2
        den = 2 * m1 + m2 - m2 * np.cos(2 * t1 - 2 * t2)
        a1 = (
            -G * (2 * m1 + m2) * np.sin(t1)
            - m2 * G * np.sin(t1 - 2 * t2)
            - 2 * np.sin(d) * m2 * (w2**2 * l2 + w1**2 * l1 * np.cos(d))
        ) / (l1 * den)
        a2 = (
            2
            * np.sin(d)
            * (w1**2 * l1 * (m1 + m2) + G * (m1 + m2) * np.cos(t1) + w2**2 * l2 * m2 * np.cos(d))
        ) / (l2 * den)
        out = sys.rhs(0.0, np.array([t1, t2, w1, w2]))
        np.testing.assert_allclose(out, [w1, w2, a1, a2], rtol=1e-12, atol=1e-12)


def test_double_pendulum_energy_conserved_over_100_periods():
    sys = mech.double_pendulum()
    period = 2 * np.pi * np.sqrt(1.0 / G)
    t = np.linspace(0, 100 * period, 1001)
    tr = sys.simulate([2.0, 1.0], [0.0, 0.0], t, rtol=1e-13, atol=1e-15)
    E = tr.energy
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= 1e-10


def test_spring_pendulum_small_oscillation_frequencies():
    m, k, l0 = 0.5, 20.0, 1.0
    sys = mech.spring_pendulum(m, k, l0, G)
    r_eq = l0 + m * G / k
    # numerical Jacobian of the rhs at equilibrium -> eigenfrequencies
    y_eq = np.array([r_eq, 0.0, 0.0, 0.0])
    A = np.zeros((4, 4))
    for j in range(4):
        e = np.zeros(4)
        e[j] = 1e-6
        A[:, j] = (sys.rhs(0, y_eq + e) - sys.rhs(0, y_eq - e)) / 2e-6
    freqs = np.sort(np.abs(np.linalg.eigvals(A).imag))[::2]
    np.testing.assert_allclose(freqs, np.sort([np.sqrt(G / r_eq), np.sqrt(k / m)]), rtol=1e-7)
    tr = sys.simulate([1.2, 0.8], [0.0, 0.3], np.linspace(0, 20, 401))
    assert np.ptp(tr.energy) < 1e-9 * abs(tr.energy[0])


def test_central_potential_kepler_orbit():
    sys = mech.central_potential(m=1.0, k=1.0)
    r0, w0 = 1.0, 1.2
    h = r0**2 * w0
    E = 0.5 * (r0 * w0) ** 2 - 1.0 / r0
    a = -1.0 / (2 * E)
    period = 2 * np.pi * a**1.5
    t = np.linspace(0, period, 201)
    tr = sys.simulate([r0, 0.0], [0.0, w0], t)
    r, phi = tr.q[:, 0], tr.q[:, 1]
    ecc = np.sqrt(1 + 2 * E * h**2)
    np.testing.assert_allclose(r, h**2 / (1 + ecc * np.cos(phi)), rtol=1e-9)
    np.testing.assert_allclose(r**2 * tr.qdot[:, 1], h, rtol=1e-10)
    assert phi[-1] == pytest.approx(2 * np.pi, rel=1e-9)
    # a user potential: isotropic oscillator V = r^2 / 2 has period 2 pi in x and y
    osc = mech.central_potential(lambda r: r**2 / 2)
    tr = osc.simulate([1.0, 0.0], [0.0, 0.5], [0.0, 2 * np.pi])
    assert tr.q[-1, 0] == pytest.approx(1.0, rel=1e-9)


def test_missing_parameters_and_damping_forces():
    x = dynamicsymbols("x")
    m, k = sp.symbols("m k")
    with pytest.raises(InvalidInputError, match="k"):
        mech.LagrangianSystem(m * x.diff() ** 2 / 2 - k * x**2 / 2, [x], {m: 1.0}).rhs(
            0.0, np.array([1.0, 0.0])
        )
    # generalised damping force reproduces the closed-form damped oscillator
    sys = mech.LagrangianSystem(
        m * x.diff() ** 2 / 2 - k * x**2 / 2,
        [x],
        {m: 1.0, k: 4.0},
        forces=lambda t, q, u: -2 * 0.3 * u,
    )
    t = np.linspace(0, 5, 51)
    tr = sys.simulate([1.0], [0.5], t)
    np.testing.assert_allclose(
        tr.q[:, 0], mech.damped_oscillator(1.0, 0.5, 2.0, 0.3, t), atol=1e-10
    )


def test_parameters_may_be_quantities():
    import astropy.units as u

    x = dynamicsymbols("x")
    m, k = sp.symbols("m k")
    sys = mech.LagrangianSystem(
        m * x.diff() ** 2 / 2 - k * x**2 / 2, [x], {m: 500 * u.g, k: 2 * u.N / u.m}
    )
    assert sys.parameters[m] == pytest.approx(0.5) and sys.parameters[k] == pytest.approx(2.0)
    tr = sys.simulate([1.0], [0.0], [0.0, np.pi])
    assert tr.q[-1, 0] == pytest.approx(1.0, abs=1e-9)


def test_nan_generalised_force_raises_instead_of_hanging():
    pen = mech.pendulum()
    damped = mech.LagrangianSystem(pen.lagrangian, pen.coordinates, pen.parameters,
                                   forces=lambda t, q, qdot: [np.nan])
    with pytest.raises(InvalidInputError, match=r"forces\(t, q, qdot\) returned NaN"):
        damped.simulate([1.0], [0.0], np.linspace(0, 1, 5))


def test_ready_made_systems_reject_unphysical_parameters():
    # pendulum(length=-1) used to integrate theta'' = +(g/|l|) sin(theta): an inverted pendulum,
    # silently; a NaN g gave NaN motion
    from visviva.errors import DomainError

    with pytest.raises(DomainError, match="length must be > 0"):
        mech.pendulum(length=-1.0)
    with pytest.raises(DomainError, match="m1 must be > 0"):
        mech.double_pendulum(m1=-1.0)
    with pytest.raises(InvalidInputError, match="NaN"):
        mech.pendulum(g=np.nan)
    with pytest.raises(DomainError, match="k must be > 0"):
        mech.spring_pendulum(k=0.0)
    with pytest.raises(DomainError, match="m must be > 0"):
        mech.central_potential(m=0.0)
    # Quantities are converted to SI: a 150 cm pendulum, small swing, period 2 pi sqrt(l/g)
    u = pytest.importorskip("astropy.units")
    pen = mech.pendulum(m=2 * u.kg, length=150 * u.cm, g=9.81 * u.m / u.s**2)
    period = 2 * np.pi * np.sqrt(1.5 / G)
    tr = pen.simulate([1e-4], [0.0], [0.0, period])
    assert tr.q[-1, 0] == pytest.approx(1e-4, rel=1e-6)


def test_degenerate_lagrangian_raises_a_domain_error():
    # L linear in x' has a zero mass matrix: was Python's bare ZeroDivisionError
    from visviva.errors import DomainError

    x = dynamicsymbols("x")
    with pytest.raises(DomainError, match="not finite"):
        mech.LagrangianSystem(x.diff() - x**2, [x]).simulate([1.0], [0.0], [0.0, 1.0])
    with pytest.raises(InvalidInputError, match="finite"):  # was a DomainError at t = nan
        mech.pendulum().simulate([1.0], [0.0], [0.0, np.nan])


def test_simulate_converts_quantities_instead_of_stripping_them():
    # audit26: np.asarray stripped units: 30 deg ran as 30 rad and [0, 1] min as [0, 1] s
    import astropy.units as u

    sys = mech.pendulum(length=1.0, g=G)
    in_deg = sys.simulate([30.0] * u.deg, [0.0] * u.deg / u.s, [0.0, 0.5] * u.min)
    in_rad = sys.simulate([np.radians(30.0)], [0.0], [0.0, 30.0])
    np.testing.assert_array_equal(in_deg.t, [0.0, 30.0])
    np.testing.assert_allclose(in_deg.q, in_rad.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(in_deg.energy, in_rad.energy, rtol=1e-14)
    np.testing.assert_allclose(sys.energy([[30.0]] * u.deg, [[0.0]] / u.s),
                               -G * np.cos(np.radians(30.0)), rtol=1e-14)


def test_parameters_may_be_named_by_string():
    # audit43: {"m": 1.0, "k": 4.0} for symbols declared positive=True was skipped by sympy's
    # subs (Symbol("m") != Symbol("m", positive=True)), and the error said "symbols without
    # values: m" although m had been given; now keys match the model's symbols by name
    x = dynamicsymbols("x")
    m, k = sp.symbols("m k", positive=True)
    osc = mech.LagrangianSystem(m * x.diff() ** 2 / 2 - k * x**2 / 2, [x], {"m": 1.0, "k": 4.0})
    tr = osc.simulate([1.0], [0.0], [0.0, np.pi / 4, np.pi / 2])
    np.testing.assert_allclose(tr.q[:, 0], np.cos(2.0 * tr.t), atol=1e-10)
    plain = mech.LagrangianSystem(m * x.diff() ** 2 / 2 - k * x**2 / 2, [x],
                                  {sp.Symbol("m"): 1.0, sp.Symbol("k"): 4.0})
    assert plain.parameters == osc.parameters
    with pytest.raises(InvalidInputError, match="'kk' is not a symbol"):
        mech.LagrangianSystem(m * x.diff() ** 2 / 2 - k * x**2 / 2, [x], {"m": 1.0, "kk": 4.0})
    q, p = sp.symbols("q p")
    w = sp.symbols("w", positive=True)
    ham = mech.HamiltonianSystem(p**2 / 2 + w**2 * q**2 / 2, [q], [p], {"w": 2.0})
    np.testing.assert_allclose(ham.simulate([1.0], [0.0], [0.0, np.pi / 2]).q[-1], [-1.0],
                               atol=1e-10)


def test_central_potential_names_a_numpy_potential():
    # audit43: lambda r: -np.exp(-r) / r gave numpy's bare TypeError "loop of ufunc does not
    # support argument 0 of type Mul which has no callable exp method"
    with pytest.raises(InvalidInputError, match="sympy.exp"):
        mech.central_potential(lambda r: -np.exp(-r) / r)
    with pytest.raises(InvalidInputError, match="sympy expression"):
        mech.central_potential(lambda r: "x")
    yukawa = mech.central_potential(lambda r: -sp.exp(-r) / r)
    tr = yukawa.simulate([1.0, 0.0], [0.0, 1.0], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(tr.energy, tr.energy[0], atol=1e-11)
    np.testing.assert_allclose(tr.q[:, 0] ** 2 * tr.qdot[:, 1], 1.0, rtol=1e-11)  # m r^2 phi'
