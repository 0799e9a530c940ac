"""SANA orbit-relative covariance frames (CCSDS 502.0-B-3 ``COV_REF_FRAME``): ``RSW_INERTIAL`` /
``TNW_INERTIAL`` (quasi-inertial: the velocity block rotated like the position block) and
``RSW_ROTATING`` / ``TNW_ROTATING`` (the frame's rotation ``omega = h/|r|^2`` in the velocity
block). Until the eighteenth session every SANA name was refused."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva._covariance import from_local, local_jacobian, to_local
from visviva.core.local_frames import RTN, TNW, local_axes

MU = 398600.4418  # km^3/s^2
EPOCH = Time("2024-03-01T00:00:00", scale="utc")


def _two_body(r, v, dt, steps=40):
    """RK4 of the Kepler problem over dt seconds (enough for +-1 s to 1e-15 relative)."""
    y = np.concatenate([r, v])
    h = dt / steps

    def f(y):
        return np.concatenate([y[3:], -MU * y[:3] / np.linalg.norm(y[:3]) ** 3])

    for _ in range(steps):
        k1 = f(y)
        k2 = f(y + h / 2 * k1)
        k3 = f(y + h / 2 * k2)
        k4 = f(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y[:3], y[3:]


def _eccentric():
    """r = 7000 km at perigee of an e = 0.1 orbit inclined 51.6 deg, then 40 deg further on
    (a flight-path angle != 0, so RSW's T is not along v)."""
    rp, e = 7000.0, 0.1
    vp = np.sqrt(MU * (1 + e) / rp)
    inc = np.radians(51.6)
    r0 = np.array([rp, 0.0, 0.0])
    v0 = np.array([0.0, vp * np.cos(inc), vp * np.sin(inc)])
    return _two_body(r0, v0, 700.0, steps=700)


def _close(a, b, tol=1e-12):
    """a == b to tol in units of b's standard deviations (each element over sigma_i sigma_j)."""
    d = np.sqrt(np.diag(b))
    return np.abs((a - b) / np.outer(d, d)).max() < tol


def _numeric_jacobian(r, v, code, h=1.0):
    """d(local state)/d(inertial state) of the rotating frame by finite differences of its axes
    along the orbit: rho = Q(t) (x - r0(t)), rho_dot = dQ/dt (x - r0) + Q (xdot - v0), so the
    Jacobian is [[Q, 0], [dQ/dt, Q]] with dQ/dt the central difference of Q over +-h s."""
    qp = local_axes(*_two_body(r, v, h), code)
    qm = local_axes(*_two_body(r, v, -h), code)
    q = local_axes(r, v, code)
    jac = np.zeros((6, 6))
    jac[:3, :3] = jac[3:, 3:] = q
    jac[3:, :3] = (qp - qm) / (2 * h)
    return jac


def test_the_rotating_jacobian_is_the_frame_transform_differentiated_along_the_orbit():
    """RSW_ROTATING: -Q [omega]x with omega = h/|r|^2 is dQ/dt of the RSW axes (exact in
    Keplerian motion, here on an e = 0.1 orbit 40 deg past perigee); TNW_ROTATING on a
    circular orbit (where v's turn rate is h/|r|^2 too)."""
    r, v = _eccentric()
    got = local_jacobian(r, v, RTN, rotating=True)
    want = _numeric_jacobian(r, v, RTN)
    omega = np.linalg.norm(np.cross(r, v)) / (r @ r)
    assert omega > 1e-3  # the block is ~1e-3 1/s; central differences: ~2e-7 of it
    assert np.allclose(got, want, rtol=0, atol=1e-6 * omega)
    assert np.linalg.norm(got[3:, :3]) == pytest.approx(np.sqrt(2) * omega, rel=1e-12)
    # the quasi-inertial form has no such block
    assert not local_jacobian(r, v, RTN)[3:, :3].any()
    # TNW on a circular orbit
    vc = np.sqrt(MU / 7000.0)
    rc, vcv = np.array([7000.0, 0, 0]), np.array([0, vc * 0.6, vc * 0.8])
    assert np.allclose(local_jacobian(rc, vcv, TNW, rotating=True),
                       _numeric_jacobian(rc, vcv, TNW), rtol=0, atol=1e-6 * omega)
    # from_local undoes to_local, rotating or not
    c = np.diag([1e-2, 4e-2, 9e-2, 1e-8, 4e-8, 9e-8])
    c[1, 3] = c[3, 1] = -0.9 * np.sqrt(4e-2 * 1e-8)
    for rotating in (False, True):
        back = from_local(to_local(c, r, v, RTN, rotating), r, v, RTN, rotating)
        assert _close(back, c)


def _state():
    r, v = _eccentric()
    return vv.StateVectors(r * u.km, v * u.km / u.s, vv.EARTH, epoch=EPOCH)


def _gcrs_covariance():
    sig = np.array([0.01, 0.1, 0.005, 1e-4, 1e-5, 5e-6])  # km, km/s
    corr = np.eye(6)
    corr[1, 3] = corr[3, 1] = -0.9  # in-track / radial-rate, as an OD gives
    local = corr * np.outer(sig, sig)
    r, v = _eccentric()
    return from_local(local, r, v, RTN)


@pytest.mark.parametrize("frame", ["RSW_ROTATING", "TNW_ROTATING", "RSW_INERTIAL",
                                   "TNW_INERTIAL"])
@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_an_opm_covariance_in_a_sana_frame_round_trips(frame, fmt):
    """read -> GCRS -> write: OPM.from_state(covariance_frame=...) writes the matrix in the SANA
    frame, read_opm gives it back on the state's axes to 1e-12; was refused ("neither
    REF_FRAME nor a local orbital frame")."""
    from visviva.ccsds.opm import OPM

    state, cov = _state(), _gcrs_covariance()
    text = vv.write_opm(OPM.from_state(state, object_name="SAT", covariance=cov,
                                       covariance_frame=frame), format=fmt)
    assert frame in text
    back = vv.read_opm(text)
    assert back.sections["covariance"]["COV_REF_FRAME"] == frame
    assert _close(back.covariance, cov)
    # and written again from what was read: the same numbers
    again = vv.read_opm(vv.write_opm(OPM.from_state(back.state, object_name="SAT",
                                                    covariance=back.covariance,
                                                    covariance_frame=frame), format=fmt))
    assert _close(again.covariance, cov)


def test_rotating_and_inertial_readings_differ_by_omega_times_the_position_sigma():
    """The same numbers read as RSW_ROTATING vs RSW_INERTIAL: the position block is the same,
    the velocity differs by omega x dr (0.1 km in-track sigma * 1.1e-3 rad/s ~ 0.11 m/s, more
    than the 0.1 m/s radial-rate sigma)."""
    from visviva.ccsds.opm import OPM

    state, cov = _state(), _gcrs_covariance()
    r, v = state.r.to_value(u.km), state.v.to_value(u.km / u.s)
    written = vv.read_opm(vv.write_opm(OPM.from_state(state, object_name="SAT", covariance=cov,
                                                      covariance_frame="RSW_INERTIAL")))
    sections = {**written.sections,
                "covariance": {**written.sections["covariance"].values,
                               "COV_REF_FRAME": "RSW_ROTATING"}}
    rotating = OPM(sections).covariance
    assert _close(rotating[:3, :3], cov[:3, :3])
    q = local_axes(r, v, RTN)
    omega = np.linalg.norm(np.cross(r, v)) / (r @ r)
    # radial-rate variance on the RSW axes: (sigma_Rdot^2 + omega^2 sigma_T^2
    # + 2 omega cov(T, Rdot))... with omega x dr's radial component = -omega * dT
    rr = (q @ rotating[3:, 3:] @ q.T)[0, 0]
    want = 1e-8 + omega**2 * 1e-2 - 2 * omega * (-0.9 * 1e-4 * 0.1)
    assert rr == pytest.approx(want, rel=1e-9)
    assert np.sqrt(rr) > 1.9 * 1e-4  # +90 %: not the inertial reading


def test_an_oem_covariance_in_tnw_rotating_and_unknown_sana_names():
    """OEM COV_REF_FRAME = TNW_ROTATING: seg.covariance(k) rotates with the state's Jacobian;
    a SANA frame visviva does not build (LVLH_ROTATING, NTW_INERTIAL ...) is refused, naming
    the frames it reads."""
    from visviva.ccsds.covariance import ORBIT_RELATIVE_FRAMES, values_from_matrix
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.opm import OPM

    state, cov = _state(), _gcrs_covariance()
    seg = OEMSegment.from_states(state.epoch.reshape(1), state.r.to_value(u.km)[None],
                                 state.v.to_value(u.km / u.s)[None],
                                 covariance=to_local(cov, *_eccentric(), TNW, True)[None],
                                 covariance_frame="TNW_ROTATING", degree=1,
                                 object_name="SAT")
    assert _close(seg.covariance(0), cov)
    assert set(ORBIT_RELATIVE_FRAMES) == {"RSW_INERTIAL", "RSW_ROTATING", "TNW_INERTIAL",
                                          "TNW_ROTATING"}
    base = OPM.from_state(state, object_name="SAT")
    for name in ("LVLH_ROTATING", "NTW_INERTIAL", "PQW_INERTIAL"):
        sections = {**base.sections, "covariance": {"COV_REF_FRAME": name,
                                                    **values_from_matrix(cov)}}
        with pytest.raises(vv.InvalidInputError, match="RSW_ROTATING"):
            OPM(sections).covariance  # noqa: B018
    with pytest.raises(vv.InvalidInputError, match="not a local orbital frame"):
        OPM.from_state(state, object_name="SAT", covariance=cov, covariance_frame="LVLH")


@settings(max_examples=40, deadline=None)
@given(st.floats(6600.0, 45000.0), st.floats(0.3, 1.4), st.floats(0.0, 3.1),
       st.floats(-0.4, 0.4), st.sampled_from([RTN, TNW]))
def test_the_inverse_jacobian_inverts_it(radius, speed_ratio, inc, gamma, code):
    """For any bound orbit state, from_local's closed-form inverse [[Q^T, 0], [-Q^T B Q^T,
    Q^T]] is the matrix inverse of the rotating Jacobian (to 1e-12)."""
    from visviva._covariance import _inverse_jacobian

    v = speed_ratio * np.sqrt(MU / radius)
    r = np.array([radius, 0.0, 0.0])
    vel = v * np.array([np.sin(gamma), np.cos(gamma) * np.cos(inc), np.cos(gamma) * np.sin(inc)])
    jac = local_jacobian(r, vel, code, rotating=True)
    assert np.allclose(_inverse_jacobian(jac) @ jac, np.eye(6), rtol=0, atol=1e-12)
