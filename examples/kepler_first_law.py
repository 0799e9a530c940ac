"""Kepler's first law: the orbit is a conic with the attractor at one focus.

We integrate Newton's equations for one satellite numerically (scipy's DOP853, no Kepler
formulas), then fit a general conic  A x^2 + B xy + C y^2 + D x + E y = 1  to the path in its
own plane -- without telling the fit where the Earth is -- and find the conic's foci. One focus
lands on the Earth's centre, and the fitted shape matches the elements visviva computes from the
initial state vector.

State vector: Curtis, *Orbital Mechanics for Engineering Students*, Example 4.3.

Run: python examples/kepler_first_law.py   (writes kepler_first_law.png)
"""

import matplotlib

matplotlib.use("Agg")
import astropy.units as u
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path
from scipy.integrate import solve_ivp

import visviva as vv

r0 = np.array([-6045.0, -3490.0, 2500.0])  # km
v0 = np.array([-3.457, 6.618, 2.533])  # km/s
mu = vv.EARTH.gm.to_value(u.km**3 / u.s**2)
elements = vv.StateVectors(r0 * u.km, v0 * u.km / u.s, vv.EARTH).to_elements()
p = elements.semi_latus_rectum.to_value(u.km)
ecc = float(elements.eccentricity)
print(f"from the state vector: p = {p:.6f} km, e = {ecc:.9f}, "
      f"T = {elements.period.to_value(u.h):.4f} h")


def newton(_t, y):
    r = y[:3]
    return np.concatenate([y[3:], -mu * r / np.linalg.norm(r) ** 3])


period = elements.period.to_value(u.s)
t = np.linspace(0.0, period, 4001)
path = solve_ivp(newton, (0, period), np.concatenate([r0, v0]), method="DOP853", t_eval=t,
                 rtol=1e-13, atol=1e-9).y[:3].T

# the orbital plane from the path itself: normal = r x v at the start, check planarity
normal = np.cross(r0, v0) / np.linalg.norm(np.cross(r0, v0))
out_of_plane = np.abs(path @ normal).max()
x_axis = r0 / np.linalg.norm(r0)
y_axis = np.cross(normal, x_axis)
x, y = path @ x_axis, path @ y_axis
print(f"largest distance from the plane: {out_of_plane:.2e} km")

# least-squares conic through the points (scaled to ~1 for conditioning)
s = np.max(np.hypot(x, y))
X, Y = x / s, y / s
A, B, C, D, E = np.linalg.lstsq(np.column_stack([X * X, X * Y, Y * Y, X, Y]), np.ones_like(X),
                                rcond=None)[0]
# centre, axes and foci of the fitted ellipse
M = np.array([[A, B / 2], [B / 2, C]])
centre = np.linalg.solve(2 * M, [-D, -E])
k = 1 + centre @ M @ centre
eigval, eigvec = np.linalg.eigh(M)
semi_axes = np.sqrt(k / eigval)  # along each eigenvector
major = int(np.argmax(semi_axes))
a_fit, b_fit = semi_axes[major] * s, semi_axes[1 - major] * s
c_fit = np.sqrt(a_fit**2 - b_fit**2)
foci = centre * s + np.outer([1, -1], eigvec[:, major] * c_fit)
focus_error = np.min(np.linalg.norm(foci, axis=1))
p_fit, e_fit = b_fit**2 / a_fit, c_fit / a_fit
print(f"fitted conic:          p = {p_fit:.6f} km, e = {e_fit:.9f}")
print(f"nearest focus to the Earth's centre: {focus_error:.2e} km (a = {a_fit:.1f} km)")
assert out_of_plane < 1e-6, "the orbit is planar"
assert focus_error < 1e-10 * a_fit, "the attractor sits at a focus"
assert abs(p_fit / p - 1) < 1e-10 and abs(e_fit - ecc) < 1e-10, "the conic is the Kepler orbit"

fig, ax = plt.subplots(figsize=(6, 6))
ax.plot(x, y, lw=2, label="numerically integrated path")
theta = np.linspace(0, 2 * np.pi, 400)
ellipse = centre * s + np.outer(a_fit * np.cos(theta), eigvec[:, major]) \
    + np.outer(b_fit * np.sin(theta), eigvec[:, 1 - major])
ax.plot(ellipse[:, 0], ellipse[:, 1], "k--", lw=1, label="fitted conic")
ax.plot(*foci.T, "r+", ms=12, label="foci of the fitted conic")
ax.add_patch(plt.Circle((0, 0), vv.EARTH.radius.to_value(u.km), color="C0", alpha=0.3))
ax.set(aspect="equal", xlabel="x in the orbital plane (km)", ylabel="y (km)",
       title=f"Kepler's first law: e = {e_fit:.4f}, focus on the Earth to {focus_error:.0e} km")
ax.legend(loc="lower left", fontsize=8)
fig.tight_layout()
fig.savefig(figure_path("kepler_first_law.png"), dpi=120)
