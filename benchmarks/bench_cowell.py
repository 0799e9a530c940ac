"""Cowell propagation with J2, timed against scipy's DOP853 with a pure-Python right-hand side.

Rows (ratio = visviva time / reference time; target: visviva <= 20 ms per run, and faster
than the reference):

* ``J2, one day of LEO``: a 7000 km, 51.6 deg orbit propagated for one day with J2, 1441
  output times (one per minute) from one integration. visviva: ``vv.propagate_cowell`` (the
  compiled DOP853 + compiled force model, public API with Quantities). Reference:
  ``scipy.integrate.solve_ivp(method="DOP853", dense_output=False, t_eval=...)`` with the same
  tolerances and a Python/numpy right-hand side (two-body + J2). The notes give both libraries'
  errors against a tight-tolerance visviva run (1 m accuracy is the requirement).
* ``J2..J6 + Sun + Moon + drag + SRP, one day``: the full force model (visviva only, to show what
  the extra perturbations cost).
* ``J2 + SRP with a conical shadow, one day``: the default settings (steps end at the shadow
  boundaries, docs/cowell.md) against ``max_step=10 s``, the step limit that was needed before
  for millimetres across the shadow; the notes give both runs' errors against a
  ``max_step=1 s``, ``rtol=atol=1e-13`` run.
* ``J2 + 3 eclipse events, one day``: penumbra, umbra and cylindrical eclipses in one run (90
  crossings), against the same run with the fixed room of 64 events it had before (the run was
  redone with more room: twice the integration).
* ``Lambert (Izzo)``: throughput of the vectorised solver on random Earth transfers.

Run: ``python -m benchmarks --only cowell`` or ``python -m benchmarks.bench_cowell``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import compile_time, interleaved, quick_from_env, result, skipped, time_call
except ImportError:  # pragma: no cover
    from common import compile_time, interleaved, quick_from_env, result, skipped, time_call

TARGET_S = 0.020


def _python_rhs(gm, R, j2):
    def rhs(t, y):
        x, yy, z = y[0], y[1], y[2]
        r2 = x * x + yy * yy + z * z
        r = np.sqrt(r2)
        k = -gm / (r2 * r)
        f = 1.5 * j2 * gm * R * R / (r2 * r2 * r)
        s = 5.0 * z * z / r2
        return np.array(
            [y[3], y[4], y[5], k * x + f * x * (s - 1), k * yy + f * yy * (s - 1),
             k * z + f * z * (s - 3)]
        )  # fmt: skip

    return rhs


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    import scipy
    from astropy import units as u
    from astropy.time import Time
    from scipy.integrate import solve_ivp

    import visviva as vv
    from visviva.satellites import propagate_cowell
    from visviva.satellites.cowell import DEFAULT_ATOL, DEFAULT_RTOL

    el = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH
    )
    state = el.to_state()
    t_s = np.linspace(0.0, 86400.0, 1441)
    t = t_s * u.s
    forces = [vv.J2(vv.EARTH)]
    rtol, atol = DEFAULT_RTOL, DEFAULT_ATOL
    first = compile_time(propagate_cowell, state, t, forces)
    tv = time_call(propagate_cowell, state, t, forces, repeat=3 if quick else 7)
    out = propagate_cowell(state, t, forces)
    truth = propagate_cowell(state, t, forces, rtol=1e-14, atol=1e-15)
    err_vv = np.abs((out.r - truth.r).to_value(u.km)).max() * 1e3

    gm, R, j2 = vv.EARTH.gm_km3_s2, vv.EARTH.radius_km, vv.EARTH.j2
    y0 = np.concatenate([state.r.to_value(u.km), state.v.to_value(u.km / u.s)])
    rhs = _python_rhs(gm, R, j2)

    def reference():
        return solve_ivp(rhs, (0.0, 86400.0), y0, method="DOP853", t_eval=t_s, rtol=rtol,
                         atol=atol)  # fmt: skip

    tr = time_call(reference, repeat=3, warmup=0 if quick else 1, max_total_s=10.0)
    ref = reference()
    err_ref = np.abs(ref.y[:3].T - truth.r.to_value(u.km)).max() * 1e3
    rows = [
        result(
            "Cowell J2, 1 day LEO, 1441 outputs",
            tv,
            f"scipy {scipy.__version__} solve_ivp DOP853, Python rhs",
            tr,
            target=None,
            notes=(
                f"rtol={rtol:g}, atol={atol:g} km; max error vs rtol=1e-14 run: visviva "
                f"{err_vv:.2g} m, scipy {err_ref:.2g} m; {out.n_steps} steps; target "
                f"<= {TARGET_S * 1e3:.0f} ms: {'met' if float(tv) <= TARGET_S else 'NOT met'}"
            ),
            compile_s=first,
        )
    ]
    rows[0]["target"] = TARGET_S / float(tr) if tr else None
    rows[0]["met"] = bool(float(tv) <= TARGET_S)

    epoch = Time("2024-03-01T00:00:00", scale="utc")
    state_e = vv.StateVectors(state.r, state.v, vv.EARTH, epoch=epoch)
    full = [
        vv.Zonal(vv.EARTH, 6),
        vv.ThirdBody(vv.SUN),
        vv.ThirdBody(vv.MOON),
        vv.AtmosphericDrag(0.01 * u.m**2 / u.kg),
        vv.SolarRadiationPressure(0.01 * u.m**2 / u.kg),
    ]
    first_full = compile_time(propagate_cowell, state_e, t, full)
    tf = time_call(propagate_cowell, state_e, t, full, repeat=3 if quick else 5)
    rows.append(
        result(
            "Cowell J2-J6 + Sun + Moon + drag + SRP, 1 day LEO",
            tf,
            "none (visviva only)",
            None,
            notes="includes tabulating DE421 Sun/Moon positions (hourly) for the run",
            compile_s=first_full,
        )
    )
    # SRP with a shadow: the defaults against the step limit that was needed before
    srp = [vv.J2(vv.EARTH), vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, 1.5, shadow="conical")]
    limit = {"max_step": 10 * u.s}
    ts = time_call(propagate_cowell, state_e, t, srp, repeat=3 if quick else 7)
    tl = time_call(lambda: propagate_cowell(state_e, t, srp, **limit), repeat=3)
    tight = propagate_cowell(state_e, t, srp, rtol=1e-13, atol=1e-13, max_step=1 * u.s)
    errs = [np.linalg.norm((run.r - tight.r).to_value(u.mm), axis=-1).max()
            for run in (propagate_cowell(state_e, t, srp), propagate_cowell(state_e, t, srp, **limit))]
    rows.append(
        result(
            "Cowell J2 + SRP (conical shadow), 1 day LEO",
            ts,
            "visviva with max_step=10 s (the old workaround)",
            tl,
            notes=(f"A/m = 0.02 m2/kg, Cr = 1.5; max error vs max_step=1 s, 1e-13: defaults "
                   f"{errs[0]:.2g} mm, max_step=10 s {errs[1]:.2g} mm"),
        )
    )
    # the post-Newtonian correction: its cost (the full right-hand side's kernel) against J2
    # alone, and its effect after the day
    rel = [vv.J2(vv.EARTH), vv.Relativity()]
    first_r = compile_time(propagate_cowell, state, t, rel)
    tr_rel, tr_j2 = interleaved([lambda: propagate_cowell(state, t, rel),
                                 lambda: propagate_cowell(state, t, forces)],
                                rounds=3 if quick else 7)
    shift = np.linalg.norm((propagate_cowell(state, t, rel).r - out.r).to_value(u.m), axis=-1)
    rows.append(
        result(
            "Cowell J2 + Relativity (Schwarzschild, Lense-Thirring), 1 day LEO",
            tr_rel,
            "visviva, J2 alone",
            tr_j2,
            notes=(f"the relativistic terms move the orbit {shift[-1]:.2f} m in the day; the "
                   "run takes the full right-hand side's kernel (J2 alone: the zonal one)"),
            compile_s=first_r,
        )
    )
    # NRLMSIS drag (tricubic B-spline of the tabulated ln rho) against exponential drag, and
    # its accuracy at the default tolerances against a 5-s step run at rtol 1e-13
    try:
        import pymsis  # noqa: F401
    except ImportError:
        rows.append(skipped("Cowell J2 + NRLMSIS drag, 1 day LEO", "pymsis not installed"))
    else:
        am = 0.05 * u.m**2 / u.kg
        msis = [vv.J2(vv.EARTH), vv.AtmosphericDrag(am, model="nrlmsis", f107=150.0, f107a=150.0,
                                                    ap=4.0)]  # fmt: skip
        expo = [vv.J2(vv.EARTH), vv.AtmosphericDrag(am)]
        low = vv.KeplerianElements.from_semi_major_axis(
            6700 * u.km, 0.0, 51.6 * u.deg, 0, 0, 0, vv.EARTH, epoch=epoch).to_state()
        first_m = compile_time(propagate_cowell, low, t, msis)
        tm = time_call(propagate_cowell, low, t, msis, repeat=3 if quick else 7)
        te = time_call(propagate_cowell, low, t, expo, repeat=3 if quick else 7)
        fine = propagate_cowell(low, t, msis, rtol=1e-13, max_step=5 * u.s)
        err = np.linalg.norm((propagate_cowell(low, t, msis).r - fine.r).to_value(u.mm), axis=-1)
        rows.append(
            result(
                "Cowell J2 + NRLMSIS drag, 1 day LEO",
                tm,
                "visviva, J2 + exponential drag",
                te,
                notes=(f"a = 6700 km, A/m = 0.05 m2/kg, F10.7 = 150; includes the pymsis grid; "
                       f"max error vs max_step=5 s, 1e-13: {err.max():.2g} mm"),
                compile_s=first_m,
            )
        )
    # eclipse events: the three of one run (conical penumbra and umbra, cylindrical), against
    # the same run with the old fixed room of 64 events (90 found: the run was done twice)
    from unittest import mock

    from visviva.satellites import Eclipse

    eclipses = [Eclipse("conical"), Eclipse("conical", umbra=True), Eclipse("cylindrical")]

    def with_events():
        return propagate_cowell(state_e, t, forces, events=eclipses)

    def old_room():
        with mock.patch("visviva.satellites.cowell.event_capacity", lambda *a: 64):
            return with_events()

    te, to = interleaved([with_events, old_room], rounds=3 if quick else 9)
    same = [(e.t.value, e.what) for e in with_events().events] == [
        (e.t.value, e.what) for e in old_room().events]
    rows.append(
        result(
            "Cowell J2 + 3 eclipse events, 1 day LEO",
            te,
            "visviva with the old event room of 64 (run twice)",
            to,
            notes=(f"{len(with_events().events)} events (penumbra, umbra, cylindrical); the "
                   f"same event times: {same}"),
        )
    )
    # many states in parallel
    n_sat = 100 if quick else 1000
    fleet = vv.KeplerianElements.from_semi_major_axis(
        np.linspace(6800.0, 8000.0, n_sat) * u.km, 0.001, np.linspace(0.1, 1.7, n_sat), 0.3,
        0.2, 0.1, vv.EARTH,
    ).to_state()  # fmt: skip
    first_b = compile_time(propagate_cowell, fleet[:2], 1 * u.day, forces)
    tb = time_call(propagate_cowell, fleet, 1 * u.day, forces, repeat=3)
    rows.append(
        result(
            f"Cowell J2, {n_sat} LEO states x 1 day (parallel)",
            tb,
            "none (visviva only)",
            None,
            notes=f"{float(tb) / n_sat * 1e3:.2f} ms per satellite-day",
            compile_s=first_b,
        )
    )

    # Lambert throughput: 10^5 random Earth transfers in one vectorised call (visviva only;
    # no Lambert solver is installed among the reference libraries)
    n = 10_000 if quick else 100_000
    rng = np.random.default_rng(5)
    r1 = rng.normal(size=(n, 3)) * 10000.0
    r2 = rng.normal(size=(n, 3)) * 10000.0
    r1 *= np.maximum(1.0, 7000.0 / np.linalg.norm(r1, axis=1))[:, None]
    r2 *= np.maximum(1.0, 7000.0 / np.linalg.norm(r2, axis=1))[:, None]
    tof = rng.uniform(1000.0, 50000.0, n)
    args = (r1 * u.km, r2 * u.km, tof * u.s, vv.EARTH.gm)
    first_l = compile_time(vv.lambert, *args)
    tl = time_call(vv.lambert, *args, repeat=3 if quick else 5)
    rows.append(
        result(
            f"Lambert (Izzo), {n} transfers",
            tl,
            "none (visviva only)",
            None,
            notes=f"{float(tl) / n * 1e9:.0f} ns per transfer",
            compile_s=first_l,
        )
    )
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
