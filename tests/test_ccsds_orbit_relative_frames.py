"""SANA orbit-relative covariance frames (CCSDS 502.0-B-3 ``COV_REF_FRAME``): RSW, TNW, NTW,
LVLH, VNC and NSW, ``*_INERTIAL`` (the velocity block rotated like the position block) and
``*_ROTATING`` (the frame's exact two-body rotation in the velocity block), PQW_INERTIAL and
EQW_INERTIAL. Until the eighteenth session every SANA name was refused; until the nineteenth
all but RSW_* / TNW_*, and TNW_ROTATING used the RSW rate h/|r|^2 (7 % off 40 deg past
the perigee of an e = 0.1 orbit)."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva._covariance import from_local
from visviva.ccsds.orbit_frames import axes, frame_spec, inverse_jacobian, jacobian
from visviva.core.local_frames import RTN, local_axes

MU = vv.EARTH.gm_km3_s2  # km^3/s^2: the GM an OPM about EARTH reads with
EPOCH = Time("2024-03-01T00:00:00", scale="utc")
ROTATING = ["RSW_ROTATING", "TNW_ROTATING", "NTW_ROTATING", "LVLH_ROTATING", "VNC_ROTATING"]
INERTIAL = ["RSW_INERTIAL", "TNW_INERTIAL", "NTW_INERTIAL", "LVLH_INERTIAL", "VNC_INERTIAL",
            "PQW_INERTIAL", "EQW_INERTIAL"]
# a fixed Sun for the NSW axes (km, km/s from the Earth): off the orbit plane, moving
SUN = (np.array([1.2e8, -8.0e7, 3.5e7]), np.array([16.0, 22.0, 9.5]))


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
    (a flight-path angle != 0, so RSW's S is not along v)."""
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


def _numeric_jacobian(name, r, v, h=1.0, sun=None):
    """d(local state)/d(inertial state) of the rotating frame by finite differences of its axes
    along the orbit: rho = Q(t) (x - r0(t)), rho_dot = dQ/dt (x - r0) + Q (xdot - v0), so the
    Jacobian is [[Q, 0], [dQ/dt, Q]] with dQ/dt the central difference of Q over +-h s (the
    Sun moved linearly for NSW)."""
    spec = frame_spec(name)

    def q_at(dt):
        s = None if sun is None else (sun[0] + dt * sun[1], sun[1])
        return axes(spec, *_two_body(r, v, dt), MU, s)

    jac = np.zeros((6, 6))
    jac[:3, :3] = jac[3:, 3:] = q_at(0.0) if sun is None else axes(spec, r, v, MU, sun)
    jac[3:, :3] = (q_at(h) - q_at(-h)) / (2 * h)
    return jac


@pytest.mark.parametrize("name", ROTATING + ["NSW_ROTATING"])
def test_the_rotating_jacobian_is_the_frame_transform_differentiated_along_the_orbit(name):
    """*_ROTATING: dQ/dt is the derivative of the axes along the two-body orbit (e = 0.1, 40
    deg past perigee), for the velocity-based frames too: TNW_ROTATING used h/|r|^2 (RSW's
    rate), 1/0.93 of the velocity's own turn rate mu h/(r^3 v^2) here."""
    r, v = _eccentric()
    sun = SUN if name.startswith("NSW") else None
    got = jacobian(frame_spec(name), r, v, MU, sun)
    want = _numeric_jacobian(name, r, v, sun=sun)
    omega = np.linalg.norm(np.cross(r, v)) / (r @ r)
    assert omega > 1e-3  # the block is ~1e-3 1/s; central differences: ~2e-7 of it
    assert np.allclose(got, want, rtol=0, atol=1e-6 * omega)
    # the quasi-inertial form has no such block
    assert not jacobian(frame_spec(name.replace("ROTATING", "INERTIAL")), r, v, MU,
                        sun)[3:, :3].any()


def test_tnw_rotating_turns_at_the_velocity_rate_not_at_h_over_r_squared():
    """The old TNW_ROTATING block, -Q [omega]x with omega = h/|r|^2, is off by the difference of
    the two rates: 1 - mu/(r v^2) of omega (7 % here)."""
    r, v = _eccentric()
    h = np.cross(r, v)
    old = -local_axes(r, v, 2) @ np.cross(np.eye(3), h / (r @ r))  # -Q [omega]x, row by row
    got = jacobian(frame_spec("TNW_ROTATING"), r, v, MU)[3:, :3]
    want = _numeric_jacobian("TNW_ROTATING", r, v)[3:, :3]
    rate = MU * np.linalg.norm(h) / (np.linalg.norm(r) ** 3 * (v @ v))
    assert np.linalg.norm(got) == pytest.approx(np.sqrt(2) * rate, rel=1e-12)
    assert np.abs(old - want).max() > 0.05 * np.abs(want).max()  # the old rate: wrong
    assert np.allclose(got, want, rtol=0, atol=1e-9)


def test_the_axes_point_where_the_registry_says():
    """Each frame's defining vector on its axis, for an eccentric inclined state."""
    r, v = _eccentric()
    h = np.cross(r, v)
    rn, vn, hn = (np.linalg.norm(x) for x in (r, v, h))

    def q(name):
        m = axes(frame_spec(name), r, v, MU, SUN)
        assert np.allclose(m @ m.T, np.eye(3), atol=1e-15) and np.linalg.det(m) > 0
        return m

    # LVLH (SANA): Z to nadir, Y against the orbit normal, X = Y x Z along S
    assert np.allclose(q("LVLH_INERTIAL") @ r, [0, 0, -rn], atol=1e-9)
    assert np.allclose(q("LVLH_INERTIAL") @ h, [0, -hn, 0], atol=1e-9)
    assert q("LVLH_INERTIAL")[0] @ v > 0
    # NTW: T along v (Y), N = T x W outward (r . N > 0), W the normal
    assert np.allclose(q("NTW_INERTIAL") @ v, [0, vn, 0], atol=1e-12)
    assert np.allclose(q("NTW_INERTIAL") @ h, [0, 0, hn], atol=1e-6)
    assert q("NTW_INERTIAL")[0] @ r > 0 > q("TNW_INERTIAL")[1] @ r  # TNW's N: inward
    # VNC: V, N = normal, C = V x N outward
    assert np.allclose(q("VNC_INERTIAL") @ v, [vn, 0, 0], atol=1e-12)
    assert np.allclose(q("VNC_INERTIAL") @ h, [0, hn, 0], atol=1e-6)
    # PQW: the eccentricity vector on P
    e_vec = ((v @ v - MU / rn) * r - (r @ v) * v) / MU
    assert np.allclose(q("PQW_INERTIAL") @ e_vec, [0.1, 0, 0], atol=1e-12)
    # NSW: nadir on X, the Sun (seen from the satellite) in the X-Y plane, Y > 0
    s = q("NSW_INERTIAL") @ (SUN[0] - r)
    assert np.allclose(q("NSW_INERTIAL") @ r, [-rn, 0, 0], atol=1e-9)
    assert abs(s[2]) < 1e-12 * np.linalg.norm(s) and s[1] > 0


def test_the_equinoctial_axes_are_broucke_and_cefolas():
    """EQW_INERTIAL: f, g, w of a direct orbit from the classical elements (Broucke & Cefola
    1972: p = tan(i/2) sin(raan), q = tan(i/2) cos(raan)); the node is at raan from f,
    f is X at zero inclination; a retrograde equatorial orbit is refused."""
    spec = frame_spec("EQW_INERTIAL")
    for inc_deg, raan_deg, u_deg in ((51.6, 70.0, 20.0), (98.0, 250.0, 300.0),
                                     (0.0, 0.0, 40.0), (179.0, 10.0, 5.0)):
        inc, raan, arg = np.radians([inc_deg, raan_deg, u_deg])
        node = np.array([np.cos(raan), np.sin(raan), 0.0])
        w = np.array([np.sin(inc) * np.sin(raan), -np.sin(inc) * np.cos(raan), np.cos(inc)])
        along = np.cross(w, node)
        r = 7000.0 * (np.cos(arg) * node + np.sin(arg) * along)
        v = 7.6 * (-np.sin(arg) * node + np.cos(arg) * along)
        p, q = np.tan(inc / 2) * np.sin(raan), np.tan(inc / 2) * np.cos(raan)
        s = 1 + p * p + q * q
        f = np.array([1 - p * p + q * q, 2 * p * q, -2 * p]) / s
        g = np.array([2 * p * q, 1 + p * p - q * q, 2 * q]) / s
        got = axes(spec, r, v)
        assert np.allclose(got, [f, g, w], rtol=0, atol=1e-13)
        assert np.allclose(got @ node, [np.cos(raan), np.sin(raan), 0], atol=1e-13)
    r, v = np.array([7000.0, 0, 0]), np.array([0, -7.6, 1e-9])
    with pytest.raises(vv.InvalidInputError, match="retrograde equatorial"):
        axes(spec, r, v)


def test_a_circular_orbit_has_no_pqw_axes():
    r = np.array([7000.0, 0, 0])
    v = np.array([0, np.sqrt(MU / 7000.0), 0])
    with pytest.raises(vv.InvalidInputError, match="circular.*periapsis direction"):
        axes(frame_spec("PQW_INERTIAL"), r, v, MU)
    assert axes(frame_spec("PQW_INERTIAL"), r, v * (1 + 1e-5), MU)[0] @ r > 0  # e = 2e-5


def test_hand_derived_lvlh_and_ntw_rotations():
    """r along X, v along Y: LVLH = (Y, -Z, -X), NTW = (X, Y, Z), VNC = (Y, Z, X). A diagonal
    LVLH covariance (1, 4, 9 km^2) is diag(9, 1, 4) on the inertial axes."""
    r, v = np.array([7000.0, 0, 0]), np.array([0, 7.5, 0])
    assert np.array_equal(axes(frame_spec("LVLH_INERTIAL"), r, v) + 0.0,
                          [[0, 1, 0], [0, 0, -1], [-1, 0, 0]])
    assert np.array_equal(axes(frame_spec("NTW_INERTIAL"), r, v) + 0.0, np.eye(3))
    assert np.array_equal(axes(frame_spec("VNC_INERTIAL"), r, v) + 0.0,
                          [[0, 1, 0], [0, 0, 1], [1, 0, 0]])
    from visviva.ccsds.covariance import on_state_axes

    c = np.diag([1.0, 4.0, 9.0, 1e-6, 4e-6, 9e-6])
    got = on_state_axes(c, "LVLH_INERTIAL", "GCRF", "gcrs", r, v, "test", "c")
    assert np.allclose(got, np.diag([9.0, 1.0, 4.0, 9e-6, 1e-6, 4e-6]), rtol=0, atol=1e-15)


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


@pytest.mark.parametrize("frame", ROTATING + INERTIAL + ["NSW_INERTIAL", "NSW_ROTATING", "NTW",
                                                         "VNC"])
@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_an_opm_covariance_in_a_sana_frame_round_trips(frame, fmt):
    """read -> GCRS -> write: OPM.from_state(covariance_frame=...) writes the matrix in the SANA
    frame, read_opm gives it back on the state's axes to 1e-12 (NTW, LVLH, VNC, NSW, PQW, EQW
    were refused)."""
    from visviva.ccsds.opm import OPM

    state, cov = _state(), _gcrs_covariance()
    text = vv.write_opm(OPM.from_state(state, object_name="SAT", covariance=cov,
                                       covariance_frame=frame), format=fmt)
    assert frame in text
    back = vv.read_opm(text)
    assert back.sections["covariance"]["COV_REF_FRAME"] == frame
    assert _close(back.covariance, cov)
    written = back.sections["covariance"]
    if frame not in ("RSW_INERTIAL", "RSW_ROTATING"):  # the numbers written are another frame's
        assert abs(written["CX_X"] - from_local(cov, *_eccentric(), RTN)[0, 0]) > 1e-9


@pytest.mark.parametrize("frame", ROTATING + INERTIAL + ["NSW_INERTIAL", "NSW_ROTATING"])
@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_an_oem_covariance_in_a_sana_frame_reads_on_the_state_axes(frame, fmt):
    """OEM COV_REF_FRAME = LVLH_ROTATING ...: seg.covariance(k) gives the state-axes matrix
    (the frame's Jacobian at the covariance's epoch), in KVN and XML."""
    from visviva.ccsds.covariance import from_state_axes, sun_from
    from visviva.ccsds.oem import Ephemeris, OEMSegment

    state, cov = _state(), _gcrs_covariance()
    r, v = state.r.to_value(u.km), state.v.to_value(u.km / u.s)
    local = from_state_axes(cov, frame, r, v, gm=MU, sun=sun_from(EPOCH, "EARTH", "GCRF"))
    seg = OEMSegment.from_states(state.epoch.reshape(1), r[None], v[None],
                                 covariance=local[None], covariance_frame=frame, degree=1,
                                 object_name="SAT")
    text = vv.write_oem(Ephemeris([seg]), format=fmt)
    back = vv.read_oem(text).segments[0]
    assert back.covariances[0].frame == frame
    assert _close(back.covariance(0), cov)


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


def test_ambiguous_unbuilt_and_undefined_frames_are_refused():
    """Plain LVLH (SANA's vs Orekit's/STK's), SEZ_*, an unknown name, PQW of a circular
    orbit and NSW on non-ICRF axes: refused, saying why."""
    from visviva.ccsds.covariance import ORBIT_RELATIVE_FRAMES, values_from_matrix
    from visviva.ccsds.opm import OPM

    state, cov = _state(), _gcrs_covariance()
    assert {"NTW_ROTATING", "LVLH_INERTIAL", "PQW_INERTIAL", "EQW_INERTIAL",
            "NSW_ROTATING"} <= set(ORBIT_RELATIVE_FRAMES)
    base = OPM.from_state(state, object_name="SAT")
    for name, match in (("LVLH", "ambiguous"), ("SEZ_ROTATING", "South-East-Zenith"),
                        ("FOO_INERTIAL", "LVLH_ROTATING")):
        sections = {**base.sections, "covariance": {"COV_REF_FRAME": name,
                                                    **values_from_matrix(cov)}}
        with pytest.raises(vv.InvalidInputError, match=match):
            OPM(sections).covariance  # noqa: B018
    with pytest.raises(vv.InvalidInputError, match="ambiguous"):
        OPM.from_state(state, object_name="SAT", covariance=cov, covariance_frame="LVLH")
    circ = vv.StateVectors([7000.0, 0, 0] * u.km, [0, np.sqrt(MU / 7000.0), 0] * u.km / u.s,
                           vv.EARTH, epoch=EPOCH)
    with pytest.raises(vv.InvalidInputError, match="periapsis"):
        OPM.from_state(circ, object_name="SAT", covariance=cov, covariance_frame="PQW_INERTIAL")
    teme = OPM.from_state(state, object_name="SAT", frame="TEME")
    sections = {**teme.sections, "covariance": {"COV_REF_FRAME": "NSW_INERTIAL",
                                                **values_from_matrix(cov)}}
    with pytest.raises(vv.InvalidInputError, match="ICRF axes"):
        OPM(sections).covariance  # noqa: B018


@settings(max_examples=40, deadline=None)
@given(st.floats(6600.0, 45000.0), st.floats(0.3, 1.4), st.floats(0.0, 3.1),
       st.floats(-0.4, 0.4), st.sampled_from(ROTATING))
def test_the_inverse_jacobian_inverts_it(radius, speed_ratio, inc, gamma, name):
    """For any bound orbit state, the closed-form inverse [[Q^T, 0], [-Q^T B Q^T, Q^T]] is the
    matrix inverse of the rotating Jacobian (to 1e-12)."""
    v = speed_ratio * np.sqrt(MU / radius)
    r = np.array([radius, 0.0, 0.0])
    vel = v * np.array([np.sin(gamma), np.cos(gamma) * np.cos(inc), np.cos(gamma) * np.sin(inc)])
    jac = jacobian(frame_spec(name), r, vel, MU)
    assert np.allclose(inverse_jacobian(jac) @ jac, np.eye(6), rtol=0, atol=1e-12)


def test_the_frames_core_local_frames_also_builds_are_the_same_axes():
    """RSW, TNW and VNC here are core.local_frames' RTN, TNW and VNB (the thrust and
    propagate_covariance frames) to the last bits, and NTW / LVLH their signed permutations."""
    from visviva.core.local_frames import TNW, VNB

    r, v = _eccentric()
    rtn, tnw, vnb = (local_axes(r, v, code) for code in (RTN, TNW, VNB))
    for name, want in (("RSW", rtn), ("TNW", tnw), ("VNC", vnb),
                       ("NTW", np.stack([-tnw[1], tnw[0], tnw[2]])),
                       ("LVLH_INERTIAL", np.stack([rtn[1], -rtn[2], -rtn[0]]))):
        assert np.allclose(axes(frame_spec(name), r, v), want, rtol=0, atol=4e-16)


def test_nsw_with_the_sun_on_the_vertical_is_refused():
    """The Sun 1e-5 rad from the zenith: the S axis is undefined (refused), 1e-3 rad: built."""
    r, v = _eccentric()
    up = r / np.linalg.norm(r)
    side = np.cross(up, np.cross(r, v))
    side /= np.linalg.norm(side)
    for angle, ok in ((1e-5, False), (1e-3, True)):
        sun = (r + 1.5e8 * (np.cos(angle) * up + np.sin(angle) * side), np.zeros(3))
        if ok:
            assert axes(frame_spec("NSW_INERTIAL"), r, v, MU, sun)[1] @ side > 0.99
        else:
            with pytest.raises(vv.InvalidInputError, match="from the local vertical"):
                axes(frame_spec("NSW_INERTIAL"), r, v, MU, sun)


def test_an_oem_writer_refuses_the_ambiguous_lvlh():
    """OEMSegment.from_states(covariance_frame="LVLH") wrote a name its reader refuses."""
    from visviva.ccsds.oem import OEMSegment

    state, cov = _state(), _gcrs_covariance()
    with pytest.raises(vv.InvalidInputError, match="ambiguous"):
        OEMSegment.from_states(state.epoch.reshape(1), state.r.to_value(u.km)[None],
                               state.v.to_value(u.km / u.s)[None], covariance=cov[None],
                               covariance_frame="lvlh", degree=1, object_name="SAT")


@pytest.mark.parametrize("given_frame", [None, "RTN"])
def test_a_propagated_rtn_covariance_is_written_in_rtn_by_the_opm_and_oem_writers(given_frame):
    """propagate_covariance(..., output_frame="RTN") gives RTN matrices (marked as such). The OPM
    writer took them for matrices on the state's axes and rotated them again (covariance_frame=
    "RTN") or wrote them without COV_REF_FRAME (none); the OEM writer, without
    covariance_frame, wrote them as on REF_FRAME's axes: wrong covariances read back, silently
    (RTN sigmas 0.01, 0.1, 0.005 km read back as 0.044, 0.045, 0.078 km, here). Now they are
    written in RTN and read back to the state-axes matrix."""
    from visviva._covariance import km_covariance, local_axes_of, to_local
    from visviva.ccsds.oem import Ephemeris, OEMSegment
    from visviva.ccsds.opm import OPM

    state, cov = _state(), _gcrs_covariance()
    r, v = state.r.to_value(u.km), state.v.to_value(u.km / u.s)
    rtn = km_covariance(to_local(cov[None], r[None], v[None], RTN), "RTN")  # what it returns
    assert local_axes_of(rtn[0]) == "RTN" and local_axes_of(rtn[0] * 2) is None  # kept by index
    opm = vv.read_opm(vv.write_opm(OPM.from_state(state, object_name="SAT", covariance=rtn[0],
                                                  covariance_frame=given_frame)))
    assert opm.sections["covariance"]["COV_REF_FRAME"] == "RTN"
    assert _close(opm.covariance, cov)
    seg = OEMSegment.from_states(state.epoch.reshape(1), r[None], v[None], covariance=rtn,
                                 covariance_frame=given_frame, degree=1, object_name="SAT")
    back = vv.read_oem(vv.write_oem(Ephemeris([seg]))).segments[0]
    assert back.covariances[0].frame == "RTN" and _close(back.covariance(0), cov)
    with pytest.raises(vv.InvalidInputError, match="on the RTN axes .* covariance_frame = 'TNW'"):
        OPM.from_state(state, object_name="SAT", covariance=rtn[0], covariance_frame="TNW")
    with pytest.raises(vv.InvalidInputError, match="OEMSegment.from_states: .* RTN axes"):
        OEMSegment.from_states(state.epoch.reshape(1), r[None], v[None], covariance=rtn,
                               covariance_frame="TNW", degree=1, object_name="SAT")
