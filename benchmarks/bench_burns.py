"""Cowell propagation with a finite burn: what the burn costs, and scipy with the same thrust.

Rows (ratio = visviva time / reference time):

* ``J2 + one finite burn, 1 day LEO``: a 7000 km, 51.6 deg orbit, one day with J2, 1441
  outputs, and a 10-minute transverse burn (400 N, 1000 kg, Isp 300 s, RTN axes turning with
  the orbit) after one hour. Reference: the same run without the burn (the ZONAL_ONLY kernel
  throughout); the burn adds two segment restarts and the full force kernel over its segment.
* ``J2 + one finite burn, 1 day LEO, vs scipy``: the same run against
  ``scipy.integrate.solve_ivp(method="DOP853")`` with a Python right-hand side of the same
  model, split at the burn's start and end as visviva does; the notes give the distance between
  the two final positions.

Run: ``python -m benchmarks --only burns`` or ``python -m benchmarks.bench_burns``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import compile_time, quick_from_env, result, skipped, time_call
except ImportError:  # pragma: no cover
    from common import compile_time, quick_from_env, result, skipped, time_call


def _python_rhs(gm, radius, j2, burn_on, accel0, rate, t0, d):
    def rhs(t, y):
        r, v = y[:3], y[3:]
        r2 = r @ r
        rn = np.sqrt(r2)
        s = 5.0 * r[2] * r[2] / r2
        f = 1.5 * j2 * gm * radius * radius / (r2 * r2 * rn)
        a = -gm / (r2 * rn) * r + f * r * np.array([s - 1.0, s - 1.0, s - 3.0])
        if burn_on:
            h = np.cross(r, v)
            w = h / np.linalg.norm(h)
            rh = r / rn
            a = a + accel0 / (1.0 - rate * (t - t0)) * (
                d[0] * rh + d[1] * np.cross(w, rh) + d[2] * w)
        return np.concatenate([v, a])

    return rhs


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    try:
        from astropy import units as u

        import visviva as vv
        from visviva.satellites import FiniteBurn, propagate_cowell
        from visviva.satellites.burns import STANDARD_GRAVITY_M_S2
    except Exception as exc:  # pragma: no cover
        return [skipped("Cowell with a finite burn", f"visviva not importable: {exc}")]
    import scipy
    from scipy.integrate import solve_ivp

    el = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH)
    state = el.to_state()
    t_s = np.linspace(0.0, 86400.0, 1441)
    t = t_s * u.s
    forces = [vv.J2(vv.EARTH)]
    d = np.array([0.0, 1.0, 0.0])
    burn = FiniteBurn(3600 * u.s, 600 * u.s, d, "RTN", thrust=400 * u.N, mass=1000 * u.kg,
                      isp=300 * u.s)
    first = compile_time(propagate_cowell, state, t, forces, maneuvers=[burn])
    repeat = 3 if quick else 7
    tb = time_call(lambda: propagate_cowell(state, t, forces, maneuvers=[burn]), repeat=repeat)
    tn = time_call(lambda: propagate_cowell(state, t, forces), repeat=repeat)
    out = propagate_cowell(state, t, forces, maneuvers=[burn])
    plain = propagate_cowell(state, t, forces)
    rows = [result(
        "Cowell J2 + one finite burn (10 min, RTN), 1 day LEO, 1441 outputs", tb,
        "visviva, the same run without the burn", tn,
        notes=(f"{out.n_steps} steps with the burn, {plain.n_steps} without; final mass "
               f"{out.final_mass.to_value(u.kg):.3f} kg; |Δv| "
               f"{out.burns[0].delta_v.to_value(u.m / u.s):.3f} m/s"),
        compile_s=first)]

    gm, radius, j2 = vv.EARTH.gm_km3_s2, vv.EARTH.radius_km, vv.EARTH.j2
    mdot = 400.0 / (300.0 * STANDARD_GRAVITY_M_S2)
    y0 = np.concatenate([state.r.to_value(u.km), state.v.to_value(u.km / u.s)])
    legs = [(0.0, 3600.0, False), (3600.0, 4200.0, True), (4200.0, 86400.0, False)]

    def reference():
        y = y0
        outs = []
        for a, b, on in legs:
            rhs = _python_rhs(gm, radius, j2, on, 0.4 / 1000.0, mdot / 1000.0, 3600.0, d)
            keep = t_s[(t_s >= a) & (t_s < b)] if b < 86400.0 else t_s[t_s >= a]
            sol = solve_ivp(rhs, (a, b), y, method="DOP853", t_eval=keep, rtol=1e-12,
                            atol=1e-12, dense_output=True)
            outs.append(sol.y)
            y = sol.sol(b)
        return np.concatenate(outs, axis=1)

    tr = time_call(reference, repeat=3, warmup=0 if quick else 1, max_total_s=20.0)
    ref = reference()
    err = np.linalg.norm(ref[:3, -1] - out.r[-1].to_value(u.km)) * 1e3
    rows.append(result(
        "Cowell J2 + one finite burn, 1 day LEO, vs scipy", tb,
        f"scipy {scipy.__version__} solve_ivp DOP853, Python rhs, split at the burn", tr,
        target=0.2,
        notes=f"rtol = atol = 1e-12 in both; final positions {err:.2g} m apart"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
