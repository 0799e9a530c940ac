"""State vectors <-> classical elements, timed against Skyfield in one process.

Rows (ratio = visviva time / reference time; below 1 visviva is faster; target 0.2 = 5x faster):

* ``states -> elements``: ``vv.StateVectors(r, v, gm).to_elements()`` from Quantities, plus
  reading p, e, i, raan, argp, nu as Quantities, vs Skyfield's
  ``elementslib.OsculatingElements(Distance, Velocity, None, mu)`` reading the same six
  elements (its properties are lazy too).
* ``elements -> states``: ``vv.KeplerianElements(p, e, i, raan, argp, nu, gm).to_state()`` from
  Quantities (with its validation), reading ``.r`` and ``.v``, vs Skyfield's
  ``keplerlib.ele_to_vec`` (which also validates its input).
* the same two with the bare compiled kernels (``visviva.core.elements.*_array``) on float64
  arrays, to show the cost of the public layer.

Random non-degenerate orbits (ellipses and hyperbolas, all inclinations), 10^6 of them
(quick: 10^5). Run: ``python -m benchmarks --only elements`` or
``python -m benchmarks.bench_elements``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import (
        compile_time,
        interleaved,
        quick_from_env,
        result,
        skipped,
        threads,
        time_call,
    )
except ImportError:  # pragma: no cover
    from common import (
        compile_time,
        interleaved,
        quick_from_env,
        result,
        skipped,
        threads,
        time_call,
    )

MU = 398600.4418
TARGET = 0.2  # at least 5x faster than Skyfield


def _orbits(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    r = rng.normal(size=(n, 3)) * 10000.0
    v = rng.normal(size=(n, 3)) * 3.0
    return r, v


def _direction_rows(label, kernel_name, reference, public, kernel, ref_fn, n, note_prefix=""):
    """The three rows of one conversion: public API, bare kernel, and the kernel on one thread.

    Parameters
    ----------
    label : str
        Start of the row names, e.g. ``"states -> elements, 1e+06 states"``.
    kernel_name : str
        Name of the compiled kernel, shown in the second row's name.
    reference : str
        The reference library and function.
    public, kernel, ref_fn : callable
        The public-API call, the bare kernel call and the reference call (no arguments).
    n : int
        Number of orbits per call (for the throughput notes).
    note_prefix : str
        Text put before the first row's notes.

    Returns
    -------
    list of dict
        The rows, timed in the order compile, interleaved (public, kernel, reference), 1 thread.
    """
    compile_s = compile_time(kernel)
    t_vv, t_k, t_ref = interleaved([public, kernel, ref_fn])
    note = f"{note_prefix}{n / t_vv.median / 1e6:.1f} M states/s"
    rows = [
        result(f"{label} (public API, Quantities)", t_vv, reference, t_ref, TARGET,
               notes=note + f"; skyfield {n / t_ref.median / 1e6:.2f} M/s", compile_s=compile_s),
        result(f"{label} (kernel {kernel_name})", t_k, reference, t_ref, TARGET,
               notes=f"{n / t_k.median / 1e6:.1f} M states/s"),
    ]
    with threads(1):
        t_k1 = time_call(kernel, repeat=5)
    rows.append(result(f"{label} (kernel, 1 thread)", t_k1, reference, t_ref, None,
                       notes=f"1 thread; {n / t_k1.median / 1e6:.1f} M states/s; informational"))
    return rows


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    n = 100_000 if quick else 1_000_000
    from astropy import units as u

    import visviva as vv
    from visviva.core.elements import (
        coe_to_rv_array,
        empty_elements,
        empty_states,
        rv_to_coe_array,
    )
    try:
        import skyfield
        from skyfield.elementslib import OsculatingElements
        from skyfield.keplerlib import ele_to_vec
        from skyfield.units import Distance, Velocity
    except ImportError as exc:  # pragma: no cover
        return [skipped("states -> elements", f"skyfield not installed: {exc}", "skyfield")]

    r, v = _orbits(n)
    gm_q = MU * u.km**3 / u.s**2
    r_q, v_q = r * u.km, v * u.km / u.s
    gm_flat = np.full(n, MU)
    sky_ref = f"skyfield {skyfield.__version__}"
    rows = []

    # --- states -> elements -------------------------------------------------------------------
    def vv_rv2coe():
        el = vv.StateVectors(r_q, v_q, gm_q).to_elements()
        return (el.semi_latus_rectum, el.eccentricity, el.inclination,
                el.longitude_of_ascending_node, el.argument_of_periapsis, el.true_anomaly)

    def sky_rv2coe():
        el = OsculatingElements(Distance(km=r.T), Velocity(km_per_s=v.T), None, MU)
        return (el.semi_latus_rectum, el.eccentricity, el.inclination,
                el.longitude_of_ascending_node, el.argument_of_periapsis, el.true_anomaly)

    def kernel_rv2coe():  # the allocation included, as in the public call
        out = empty_elements(n)
        rv_to_coe_array(r, v, gm_flat, *out)
        return out

    rows += _direction_rows(f"states -> elements, {n:.0e} states", "rv_to_coe_array",
                            sky_ref + " OsculatingElements", vv_rv2coe, kernel_rv2coe,
                            sky_rv2coe, n, note_prefix=f"{n:.0e} random ellipses/hyperbolas; ")

    # --- elements -> states -------------------------------------------------------------------
    p, e, i, raan, argp, nu, _ = out = empty_elements(n)
    rv_to_coe_array(r, v, gm_flat, *out)
    p_q = p * u.km

    def vv_coe2rv():
        s = vv.KeplerianElements(p_q, e, i, raan, argp, nu, gm_q).to_state()
        return s.r, s.v

    def sky_coe2rv():
        return ele_to_vec(p, e, i, raan, argp, nu, MU)

    def kernel_coe2rv():
        out = empty_states(n)
        coe_to_rv_array(p, e, i, raan, argp, nu, gm_flat, *out)
        return out

    rows += _direction_rows(f"elements -> states, {n:.0e} orbits", "coe_to_rv_array",
                            sky_ref + " keplerlib.ele_to_vec", vv_coe2rv, kernel_coe2rv,
                            sky_coe2rv, n)
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
