"""Effective potential: why orbits are bounded, and where they turn around.

A particle in a central potential V(r) moves radially as if in the effective potential
V_eff(r) = h^2 / (2 r^2) + V(r). For a given energy E the motion is confined to where
V_eff(r) <= E; the turning points (the apsides) are where V_eff(r) = E.

Run: python examples/effective_potential.py   (writes effective_potential.png)
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

from visviva.central_force import effective_potential, kepler_potential, turning_points

mu, h = 1.0, 1.0  # G M = 1 and angular momentum 1: the circular orbit has r = h^2/mu = 1
potential = kepler_potential(mu)
r = np.linspace(0.3, 8.0, 800)
v_eff = effective_potential(r, h, potential)

fig, ax = plt.subplots(figsize=(7, 4.5))
ax.plot(r, v_eff, "k", label=r"$V_{eff} = h^2/2r^2 - \mu/r$")
ax.plot(r, potential(r), "k:", label=r"$V = -\mu/r$")
for energy, colour, kind in [(-0.5, "C2", "circle"), (-0.3, "C0", "ellipse"),
                             (0.0, "C1", "parabola"), (0.15, "C3", "hyperbola")]:
    radii = turning_points(energy, h, potential, 0.05, 1e3)
    ax.axhline(energy, color=colour, lw=0.8)
    ax.plot(radii, np.full_like(radii, energy), "o", color=colour,
            label=f"E = {energy:+.2f} ({kind}): turning points {np.round(radii, 3)}")
    if kind == "ellipse":
        # the turning points of the Kepler problem are the apsides a(1 -+ e)
        a = -mu / (2 * energy)
        e = np.sqrt(1 + 2 * energy * h**2 / mu**2)
        assert np.allclose(radii, [a * (1 - e), a * (1 + e)], rtol=1e-12), radii
ax.set(xlabel="r", ylabel="energy per unit mass", ylim=(-0.7, 0.5),
       title="Effective potential of the Kepler problem (G M = 1, h = 1)")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(figure_path("effective_potential.png"), dpi=120)
print("ellipse E = -0.3: turning points", turning_points(-0.3, h, potential, 0.05, 1e3))
