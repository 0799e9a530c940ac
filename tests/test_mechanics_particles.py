"""Newtonian particles, work and energy: exact solutions and conservation laws."""

import numpy as np
import pytest
from astropy import units as u

from visviva import mechanics as mech
from visviva.errors import DomainError, InvalidInputError, ShapeError


def test_projectile_linear_drag_exact_vs_integration():
    t = np.linspace(0, 3, 61)
    k = 0.7
    tr = mech.projectile([0.0, 0.0, 1.0], [10.0, 2.0, 10.0], t, drag="linear", k=k)
    r, v = mech.projectile_linear_drag([0.0, 0.0, 1.0], [10.0, 2.0, 10.0], t, k)
    np.testing.assert_allclose(tr.r, r, atol=1e-8)
    np.testing.assert_allclose(tr.v, v, atol=1e-8)
    # terminal velocity reached
    _, v_late = mech.projectile_linear_drag([0, 0], [5.0, 5.0], [100.0], 0.5)
    np.testing.assert_allclose(v_late[0], [0.0, -9.81 / 0.5], atol=1e-12)


def test_projectile_linear_drag_vacuum_limit_is_smooth():
    t = np.linspace(0, 2, 5)
    r0, v0 = mech.projectile_linear_drag([0, 0], [3.0, 4.0], t, 0.0)
    np.testing.assert_allclose(r0[:, 1], 4 * t - 0.5 * 9.81 * t**2, rtol=1e-15, atol=1e-15)
    for k in (1e-12, 1e-8, 1e-4):
        r, v = mech.projectile_linear_drag([0, 0], [3.0, 4.0], t, k)
        assert np.max(np.abs(r - r0)) < 10 * k
    r, v = mech.projectile_linear_drag([0, 0] * u.m, [3, 4] * u.m / u.s, t * u.s, 0.1 / u.s)
    assert r.unit == u.m and v.unit == u.m / u.s


def test_quadratic_drag_fall_tanh():
    t = np.linspace(0, 5, 51)
    k = 0.2
    tr = mech.projectile([0.0], [0.0], t, drag="quadratic", k=k)
    vt = np.sqrt(9.81 / k)
    np.testing.assert_allclose(tr.v[:, 0], -vt * np.tanh(9.81 * t / vt), atol=1e-8)
    np.testing.assert_allclose(
        tr.r[:, 0], -(vt**2 / 9.81) * np.log(np.cosh(9.81 * t / vt)), atol=1e-8
    )


def test_many_particles_spring_and_momentum():
    # two particles joined by a spring: centre of mass moves uniformly, relative motion is SHM
    m = np.array([1.0, 3.0])
    k = 12.0

    def force(t, r, v):
        d = r[1] - r[0]
        return np.array([k * d, -k * d])

    t = np.linspace(0, 4, 81)
    tr = mech.solve_particles(force, m, [[0.0, 0, 0], [1.0, 0, 0]], [[0.0, 1, 0], [0.0, 0, 0]], t)
    assert tr.r.shape == (81, 2, 3)
    mu = m.prod() / m.sum()
    w = np.sqrt(k / mu)
    sep = tr.r[:, 1, 0] - tr.r[:, 0, 0]
    np.testing.assert_allclose(sep, np.cos(w * t), atol=1e-8)
    rep = mech.conservation_report(tr, lambda r: 0.5 * k * np.sum((r[1] - r[0]) ** 2))
    assert rep["energy"] < 1e-9 and rep["momentum"] < 1e-12


def test_solve_particles_errors():
    f = mech.uniform_gravity(1.0)
    with pytest.raises(DomainError):
        mech.solve_particles(f, -1.0, [0.0, 0.0], [0.0, 0.0], [0, 1])
    with pytest.raises(ShapeError):
        mech.solve_particles(f, 1.0, [0.0, 0.0], [0.0, 0.0, 0.0], [0, 1])
    with pytest.raises(InvalidInputError, match="increasing"):
        mech.solve_particles(f, 1.0, [0.0, 0.0], [0.0, 0.0], [1, 0])
    with pytest.raises(ShapeError, match="force returned"):
        mech.solve_particles(lambda t, r, v: np.zeros(5), 1.0, [0.0, 0.0], [0.0, 0.0], [0, 1])


def test_potentials_are_minus_gradient():
    rng = np.random.default_rng(0)
    fields = [
        mech.UniformGravity(2.0),
        mech.Spring(3.0, [0.1, 0.2, 0.3], 0.5),
        mech.InverseSquare(4.0),
        mech.Coulomb(1e-6, -2e-6),
    ]
    for fld in fields:
        for _ in range(5):
            r = rng.normal(size=3) + [2.0, 0, 0]
            grad = np.zeros(3)
            for j in range(3):
                e = np.zeros(3)
                e[j] = 1e-6
                grad[j] = (fld.potential(r + e) - fld.potential(r - e)) / 2e-6
            np.testing.assert_allclose(
                fld.force(r), -grad, rtol=1e-6, atol=1e-8 * np.abs(grad).max()
            )
    # Coulomb attraction between opposite charges
    assert mech.Coulomb(1.0, -1.0).force(np.array([1.0, 0, 0]))[0] < 0


def test_work_energy_theorem_with_drag_and_gravity():
    t = np.linspace(0, 2, 401)
    k = 0.3
    drag = mech.linear_drag(k)
    grav = mech.UniformGravity(1.0, 9.81)
    tr = mech.solve_particles(
        lambda t, r, v: drag(t, r, v) + grav.force(r), 1.0, [0.0, 0.0, 0.0], [4.0, 0.0, 6.0], t
    )
    W_total = mech.work(lambda t, r, v: drag(t, r, v) + grav.force(r), tr)
    dK = tr.kinetic_energy[-1] - tr.kinetic_energy[0]
    assert W_total == pytest.approx(dK, rel=1e-9)
    # gravity's work is minus the change of its potential energy
    W_g = mech.work(grav, tr)
    assert W_g == pytest.approx(-(grav.potential(tr.r[-1]) - grav.potential(tr.r[0])), rel=1e-9)
    cw = mech.cumulative_work(grav, tr)
    np.testing.assert_allclose(cw, -(grav.potential(tr.r) - grav.potential(tr.r[0])), atol=1e-8)


def test_conservation_for_different_masses_inverse_square():
    m = np.array([5.0, 1.0, 0.01])
    pairs = mech.InverseSquarePairs(m, G=1.0)
    r0 = np.array([[0.0, 0, 0], [1.0, 0, 0], [0, 2.0, 0.1]])
    v0 = np.array([[0.0, -0.45, 0], [0.0, 2.2, 0], [-1.6, 0.0, 0]])
    t = np.linspace(0, 5, 201)
    tr = mech.solve_particles(pairs, m, r0, v0, t, rtol=1e-12, atol=1e-14)
    rep = mech.conservation_report(tr, pairs.potential)
    assert rep["energy"] < 1e-9
    assert rep["momentum"] < 1e-11
    assert rep["angular_momentum"] < 1e-10


def test_work_along_curve_path_independence_and_circulation():
    field = mech.InverseSquare(2.0)
    V = field.potential

    def straight(s):
        return np.array([1.0 + s, 0.5 * s, 0.0])

    def wiggly(s):
        return np.array([1.0 + s, 0.5 * s + 0.3 * np.sin(np.pi * s), 0.2 * np.sin(2 * np.pi * s)])

    expected = V(straight(0.0)) - V(straight(1.0))
    for path in (straight, wiggly):
        assert mech.work_along_curve(field.force, path, (0, 1)) == pytest.approx(
            expected, rel=1e-10
        )
    # a non-conservative field F = (-y, x, 0) has circulation 2 pi around the unit circle
    swirl = lambda r: np.array([-r[1], r[0], 0.0])  # noqa: E731
    circle = lambda s: np.array([np.cos(s), np.sin(s), 0.0])  # noqa: E731
    tangent = lambda s: np.array([-np.sin(s), np.cos(s), 0.0])  # noqa: E731
    assert mech.work_along_curve(swirl, circle, (0, 2 * np.pi)) == pytest.approx(
        2 * np.pi, rel=1e-10
    )
    assert mech.work_along_curve(swirl, circle, (0, 2 * np.pi), tangent) == pytest.approx(
        2 * np.pi, rel=1e-12
    )


def test_nan_force_raises_instead_of_hanging():
    # solve_ivp shrinks its step for ever on a NaN derivative: the call used to hang
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(InvalidInputError, match=r"force\(t, r, v\) returned NaN"):
        mech.solve_particles(lambda t, r, v: np.full_like(r, np.nan), 1.0, [0, 0, 0], [1, 0, 0], t)
    # NaN only later in the motion: the time is named
    late = lambda t, r, v: -r if t < 0.5 else r / 0.0  # noqa: E731
    with np.errstate(divide="ignore", invalid="ignore"), pytest.raises(
        InvalidInputError, match=r"at t = 0\.5"
    ):
        mech.solve_particles(late, 1.0, [1.0, 0, 0], [0, 1.0, 0], t)
    with pytest.raises(ShapeError, match=r"must return shape \(3,\)"):
        mech.solve_particles(lambda t, r, v: np.zeros(2), 1.0, [0, 0, 0], [1, 0, 0], t)


def test_work_of_a_nan_force_raises_instead_of_returning_nan():
    tr = mech.solve_particles(mech.uniform_gravity(1.0), 1.0, [0.0, 0.0, 0.0], [1.0, 0.0, 5.0],
                              np.linspace(0, 1, 11))
    with pytest.raises(InvalidInputError, match=r"force\(t, r, v\) returned NaN"):
        mech.work(lambda t, r, v: np.full(3, np.nan), tr)
    with np.errstate(divide="ignore", invalid="ignore"), pytest.raises(
        InvalidInputError, match=r"field\(r\) returned NaN or inf at s = 0"
    ):
        mech.work_along_curve(lambda r: r / 0.0,
                              lambda s: np.array([s, 0.0, 0.0]), (0.0, 1.0))
    # the work of gravity on the same motion is m g (z0 - z1) (published closed form)
    W = mech.work(lambda t, r, v: np.array([0.0, 0.0, -9.81]), tr)
    assert W == pytest.approx(9.81 * (tr.r[0, 2] - tr.r[-1, 2]), rel=1e-12)


def test_conservation_report_rejects_a_nan_potential():
    # a potential that is NaN somewhere on the path made every drift NaN, silently
    tr = mech.solve_particles(mech.uniform_gravity(1.0), 1.0, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0],
                              np.linspace(0, 0.5, 11))
    with np.errstate(invalid="ignore"), pytest.raises(InvalidInputError, match=r"potential\(r\)"):
        mech.conservation_report(tr, lambda r: np.sqrt(r[2] - 0.5))
    report = mech.conservation_report(tr, mech.UniformGravity(1.0, 9.81).potential)
    assert report["energy"] < 1e-9 and report["momentum"] > 0.1  # gravity changes momentum


def test_force_builders_reject_negative_drag_and_nan_gravity():
    # projectile(drag="linear", k=-0.1) integrated an accelerating "anti-drag" silently (the exact
    # projectile_linear_drag already refused k < 0); k without a drag law was ignored silently
    t = [0.0, 1.0]
    with pytest.raises(DomainError, match="k must be >= 0"):
        mech.projectile([0, 0], [10, 10], t, drag="linear", k=-0.1)
    with pytest.raises(DomainError, match="k must be >= 0"):
        mech.projectile([0, 0], [10, 10], t, drag="quadratic", k=-0.1)
    with pytest.raises(InvalidInputError, match="without a drag law"):
        mech.projectile([0, 0], [10, 10], t, k=0.5)
    with pytest.raises(DomainError, match="b must be >= 0"):
        mech.linear_drag(-0.3)
    with pytest.raises(DomainError, match="c must be >= 0"):
        mech.quadratic_drag(-0.3)
    with pytest.raises(InvalidInputError, match="g contains NaN"):
        mech.uniform_gravity(1.0, np.nan)
    with pytest.raises(DomainError, match="masses must be > 0"):
        mech.uniform_gravity(-1.0)
    # Quantities: k = 0.5 / s equals k = 0.5 in SI, and matches the exact solution
    tr = mech.projectile([0, 0], [10, 10], [0.0, 1.0], drag="linear", k=0.5 / u.s)
    r, _ = mech.projectile_linear_drag([0, 0], [10, 10], [1.0], 0.5)
    np.testing.assert_allclose(tr.r[-1], r[0], atol=1e-9)


def test_force_returning_a_quantity_is_converted_not_stripped():
    # audit26: np.asarray stripped the unit of a force callable's Quantity: 9.81e-3 kN fell as
    # 9.81e-3 N (1000 times too slowly), and an acceleration passed for a force silently
    import astropy.units as u

    from visviva.errors import UnitsError

    t = [0.0, 0.5, 1.0]
    plain = mech.solve_particles(lambda t, r, v: np.array([0.0, 0.0, -9.81]), 1.0,
                                 [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], t)
    kilo = mech.solve_particles(lambda t, r, v: np.array([0.0, 0.0, -9.81e-3]) * u.kN, 1.0,
                                [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], t)
    np.testing.assert_allclose(kilo.r[-1], [0.0, 0.0, -9.81 / 2], rtol=1e-12)
    np.testing.assert_allclose(kilo.r, plain.r, rtol=1e-12, atol=1e-15)
    with pytest.raises(UnitsError, match="force"):
        mech.solve_particles(lambda t, r, v: np.array([0.0, 0.0, -9.81]) * u.m / u.s**2, 1.0,
                             [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], t)
    W = mech.work(lambda t, r, v: np.array([0.0, 0.0, -9.81e-3]) * u.kN, plain)
    np.testing.assert_allclose(W, 9.81 * 9.81 / 2, rtol=1e-10)


def test_projectile_linear_drag_shapes():
    # audit26: r0 (3,) with v0 (2,) raised a bare numpy ValueError; a 2-D t gave a (1, 1, 2) r
    with pytest.raises(ShapeError, match="r0 and v0"):
        mech.projectile_linear_drag([0.0, 0.0, 0.0], [10.0, 10.0], [1.0], 0.5)
    with pytest.raises(ShapeError, match="1-D"):
        mech.projectile_linear_drag([0.0, 0.0], [10.0, 10.0], [[1.0, 2.0]], 0.5)


def test_conservative_fields_convert_quantity_positions():
    # audit26: np.asarray stripped units: UniformGravity(1).potential([0, 0, 100] cm) was 981 J
    # (100 m), and InverseSquarePairs read charges in microcoulomb as coulomb (1e12 times the
    # energy)
    grav = mech.UniformGravity(1.0, 9.81)
    assert grav.potential([0.0, 0.0, 100.0] * u.cm).to_value(u.J) == pytest.approx(9.81, rel=1e-15)
    assert grav.potential([0.0, 0.0, 1.0]) == pytest.approx(9.81, rel=1e-15)
    spring = mech.Spring(2.0, rest_length=1.0)
    np.testing.assert_allclose(spring.force([200.0, 0.0, 0.0] * u.cm).to_value(u.N), [-2.0, 0, 0])
    assert mech.InverseSquare(1.0).potential([1.0, 0.0, 0.0] * u.km).to_value(u.J) == -1e-3
    r = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    micro = mech.InverseSquarePairs([1.0, 1.0], charges=[1.0, 1.0] * u.uC)
    coulomb = mech.InverseSquarePairs([1.0, 1.0], charges=[1e-6, 1e-6])
    assert micro.potential(r) == pytest.approx(coulomb.potential(r), rel=1e-15)
    assert coulomb.potential(r) == pytest.approx(8.9875517923e9 * 1e-12, rel=1e-12)


def test_uniform_gravity_axis_outside_the_positions_is_a_shape_error():
    # audit26: axis=5 on 3-D positions raised a bare IndexError from inside the force
    with pytest.raises(ShapeError, match="axis 5"):
        mech.uniform_gravity(2.0, 9.81, axis=5)(0.0, np.zeros(3), np.zeros(3))
    np.testing.assert_array_equal(mech.uniform_gravity(2.0, 9.81, axis=1)(0.0, np.zeros(3), None),
                                  [0.0, -19.62, 0.0])


def test_radial_infall_collision_names_the_time():
    # audit43: radial infall from rest at r0 = 1 (mu = 1) reaches r = 0 at the free-fall time
    # pi/2 sqrt(r0^3 / 2 mu) = 1.1107; integrating past it failed with scipy's bare "Required
    # step size is less than spacing between numbers", naming neither the time nor the cause
    from visviva.errors import ConvergenceError

    t_ff = np.pi / 2 * np.sqrt(0.5)
    field = mech.InverseSquare(1.0)
    t = np.linspace(0.0, 1.01 * t_ff, 41)
    with pytest.raises(ConvergenceError, match="collision") as err:
        mech.solve_particles(lambda t, r, v: field.force(r), 1.0, [1.0, 0, 0], [0, 0, 0], t)
    reached = float(str(err.value).split("failed after t = ")[1].split(" ")[0])
    assert t_ff - 2 * (t[1] - t[0]) < reached < t_ff
    # up to the last sample before the collision the motion is the exact cycloid
    # r = (1 + cos eta) / 2, t = (eta + sin eta) / sqrt(8)
    from scipy.optimize import brentq

    tr = mech.solve_particles(lambda t, r, v: field.force(r), 1.0, [1.0, 0, 0], [0, 0, 0],
                              t[t <= reached])
    eta = [brentq(lambda e, s=s: (e + np.sin(e)) / np.sqrt(8.0) - s, 0.0, np.pi) for s in tr.t]
    np.testing.assert_allclose(tr.r[:, 0], (1.0 + np.cos(eta)) / 2.0, rtol=1e-7)


def test_work_warns_when_the_samples_do_not_resolve_the_power():
    # audit43: work and cumulative_work integrate F . v by Simpson's rule on the output samples;
    # 11 samples over 0.6 of an e = 0.44 Kepler orbit gave W = -0.6036 J against the change of
    # kinetic energy -0.5994 J (0.7 % off) without a word. Now a UserWarning gives the
    # Richardson estimate of the error; densely sampled motion (401 samples: 5e-9) stays quiet.
    import warnings

    field = mech.InverseSquare(1.0)
    F = lambda t, r, v: field.force(r)  # noqa: E731
    v0 = 1.2
    period = 2 * np.pi * (1.0 / (2.0 - v0**2)) ** 1.5
    coarse = mech.solve_particles(F, 1.0, [1.0, 0, 0], [0, v0, 0], np.linspace(0, 0.6 * period, 11))
    dK = coarse.kinetic_energy[-1] - coarse.kinetic_energy[0]
    with pytest.warns(UserWarning, match="do not resolve") as record:
        W = mech.work(F, coarse)
    estimate = float(str(record[0].message).split("uncertain by about ")[1].split(" ")[0])
    assert estimate / 3 < abs(W - dK) < estimate * 3
    with pytest.warns(UserWarning, match="cumulative_work"):
        mech.cumulative_work(F, coarse)
    dense = mech.solve_particles(F, 1.0, [1.0, 0, 0], [0, v0, 0], np.linspace(0, 0.6 * period, 401))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        W = mech.work(F, dense)
    assert W == pytest.approx(dense.kinetic_energy[-1] - dense.kinetic_energy[0], rel=1e-7)
