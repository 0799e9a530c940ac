"""Rigid bodies: inertia tensors, Euler angles vs scipy, Euler's equations with exact results."""

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from visviva import mechanics as mech
from visviva.errors import DomainError, InvalidInputError, ShapeError, UnitsError


def test_inertia_tensor_point_masses():
    I = mech.inertia_tensor([1.0, 2.0], [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    expected = np.array([[4.0, 0.0, 0.0], [0.0, 3.0, -2.0], [0.0, -2.0, 3.0]])
    np.testing.assert_allclose(I, expected)
    I = mech.inertia_tensor(2 * u.kg, [0, 0, 100] * u.cm)
    assert I.unit == u.kg * u.m**2
    np.testing.assert_allclose(I.value, np.diag([2.0, 2.0, 0.0]))
    with pytest.raises(DomainError):
        mech.inertia_tensor([-1.0], [[1, 0, 0]])
    with pytest.raises(ShapeError):
        mech.inertia_tensor([1.0, 1.0], [[1, 0, 0]])
    with pytest.raises(ShapeError):
        mech.inertia_tensor([1.0], [[1, 0]])


def test_solids_against_point_mass_sampling():
    rng = np.random.default_rng(1)
    n = 400_000
    # box: uniform samples converge to the formula
    pts = (rng.random((n, 3)) - 0.5) * [1.0, 2.0, 3.0]
    I = mech.inertia_tensor(np.full(n, 6.0 / n), pts)
    np.testing.assert_allclose(I, mech.inertia_box(6.0, 1.0, 2.0, 3.0), rtol=5e-3, atol=5e-3)
    # rod, sphere, shell, cylinder closed forms
    assert mech.inertia_thin_rod(3.0, 2.0)[0, 0] == pytest.approx(1.0)
    assert mech.inertia_solid_sphere(5.0, 2.0)[2, 2] == pytest.approx(8.0)
    assert mech.inertia_spherical_shell(3.0, 1.0)[1, 1] == pytest.approx(2.0)
    c = mech.inertia_solid_cylinder(12.0, 1.0, 2.0)
    np.testing.assert_allclose(np.diag(c), [7.0, 7.0, 6.0])


def test_parallel_axis_equals_direct_sum():
    rng = np.random.default_rng(2)
    m = rng.random(10)
    r = rng.normal(size=(10, 3))
    com = m @ r / m.sum()
    I_cm = mech.inertia_tensor(m, r, origin=com)
    I_o = mech.inertia_tensor(m, r)
    np.testing.assert_allclose(mech.parallel_axis(I_cm, m.sum(), com), I_o, atol=1e-13)


def test_principal_axes_diagonalise():
    R = Rotation.from_euler("ZXZ", [0.3, 0.8, -1.1]).as_matrix()
    I = R @ np.diag([1.0, 2.0, 2.5]) @ R.T
    moments, axes = mech.principal_axes(I)
    np.testing.assert_allclose(moments, [1.0, 2.0, 2.5], rtol=1e-13)
    np.testing.assert_allclose(axes.T @ I @ axes, np.diag(moments), atol=1e-13)
    assert np.linalg.det(axes) == pytest.approx(1.0)


angles = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(angles, angles, angles)
def test_rotation_matrix_313_is_scipy_zxz_and_round_trips(phi, theta, psi):
    R = mech.rotation_matrix_313(phi, theta, psi)
    np.testing.assert_allclose(
        R, Rotation.from_euler("ZXZ", [phi, theta, psi]).as_matrix(), atol=1e-14
    )
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-14)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
    back = mech.rotation_matrix_313(*mech.euler_angles_313(R))
    np.testing.assert_allclose(back, R, atol=4e-15)


near_lock = st.one_of(st.floats(0.0, 1e-6), st.floats(np.pi - 1e-6, np.pi),
                      st.sampled_from([0.0, 9e-13, 1e-8, np.pi - 1e-8, np.pi]))


@settings(max_examples=300, deadline=None)
@given(angles, near_lock, angles)
def test_euler_angles_313_round_trip_to_rounding_near_gimbal_lock(phi, theta, psi):
    # R rounded by another library (scipy): its elements of size sin(theta) carry absolute
    # rounding errors; the round trip must still return R to rounding (it was 2e-12 off at
    # theta = 9e-13 when a threshold switched to the locked formula, 1e-8 at theta = 1e-8 with
    # psi taken from R20 and R21)
    R = Rotation.from_euler("ZXZ", [phi, theta, psi]).as_matrix()
    p, t, q = mech.euler_angles_313(R)
    assert -np.pi < p <= np.pi and -np.pi < q <= np.pi and 0.0 <= t <= np.pi
    np.testing.assert_allclose(mech.rotation_matrix_313(p, t, q), R, atol=4e-15)


def test_euler_angles_313_agree_with_scipy_and_gimbal_lock():
    rng = np.random.default_rng(3)
    rots = Rotation.random(100, random_state=4)
    phi, theta, psi = mech.euler_angles_313(rots.as_matrix())
    np.testing.assert_allclose(np.column_stack([phi, theta, psi]), rots.as_euler("ZXZ"), atol=1e-10)
    assert rng is not None
    for th in (0.0, np.pi):
        R = mech.rotation_matrix_313(0.4, th, 0.3)
        np.testing.assert_allclose(
            mech.rotation_matrix_313(*mech.euler_angles_313(R)), R, atol=1e-14
        )
    assert mech.rotation_matrix_313([0.1, 0.2], 0.3, 0.4).shape == (2, 3, 3)
    with pytest.raises(InvalidInputError, match="rotation"):
        mech.euler_angles_313(2 * np.eye(3))


def test_euler_equations_principal_form():
    w = np.array([0.3, -0.5, 0.7])
    I = np.array([1.0, 2.0, 3.0])
    dw = mech.euler_equations(I, w)
    expected = [
        (I[1] - I[2]) * w[1] * w[2] / I[0],
        (I[2] - I[0]) * w[2] * w[0] / I[1],
        (I[0] - I[1]) * w[0] * w[1] / I[2],
    ]
    np.testing.assert_allclose(dw, expected, rtol=1e-14)
    with pytest.raises(DomainError, match="triangle"):
        mech.euler_equations([1.0, 1.0, 3.0], w)


def test_torque_free_symmetric_body_precession():
    I1, I3 = 2.0, 3.0
    w0 = np.array([0.2, 0.0, 1.5])
    t = np.linspace(0, 20, 401)
    tr = mech.integrate_rigid_body([I1, I1, I3], w0, t)
    Ob = mech.torque_free_precession_rate(I1, I3, w0[2])
    # body frame: (w1, w2) rotates at (I3 - I1) w3 / I1 with w3 constant
    np.testing.assert_allclose(tr.omega[:, 0], 0.2 * np.cos(Ob * t), atol=1e-9)
    np.testing.assert_allclose(tr.omega[:, 1], 0.2 * np.sin(Ob * t), atol=1e-9)
    # space frame: L fixed, symmetry axis cones about L at |L| / I1
    L = tr.angular_momentum
    np.testing.assert_allclose(L, np.broadcast_to(L[0], L.shape), atol=1e-9)
    axis = tr.rotation_matrices[:, :, 2]
    Lhat = L[0] / np.linalg.norm(L[0])
    e1 = np.cross(Lhat, [0, 0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(Lhat, e1)
    angle = np.unwrap(np.arctan2(axis @ e2, axis @ e1))
    rate = np.polyfit(t, angle, 1)[0]
    assert rate == pytest.approx(np.linalg.norm(L[0]) / I1, rel=1e-8)
    assert np.ptp(tr.rotational_energy) < 1e-10


def test_intermediate_axis_instability():
    t = np.linspace(0, 40, 801)
    I = [1.0, 2.0, 3.0]
    mid = mech.integrate_rigid_body(I, [1e-3, 1.0, 1e-3], t)
    assert mid.omega[:, 1].min() < -0.9  # the spin about the middle axis flips
    for w0 in ([1.0, 1e-3, 1e-3], [1e-3, 1e-3, 1.0]):
        stable = mech.integrate_rigid_body(I, w0, t)
        big = int(np.argmax(np.abs(w0)))
        assert stable.omega[:, big].min() > 0.99


def test_heavy_top_steady_precession():
    m, g, ell = 1.0, 9.81, 0.1
    I1_cm, I3 = 2e-3, 3e-3
    I1 = I1_cm + m * ell**2  # about the fixed point
    theta, w3 = 0.6, 150.0
    Omega = mech.heavy_top_precession_rate(I1, I3, m, g, ell, w3, theta)
    assert Omega == pytest.approx(m * g * ell / (I3 * w3), rel=0.1)  # gyroscope limit
    # start exactly on the steady precession: phi' = Omega, theta' = 0, psi' = w3 - Omega cos
    R0 = mech.rotation_matrix_313(0.0, theta, 0.0)
    w0 = [0.0, Omega * np.sin(theta), w3]
    t = np.linspace(0, 2.0, 201)
    tr = mech.integrate_rigid_body(
        [I1, I1, I3], w0, t, attitude0=R0, torque=mech.heavy_top_torque(m, g, ell)
    )
    phi, th, psi = tr.euler_angles_313
    assert np.max(np.abs(th - theta)) < 1e-8
    np.testing.assert_allclose(phi, Omega * t, atol=1e-7)
    fast = mech.heavy_top_precession_rate(I1, I3, m, g, ell, w3, theta, branch="fast")
    assert fast * Omega == pytest.approx(m * g * ell / (I1 * np.cos(theta)), rel=1e-12)
    with pytest.raises(DomainError, match="faster"):
        mech.heavy_top_precession_rate(I1, I3, m, g, ell, 1.0, 0.1)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_inertia_tensor_rotates_as_a_tensor_and_obeys_triangle(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 12))
    m = rng.uniform(0.1, 5.0, n)
    r = rng.normal(size=(n, 3))
    R = Rotation.random(random_state=seed).as_matrix()
    I = mech.inertia_tensor(m, r)
    np.testing.assert_allclose(
        mech.inertia_tensor(m, r @ R.T), R @ I @ R.T, atol=1e-12 * np.abs(I).max()
    )
    moments, axes = mech.principal_axes(I)
    assert moments[0] >= -1e-12 and moments[2] <= moments[0] + moments[1] + 1e-12 * moments[2]
    np.testing.assert_allclose(axes.T @ I @ axes, np.diag(moments), atol=1e-12 * moments[2])


def test_bad_torque_raises_instead_of_hanging():
    # a NaN torque used to hang solve_ivp; a (2,) torque gave numpy's broadcasting ValueError
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(InvalidInputError, match=r"torque\(t, R, omega\) returned NaN"):
        mech.integrate_rigid_body([1, 2, 3], [1, 0, 0], t, torque=lambda t, R, w: [np.nan, 0, 0])
    with pytest.raises(ShapeError, match=r"must return shape \(3,\)"):
        mech.integrate_rigid_body([1, 2, 3], [1, 0, 0], t, torque=lambda t, R, w: [1.0, 0.0])


def test_heavy_top_rate_takes_scalars_with_a_clear_error():
    # an array omega3 gave numpy's "only 0-dimensional arrays" TypeError
    with pytest.raises(ShapeError, match="omega3 must be a scalar"):
        mech.heavy_top_precession_rate(0.012, 0.003, 1.0, 9.81, 0.1, np.array([150.0, 200.0]), 0.6)
    # a fast top: the slow rate tends to m g l / (I3 omega3) (Goldstein eq. 5.79)
    rate = mech.heavy_top_precession_rate(0.012, 0.003, 1.0, 9.81, 0.1, 1e5, 0.6)
    assert rate == pytest.approx(9.81 * 0.1 / (0.003 * 1e5), rel=1e-6)


def test_asymmetric_top_period_is_the_elliptic_integral():
    # torque-free asymmetric top started near the intermediate axis: omega_2 is a Jacobi elliptic
    # function with period 4 K(k^2) / tau (Landau & Lifshitz, Mechanics, sec. 37), while the
    # energy and |L| (and L itself in the reference frame) are conserved; the angular velocity
    # stays on the invariable plane, omega . L = 2 E (Poinsot)
    from scipy.special import ellipk

    I1, I2, I3 = 1.0, 2.0, 3.0
    w0 = np.array([0.01, 1.0, 0.01])
    moments = np.array([I1, I2, I3])
    L2, E2 = np.sum((moments * w0) ** 2), np.sum(moments * w0**2)  # |L|^2 and 2E
    assert L2 > E2 * I2  # this branch of Landau's formula (eq. 37.10)
    tau = np.sqrt((I3 - I2) * (L2 - E2 * I1) / (I1 * I2 * I3))
    k2 = (I2 - I1) * (E2 * I3 - L2) / ((I3 - I2) * (L2 - E2 * I1))
    period = 4 * ellipk(k2) / tau
    t = np.linspace(0, 2 * period, 4001)
    tr = mech.integrate_rigid_body(moments, w0, t)
    w2 = tr.omega[:, 1]
    # zero crossings of omega_2 (two per period), located by linear interpolation
    i = np.flatnonzero(np.sign(w2[:-1]) != np.sign(w2[1:]))
    crossings = t[i] - w2[i] * (t[i + 1] - t[i]) / (w2[i + 1] - w2[i])
    assert len(crossings) == 4
    assert 2 * np.mean(np.diff(crossings)) == pytest.approx(period, rel=1e-6)
    E = tr.rotational_energy
    L = tr.angular_momentum
    assert np.ptp(E) / E[0] < 1e-9
    np.testing.assert_allclose(L, np.broadcast_to(L[0], L.shape), atol=1e-9 * np.linalg.norm(L[0]))
    omega_ref = tr.rotation.apply(tr.omega)
    np.testing.assert_allclose(np.sum(omega_ref * L, axis=1), E2, rtol=1e-9)


def test_parallel_axis_refuses_batches_instead_of_broadcasting():
    # audit19: a mass array of 3 broadcast against the (3, 3) tensor column-wise and returned a
    # non-symmetric, wrong tensor silently; several displacements raised a bare numpy ValueError
    with pytest.raises(ShapeError, match="one inertia tensor"):
        mech.parallel_axis(np.eye(3), [1.0, 2.0, 3.0], [1.0, 0.0, 0.0])
    with pytest.raises(ShapeError, match="one inertia tensor"):
        mech.parallel_axis(np.eye(3), 1.0, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    # Steiner for a rod about its end: m L^2 / 12 + m (L/2)^2 = m L^2 / 3
    rod = mech.parallel_axis(mech.inertia_thin_rod(3.0, 2.0), 3.0 * u.kg, [0, 0, 100.0] * u.cm)
    np.testing.assert_allclose(rod.to_value(u.kg * u.m**2).diagonal(), [4.0, 4.0, 0.0], atol=1e-14)


def test_angular_velocity_refuses_hertz():
    # audit19: omega in Hz was silently read as rad/s (2 pi too slow)
    with pytest.raises(UnitsError, match="angular frequency"):
        mech.euler_equations(np.diag([1.0, 2.0, 3.0]), [0.1, 0.2, 0.3] * u.Hz)


def test_heavy_top_horizontal_axis_at_float_half_pi():
    # audit19: theta = np.pi / 2 (cos = 6e-17) returned a fast precession of 1.6e18 rad/s
    # instead of the documented DomainError; the slow branch is m g l / (I3 w3) exactly
    args = (0.02, 0.01, 1.0, 9.81, 0.1, 200.0)
    with pytest.raises(DomainError, match="pi/2"):
        mech.heavy_top_precession_rate(*args, np.pi / 2, branch="fast")
    slow = mech.heavy_top_precession_rate(*args, np.pi / 2, branch="slow")
    assert slow == pytest.approx(1.0 * 9.81 * 0.1 / (0.01 * 200.0), rel=1e-15)
    # a tilt resolvable in double precision keeps its (large, finite) fast root
    fast = mech.heavy_top_precession_rate(*args, np.pi / 2 - 1e-9, branch="fast")
    assert fast == pytest.approx(0.01 * 200.0 / (0.02 * np.sin(1e-9)), rel=1e-6)


def test_mismatched_shapes_are_shape_errors():
    # audit26: bare numpy ValueErrors ("operands could not be broadcast together")
    with pytest.raises(ShapeError, match="euler_equations"):
        mech.euler_equations([1.0, 2.0, 3.0], np.ones((4, 3)), np.ones((2, 3)))
    with pytest.raises(ShapeError, match="torque_free_precession_rate"):
        mech.torque_free_precession_rate([2.0, 1.0], [3.0, 1.0, 1.0], 1.5)
    with pytest.raises(ShapeError, match="origin must be one point"):
        mech.inertia_tensor([1.0, 1.0], [[1, 0, 0], [0, 1, 0]], origin=np.zeros((3, 3)))
    # what still broadcasts keeps working: Euler's equations for a batch with one torque
    w = np.array([[1.0, 2.0, 3.0], [0.5, 0.0, 1.0]])
    got = mech.euler_equations([1.0, 2.0, 3.0], w, [0.0, 0.0, 3.0])
    np.testing.assert_allclose(got[0], [(2 - 3) * 6 / 1, (3 - 1) * 3 / 2, (1 - 2) * 2 / 3 + 1.0])


def test_torque_returning_a_quantity_is_converted_not_stripped():
    # audit26: a torque of 100 N cm spun the body up as 100 N m (omega3 34.3 instead of 1.33)
    tr = mech.integrate_rigid_body([1.0, 2.0, 3.0], [0.0, 0.0, 1.0], [0.0, 1.0],
                                   torque=lambda t, R, w: np.array([0.0, 0.0, 100.0]) * u.N * u.cm)
    np.testing.assert_allclose(tr.omega[-1], [0.0, 0.0, 1.0 + 1.0 / 3.0], rtol=1e-10, atol=1e-15)
    with pytest.raises(UnitsError, match="torque"):
        mech.integrate_rigid_body([1.0, 2.0, 3.0], [0.0, 0.0, 1.0], [0.0, 1.0],
                                  torque=lambda t, R, w: np.array([0.0, 0.0, 1.0]) * u.N)


def test_solids_broadcast_one_tensor_per_body():
    # audit26: three spheres of masses 1, 2, 3 gave ONE tensor diag(0.4, 0.8, 1.2) (the batch was
    # spread over the axes); two cylinders gave a (2,) array; three rods a bare ValueError
    spheres = mech.inertia_solid_sphere([1.0, 2.0, 3.0], 1.0)
    assert spheres.shape == (3, 3, 3)
    for m, I in zip([1.0, 2.0, 3.0], spheres, strict=True):
        np.testing.assert_array_equal(I, 0.4 * m * np.eye(3))
    shells = mech.inertia_spherical_shell(1.0, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(shells[2], 6.0 * np.eye(3))
    cylinders = mech.inertia_solid_cylinder([1.0, 2.0], 1.0, 1.0)
    np.testing.assert_allclose(cylinders[1], np.diag([2 * 4 / 12, 2 * 4 / 12, 1.0]))
    rods = mech.inertia_thin_rod([1.0, 2.0, 3.0], 1.0)
    np.testing.assert_allclose(rods[2], np.diag([0.25, 0.25, 0.0]))
    boxes = mech.inertia_box([12.0, 24.0], 1.0, 2.0, 3.0)
    np.testing.assert_allclose(boxes[1], 2 * np.diag([13.0, 10.0, 5.0]))
    one = mech.inertia_box(12.0 * u.kg, 100 * u.cm, 2 * u.m, 3 * u.m)
    assert one.shape == (3, 3) and one.unit == u.kg * u.m**2
    np.testing.assert_allclose(one.value, np.diag([13.0, 10.0, 5.0]))
    with pytest.raises(ShapeError, match="inertia_solid_sphere"):
        mech.inertia_solid_sphere([1.0, 2.0], [1.0, 2.0, 3.0])


def test_non_symmetric_inertia_tensors_are_refused():
    # audit26: parallel_axis passed the asymmetry on; euler_equations and integrate_rigid_body
    # symmetrised [[1, 0.5, 0], [0, 2, 0], [0, 0, 3]] silently into a tensor nobody gave
    bad = [[1.0, 0.5, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]]
    with pytest.raises(InvalidInputError, match="symmetric"):
        mech.parallel_axis(bad, 1.0, [1.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="symmetric"):
        mech.euler_equations(bad, [1.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match="symmetric"):
        mech.integrate_rigid_body(bad, [1.0, 0.0, 0.0], [0.0, 1.0])
    with pytest.raises(InvalidInputError, match="symmetric"):
        mech.principal_axes(bad)


def test_unphysical_inertia_is_refused_everywhere():
    # audit43: principal_axes and parallel_axis took a tensor with a negative moment or with
    # I3 > I1 + I2 (returned moments [-1, 1, 1] / [1, 1, 5] as if of a body), and
    # torque_free_precession_rate(1, 3, 1) gave a rate of 2 rad/s for a "symmetric body" with
    # I3 = 3 I1, which no body has (I3 <= 2 I1: a flat disc is the limit)
    negative, triangle = np.diag([-1.0, 1.0, 1.0]), np.diag([1.0, 1.0, 5.0])
    for bad, match in ((negative, "negative principal moment"), (triangle, "triangle")):
        with pytest.raises(DomainError, match=match):
            mech.principal_axes(bad)
        with pytest.raises(DomainError, match=match):
            mech.parallel_axis(bad, 1.0, [1.0, 0.0, 0.0])
        with pytest.raises(DomainError):  # refused before audit43 too
            mech.euler_equations(bad, [1.0, 0.0, 0.0])
    with pytest.raises(DomainError, match="triangle"):
        mech.torque_free_precession_rate(1.0, 3.0, 1.0)
    with pytest.raises(DomainError, match="triangle"):
        mech.torque_free_precession_rate([1.0, 1.0], [1.5, 2.5], 1.0)
    # the limits are real bodies: a thin rod (0, I, I), a flat plate (I1 + I2 = I3), a disc
    rod = mech.inertia_thin_rod(3.0, 2.0)
    np.testing.assert_allclose(mech.principal_axes(rod)[0], [0.0, 1.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(mech.parallel_axis(rod, 3.0, [0, 0, 1.0])[0, 0], 4.0)
    plate = mech.inertia_box(12.0, 1.0, 2.0, 0.0)
    rot = Rotation.from_euler("ZXZ", [0.3, 1.1, -0.4]).as_matrix()
    np.testing.assert_allclose(mech.principal_axes(rot @ plate @ rot.T)[0], [1.0, 4.0, 5.0],
                               rtol=1e-13)
    disc = mech.inertia_solid_cylinder(2.0, 1.0, 0.0)  # I1 = m R^2 / 4, I3 = m R^2 / 2 = 2 I1
    assert mech.torque_free_precession_rate(disc[0, 0], disc[2, 2], 3.0) == pytest.approx(3.0)
