"""Precession and Bertrand's theorem, from the orbit equation u'' + u = -F(1/u) / (h^2 u^2).

* Gravity (F = -mu/r^2) and Hooke's law (F = -k r) give closed orbits at every amplitude: their
  apsidal angles are pi and pi/2 (Bertrand's theorem: the only two such power laws).
* Add a small 1/r^3 term to the potential, V = -mu/r - beta/r^3 (the form of general relativity's
  correction), and the ellipse precesses: the periapsis advances every orbit, by about
  6 pi beta mu / h^4 per orbit for small beta (first order in beta).
* Other power laws give rosettes whose apsidal angle, for nearly circular orbits, is
  pi / sqrt(n + 3).

Run: python examples/bertrand_precession.py   (writes bertrand_precession.png)
"""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from _output import figure_path

from visviva.central_force import bertrand_apsidal_angle, orbit_equation, power_law_force

mu, h = 1.0, 1.0
cases = {
    "gravity, F = -1/r^2": orbit_equation(power_law_force(1.0, -2), r0=0.6, h=h, theta_max=6 * math.pi),
    "Hooke, F = -r": orbit_equation(power_law_force(1.0, 1), r0=0.6, h=h, theta_max=6 * math.pi),
    "F = -1/r^1.5": orbit_equation(power_law_force(1.0, -1.5), r0=0.7, h=h, theta_max=8 * math.pi),
}
beta = 0.002
precessing = orbit_equation(lambda r: -mu / r**2 - 3 * beta / r**4, r0=0.6, h=h,
                            theta_max=16 * math.pi, n_points=6000)
cases[f"V = -1/r - {beta}/r^3"] = precessing

for name, orbit in cases.items():
    print(f"{name:24s} apsidal angle = {orbit.apsidal_angle / math.pi:.6f} pi, "
          f"closed: {orbit.is_closed()}")
assert cases["gravity, F = -1/r^2"].is_closed() and cases["Hooke, F = -r"].is_closed()
assert abs(cases["Hooke, F = -r"].apsidal_angle - bertrand_apsidal_angle(1)) < 1e-9
assert not cases["F = -1/r^1.5"].is_closed()

first_order = 6 * math.pi * beta * mu / h**4
print(f"precession per orbit: {precessing.precession_per_orbit:.6e} rad "
      f"(first-order estimate 6 pi beta mu / h^4 = {first_order:.6e})")
assert abs(precessing.precession_per_orbit / first_order - 1) < 0.05

fig, axes = plt.subplots(1, 4, figsize=(14, 3.8))
for ax, (name, orbit) in zip(axes, cases.items(), strict=True):
    ax.plot(orbit.xy[:, 0], orbit.xy[:, 1], lw=0.8, label="orbit")
    ax.plot(0, 0, "k*", label="centre of force")
    ax.set_title(f"{name}\napsidal angle {orbit.apsidal_angle / math.pi:.4f} pi", fontsize=9)
    ax.set_aspect("equal")
    ax.set(xlabel="x (model units)", ylabel="y (model units)")
axes[0].legend(loc="lower left", fontsize="x-small")
fig.suptitle("Bertrand's theorem: only F ~ -1/r^2 and F ~ r give closed bound orbits", fontsize=10)
fig.tight_layout()
fig.savefig(figure_path("bertrand_precession.png"), dpi=120)
