"""Two-body (Kepler) propagation, checked live against REBOUND, Skyfield and exact arithmetic.

* REBOUND's IAS15 (adaptive, machine-precision setting; a test particle around a point mass) over
  a regime sweep: circular, e = 0.5, 0.99, 0.99999, exact parabola, e = 1.0001, 1.1, 3, 10,
  radial outgoing / infall / from rest, and 20 revolutions; max relative |dr|, |dv|.
* Skyfield's ``keplerlib.propagate`` (SPICE prop2b algorithm) over the same conics (not radial:
  Skyfield refuses h = 0).
* The same universal-variable equations in 40-digit arithmetic (mpmath) on far starts falling
  through periapsis, where a naive universal-variable solver loses up to six digits.
* Published examples: Vallado (2013) Example 2-4 and Curtis (2014) Example 3.7.
* Invariants over 10^5 random states of every conic: energy and angular momentum, and the
  forward-then-back round trip.
"""

from __future__ import annotations

import math

import numpy as np

from .base import Check

__all__ = ["checks"]

TOL_REF = 1e-11  # relative, vs REBOUND IAS15 and vs exact arithmetic
TOL_SKYFIELD = 1e-9  # relative: Skyfield stops its bisection/secant search near 1e-10..1e-11
TOL_INVARIANT = 1e-13
TOL_ROUND_TRIP = 1e-12

REGIMES = {
    "circular": 0.0,
    "e = 0.5": 0.5,
    "e = 0.99": 0.99,
    "e = 0.99999": 0.99999,
    "exact parabola": 1.0,
    "e = 1.0001": 1.0001,
    "e = 1.1": 1.1,
    "e = 3": 3.0,
    "e = 10": 10.0,
}


def conic_state(ecc, nu, q=1.0, gm=1.0, inc=0.4, raan=0.3, argp=1.1):
    """Perifocal state of a conic with periapsis q, rotated by (raan, inc, argp).

    Shared with ``tests/test_core_universal.py``.
    """
    p = q * (1.0 + ecc)
    r = p / (1.0 + ecc * math.cos(nu))
    rp = np.array([r * math.cos(nu), r * math.sin(nu), 0.0])
    vp = math.sqrt(gm / p) * np.array([-math.sin(nu), ecc + math.cos(nu), 0.0])
    cO, sO, ci, si = math.cos(raan), math.sin(raan), math.cos(inc), math.sin(inc)
    cw, sw = math.cos(argp), math.sin(argp)
    rot = np.array(
        [
            [cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
            [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
            [sw * si, cw * si, ci],
        ]
    )
    return rot @ rp, rot @ vp


def _cases(ecc):
    """(r0, v0, dt) with gm = 1 (units km, s, km3/s2: any consistent set works)."""
    out = []
    for nu in (-1.2, 0.0, 0.7, 2.0):
        if ecc >= 1.0 and abs(nu) >= math.acos(-1.0 / ecc) - 0.3:
            continue
        r0, v0 = conic_state(ecc, nu)
        for dt in (0.05, 1.7, -3.3, 25.0):
            out.append((r0, v0, dt))
    return out


def _radial_cases():
    u = np.array([0.48, 0.6, 0.64])
    return {
        "radial outgoing (bound)": [(u, 0.8 * u, dt) for dt in (0.4, 1.5, -0.1)],
        "radial outgoing (escape)": [(u, 2.0 * u, dt) for dt in (0.4, 30.0, -0.1)],
        "radial infall": [(u, -0.8 * u, dt) for dt in (0.1, 0.3, -2.0)],
        "radial from rest": [(u, 0.0 * u, dt) for dt in (0.3, -0.5)],
    }


def _visviva(cases):
    from astropy import units as u

    import visviva as vv

    r0 = np.array([c[0] for c in cases])
    v0 = np.array([c[1] for c in cases])
    dt = np.array([c[2] for c in cases])
    s = vv.StateVectors(r0 * u.km, v0 * u.km / u.s, 1.0 * u.km**3 / u.s**2).propagate(dt * u.s)
    return s.r.to_value(u.km), s.v.to_value(u.km / u.s)


def rebound_propagate(r0, v0, gm, dt):
    """REBOUND IAS15 (adaptive, machine precision) for a test particle around a point mass
    ``gm``, G = 1. Shared with ``tests/test_core_universal.py``."""
    import rebound

    sim = rebound.Simulation()
    sim.G = 1.0
    sim.integrator = "ias15"
    sim.add(m=gm)
    sim.add(m=0.0, x=r0[0], y=r0[1], z=r0[2], vx=v0[0], vy=v0[1], vz=v0[2])
    sim.integrate(dt, exact_finish_time=1)
    c, b = sim.particles[0], sim.particles[1]
    return (
        np.array([b.x - c.x, b.y - c.y, b.z - c.z]),
        np.array([b.vx - c.vx, b.vy - c.vy, b.vz - c.vz]),
    )


def _rel(a, b):
    return float(np.max(np.linalg.norm(a - b, axis=-1) / np.linalg.norm(b, axis=-1)))


def _vs_rebound() -> list[Check]:
    try:
        import rebound
    except ImportError as exc:  # pragma: no cover
        return [Check("propagation vs REBOUND", "max relative |dr|, |dv|", math.nan, TOL_REF,
                      "rebound", {"skipped": f"rebound not installed ({exc})"})]
    ref = f"rebound {rebound.__version__} IAS15 (adaptive, default epsilon)"
    groups = {name: _cases(ecc) for name, ecc in REGIMES.items()}
    groups.update(_radial_cases())
    r0, v0 = conic_state(0.5, 0.3)
    groups["e = 0.5, 20.3 revolutions"] = [(r0, v0, 20.3 * 2 * math.pi * 2.0**1.5)]
    out = []
    for name, cases in groups.items():
        r, v = _visviva(cases)
        refs = [rebound_propagate(r0, v0, 1.0, dt) for r0, v0, dt in cases]
        r_ref = np.array([x[0] for x in refs])
        v_ref = np.array([x[1] for x in refs])
        err = max(_rel(r, r_ref), _rel(v, v_ref))
        out.append(Check(f"Kepler propagation vs REBOUND IAS15: {name}",
                         "max relative |dr|, |dv|", err, TOL_REF, ref,
                         {"n_cases": len(cases)}))
    return out


def _vs_skyfield() -> list[Check]:
    try:
        import skyfield
        from skyfield.keplerlib import propagate
    except ImportError as exc:  # pragma: no cover
        return [Check("propagation vs Skyfield", "max relative |dr|, |dv|", math.nan,
                      TOL_SKYFIELD, "skyfield", {"skipped": f"skyfield not installed ({exc})"})]
    ref = f"skyfield {skyfield.__version__} keplerlib.propagate"
    worst, where = 0.0, ""
    n = 0
    for name, ecc in REGIMES.items():
        cases = _cases(ecc)
        r, v = _visviva(cases)
        for (r0, v0, dt), ri, vi in zip(cases, r, v, strict=True):
            pos, vel = propagate(r0, v0, 0.0, np.array([dt]), 1.0)
            err = max(_rel(ri, pos[:, 0]), _rel(vi, vel[:, 0]))
            n += 1
            if err > worst:
                worst, where = err, f"{name}, dt = {dt}"
    return [Check("Kepler propagation vs Skyfield keplerlib.propagate (every conic)",
                  "max relative |dr|, |dv|", worst, TOL_SKYFIELD, ref,
                  {"n_cases": n, "worst": where})]


def mp_propagate(r0, v0, gm, dt, digits=40):
    """Slow obvious reference: the universal-variable equations in ``digits``-digit arithmetic
    (mpmath), solved by bisection, so no cancellation can matter at this precision.

    Shared with ``tests/test_core_universal.py``.
    """
    import mpmath

    mp = mpmath.mp
    mp.dps = digits
    r0 = [mp.mpf(float(c)) for c in r0]
    v0 = [mp.mpf(float(c)) for c in v0]
    gm, dt = mp.mpf(float(gm)), mp.mpf(float(dt))
    rr = mp.sqrt(sum(c * c for c in r0))
    eta = sum(a * b for a, b in zip(r0, v0, strict=True))
    beta = 2 * gm / rr - sum(c * c for c in v0)

    def gfun(s):
        psi = beta * s * s
        if psi > 0:
            x = mp.sqrt(psi)
            c = (mp.cos(x), mp.sin(x) / x, (1 - mp.cos(x)) / psi, (x - mp.sin(x)) / (x * psi))
        elif psi < 0:
            x = mp.sqrt(-psi)
            c = (mp.cosh(x), mp.sinh(x) / x, (mp.cosh(x) - 1) / -psi,
                 (mp.sinh(x) - x) / (-x * psi))
        else:
            c = (1, 1, mp.mpf(1) / 2, mp.mpf(1) / 6)
        return c[0], s * c[1], s * s * c[2], s**3 * c[3]

    def F(s):
        _, G1, G2, G3 = gfun(s)
        return rr * G1 + eta * G2 + gm * G3 - dt

    lo, hi = mp.mpf(0), dt / rr
    while (F(hi) < 0) == (dt > 0):
        lo, hi = hi, 2 * hi
    a, b = min(lo, hi), max(lo, hi)
    for _ in range(3 * digits + 40):
        m = (a + b) / 2
        a, b = (m, b) if F(m) < 0 else (a, m)
    G0, G1, G2, _ = gfun((a + b) / 2)
    r = rr * G0 + eta * G1 + gm * G2
    f, g = 1 - gm * G2 / rr, rr * G1 + eta * G2
    fd, gd = -gm * G1 / (r * rr), 1 - gm * G2 / r
    return (np.array([float(f * a + g * b) for a, b in zip(r0, v0, strict=True)]),
            np.array([float(fd * a + gd * b) for a, b in zip(r0, v0, strict=True)]))


def _vs_exact() -> list[Check]:
    try:
        import mpmath
    except ImportError as exc:  # pragma: no cover
        return [Check("propagation vs 40-digit arithmetic", "max relative |dr|, |dv|", math.nan,
                      TOL_REF, "mpmath", {"skipped": f"mpmath not installed ({exc})"})]
    # (e, nu0, dt): far starts (100..2200 periapsis radii) through periapsis and out again
    cases = [(3.0, -1.91, 1590.0), (3.0, -1.91, 3150.0), (10.0, -1.66, 33.8),
             (10.0, -1.66, 66.9), (0.99999, -3.1, 5.23e4), (1.0, -3.1, 5.3e4),
             (1.00001, -3.1, 1.06e5), (1.5, -2.25, 100.0), (0.5, 2.0, 7.7)]
    states = [(*conic_state(e, nu), dt) for e, nu, dt in cases]
    r, v = _visviva(states)
    worst, where = 0.0, ""
    for (r0, v0, dt), ri, vi, case in zip(states, r, v, cases, strict=True):
        r_ex, v_ex = mp_propagate(r0, v0, 1.0, dt)
        err = max(_rel(ri, r_ex), _rel(vi, v_ex))
        if err > worst:
            worst, where = err, f"e = {case[0]}, nu0 = {case[1]}, dt = {case[2]}"
    return [Check("Kepler propagation vs 40-digit arithmetic: far starts through periapsis",
                  "max relative |dr|, |dv|", worst, TOL_REF,
                  f"mpmath {mpmath.__version__}, same equations at 40 digits",
                  {"n_cases": len(cases), "worst": where})]


def _published() -> list[Check]:
    from astropy import units as u

    import visviva as vv

    out = []
    # Vallado (2013) Example 2-4, mu = 398600.4418; published r (km, 4 decimals), v (6 decimals)
    s = vv.StateVectors([1131.34, -2282.343, 6672.423] * u.km,
                        [-5.64305, 4.30333, 2.42879] * u.km / u.s,
                        398600.4418 * u.km**3 / u.s**2).propagate(40 * u.min)
    dr = np.abs(s.r.to_value(u.km) - [-4219.7527, 4363.0292, -3958.7666]).max()
    dv = np.abs(s.v.to_value(u.km / u.s) - [3.689866, -1.916735, -6.112511]).max()
    out.append(Check("Vallado Example 2-4 (published values)",
                     "max difference / published rounding (1e-3 km, 1e-6 km/s)",
                     float(max(dr / 1e-3, dv / 1e-6)), 1.0,
                     "Vallado, Fundamentals of Astrodynamics and Applications, 4th ed., Ex. 2-4",
                     {"dr_km": float(dr), "dv_km_s": float(dv)}))
    # Curtis (2014) Example 3.7, mu = 398600: r = (-3297.8, 7413.4, 0) km after 60 min
    # (the book carries five significant figures through f and g)
    s = vv.StateVectors([7000.0, -12124.0, 0.0] * u.km, [2.6679, 4.6210, 0.0] * u.km / u.s,
                        398600.0 * u.km**3 / u.s**2).propagate(60 * u.min)
    dr = np.abs(s.r.to_value(u.km) - [-3297.8, 7413.4, 0.0]).max()
    out.append(Check("Curtis Example 3.7 (published position)",
                     "max |dr| / book precision (0.05 km)", float(dr / 0.05), 1.0,
                     "Curtis, Orbital Mechanics for Engineering Students, 3rd ed., Ex. 3.7",
                     {"dr_km": float(dr)}))
    return out


def _invariants(n: int) -> list[Check]:
    from visviva.core.universal import propagate_many

    rng = np.random.default_rng(11)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    r0 = d * 10.0 ** rng.uniform(-2, 2, n)[:, None]
    vd = rng.normal(size=(n, 3))
    vd /= np.linalg.norm(vd, axis=1)[:, None]
    n0 = np.linalg.norm(r0, axis=1)
    v_esc = np.sqrt(2.0 / n0)
    kind = rng.integers(0, 3, n)
    factor = np.where(kind == 0, rng.uniform(0.05, 3.0, n),
                      np.where(kind == 1, 1.0 + rng.uniform(-1e-5, 1e-5, n), 1.0))
    v0 = vd * (factor * v_esc)[:, None]
    log_dt = rng.uniform(-3, 0, n)  # up to one dynamical time r0 / v_esc
    dt = np.where(rng.uniform(size=n) < 0.5, -1.0, 1.0) * 10.0**log_dt * n0 / v_esc
    gm = np.ones(n)
    r1, v1, st1 = np.empty_like(r0), np.empty_like(v0), np.empty(n, np.int64)
    propagate_many(r0, v0, gm, dt, r1, v1, st1)
    r2, v2, st2 = np.empty_like(r0), np.empty_like(v0), np.empty(n, np.int64)
    propagate_many(r1, v1, gm, -dt, r2, v2, st2)
    n1 = np.linalg.norm(r1, axis=1)
    s0, s1 = np.linalg.norm(v0, axis=1), np.linalg.norm(v1, axis=1)
    e_scale = np.maximum(0.5 * s0**2 + 1 / n0, 0.5 * s1**2 + 1 / n1)
    d_energy = np.abs((0.5 * s1**2 - 1 / n1) - (0.5 * s0**2 - 1 / n0)) / e_scale
    d_h = np.linalg.norm(np.cross(r1, v1) - np.cross(r0, v0), axis=1) / np.maximum(
        n0 * s0, n1 * s1)
    back = np.maximum(np.linalg.norm(r2 - r0, axis=1) / np.maximum(n0, n1),
                      np.linalg.norm(v2 - v0, axis=1) / np.maximum(s0, s1))
    bad = int(np.count_nonzero(st1) + np.count_nonzero(st2))
    details = {"n_states": n, "failed_status": bad,
               "p99.9_round_trip": float(np.quantile(back, 0.999))}
    ref = "invariants of the two-body problem"
    return [
        Check("Kepler propagation: energy conservation (10^5 random states, every conic)",
              "max |dE| / (v^2/2 + mu/r)", float(d_energy.max()) if not bad else math.nan,
              TOL_INVARIANT, ref, details),
        Check("Kepler propagation: angular momentum conservation",
              "max |dh| / (|r| |v|)", float(d_h.max()) if not bad else math.nan,
              TOL_INVARIANT, ref, details),
        Check("Kepler propagation: forward then back (flights up to r0 / v_esc)",
              "max relative |dr|, |dv| (of the larger end)",
              float(back.max()) if not bad else math.nan, TOL_ROUND_TRIP, ref, details),
    ]


def checks(full: bool = False) -> list[Check]:
    """Run the propagation checks (a few seconds after compilation; ``full`` uses 10^6 states
    for the invariants)."""
    out = []
    out += _published()
    out += _vs_rebound()
    out += _vs_skyfield()
    out += _vs_exact()
    out += _invariants(1_000_000 if full else 100_000)
    return out
