"""Two-body (Kepler) propagation, timed against Skyfield's ``keplerlib.propagate`` in one process.

Rows (ratio = visviva time / reference time; below 1 visviva is faster; target 1/15, i.e. at
least 15x faster than Skyfield):

* ``one time per orbit``: 10^6 random Earth orbits (LEO to GEO radii, speeds 0.3-1.3 of circular:
  ellipses up to e ~ 0.9 and hyperbolas) each propagated by its own random dt in
  [-10^5, 10^5] s. visviva through the public API (``StateVectors.propagate`` with Quantities)
  and through the bare kernel ``visviva.core.universal.propagate_many``; Skyfield with
  ``propagate(r.T, v.T, 0, dt[:, None], gm)`` (one time per orbit). Skyfield is timed on 10^5
  orbits (its memory grows quickly) and compared per orbit.
* ``orbits x times``: 1,000 orbits x 100 times, Skyfield's native grid vs visviva's broadcast
  ``(T, 1)`` against ``(N,)``.

The notes give both libraries' throughput and the largest difference between them (relative to
|r|); visviva's own accuracy against 40-digit arithmetic is checked in
``visviva.validation.checks_propagation``. Run: ``python -m benchmarks --only propagation`` or
``python -m benchmarks.bench_propagation``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import compile_time, quick_from_env, result, skipped, time_call
except ImportError:  # pragma: no cover
    from common import compile_time, quick_from_env, result, skipped, time_call

MU = 398600.4418
TARGET = 1.0 / 15.0  # at least 15x faster than Skyfield


def _orbits(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    r = rng.normal(size=(n, 3))
    r *= (rng.uniform(6600.0, 42000.0, n) / np.linalg.norm(r, axis=1))[:, None]
    v_circ = np.sqrt(MU / np.linalg.norm(r, axis=1))
    v = rng.normal(size=(n, 3))
    v *= (v_circ * rng.uniform(0.3, 1.3, n) / np.linalg.norm(v, axis=1))[:, None]
    dt = rng.uniform(-1e5, 1e5, n)
    return r, v, dt


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    n = 100_000 if quick else 1_000_000
    n_sky = min(n, 100_000)
    from astropy import units as u

    import visviva as vv
    from visviva.core.universal import propagate_many
    try:
        import skyfield
        from skyfield.keplerlib import propagate as sky_propagate
    except ImportError as exc:  # pragma: no cover
        return [skipped("Kepler propagation", f"skyfield not installed: {exc}", "skyfield")]

    sky_ref = f"skyfield {skyfield.__version__} keplerlib.propagate"
    rows = []

    # --- one time per orbit -------------------------------------------------------------------
    r, v, dt = _orbits(n)
    gm_flat = np.full(n, MU)
    r_out, v_out = np.empty_like(r), np.empty_like(v)
    status = np.empty(n, dtype=np.int64)
    gm_q = MU * u.km**3 / u.s**2
    r_q, v_q, dt_q = r * u.km, v * u.km / u.s, dt * u.s

    def vv_public():
        s = vv.StateVectors(r_q, v_q, gm_q).propagate(dt_q)
        return s.r, s.v

    def vv_kernel():
        propagate_many(r, v, gm_flat, dt, r_out, v_out, status)

    rs, vs, dts = r[:n_sky], v[:n_sky], dt[:n_sky]

    def sky():
        return sky_propagate(rs.T, vs.T, 0.0, dts[:, None], MU)

    c = compile_time(vv_kernel)
    t_k = time_call(vv_kernel, repeat=5)
    t_pub = time_call(vv_public, repeat=5)
    t_sky = time_call(sky, repeat=3)
    per_orbit_sky = t_sky.median / n_sky
    pos, _vel = sky()
    diff = float(
        np.max(np.linalg.norm(pos[:, :, 0].T - r_out[:n_sky], axis=1) / np.linalg.norm(
            r_out[:n_sky], axis=1))
    )
    assert not status.any()
    sky_rate = 1.0 / per_orbit_sky / 1e6
    rows.append(result(
        f"Kepler propagation, {n:.0e} orbits x 1 time (kernel propagate_many)",
        t_k.median / n, sky_ref, per_orbit_sky, TARGET,
        notes=(f"per orbit; visviva {n / t_k.median / 1e6:.2f} M orbits/s, skyfield "
               f"{sky_rate:.3f} M orbits/s (timed on {n_sky:.0e}); max |dr|/|r| vs skyfield "
               f"{diff:.1e}"),
        compile_s=c))
    rows.append(result(
        f"Kepler propagation, {n:.0e} orbits x 1 time (public StateVectors.propagate)",
        t_pub.median / n, sky_ref, per_orbit_sky, TARGET,
        notes=f"per orbit, Quantities in and out; {n / t_pub.median / 1e6:.2f} M orbits/s"))

    # --- orbits x times grid ------------------------------------------------------------------
    n_orb, n_t = (300, 30) if quick else (1000, 100)
    r2, v2, _ = _orbits(n_orb, seed=2)
    times = np.linspace(-5e4, 5e4, n_t)
    states = vv.StateVectors(r2 * u.km, v2 * u.km / u.s, gm_q)
    times_q = times[:, None] * u.s

    def vv_grid():
        s = states.propagate(times_q)
        return s.r, s.v

    def sky_grid():
        return sky_propagate(r2.T, v2.T, 0.0, np.broadcast_to(times, (n_orb, n_t)), MU)

    t_g = time_call(vv_grid, repeat=5)
    t_sg = time_call(sky_grid, repeat=3)
    rows.append(result(
        f"Kepler propagation, {n_orb} orbits x {n_t} times (public, broadcast (T,1) x (N,))",
        t_g, sky_ref + " (orbits x times grid)", t_sg, TARGET,
        notes=(f"{n_orb * n_t / t_g.median / 1e6:.2f} M states/s vs skyfield "
               f"{n_orb * n_t / t_sg.median / 1e6:.3f} M states/s")))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
