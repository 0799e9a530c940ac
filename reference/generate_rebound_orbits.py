"""Reference two-body data from REBOUND: elements -> state vectors, and Kepler propagation.

For orbits across every regime (near-circular, elliptic up to e = 0.99, hyperbolic up to e = 5,
low to retrograde inclinations) REBOUND converts classical elements to state vectors
(``rebound.Particle(primary=..., a, e, inc, Omega, omega, f)``) and propagates them with WHFast,
whose Kepler drift is exact for a test particle around a single mass (no interaction kicks).

Run ``python reference/generate_rebound_orbits.py`` to rewrite
``reference/data/rebound_orbits.json``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _provenance  # noqa: E402

NAME = "rebound_orbits.json"
GM_EARTH_KM3_S2 = 398600.4418
SEED = 20261121
DT_FRACTIONS = (-0.37, 0.25, 1.0, 3.3)  # of the period (ellipses) or of |a|^1.5/sqrt(GM)


def _cases(rng: np.random.Generator) -> list[dict]:
    cases = []
    regimes = [
        ("near-circular", lambda: (rng.uniform(6800, 42164), rng.uniform(1e-6, 1e-3))),
        ("elliptic", lambda: (rng.uniform(7000, 1e5), rng.uniform(0.01, 0.7))),
        ("highly elliptic", lambda: (rng.uniform(2e4, 3e5), rng.uniform(0.7, 0.99))),
        ("hyperbolic", lambda: (-rng.uniform(7000, 1e5), rng.uniform(1.05, 5.0))),
    ]
    for regime, draw in regimes:
        for _ in range(6):
            a, e = draw()
            inc = rng.choice([rng.uniform(0.01, 1.5), rng.uniform(1.6, 3.13)])
            raan, argp = rng.uniform(0, 2 * np.pi, 2)
            if e > 1:
                nu_max = np.arccos(-1.0 / e)
                nu = rng.uniform(-0.9 * nu_max, 0.9 * nu_max)
            else:
                nu = rng.uniform(-np.pi, np.pi)
            cases.append({"regime": regime, "a_km": a, "ecc": e, "inc_rad": inc, "raan_rad": raan,
                          "argp_rad": argp, "nu_rad": nu})
    return cases


def generate() -> dict:
    """Build the whole data set (no file written)."""
    import rebound

    rng = np.random.default_rng(SEED)
    out = []
    for case in _cases(rng):
        sim = rebound.Simulation()
        sim.G = 1.0
        sim.add(m=GM_EARTH_KM3_S2)
        sim.add(primary=sim.particles[0], m=0.0, a=case["a_km"], e=case["ecc"],
                inc=case["inc_rad"], Omega=case["raan_rad"], omega=case["argp_rad"],
                f=case["nu_rad"])
        p = sim.particles[1]
        case["r_km"] = list(p.xyz)
        case["v_km_s"] = list(p.vxyz)
        orbit = p.orbit(primary=sim.particles[0], G=1.0)
        case["rebound_elements"] = {"a_km": orbit.a, "ecc": orbit.e, "inc_rad": orbit.inc,
                                    "raan_rad": orbit.Omega, "argp_rad": orbit.omega,
                                    "nu_rad": orbit.f, "M_rad": orbit.M}
        scale_s = 2 * np.pi * np.sqrt(abs(case["a_km"]) ** 3 / GM_EARTH_KM3_S2)
        props = []
        for frac in DT_FRACTIONS:
            dt = frac * scale_s
            s2 = rebound.Simulation()
            s2.G = 1.0
            s2.add(m=GM_EARTH_KM3_S2)
            s2.add(m=0.0, x=case["r_km"][0], y=case["r_km"][1], z=case["r_km"][2],
                   vx=case["v_km_s"][0], vy=case["v_km_s"][1], vz=case["v_km_s"][2])
            s2.integrator = "whfast"
            s2.dt = dt / 8.0
            s2.integrate(dt, exact_finish_time=1)
            q = s2.particles[1]
            c = s2.particles[0]
            props.append({"dt_s": dt,
                          "r_km": [q.x - c.x, q.y - c.y, q.z - c.z],
                          "v_km_s": [q.vx - c.vx, q.vy - c.vy, q.vz - c.vz]})
        case["propagated"] = props
        out.append(case)
    settings = {"gm_km3_s2": GM_EARTH_KM3_S2, "seed": SEED, "dt_fractions": DT_FRACTIONS,
                "rebound": "G = 1, primary mass = GM (km3/s2), test particle m = 0; "
                           "propagation with WHFast, dt = interval / 8, exact_finish_time=1"}
    return _provenance.document(
        __file__, ("rebound",), settings,
        "State vectors from classical elements and two-body propagation computed by REBOUND, "
        "for near-circular, elliptic, highly elliptic and hyperbolic orbits.",
        {"a_km": "km", "r_km": "km", "v_km_s": "km/s", "angles": "rad", "dt_s": "s"}, out)


if __name__ == "__main__":
    _provenance.main(NAME, generate)
