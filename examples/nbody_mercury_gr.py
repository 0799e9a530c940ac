"""Mercury's relativistic perihelion advance: 43 arcseconds per century.

The Sun and Mercury with the 1PN correction (IAS15, velocity-dependent force) and with the
Nobili-Roxburgh potential (WHFast, positions only); the theory gives
``6 pi G M / (c**2 a (1 - e**2))`` per orbit = 42.98" per century.
"""

from __future__ import annotations

import math

import numpy as np

import visviva as vv
from visviva.nbody import GeneralRelativity, GeneralRelativityPotential


def perihelion_advance(force, integrator, years=100.0):
    sim = vv.Simulation(integrator, units=("au", "yr", "Msun"), dt=0.24 / 40)
    sim.add(1.0)
    sim.add(0.0, a=0.38709893, e=0.20563069, primary=0)
    sim.add_force(force(primary=0))
    sim.integrate(years)
    r = sim.positions[1] - sim.positions[0]
    w = sim.velocities[1] - sim.velocities[0]
    e_vec = np.cross(w, np.cross(r, w)) / sim.G - r / np.linalg.norm(r)
    return math.degrees(math.atan2(e_vec[1], e_vec[0])) * 3600 * 100.0 / years


def main():
    for force, integrator in ((GeneralRelativity, "ias15"), (GeneralRelativityPotential, "whfast")):
        print(f"{force.__name__:28s} {integrator:7s}: {perihelion_advance(force, integrator):.2f}\" per century")


if __name__ == "__main__":
    main()
