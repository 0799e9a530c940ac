"""Cowell propagation, secular J2, Lambert and the offline ephemeris, checked live.

* Cowell with no perturbation against visviva's universal-variable Kepler propagation
  (an independent algorithm) after one day of LEO: max |dr| (km), tolerance 1 mm.
* Cowell with J2 against scipy's ``solve_ivp`` (DOP853, rtol 1e-13) with a plain numpy J2
  right-hand side written from the textbook formula: max |dr| after one day, tolerance 1 m.
* J2 RAAN drift of a 700 km sun-synchronous orbit from a 10-day Cowell run (mean elements by
  one-orbit averaging) against the analytic secular rate: relative difference, 1e-3.
* Lambert (Izzo) round trip through the Kepler propagator over random geometries, M = 0..2:
  max miss distance (km), 1 mm; and Izzo against the universal-variable solver.
* Drag: one-day decay of a 420 km equatorial circular orbit against the analytic
  da/dt = -(a^2/mu) rho B (v - omega a)^2 v (relative, 1e-3).
* SRP: eccentricity growth of a GEO orbit over two days against Gauss's averaged equations,
  |de/dt| = 3/2 F cos(dec) / v (relative, 5e-3).
* Curtis (2014) Example 5.2 published velocities: max |dv| (km/s), 1e-4 (printed digits).
* Sun and Moon geocentric positions from the offline ephemeris (DE421 via jplephem) against
  astropy's built-in ERFA ephemeris and against Skyfield with the same DE421 data when
  available: max |dr| (km).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .base import ONE_M_KM, ONE_MM_KM, Check

__all__ = ["checks"]



def _run(name, metric, tolerance, reference, fn):
    try:
        measured, details = fn()
    except Exception as exc:  # a missing capability or library is a skip, not a crash
        return Check(name, metric, math.nan, tolerance, reference, {"skipped": repr(exc)})
    return Check(name, metric, float(measured), tolerance, reference, details)


def _leo():
    from astropy import units as u

    import visviva as vv

    return vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH
    ).to_state()


def _cowell_vs_kepler():
    from astropy import units as u

    from visviva.satellites import propagate_cowell

    state = _leo()
    t = np.linspace(0, 1, 25) * u.day
    out = propagate_cowell(state, t, [])
    kep = state.propagate(t)
    err = np.linalg.norm((out.r - kep.r).to_value(u.km), axis=-1).max()
    return err, {"outputs": 25, "steps": out.n_steps}


def _cowell_j2_vs_scipy():
    from astropy import units as u
    from scipy.integrate import solve_ivp

    import visviva as vv
    from visviva.satellites import propagate_cowell

    state = _leo()
    gm, R, j2 = vv.EARTH.gm_km3_s2, vv.EARTH.radius_km, vv.EARTH.j2

    def rhs(t, y):
        r = y[:3]
        rn = np.linalg.norm(r)
        z2 = (r[2] / rn) ** 2
        a = -gm * r / rn**3
        k = -1.5 * j2 * gm * R**2 / rn**5
        a = a + k * r * np.array([1 - 5 * z2, 1 - 5 * z2, 3 - 5 * z2])
        return np.concatenate([y[3:], a])

    t = np.linspace(0, 86400.0, 25)
    y0 = np.concatenate([state.r.to_value(u.km), state.v.to_value(u.km / u.s)])
    ref = solve_ivp(rhs, (0, 86400.0), y0, method="DOP853", t_eval=t, rtol=1e-13, atol=1e-13)
    out = propagate_cowell(state, t * u.s, [vv.J2(vv.EARTH)])
    err = np.linalg.norm(out.r.to_value(u.km) - ref.y[:3].T, axis=-1).max()
    return err, {"scipy_nfev": int(ref.nfev), "visviva_nfev": out.n_evaluations}


def _sso_raan_rate():
    from astropy import units as u

    import visviva as vv
    from visviva.satellites import propagate_cowell
    from visviva.satellites.secular import j2_secular_rates, sun_synchronous_inclination

    a_mean = 7078.137
    i_mean = sun_synchronous_inclination(a_mean * u.km).to_value(u.rad)
    forces = [vv.J2(vv.EARTH)]
    period = 2 * np.pi * np.sqrt(a_mean**3 / vv.EARTH.gm_km3_s2)
    a, i = a_mean, i_mean
    for _ in range(3):  # osculating start whose one-orbit means are (a_mean, i_mean)
        st = vv.KeplerianElements.from_semi_major_axis(a * u.km, 0.0, i, 0, 0, 0, vv.EARTH)
        out = propagate_cowell(st.to_state(), np.linspace(0, period, 400, endpoint=False) * u.s,
                               forces)  # fmt: skip
        el = vv.StateVectors(out.r, out.v, vv.EARTH).to_elements()
        a += a_mean - el.semi_major_axis.to_value(u.km).mean()
        i += i_mean - el.inclination.to_value(u.rad).mean()
    st = vv.KeplerianElements.from_semi_major_axis(a * u.km, 0.0, i, 0, 0, 0, vv.EARTH)
    t = np.arange(0, 10 * 86400.0, 300.0)
    out = propagate_cowell(st.to_state(), t * u.s, forces)
    el = vv.StateVectors(out.r, out.v, vv.EARTH).to_elements()
    rate = np.polyfit(t, np.unwrap(el.longitude_of_ascending_node.to_value(u.rad)), 1)[0]
    analytic = j2_secular_rates(a_mean * u.km, 0.0, i_mean)[0].to_value(u.rad / u.s)
    return abs(rate / analytic - 1), {
        "cowell_deg_per_day": math.degrees(rate) * 86400,
        "analytic_deg_per_day": math.degrees(analytic) * 86400,
    }


def _lambert_cases(n=100, seed=7):
    rng = np.random.default_rng(seed)
    r1 = rng.normal(size=(n, 3)) * rng.uniform(6600, 40000, (n, 1))
    r2 = rng.normal(size=(n, 3)) * rng.uniform(6600, 40000, (n, 1))
    r1 *= np.maximum(1.0, 6600 / np.linalg.norm(r1, axis=1))[:, None]
    r2 *= np.maximum(1.0, 6600 / np.linalg.norm(r2, axis=1))[:, None]
    tof = rng.uniform(1000, 100000, n)
    return r1, r2, tof


@functools.lru_cache(maxsize=1)
def _lambert_round_trip():
    from astropy import units as u

    import visviva as vv
    from visviva.core.universal import propagate_one

    mu = 398600.4418
    r1, r2, tof = _lambert_cases()
    worst = 0.0
    diff = 0.0
    solved = 0
    for M in (0, 1, 2):
        for k in range(len(tof)):
            try:
                v1, _ = vv.lambert(r1[k] * u.km, r2[k] * u.km, tof[k] * u.s,
                                   mu * u.km**3 / u.s**2, M)  # fmt: skip
                w1, _ = vv.lambert(r1[k] * u.km, r2[k] * u.km, tof[k] * u.s,
                                   mu * u.km**3 / u.s**2, M, method="universal")  # fmt: skip
            except vv.DomainError:
                continue
            r = np.empty(3)
            v = np.empty(3)
            propagate_one(r1[k], v1.to_value(u.km / u.s), mu, tof[k], r, v)
            worst = max(worst, float(np.linalg.norm(r - r2[k])))
            diff = max(diff, float(np.linalg.norm((v1 - w1).to_value(u.km / u.s))))
            solved += 1
    return worst, {"solved": solved, "izzo_vs_universal_max_dv_km_s": diff}


def _lambert_methods():
    return _lambert_round_trip()[1]["izzo_vs_universal_max_dv_km_s"], {}


def _curtis_5_2():
    from astropy import units as u

    import visviva as vv

    v1, v2 = vv.lambert([5000.0, 10000.0, 2100.0] * u.km, [-14600.0, 2500.0, 7000.0] * u.km,
                        3600 * u.s, 398600 * u.km**3 / u.s**2)  # fmt: skip
    e1 = np.abs(v1.to_value(u.km / u.s) - [-5.9925, 1.9254, 3.2456]).max()
    e2 = np.abs(v2.to_value(u.km / u.s) - [-3.3125, -4.1966, -0.38529]).max()
    return max(e1, e2), {}


def _drag_decay():
    from astropy import units as u

    import visviva as vv
    from visviva.core.perturbations import VALLADO_EXPONENTIAL_TABLE, exponential_density
    from visviva.satellites import propagate_cowell

    R, mu = vv.EARTH.radius_km, vv.EARTH.gm_km3_s2
    omega = vv.constants.EARTH_ROTATION_RAD_S
    st = vv.KeplerianElements.from_semi_major_axis((R + 420.0) * u.km, 0, 0, 0, 0, 0, vv.EARTH)
    B = 0.02
    out = propagate_cowell(st.to_state(), [0.0, 86400.0] * u.s,
                           [vv.AtmosphericDrag(B * u.m**2 / u.kg)])  # fmt: skip
    r = np.linalg.norm(out.r.to_value(u.km), axis=1)
    v = np.linalg.norm(out.v.to_value(u.km / u.s), axis=1)
    a = -mu / (2 * (v**2 / 2 - mu / r))
    am = a.mean()
    rho = exponential_density(am - R, VALLADO_EXPONENTIAL_TABLE) * 1e9
    vc = np.sqrt(mu / am)
    expect = -(am**2 / mu) * rho * B * 1e-6 * (vc - omega * am) ** 2 * vc * 86400.0
    return abs((a[-1] - a[0]) / expect - 1), {"da_km": a[-1] - a[0], "analytic_km": expect}


def srp_eccentricity_growth():
    """GEO under constant in-plane SRP for 2 days: |de| against 3/2 F cos(dec) span / v.

    Returns ``(relative error, details)`` (Gauss's equations averaged over an orbit;
    Montenbruck & Gill 2000, sec. 3.4). Shared with ``tests/test_cowell.py``.
    """
    from astropy import units as u
    from astropy.time import Time

    import visviva as vv
    from visviva.satellites import propagate_cowell
    from visviva.satellites.ephemeris import sun_position

    epoch = Time("2024-06-10T00:00:00", scale="utc")  # no GEO eclipses in June
    geo = vv.KeplerianElements.from_semi_major_axis(
        42164.17 * u.km, 0.0, 0.0, 0.0, 0.0, 0.0, vv.EARTH, epoch=epoch
    ).to_state()
    span = 2 * 86400.0
    srp = vv.SolarRadiationPressure(1.0 * u.m**2 / u.kg, reflectivity=1.0, shadow=None)
    out = propagate_cowell(geo, [0.0, span] * u.s, [srp])
    ev = np.asarray(vv.StateVectors(out.r, out.v, vv.EARTH).eccentricity_vector)
    de = float(np.linalg.norm(ev[-1] - ev[0]))
    s = sun_position(epoch + span / 2 * u.s).to_value(u.km)
    d = np.linalg.norm(s)
    force = 4.56e-6 * 1e-3 * (vv.constants.AU_KM / d) ** 2
    expect = 1.5 * force * np.cos(np.arcsin(s[2] / d)) * span / np.linalg.norm(geo.v.value)
    return abs(de / expect - 1), {"de": de, "analytic": float(expect)}


def _times():
    from astropy import units as u
    from astropy.time import Time

    return Time("2024-01-01T00:00:00", scale="tdb") + np.arange(0, 365, 7.3) * u.day


def _ephemeris_vs_astropy(body):
    def fn():
        from astropy import units as u
        from astropy.coordinates import get_body_barycentric, solar_system_ephemeris

        from visviva.satellites import ephemeris

        t = _times()
        with solar_system_ephemeris.set("builtin"):
            ref = (get_body_barycentric(body, t) - get_body_barycentric("earth", t)).xyz
        mine = ephemeris.position_velocity(body, t, "earth")[0]
        err = np.linalg.norm(mine.to_value(u.km) - ref.to_value(u.km).T, axis=1).max()
        return err, {"backend": ephemeris.backend(), "times": len(t)}

    return fn


def _ephemeris_vs_skyfield(body):
    def fn():
        from pathlib import Path

        from astropy import units as u
        from skyfield.api import load

        from visviva.satellites import ephemeris

        if not Path("de421.bsp").exists():  # never download: skip when not here offline
            raise FileNotFoundError("de421.bsp not in the working directory (no download)")
        eph = load("de421.bsp")
        ts = load.timescale()
        t = _times()
        tt = ts.tdb_jd(t.tdb.jd)
        target = eph["sun" if body == "sun" else "moon"]
        ref = (target - eph["earth"]).at(tt).position.km.T
        mine = ephemeris.position_velocity(body, t, "earth")[0].to_value(u.km)
        return np.linalg.norm(mine - ref, axis=1).max(), {"backend": ephemeris.backend()}

    return fn


def checks(full: bool = False) -> list[Check]:
    import scipy

    sci = f"scipy {scipy.__version__} solve_ivp DOP853"
    out = [
        _run("cowell: no perturbation vs Kepler, 1 day LEO", "max |dr| (km)", ONE_MM_KM,
             "visviva universal-variable Kepler (independent algorithm)", _cowell_vs_kepler),
        _run("cowell: J2 vs scipy DOP853 textbook rhs, 1 day LEO", "max |dr| (km)", ONE_M_KM,
             sci, _cowell_j2_vs_scipy),
        _run("cowell: SSO RAAN rate vs analytic secular J2 (10 d)", "relative difference",
             1e-3, "Vallado 2013 eq. 9-41", _sso_raan_rate),
        _run("cowell: drag decay vs analytic (co-rotating, 420 km)", "relative difference",
             1e-3, "King-Hele 1987 / Vallado 2013 eq. 9-25", _drag_decay),
        _run("cowell: SRP eccentricity growth vs Gauss equations (GEO)",
             "relative difference", 5e-3, "Montenbruck & Gill 2000 sec. 3.4", srp_eccentricity_growth),
        _run("lambert: Izzo round trip through Kepler, M=0..2", "max miss (km)", ONE_MM_KM,
             "visviva universal-variable Kepler", _lambert_round_trip),
        _run("lambert: Izzo vs universal-variable solver", "max |dv1| (km/s)", 1e-8,
             "Vallado 2013 Algorithm 58 (bisection)", _lambert_methods),
        _run("lambert: Curtis Example 5.2", "max |dv| (km/s)", 1e-4,
             "Curtis 2014, Orbital Mechanics for Engineering Students, Ex. 5.2", _curtis_5_2),
        _run("ephemeris: Sun vs astropy builtin (ERFA epv00)", "max |dr| (km)", 20.0,
             "astropy builtin ephemeris", _ephemeris_vs_astropy("sun")),
        _run("ephemeris: Moon vs astropy builtin (ERFA moon98)", "max |dr| (km)", 50.0,
             "astropy builtin ephemeris", _ephemeris_vs_astropy("moon")),
    ]  # fmt: skip
    if full:
        out += [
            _run("ephemeris: Sun vs Skyfield DE421", "max |dr| (km)", 1e-3,
                 "skyfield + de421.bsp", _ephemeris_vs_skyfield("sun")),
            _run("ephemeris: Moon vs Skyfield DE421", "max |dr| (km)", 1e-3,
                 "skyfield + de421.bsp", _ephemeris_vs_skyfield("moon")),
        ]  # fmt: skip
    return out
