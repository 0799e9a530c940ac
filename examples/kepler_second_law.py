"""Kepler's second law: the radius vector sweeps equal areas in equal times.

We integrate an eccentric orbit (e = 0.6) numerically, cut one period into 12 equal time
intervals, and measure the area of each swept sector geometrically, as the area of a fan of
many thin triangles with their apex at the attractor. The 12 areas agree to a few parts in 1e8
(the polygon's own error), although the arcs are very different in length.

Run: python examples/kepler_second_law.py   (writes kepler_second_law.png)
"""

import matplotlib

matplotlib.use("Agg")
import astropy.units as u
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path
from scipy.integrate import solve_ivp

import visviva as vv
from visviva.central_force import areal_velocity

elements = vv.KeplerianElements.from_semi_major_axis(
    20000 * u.km, 0.6, 0.0, 0.0, 0.0, 0.0, vv.EARTH
)
state = elements.to_state()
mu = vv.EARTH.gm.to_value(u.km**3 / u.s**2)
period = elements.period.to_value(u.s)
y0 = np.concatenate([state.r.to_value(u.km), state.v.to_value(u.km / u.s)])


def newton(_t, y):
    r = y[:3]
    return np.concatenate([y[3:], -mu * r / np.linalg.norm(r) ** 3])


n_sectors, n_sub = 12, 4000
t = np.linspace(0.0, period, n_sectors * n_sub + 1)
xy = solve_ivp(newton, (0, period), y0, method="DOP853", t_eval=t, rtol=1e-13,
               atol=1e-9).y[:2].T

# fan of triangles from the focus: area = 1/2 |x_i y_{i+1} - x_{i+1} y_i|
triangles = 0.5 * (xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1])
areas = triangles.reshape(n_sectors, n_sub).sum(axis=1)
spread = (areas.max() - areas.min()) / areas.mean()
expected = areal_velocity(state.r, state.v).to_value(u.km**2 / u.s) * period / n_sectors
print("areas swept in equal times (km^2):", np.array2string(areas, precision=1))
print(f"relative spread {spread:.1e}; h T / (2 * 12) = {expected:.1f} km^2")
assert spread < 1e-7, "equal areas in equal times"
assert abs(areas.mean() / expected - 1) < 1e-7

fig, ax = plt.subplots(figsize=(7, 5))
for i in range(n_sectors):
    arc = xy[i * n_sub:(i + 1) * n_sub + 1]
    ax.fill(np.vstack([[0, 0], arc])[:, 0], np.vstack([[0, 0], arc])[:, 1],
            color=f"C{i % 2}", alpha=0.5)
ax.plot(0, 0, "k*", ms=10)
ax.set(aspect="equal", xlabel="x (km)", ylabel="y (km)",
       title=f"Kepler's second law: 12 sectors of T/12, areas equal to {spread:.0e}")
fig.tight_layout()
fig.savefig(figure_path("kepler_second_law.png"), dpi=120)
