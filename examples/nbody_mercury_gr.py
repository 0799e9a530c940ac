"""Mercury's relativistic perihelion advance: 43 arcseconds per century.

The Sun and Mercury with the 1PN correction (IAS15, velocity-dependent force) and with the
Nobili-Roxburgh potential (WHFast, positions only); the theory gives
``6 pi G M / (c**2 a (1 - e**2))`` per orbit = 42.98" per century. Writes nbody_mercury_gr.png:
the direction of the perihelion against time.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

import visviva as vv
from visviva.nbody import GeneralRelativity, GeneralRelativityPotential


def perihelion_longitude_arcsec(force, integrator, years=100.0, samples=50):
    """Times (yr) and perihelion longitudes (arcsec) of Mercury about the Sun, with GR."""
    sim = vv.Simulation(integrator, units=("au", "yr", "Msun"), dt=0.24 / 40)
    sim.add(1.0)
    sim.add(0.0, a=0.38709893, e=0.20563069, primary=0)
    sim.add_force(force(primary=0))
    times = np.linspace(years / samples, years, samples)
    traj = sim.integrate(times)
    r = traj.positions[:, 1] - traj.positions[:, 0]
    w = traj.velocities[:, 1] - traj.velocities[:, 0]
    e_vec = np.cross(w, np.cross(r, w)) / sim.G - r / np.linalg.norm(r, axis=-1)[:, None]
    return times, np.degrees(np.arctan2(e_vec[:, 1], e_vec[:, 0])) * 3600


def main():
    fig, ax = plt.subplots(figsize=(6, 4))
    for force, integrator in ((GeneralRelativity, "ias15"), (GeneralRelativityPotential, "whfast")):
        t, varpi = perihelion_longitude_arcsec(force, integrator)
        rate = np.polyfit(t, varpi, 1)[0] * 100.0  # arcsec per century
        print(f"{force.__name__:28s} {integrator:7s}: {rate:.2f}\" per century")
        assert abs(rate - 42.98) < 0.5, "GR advances Mercury's perihelion by 43 arcsec/century"
        ax.plot(t, varpi - varpi[0], label=f"{force.__name__} ({integrator}): {rate:.2f}\"/cy")
    ax.set(xlabel="time (yr)", ylabel="perihelion advance (arcsec)",
           title="Mercury's relativistic perihelion advance")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(figure_path("nbody_mercury_gr.png"), dpi=120)


if __name__ == "__main__":
    main()
