"""Drag, altitude events and the Lense-Thirring spin turn about the Earth's pole, not GCRS z.

The celestial intermediate pole is 0.134 deg from the GCRS z axis in 2024. Before the eighteenth
session only the zonal field used it: the atmosphere co-rotated about GCRS z, the geodetic
altitude of drag and of ``AltitudeCrossing`` was measured about GCRS z (to first order in the
flattening: 10-26 m low at mid-latitudes, plus up to ~50 m from the axis), and the
Lense-Thirring spin lay along GCRS z. References here are independent: astropy's GCRS -> ITRS
transformation and its WGS-84 geodetic height, ERFA's CIP (``xys06a``), the textbook formulas.
"""

import erfa
import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import GCRS, ITRS, CartesianRepresentation
from astropy.time import Time

import visviva as vv
from visviva.core import force_block as fb
from visviva.core.geodetic import body_pole, pole_altitude
from visviva.core.perturbations import (
    VALLADO_EXPONENTIAL_TABLE,
    accel_drag_rho,
    cowell_rhs,
    drag_density,
    exponential_density,
)
from visviva.core.relativity import accel_relativity, add_relativity_partials
from visviva.satellites.cowell import ForceModel
from visviva.satellites.frames import offline_iers

EPOCH = Time("2024-06-01T00:00:00", scale="utc")
GM = vv.EARTH.gm_km3_s2
KMS = u.km / u.s
# GCRS points at 350-650 km over mid and high latitudes (where the axis and the flattening
# change the height most), km
POINTS = np.array([[4500.0, 1200.0, 5000.0], [-3000.0, 4100.0, -4600.0],
                   [1000.0, -5200.0, 4200.0], [6700.0, 300.0, 900.0]])  # fmt: skip


def _astropy_height_km(r_km, t):
    """WGS-84 height (km) of GCRS positions at ``t`` through astropy's ITRS (polar motion
    included)."""
    with offline_iers():
        g = GCRS(CartesianRepresentation(r_km.T * u.km), obstime=t)
        return g.transform_to(ITRS(obstime=t)).earth_location.height.to_value(u.km)


def _cip(t):
    tt = t.tt
    x, y, _ = erfa.xys06a(tt.jd1, tt.jd2)
    return np.array([x, y, np.sqrt(1.0 - x * x - y * y)])


def test_drag_altitude_is_astropy_geodetic_height():
    """The altitude of drag and events (the block's pole, exact geodetic height) is astropy's
    ITRS WGS-84 height to 5 cm (polar motion, left out, moves it by ~3 cm at 400 km); it was
    first order in f about GCRS z: 14-73 m low at these points."""
    model = ForceModel(GM, [vv.AtmosphericDrag(0.02 * u.m**2 / u.kg)], (), EPOCH, (0.0, 86400.0))
    for dt in (0.0, 50000.0):
        want = _astropy_height_km(POINTS, EPOCH + dt * u.s)
        got = np.array([pole_altitude(dt, *p, model.force) for p in POINTS])
        assert np.abs(got - want).max() < 5e-5  # km


def test_drag_corotates_about_the_earths_pole():
    """The drag acceleration is -1/2 rho B |v_rel| v_rel with v_rel = v - omega p x r about
    ERFA's CIP p and rho the table's at astropy's height: to 3e-6 relative (about GCRS z,
    v_rel was ~1 m/s off: 1.5e-4 of the acceleration)."""
    bc = 0.02
    t = 30000.0
    forces = [vv.AtmosphericDrag(bc * u.m**2 / u.kg)]
    model = ForceModel(GM, forces, (), EPOCH, (0.0, 86400.0))
    plain = ForceModel(GM, [], (), EPOCH, (0.0, 86400.0))
    p = _cip(EPOCH + t * u.s)
    omega = vv.EARTH.rotation_rate.to_value(u.rad / u.s)
    heights = _astropy_height_km(POINTS, EPOCH + t * u.s)
    for r, h in zip(POINTS, heights, strict=True):
        v = 7.6 * np.cross([0.3, -0.2, 0.93], r) / np.linalg.norm(np.cross([0.3, -0.2, 0.93], r))
        y = np.r_[r, v]
        a, b = np.zeros(6), np.zeros(6)
        cowell_rhs(t, y, *model.arrays(), a)
        cowell_rhs(t, y, *plain.arrays(), b)
        w = v - omega * np.cross(p, r)
        rho = exponential_density(h, VALLADO_EXPONENTIAL_TABLE) * 1e9  # kg/km^3
        want = -0.5 * rho * bc * 1e-6 * np.linalg.norm(w) * w
        assert np.abs((a - b)[3:] - want).max() < 3e-6 * np.linalg.norm(want)  # 3.5 cm: polar motion


def test_altitude_crossing_is_astropy_height_at_the_event():
    """An AltitudeCrossing at 450 km on an orbit inclined 63 deg: astropy's ITRS height of the
    event's state is 450 km to 0.1 m (measured 0.04 m; was 24.9 and 0.33 m off about GCRS z,
    first order in f)."""
    state = vv.KeplerianElements.from_semi_major_axis(
        6878.137 * u.km, 0.02, 63 * u.deg, 40 * u.deg, 70 * u.deg, 0 * u.deg, vv.EARTH,
        epoch=EPOCH).to_state()  # fmt: skip
    res = vv.propagate_cowell(state, 6000 * u.s, [], events=[vv.AltitudeCrossing(450 * u.km)],
                              rtol=1e-12, atol=1e-12)  # fmt: skip
    records = res.events_named("altitude")
    assert len(records) >= 2
    for rec in records:
        h = _astropy_height_km(rec.r.to_value(u.km)[None], EPOCH + rec.t)[0]
        assert abs(h - 450.0) < 1e-4, (rec, h)


def test_lense_thirring_spin_along_the_earths_pole():
    """The Lense-Thirring acceleration of a GCRS state with an epoch is the IERS formula
    (Conventions 2010, eq. 10.12) with J along ERFA's CIP, to the round-off of the total
    acceleration (3e-5 of the term; along GCRS z it was 2.3e-3 off), and its partials match central differences."""
    from visviva.core.variational import acceleration_partials

    t = 20000.0
    full = ForceModel(GM, [vv.Relativity()], (), EPOCH, (0.0, 86400.0))
    schw = ForceModel(GM, [vv.Relativity(lense_thirring=False)], (), EPOCH, (0.0, 86400.0))
    assert full.force[fb.POLE + 2] > 0 and schw.force[fb.POLE + 2] == 0  # no table unused
    j = full.force[fb.LENSE_THIRRING_J] * _cip(EPOCH + t * u.s)
    c2 = 299792.458**2
    y = np.array([5200.0, -3100.0, 3400.0, 2.1, 6.0, -3.9])
    a, b = np.zeros(6), np.zeros(6)
    cowell_rhs(t, y, *full.arrays(), a)
    cowell_rhs(t, y, *schw.arrays(), b)
    r, v = y[:3], y[3:]
    rn = np.linalg.norm(r)
    want = 2 * GM / (c2 * rn**3) * (3 / rn**2 * np.cross(r, v) * (r @ j) + np.cross(v, j))
    # a - b is 3e-5 of an ulp of |a| (8e-3 km/s^2): its round-off, 1.5e-6 of the term here
    assert np.abs((a - b)[3:] - want).max() < 3e-5 * np.linalg.norm(want)
    # the partials of the term about a tilted pole, against central differences of the kernel,
    # and the block's STM partials carry them about its pole
    px, py = body_pole(t, full.force)
    jm = full.force[fb.LENSE_THIRRING_J]
    dadr, dadv = np.zeros((3, 3)), np.zeros((3, 3))
    add_relativity_partials(*y, GM, jm, px, py, dadr, dadv)
    s0, s1 = np.zeros((3, 3)), np.zeros((3, 3))
    add_relativity_partials(*y, GM, 0.0, px, py, s0, s1)
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-3 * (np.linalg.norm(r) if k < 3 else np.linalg.norm(v))
        up, down = np.zeros(3), np.zeros(3)
        accel_relativity(*(y + d), GM, jm, px, py, up)
        accel_relativity(*(y - d), GM, jm, px, py, down)
        fd = (up - down) / (2 * d[k])
        col = dadr[:, k] if k < 3 else dadv[:, k - 3]
        assert np.abs(col - fd).max() < 1e-5 * np.abs(fd).max()
    p = [np.zeros((3, 3)) for _ in range(4)]
    acceleration_partials(t, y, *full.arrays(), p[0], p[1])
    acceleration_partials(t, y, *schw.arrays(), p[2], p[3])
    # (round-off of the two-body gradient, 1e-6 km/s^2/km: 2e-6 of the term; z axis: 2e-3)
    assert np.abs((p[0] - p[2]) - (dadr - s0)).max() <= 1e-4 * np.abs(dadr - s0).max()
    assert np.abs((p[1] - p[3]) - (dadv - s1)).max() <= 1e-9 * np.abs(dadv - s1).max()


def test_drag_partials_about_the_pole_match_central_differences():
    """acceleration_partials of drag (co-rotation about the CIP, the height's gradient the
    ellipsoid's normal) against central differences of cowell_rhs, within one band."""
    from visviva.core.variational import acceleration_partials

    model = ForceModel(GM, [vv.AtmosphericDrag(0.02 * u.m**2 / u.kg)], (), EPOCH, (0.0, 86400.0))
    plain = ForceModel(GM, [], (), EPOCH, (0.0, 86400.0))
    t = 40000.0
    y = np.array([4500.0, 1200.0, 5000.0, -5.5, 1.0, 4.7])
    force = model.force.copy()
    force[fb.DENSITY_BAND] = 1 + int(np.searchsorted(VALLADO_EXPONENTIAL_TABLE[:, 0],
                                                     pole_altitude(t, *y[:3], force)) - 1)
    arrays = (force,) + model.arrays()[1:]
    dadr, dadv = np.zeros((3, 3)), np.zeros((3, 3))
    g0, g1 = np.zeros((3, 3)), np.zeros((3, 3))
    acceleration_partials(t, y, *arrays, dadr, dadv)
    acceleration_partials(t, y, *plain.arrays(), g0, g1)
    px, py = body_pole(t, force)
    omega = force[fb.ROTATION_RATE]

    def drag(yy):  # the drag term alone (cowell_rhs's kernels), no two-body round-off
        out = np.zeros(3)
        rho = drag_density(t, *yy[:3], px, py, -1, np.zeros(3), force, model.atm)
        accel_drag_rho(*yy, rho, force[fb.BALLISTIC], omega, px, py, out)
        return out

    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-2 if k < 3 else 1e-5
        fd = (drag(y + d) - drag(y - d)) / (2 * d[k])
        col = (dadr - g0)[:, k] if k < 3 else (dadv - g1)[:, k - 3]
        # (dadr - g0 keeps the round-off of the two-body gradient, 2e-22: 1e-9 of these)
        assert np.abs(col - fd).max() < 1e-6 * np.abs(fd).max()


def test_one_pole_table_shared_and_absent_without_a_user():
    """The force model tabulates the pole once for every force that turns with it (its knots
    after the block's slots), and not at all when none does."""
    both = ForceModel(GM, [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.02 * u.m**2 / u.kg)], (),
                      EPOCH, (0.0, 86400.0))  # fmt: skip
    n = int(both.force[fb.POLE + 2])
    assert n >= 3 and both.force.size == fb.FORCE_SIZE + 2 * n
    assert both.zonal.size == 3  # J_n only
    assert np.degrees(np.hypot(*body_pole(0.0, both.force))) == pytest.approx(0.1354, abs=5e-4)
    third = ForceModel(GM, [vv.ThirdBody(vv.MOON)], (), EPOCH, (0.0, 86400.0))
    assert third.force.size == fb.FORCE_SIZE and third.force[fb.POLE + 2] == 0


def test_nrlmsis_log_density_gradient_about_the_pole_matches_central_differences():
    """The analytic gradient of the gridded ln(rho) through the exact geodetic height,
    latitude and hour angle about the CIP (what the STM of a fit with NRLMSIS drag uses)."""
    pytest.importorskip("pymsis")
    from visviva.core.perturbations import grid_density_at, grid_log_density_gradient_at
    from visviva.satellites import ephemeris

    drag = vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, model="nrlmsis", f107=150.0, f107a=150.0,
                              ap=4.0)  # fmt: skip
    model = ForceModel(GM, [drag], (), EPOCH, (0.0, 3600.0))
    assert model.force[fb.POLE + 2] > 0
    sun = ephemeris.sun_position(EPOCH).to_value(u.km)
    for pos in POINTS:
        g = np.zeros(3)
        grid_log_density_gradient_at(600.0, *pos, sun, model.force, model.atm, g)
        fd = np.zeros(3)
        for k in range(3):
            d = np.zeros(3)
            d[k] = 0.05  # km
            up = grid_density_at(600.0, *(pos + d), sun, model.force, model.atm)
            down = grid_density_at(600.0, *(pos - d), sun, model.force, model.atm)
            fd[k] = (np.log(up) - np.log(down)) / 0.1
        assert np.abs(g - fd).max() < 1e-4 * np.linalg.norm(fd)
