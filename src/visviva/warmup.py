"""``visviva warmup``: compile every numba kernel once, with a progress bar, right after install.

numba compiles a kernel on its first call and caches the machine code on disk (next to the
installed sources, or in numba's user cache directory when that is read-only; ``NUMBA_CACHE_DIR``
overrides both). With an empty cache the first call of an N-body integrator takes tens of
seconds (docs/performance.md, "Cold start"); after ``visviva warmup`` every process loads the
machine code from the cache in milliseconds. Each task below is one small public call that
compiles one family of kernels with the argument types the public API passes (float64,
C-contiguous: :mod:`visviva._units` normalises every input), so the cache holds exactly the
versions later calls need.
"""

from __future__ import annotations

import sys
import time


def _states():
    from astropy import units as u

    import visviva as vv

    r = [[7000.0, 0.0, 0.0], [0.0, 42164.0, 0.0], [8000.0, 0.0, 100.0]] * u.km
    v = [[0.0, 7.5, 1.0], [-3.07, 0.0, 0.0], [0.0, 11.0, 0.5]] * u.km / u.s
    return vv.StateVectors(r, v, vv.EARTH)


def _one_state():
    from astropy import units as u

    import visviva as vv

    return vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s, vv.EARTH)


def _elements():
    elements = _states().to_elements()
    elements.mean_anomaly.to_value()
    elements.to_state()
    # one item: its arrays are C-contiguous where a batch's broadcast GM is not, another
    # signature (audit40: a first Maneuver.phasing after the warmup compiled coe_to_rv_array,
    # scan_coe and propagate_many, 5 s, when the interpreter tier was off or spent)
    _one_state().to_elements().to_state()
    # element sets built from the user's numbers are checked by scan_coe (one item and a batch)
    from astropy import units as u

    import visviva as vv

    for a_km, ecc in ((7000.0, 0.1), ([7000.0, 8000.0, 9000.0], [0.0, 0.1, 0.2])):
        # (states from elements carry one GM, broadcast: another layout than _states()'s)
        vv.KeplerianElements.from_semi_major_axis(
            a_km * u.km, ecc, 0.5 * u.rad, 0.0 * u.rad, 0.0 * u.rad, 1.0 * u.rad,
            vv.EARTH).to_state().propagate(60.0 * u.s).to_elements()


def _anomalies():
    import numpy as np

    import visviva as vv

    M = np.linspace(0.1, 3.0, 4)
    vv.solve_kepler(M, 0.3)
    vv.solve_kepler_hyperbolic(M, 1.5)
    vv.mean_to_true(M, np.array([0.0, 0.5, 1.0, 2.0]))
    vv.true_to_mean(M / 2.0, np.array([0.0, 0.5, 1.0, 2.0]))


def _propagation():
    from astropy import units as u

    _states().propagate([60.0, 3600.0, -600.0] * u.s)
    _one_state().propagate(60.0 * u.s)


def _lambert():
    from astropy import units as u

    import visviva as vv

    # one kernel per solver (LAMBERT_METHODS): Izzo's and the universal-variable one
    for method in ("izzo", "universal"):
        vv.lambert([7000.0, 0.0, 0.0] * u.km, [0.0, 8000.0, 0.0] * u.km, 3000 * u.s, vv.EARTH,
                   method=method)


def _cowell():
    import numpy as np
    from astropy import units as u

    import visviva as vv

    state = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s, vv.EARTH)
    vv.propagate_cowell(state, np.linspace(0.0, 600.0, 3) * u.s,
                        perturbations=[vv.J2(vv.EARTH)])


def _cowell_full():
    # the full force model (drag, SRP, third bodies, harmonics, eclipse events, a finite burn's
    # thrust) is another compiled kernel than the two-body + zonal one of _cowell, and a batch
    # of states runs a third, in both variants (coasts zonal-only, the burn full)
    import numpy as np
    from astropy import units as u

    import visviva as vv

    burn = vv.FiniteBurn(60.0 * u.s, 60.0 * u.s, [1.0, 0.0, 0.0], "TNW",
                         acceleration=1e-6 * u.km / u.s**2)
    t = np.linspace(0.0, 600.0, 3) * u.s
    one = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s, vv.EARTH)
    vv.propagate_cowell(one, t, [vv.J2(vv.EARTH)], maneuvers=[burn])
    many = vv.StateVectors([[7000.0, 0.0, 0.0], [7100.0, 0.0, 0.0]] * u.km,
                           [[0.0, 7.5, 1.0], [0.0, 7.4, 1.0]] * u.km / u.s, vv.EARTH)
    vv.propagate_cowell(many, t, [vv.J2(vv.EARTH)], maneuvers=[burn])


def _simulation(integrator, **kw):
    def run():
        import visviva as vv

        sim = vv.Simulation(integrator=integrator, G=1.0, **kw)
        sim.add(1.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        sim.add(1e-3, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        sim.add(1e-3, [2.0, 0.0, 0.0], [0.0, 0.7, 0.0])
        sim.integrate(0.1)
        sim.energy()

    return run


def _nbody_all_paths():
    # the 3-body runs above use each integrator's few-body kernel; these are the ones with
    # every gravity path (threads, large N, ensembles)
    from .nbody.integrators import INTEGRATORS

    for info in INTEGRATORS.values():
        info.kernel()


def _three_bodies(integrator, **kw):
    import visviva as vv

    sim = vv.Simulation(integrator=integrator, **kw)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(1e-3, a=1.6, primary=0)
    return sim


def _megno():
    # MEGNO's tangent maps (IAS15's collocation, leapfrog's and WHFast's linearised steps) run
    # in each integrator's MEGNO kernel (<name>_run_megno: the few-body kernel without event
    # checks, WHFast's corrector and democratic heliocentric step; a first MEGNO run on an empty
    # cache compiles it for 9-30 s of CPU), which the tasks above leave cold; this one also
    # compiles the scalar elements -> state kernels of sim.add(a=..., primary=0) (audit40)
    for integrator, kw in (("ias15", {}), ("leapfrog", {"dt": 0.01}), ("whfast", {"dt": 0.01})):
        sim = _three_bodies(integrator, **kw)
        sim.init_megno(seed=1)
        sim.integrate(0.1)
        sim.megno()


def _ensemble():
    # the ensemble kernel (threads over the members; each member runs its integrator's kernel
    # through a function pointer), with and without MEGNO members
    import visviva as vv

    sims = [_three_bodies("whfast", dt=0.01) for _ in range(2)]
    sims[1].init_megno(seed=1)
    ens = vv.Ensemble.from_simulations(sims)
    ens.integrate(0.1)
    ens.energy()


def _satellite():
    import numpy as np
    from astropy import units as u

    import visviva as vv

    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
        "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")
    sat.gcrs(np.linspace(0.0, 600.0, 3) * u.s)


def _variational():
    # the state + STM kernel of covariance propagation and orbit fits, and the Jacobian of a
    # local-frame impulse (through manoeuvres)
    import numpy as np
    from astropy import units as u

    import visviva as vv

    state = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s, vv.EARTH)
    vv.propagate_covariance(state, np.diag([1e-6] * 3 + [1e-12] * 3), [-60.0, 60.0] * u.s,
                            [vv.J2(vv.EARTH)],
                            maneuvers=[vv.ImpulsiveBurn(30.0 * u.s, [0.0, 1e-4, 0.0] * u.km / u.s,
                                                        "RTN")])


def _conjunctions():
    import numpy as np

    from visviva.conjunctions import collision_probability

    r1, v1 = np.array([7000e3, 0.0, 0.0]), np.array([0.0, 7500.0, 0.0])  # plain numbers: m, m/s
    c = np.diag([1e4, 4e4, 1e4, 1.0, 1.0, 1.0])
    args = (r1, v1, c, r1 + np.array([100.0, 50.0, 0.0]), np.array([0.0, 0.0, 7500.0]), c, 20.0)
    collision_probability(*args)
    collision_probability(*args, method="pc3d_hall")  # the default window: the segment scan too


def _conjunction_kernels():
    # the two-body STM of state_transition_matrix / propagate_covariance (conjunctions) and of
    # collision_probability(method="3d"), and the Foster kernel over arrays (visviva.core)
    import numpy as np
    from astropy import units as u

    import visviva as vv
    from visviva.conjunctions import state_transition_matrix
    from visviva.core import collision as kern

    state_transition_matrix([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s,
                            60.0 * u.s, vv.EARTH)
    x = np.array([10.0, 200.0])
    out, status = np.empty(2), np.empty(2, dtype=np.int64)
    kern.log_pc_many(x, x, np.array([100.0, 400.0]), np.array([50.0, 80.0]),
                     np.array([5.0, 20.0]), kern.GAUSS_LO, kern.GAUSS_HI, 1e-13, out, status)
    kern.log_pc_chan_many(x, x, np.array([100.0, 400.0]), np.array([50.0, 80.0]),
                          np.array([5.0, 20.0]), out)


def _passes():
    # the pass search (secular node grid, pass scan, elevation rates, look angles, the Earth's
    # shadow), what `visviva passes` and vv.find_passes compile on first use (about 25 s cold)
    from astropy import units as u

    import visviva as vv

    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
        "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")
    site = vv.GroundStation(52.0 * u.deg, 0.0 * u.deg, 0.0 * u.m)
    vv.find_passes(sat, site, sat.epoch, sat.epoch + 3 * u.h)


def _screening():
    # the catalogue screening kernel of `visviva screen` and vv.screen_conjunctions
    from astropy import units as u

    import visviva as vv

    sats = vv.Catalog([vv.Satellite.from_tle(
        "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
        "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482"),
        vv.Satellite.from_tle(
        "1 25545U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9992",
        "2 25545  51.6439 211.2001 0007417  17.6667  86.1398 15.50103472202489")])
    vv.screen_conjunctions(sats, None, sats[0].epoch, sats[0].epoch + 1 * u.h, 100 * u.km)
    # the filters' pair counts (apogee/perigee, orbit path) of the screening diagnostics
    from visviva.conjunctions.screening import filter_statistics
    from visviva.conjunctions.sources import SgpSource

    t0 = sats[0].epoch.utc
    src = SgpSource(sats, float(t0.jd1), float(t0.jd2))
    filter_statistics(src, src, 3600.0, 100.0)


#: (label, function): what ``visviva warmup`` runs, in order.
TASKS = (
    ("states <-> elements", _elements),
    ("anomalies (Kepler's equation)", _anomalies),
    ("two-body propagation", _propagation),
    ("Lambert", _lambert),
    ("Cowell propagation", _cowell),
    ("Cowell: full force model, burns, batches", _cowell_full),
    ("covariance propagation and orbit fits (STM)", _variational),
    ("N-body: IAS15", _simulation("ias15")),
    ("N-body: WHFast", _simulation("whfast", dt=0.01)),
    ("N-body: WHFast, corrector and other coordinates", _simulation("whfast", dt=0.01, corrector=5)),
    ("N-body: leapfrog", _simulation("leapfrog", dt=0.01)),
    ("N-body: threaded and large-N kernels", _nbody_all_paths),
    ("N-body: MEGNO (tangent maps)", _megno),
    ("N-body: ensembles", _ensemble),
    ("satellites: SGP4 and frames", _satellite),
    ("conjunctions: Foster and 3D-Nc (pc3d_hall)", _conjunctions),
    ("conjunctions: two-body STM, Foster over arrays", _conjunction_kernels),
    ("ground stations: look angles and pass search", _passes),
    ("conjunctions: catalogue screening", _screening),
)


def warmup(tasks=TASKS, progress: bool = True, stream=None) -> list[tuple[str, float, str | None]]:
    """Run every warm-up task once; return ``(label, seconds, error or None)`` per task.

    Parameters
    ----------
    tasks : sequence of (str, callable)
        What to run (default :data:`TASKS`).
    progress : bool
        Show a tqdm progress bar naming the running task (on ``stream``).
    stream : file, optional
        Where the bar and the per-task lines go (default ``sys.stderr``).

    Returns
    -------
    list of (str, float, str or None)
        Label, wall time (s) and the error message of a task that raised.

    Notes
    -----
    The per-kernel compile notice (:func:`visviva.core._jit.compile_notice`) is switched off
    while this runs: the bar says what is compiling. So is the interpreter tier
    (:mod:`visviva.core.tier`): the small calls of the tasks compile instead of running
    interpreted.
    """
    from tqdm import tqdm

    from .core import _jit, tier

    stream = sys.stderr if stream is None else stream
    out = []
    enabled = _jit.notices["enabled"]
    _jit.notices["enabled"] = False
    tier_off = tier.spent["off"]
    tier.spent["off"] = True
    try:
        bar = tqdm(tasks, desc="visviva warmup", unit="task", file=stream, disable=not progress,
                   bar_format="{desc}: {n_fmt}/{total_fmt} |{bar}| {elapsed} {postfix}")
        for label, fn in bar:
            bar.set_postfix_str(label)
            t0 = time.perf_counter()
            error = None
            try:
                fn()
            except Exception as exc:  # report and go on with the other kernels
                error = f"{type(exc).__name__}: {exc}"
            dt = time.perf_counter() - t0
            out.append((label, dt, error))
            msg = f"  {label:<32s} {dt:7.1f} s" + (f"  FAILED: {error}" if error else "")
            if progress:
                bar.write(msg, file=stream)
            else:
                print(msg, file=stream)
    finally:
        _jit.notices["enabled"] = enabled
        tier.spent["off"] = tier_off
    return out


def add_parser(sub) -> None:
    """Register ``visviva warmup``."""
    p = sub.add_parser(
        "warmup", help="compile every numba kernel once (run after installing)",
        description="Compile visviva's numba kernels and fill numba's on-disk cache, so that "
        "the first call in every later process loads machine code instead of compiling "
        "(a few minutes of CPU once; later first calls take about 0.1 s).")
    p.add_argument("--quiet", action="store_true", help="no progress bar, one line per task")


def run(args) -> int:
    """Run :func:`warmup`; exit code 1 if a task failed."""
    import numba

    t0 = time.perf_counter()
    results = warmup(progress=not args.quiet)
    failed = [r for r in results if r[2]]
    where = numba.config.CACHE_DIR or "__pycache__ next to visviva's sources"
    print(f"visviva warmup: {len(results) - len(failed)} of {len(results)} kernel families "
          f"compiled in {time.perf_counter() - t0:.0f} s; cached in {where}")
    return 1 if failed else 0
