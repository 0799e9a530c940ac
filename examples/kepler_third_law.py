"""Kepler's third law: T^2 is proportional to a^3, measured on the real planets.

Semi-major axes come from the planets' heliocentric state vectors at J2000 (JPL DE421, in
visviva's reference data) through visviva's elements; the sidereal periods are the published
ones (NASA Planetary Fact Sheet). A straight-line fit of log T against log a gives the slope 3/2.

Run: python examples/kepler_third_law.py   (writes kepler_third_law.png)
"""

import json
from importlib import resources

import matplotlib

matplotlib.use("Agg")
import astropy.units as u
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

import visviva as vv
from visviva.central_force import orbital_period

data = json.loads(resources.files("visviva").joinpath("data/solar_system_j2000.json").read_text())
states, gm = data["states_km_km_s"], data["gm_km3_s2_system_barycentres"]
# sidereal orbital periods in days, NASA Planetary Fact Sheet
published_days = {"mercury": 87.969, "venus": 224.701, "earthmoon": 365.256, "mars": 686.980,
                  "jupiter": 4332.589, "saturn": 10759.22, "uranus": 30685.4, "neptune": 60189.0}
gm_key = {"earthmoon": "earth_moon_bary"}

names = list(published_days)
r = np.array([states[n]["r"] for n in names]) - states["sun"]["r"]
v = np.array([states[n]["v"] for n in names]) - states["sun"]["v"]
mu = gm["sun"] + np.array([gm[gm_key.get(n, f"{n}_sys")] for n in names])
orbits = vv.StateVectors(r * u.km, v * u.km / u.s, mu * u.km**3 / u.s**2).to_elements()
a_au = orbits.semi_major_axis.to_value(u.au)
T_yr = np.array([published_days[n] for n in names]) / 365.25

slope, intercept = np.polyfit(np.log(a_au), np.log(T_yr), 1)
print(f"{'planet':10s} {'a (au)':>10s} {'T (yr)':>10s} {'T^2/a^3':>9s}  Kepler's T (yr)")
kepler_T = orbital_period(a_au * u.au, mu * u.km**3 / u.s**2).to_value(u.yr)
for n, a, T, TK in zip(names, a_au, T_yr, kepler_T, strict=True):
    print(f"{n:10s} {a:10.5f} {T:10.4f} {T**2 / a**3:9.5f}  {TK:.4f}")
print(f"fit: log T = {slope:.5f} log a + {intercept:+.5f}   (Kepler: slope 3/2, intercept 0)")
assert abs(slope - 1.5) < 2e-3 and abs(intercept) < 5e-3

fig, ax = plt.subplots(figsize=(6, 4.5))
ax.loglog(a_au, T_yr, "o")
for n, a, T in zip(names, a_au, T_yr, strict=True):
    ax.annotate(n.replace("earthmoon", "earth"), (a, T), textcoords="offset points", xytext=(5, -10))
grid = np.geomspace(0.3, 40, 50)
ax.loglog(grid, np.exp(intercept) * grid**slope, "k--", lw=1, label=f"fit: slope {slope:.4f}")
ax.set(xlabel="semi-major axis a (au)", ylabel="sidereal period T (yr)",
       title="Kepler's third law over the planets")
ax.legend()
fig.tight_layout()
fig.savefig(figure_path("kepler_third_law.png"), dpi=120)
