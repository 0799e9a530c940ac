"""Reference N-body data from REBOUND's IAS15: the Sun and planets, and the figure-eight.

1. The Sun and the eight planet-system barycentres at J2000 (DE421 states, DE440 GM, from
   ``src/visviva/data/solar_system_j2000.json``) integrated with IAS15 for 20 Julian years, in
   units of km, s and G = 1 with each mass equal to its GM in km3/s2.
2. The Chenciner-Montgomery figure-eight (``tests/data/figure_eight.json``, G = 1) integrated
   with IAS15 for one period.

IAS15 is accurate to round-off, so any correct high-order integrator must reproduce these final
states up to the chaotic growth of round-off (tolerances in tests/test_validation_data.py).

Run ``python reference/generate_rebound_nbody.py`` to rewrite
``reference/data/rebound_nbody.json``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _provenance  # noqa: E402

NAME = "rebound_nbody.json"
BODIES = ("sun", "mercury", "venus", "earthmoon", "mars", "jupiter", "saturn", "uranus",
          "neptune")
JULIAN_YEAR_S = 365.25 * 86400.0
SOLAR_SYSTEM_YEARS = 20.0
SNAPSHOTS = 5


def solar_system_initial() -> dict:
    """Masses (GM, km3/s2), positions (km) and velocities (km/s) at J2000."""
    data = json.loads((_provenance.REPO / "src" / "visviva" / "data" /
                       "solar_system_j2000.json").read_text())
    gm = data["gm_km3_s2_system_barycentres"]
    key = {"sun": "sun", "earthmoon": "earth_moon_bary"}
    masses = [float(gm[key.get(b, f"{b}_sys")]) for b in BODIES]
    states = data["states_km_km_s"]
    return {"bodies": list(BODIES), "masses": masses,
            "positions_km": [states[b]["r"] for b in BODIES],
            "velocities_km_s": [states[b]["v"] for b in BODIES]}


def figure_eight_initial() -> dict:
    data = json.loads((_provenance.REPO / "tests" / "data" / "figure_eight.json").read_text())
    return {"G": data["G"], "masses": data["masses"], "positions": data["positions"],
            "velocities": data["velocities"], "period": data["period"]}


def _run(G, masses, positions, velocities, times):
    import rebound

    sim = rebound.Simulation()
    sim.G = G
    sim.integrator = "ias15"
    for m, r, v in zip(masses, positions, velocities, strict=True):
        sim.add(m=m, x=r[0], y=r[1], z=r[2], vx=v[0], vy=v[1], vz=v[2])
    e0 = sim.energy()
    out = []
    for t in times:
        sim.integrate(t, exact_finish_time=1)
        pos = np.array([[p.x, p.y, p.z] for p in sim.particles])
        vel = np.array([[p.vx, p.vy, p.vz] for p in sim.particles])
        out.append({"t": t, "positions": pos, "velocities": vel,
                    "relative_energy_error": (sim.energy() - e0) / abs(e0)})
    return out, {"steps": int(sim.steps_done)}


def generate() -> dict:
    """Build the whole data set (no file written)."""
    ss = solar_system_initial()
    times = list(np.linspace(0.0, SOLAR_SYSTEM_YEARS * JULIAN_YEAR_S, SNAPSHOTS + 1)[1:])
    ss_out, ss_info = _run(1.0, ss["masses"], ss["positions_km"], ss["velocities_km_s"], times)
    f8 = figure_eight_initial()
    f8_times = [f8["period"] / 3.0, f8["period"]]
    f8_out, f8_info = _run(f8["G"], f8["masses"], f8["positions"], f8["velocities"], f8_times)
    cases = [
        {"name": "solar_system_ias15", "G": 1.0, "units": "km, s, masses = GM in km3/s2",
         "initial": ss, "snapshots": ss_out, "rebound_info": ss_info},
        {"name": "figure_eight_ias15", "G": f8["G"], "units": "G = 1 (dimensionless)",
         "initial": f8, "snapshots": f8_out, "rebound_info": f8_info},
    ]
    settings = {"integrator": "ias15 (REBOUND defaults: epsilon = 1e-9, adaptive)",
                "exact_finish_time": 1, "solar_system_years": SOLAR_SYSTEM_YEARS,
                "solar_system_snapshots": SNAPSHOTS, "julian_year_s": JULIAN_YEAR_S,
                "frame": "ICRF axes, solar-system barycentre origin at J2000 (TDB)"}
    return _provenance.document(
        __file__, ("rebound",), settings,
        "REBOUND IAS15 integrations of the Sun + planets (20 years) and of the figure-eight "
        "choreography (one period): snapshots of positions, velocities and energy error.",
        {"solar_system": "km, km/s, s, GM km3/s2 with G = 1", "figure_eight": "G = 1 units"}, cases)


if __name__ == "__main__":
    _provenance.main(NAME, generate)
