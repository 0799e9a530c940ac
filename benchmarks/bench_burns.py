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
    from .bench_cowell import _python_rhs as _gravity_rhs
    from .common import compile_time, quick_from_env, result, time_call
except ImportError:  # pragma: no cover
    from bench_cowell import _python_rhs as _gravity_rhs
    from common import compile_time, quick_from_env, result, time_call


def _python_rhs(gravity, burn_on, accel0, rate, t0, d):
    """Two-body + J2 (``gravity``, bench_cowell's), plus the thrust in RTN while ``burn_on``."""
    if not burn_on:
        return gravity

    def rhs(t, y):
        dy = gravity(t, y)
        r, v = y[:3], y[3:]
        w = np.cross(r, v)
        w /= np.linalg.norm(w)
        rh = r / np.linalg.norm(r)
        dy[3:] += accel0 / (1.0 - rate * (t - t0)) * (
            d[0] * rh + d[1] * np.cross(w, rh) + d[2] * w)
        return dy

    return rhs


def _imports():
    from astropy import units as u

    import visviva as vv
    from visviva.satellites import burns

    return u, vv, burns


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    u, vv, burns = _imports()
    import scipy
    from scipy.integrate import solve_ivp

    propagate_cowell = vv.propagate_cowell
    state = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH).to_state()
    t_s = np.linspace(0.0, 86400.0, 1441)
    t = t_s * u.s
    forces = [vv.J2(vv.EARTH)]
    d = np.array([0.0, 1.0, 0.0])
    burn = burns.FiniteBurn(3600 * u.s, 600 * u.s, d, "RTN", thrust=400 * u.N,
                            mass=1000 * u.kg, isp=300 * u.s)
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

    gravity = _gravity_rhs(vv.EARTH.gm_km3_s2, vv.EARTH.radius_km, vv.EARTH.j2)
    mdot = 400.0 / (300.0 * burns.STANDARD_GRAVITY_M_S2)
    y0 = np.concatenate([state.r.to_value(u.km), state.v.to_value(u.km / u.s)])
    legs = [(0.0, 3600.0, False), (3600.0, 4200.0, True), (4200.0, 86400.0, False)]

    def reference():
        y = y0
        outs = []
        for a, b, on in legs:
            rhs = _python_rhs(gravity, on, 0.4 / 1000.0, mdot / 1000.0, 3600.0, d)
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
