"""N-body: visviva's compiled integrators side by side with REBOUND (same process, same input).

Rows
----
* WHFast, Sun + 8 planets, 1,000 years, dt = 4.4 d (target <= 1.0x REBOUND's WHFast).
* The same in democratic heliocentric coordinates (target <= 1.0x REBOUND's WHFast with
  ``coordinates="democraticheliocentric"``).
* IAS15, Sun + 8 planets, 1,000 years (target <= 1.0x REBOUND's IAS15 at equal energy error:
  both relative energy errors are reported in the notes), with visviva's default step control
  (PRS23, REBOUND's default criterion) and with Rein & Spiegel (2015)'s (``adaptive_mode="rs15"``).
* IAS15 on the Pythagorean three-body problem to t = 100 (close encounters, then an e ~ 0.99
  binary; no target: the time ratio, and both energy errors in the notes).
* Direct summation, one leapfrog step at N = 4,000 on every core (target >= 10x faster than
  REBOUND's leapfrog with gravity "basic", i.e. ratio <= 0.1).
* A compiled user force (no-op) inside WHFast (target <= 1.2x the run without it).
* IAS15 with MEGNO (``init_megno``), Sun + 8 planets, 1,000 years (target <= 1.0x REBOUND's IAS15
  with ``init_megno``; the notes give both plain runs, i.e. what MEGNO costs each, and both
  MEGNO values); the same with WHFast (dt = 4.4 d, Jacobi coordinates) against REBOUND's
  WHFast with ``init_megno`` (no target: the time ratio).
"""

from __future__ import annotations

import numpy as np

from benchmarks.common import compile_time, interleaved, result, skipped, threads, time_call

NAME = "nbody"


def _rebound():
    try:
        import rebound

        return rebound
    except ImportError:
        return None


def _solar(integrator):
    import visviva as vv

    return vv.solar_system(integrator=integrator)


def _run_vv(integrator, years):
    sim = _solar(integrator)
    sim.integrate(years)
    return sim


def _run_rb(integrator, years):
    r = _solar(integrator).to_rebound()
    r.integrate(years)
    return r


#: Burrau's problem: masses 3, 4, 5 at rest at the corners of a 3-4-5 triangle (G = 1).
_PYTHAGOREAN = ([3.0, 4.0, 5.0], [[1.0, 3.0, 0.0], [-2.0, -1.0, 0.0], [1.0, -1.0, 0.0]])


def _cluster(n, seed=1):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    v = 0.1 * rng.normal(size=(n, 3))
    m = np.full(n, 1.0 / n)
    return x, v, m


def _direct_sum_rows(vv, rebound, quick: bool, repeat: int) -> list[dict]:
    """leapfrog + direct summation at N = 4000 against REBOUND's basic gravity."""
    rows = []
    n = 1000 if quick else 4000
    x, v, m = _cluster(n)
    sim = vv.Simulation("leapfrog", dt=1e-3, softening=0.01, parallel=True)
    for k in range(n):
        sim.add(m[k], x[k], v[k])
    nsteps = 3
    pairs = float(n) * n * nsteps  # interactions per timed call (one evaluation per step)

    def step_vv():
        sim.integrate(sim.t + nsteps * 1e-3)

    with threads(None) as nth:
        c = compile_time(step_vv)
    with threads(1):
        t_vv1 = time_call(step_vv, repeat=repeat, number=1)
    if rebound is None:
        with threads(None):
            t_vv = time_call(step_vv, repeat=repeat, number=1)
        rows.append(skipped(f"direct summation N={n}", "rebound not installed"))
    else:
        r = rebound.Simulation()
        r.G = 1.0
        r.softening = 0.01
        for k in range(n):
            r.add(m=m[k], x=x[k, 0], y=x[k, 1], z=x[k, 2], vx=v[k, 0], vy=v[k, 1], vz=v[k, 2])
        r.integrator = "leapfrog"
        r.gravity = "basic"
        r.dt = 1e-3

        def step_rb():
            r.steps(nsteps)

        # best of alternating rounds, each side warmed up: a busy machine (other processes
        # taking a core for a moment) slows single rounds of either side, not the best ones
        with threads(None):
            t_vv, t_rb = interleaved((step_vv, step_rb), rounds=3 * repeat)
        ns = 1e9 / pairs
        from visviva.core.gravity_simd import has_rsqrt14

        seed = ("vrsqrt14pd (AVX-512) and one folded step" if has_rsqrt14()
                else "a bit-level guess and two steps")
        rows.append(result(
            f"leapfrog + direct summation, N={n}, {nsteps} steps", t_vv.best,
            f"rebound {rebound.__version__} leapfrog, gravity basic", t_rb.best, target=0.1,
            compile_s=c,
            notes=(f"best of {3 * repeat} alternating rounds each (medians: visviva "
                   f"{t_vv.median * 1e3:.1f} ms, rebound {t_rb.median * 1e3:.1f} ms, ratio "
                   f"{t_vv.median / t_rb.median:.3f}); {nth} thread(s): "
                   f"{t_vv.best * ns:.2f} ns/interaction; 1 thread: "
                   f"{t_vv1.median * ns:.2f} ns/interaction (ratio {t_vv1.median / t_rb.best:.2f}); "
                   f"rebound {t_rb.best * ns:.2f} ns/interaction; large-N kernel: each pair "
                   f"once, r**-3 from {seed} (no divide/sqrt), explicit "
                   "8-double vector loops, fixed work items shared dynamically: same bits for "
                   "any thread count"),
        ))

    return rows


def _megno_rows(rebound, years, repeat) -> list[dict]:
    """IAS15 and WHFast with MEGNO against REBOUND's, and each against its own plain run."""
    rows = []
    for integrator, target in (("ias15", 1.0), ("whfast", None)):

        def vv_megno(integrator=integrator):
            sim = _solar(integrator)
            sim.init_megno(seed=1)
            sim.integrate(years)
            return sim

        def rb_megno(integrator=integrator):
            r = _solar(integrator).to_rebound()
            r.init_megno(seed=1)
            r.integrate(years)
            return r

        def short(integrator=integrator):
            sim = _solar(integrator)
            sim.init_megno(seed=1)
            sim.integrate(1.0)

        c = compile_time(short)
        t_vv = time_call(vv_megno, repeat=max(3, repeat - 2), number=1)
        t_vv0 = time_call(_run_vv, integrator, years, repeat=max(3, repeat - 2), number=1)
        if rebound is None:
            rows.append(skipped(f"{integrator} + MEGNO solar system", "rebound not installed"))
            continue
        t_rb = time_call(rb_megno, repeat=max(3, repeat - 2), number=1)
        t_rb0 = time_call(_run_rb, integrator, years, repeat=max(3, repeat - 2), number=1)
        s, r = vv_megno(), rb_megno()
        rows.append(result(
            f"{integrator} + MEGNO, Sun + 8 planets, {years:g} yr", t_vv,
            f"rebound {rebound.__version__} {integrator} + init_megno", t_rb, target=target,
            compile_s=c,
            notes=(f"MEGNO costs visviva {t_vv.median / t_vv0.median:.2f}x its plain run "
                   f"({t_vv0.median:.3g} s), rebound {t_rb.median / t_rb0.median:.2f}x "
                   f"({t_rb0.median:.3g} s); MEGNO visviva {s.megno():.4f} ({s.steps_done} "
                   f"steps), rebound {r.megno():.4f} ({r.steps_done} steps)"),
        ))
    return rows


def run(quick: bool = False) -> list[dict]:
    import numba

    import visviva as vv

    rows = []
    rebound = _rebound()
    years = 100.0 if quick else 1000.0
    repeat = 3 if quick else 5

    # -- WHFast -------------------------------------------------------------------------------
    c = compile_time(_run_vv, "whfast", 1.0)
    t_vv = time_call(_run_vv, "whfast", years, repeat=repeat, number=1)
    if rebound is None:
        rows.append(skipped("whfast solar system", "rebound not installed"))
    else:
        t_rb = time_call(_run_rb, "whfast", years, repeat=repeat, number=1)
        s, r = _run_vv("whfast", years), _run_rb("whfast", years)
        e_vv = abs(s.energy() / _solar("whfast").energy() - 1)
        e_rb = abs(r.energy() / _solar("whfast").to_rebound().energy() - 1)
        rows.append(result(
            f"whfast, Sun + 8 planets, {years:g} yr, dt 4.4 d", t_vv, f"rebound {rebound.__version__} whfast",
            t_rb, target=1.0, compile_s=c,
            notes=f"|dE/E| visviva {e_vv:.1e}, rebound {e_rb:.1e}; both synchronise only at the end",
        ))

    # -- WHFast, democratic heliocentric coordinates --------------------------------------------
    def dh_solar():
        sim = _solar("whfast")
        sim.coordinates = "democratic_heliocentric"
        return sim

    def dh_vv():
        sim = dh_solar()
        sim.integrate(years)
        return sim

    def dh_rb():
        r = dh_solar().to_rebound()  # carries coordinates="democraticheliocentric"
        r.integrate(years)
        return r

    c = compile_time(lambda: dh_solar().integrate(1.0))
    t_vv = time_call(dh_vv, repeat=repeat, number=1)
    if rebound is None:
        rows.append(skipped("whfast democratic heliocentric solar system", "rebound not installed"))
    else:
        t_rb = time_call(dh_rb, repeat=repeat, number=1)
        s, r = dh_vv(), dh_rb()
        e_vv = abs(s.energy() / dh_solar().energy() - 1)
        e_rb = abs(r.energy() / dh_solar().to_rebound().energy() - 1)
        rows.append(result(
            f"whfast democratic heliocentric, Sun + 8 planets, {years:g} yr, dt 4.4 d", t_vv,
            f"rebound {rebound.__version__} whfast democraticheliocentric", t_rb, target=1.0,
            compile_s=c,
            notes=(f"|dE/E| visviva {e_vv:.1e}, rebound {e_rb:.1e}; same kernel as the Jacobi "
                   "row (compiled there)"),
        ))

    # -- IAS15 --------------------------------------------------------------------------------
    c = compile_time(_run_vv, "ias15", 1.0)
    t_vv = time_call(_run_vv, "ias15", years, repeat=max(3, repeat - 2), number=1)
    if rebound is None:
        rows.append(skipped("ias15 solar system", "rebound not installed"))
    else:
        t_rb = time_call(_run_rb, "ias15", years, repeat=max(3, repeat - 2), number=1)
        s, r = _run_vv("ias15", years), _run_rb("ias15", years)
        e_vv = abs(s.energy() / _solar("ias15").energy() - 1)
        e_rb = abs(r.energy() / _solar("ias15").to_rebound().energy() - 1)
        rows.append(result(
            f"ias15, Sun + 8 planets, {years:g} yr", t_vv, f"rebound {rebound.__version__} ias15", t_rb,
            target=1.0, compile_s=c,
            notes=(f"|dE/E| visviva {e_vv:.1e} ({s.steps_done} steps, epsilon 1e-9, default PRS23 "
                   f"step control), rebound {e_rb:.1e} ({r.steps_done} steps, default control)"),
        ))

        # the older criterion of Rein & Spiegel (2015), still selectable: about twice the steps
        def run_rs15():
            sim = _solar("ias15")
            sim.adaptive_mode = "rs15"
            sim.integrate(years)
            return sim

        t_e = time_call(run_rs15, repeat=max(3, repeat - 2), number=1)
        s = run_rs15()
        e_e = abs(s.energy() / _solar("ias15").energy() - 1)
        rows.append(result(
            f"ias15 (adaptive_mode rs15), Sun + 8 planets, {years:g} yr", t_e,
            f"rebound {rebound.__version__} ias15", t_rb, target=None,
            notes=(f"Rein & Spiegel (2015) criterion, for reference: |dE/E| visviva {e_e:.1e} "
                   f"({s.steps_done} steps), rebound {e_rb:.1e} ({r.steps_done} steps)"),
        ))

        # close encounters and an e ~ 0.99 binary: the Pythagorean three-body problem
        def pyth_vv():
            sim = vv.Simulation("ias15")
            for mass, pos in zip(*_PYTHAGOREAN, strict=True):
                sim.add(mass, r=pos)
            e0 = sim.energy()
            sim.integrate(20.0)
            sim.integrate(100.0)
            return sim, abs(sim.energy() / e0 - 1)

        def pyth_rb():
            r = rebound.Simulation()
            r.integrator = "ias15"
            for mass, pos in zip(*_PYTHAGOREAN, strict=True):
                r.add(m=mass, x=pos[0], y=pos[1], z=pos[2])
            e0 = r.energy()
            r.integrate(20.0)
            r.integrate(100.0)
            return r, abs(r.energy() / e0 - 1)

        c = compile_time(pyth_vv)
        t_p = time_call(pyth_vv, repeat=repeat, number=1)
        t_pr = time_call(pyth_rb, repeat=repeat, number=1)
        (s, e_p), (r, e_pr) = pyth_vv(), pyth_rb()
        rows.append(result(
            "ias15, Pythagorean three-body problem to t = 100", t_p,
            f"rebound {rebound.__version__} ias15", t_pr, target=None, compile_s=c,
            notes=(f"|dE/E| visviva {e_p:.1e} ({s.steps_done} steps; gravity on two-part positions "
                   f"while a pair is tight), rebound {e_pr:.1e} ({r.steps_done} steps)"),
        ))

    rows += _direct_sum_rows(vv, rebound, quick, repeat)
    rows += _megno_rows(rebound, years, repeat)

    # -- user force cost ----------------------------------------------------------------------
    @numba.njit
    def nothing(t, x, v, m, params, acc):
        acc[0, 0] += params[0]

    def with_force():
        s = _solar("whfast")
        s.add_force(nothing, params=[0.0])
        s.integrate(years)

    c = compile_time(with_force)
    t_f = time_call(with_force, repeat=repeat, number=1)
    t_0 = time_call(_run_vv, "whfast", years, repeat=repeat, number=1)
    rows.append(result(
        f"whfast + compiled user force, {years:g} yr", t_f, "visviva whfast without the force", t_0,
        target=1.2, compile_s=c, notes="force called through a first-class function pointer",
    ))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
