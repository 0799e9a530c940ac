"""Screen a small catalogue, then compute and plot the collision probability of the closest pair.

A synthetic catalogue of SGP4 element sets (with pairs built to cross) is screened against itself
over three hours; the closest approach gets covariances (100 m radial, 1 km in-track, 100 m
cross-track, in each object's RTN frame), the probability of collision by three methods, the
encounter-plane picture and Pc against the hard-body radius.

Run: python examples/conjunction_screening.py   (writes conjunction_plane.png, conjunction_pc_hbr.png)
"""

import matplotlib

matplotlib.use("Agg")
import astropy.units as u
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

import visviva as vv
from visviva.conjunctions import rtn_to_inertial
from visviva.conjunctions.plots import plot_encounter_plane, plot_pc_vs_hbr
from visviva.conjunctions.synthetic import synthetic_catalog

cat = synthetic_catalog(40, seed=5, crossing_pairs=3)
t0 = cat.epochs[0]
table = vv.screen_conjunctions(cat, None, t0, t0 + 3 * u.hour, threshold=20 * u.km)
print(table["object1", "object2", "tca", "miss_distance", "relative_speed"])
assert len(table) >= 1, "a crossing pair must be found"

row = table[np.argmin(table["miss_distance"])]
s1, s2 = cat[int(row["index1"])], cat[int(row["index2"])]
a, b = s1.teme(row["tca"]), s2.teme(row["tca"])
r1, v1 = a.r.to_value(u.m), a.v.to_value(u.m / u.s)
r2, v2 = b.r.to_value(u.m), b.v.to_value(u.m / u.s)
cov_rtn = np.diag([100.0**2, 1000.0**2, 100.0**2])
c1 = rtn_to_inertial(cov_rtn, a.r, a.v)
c2 = rtn_to_inertial(cov_rtn, b.r, b.v)
hbr = 20 * u.m
for method in ("foster", "chan", "3d"):
    print(f"Pc ({method:>6s}) = {vv.collision_probability(r1, v1, c1, r2, v2, c2, hbr, method=method):.4e}")
mc = vv.monte_carlo_probability(r1, v1, c1, r2, v2, c2, hbr, samples=400_000, seed=1)
print(f"Pc (Monte Carlo) = {mc.pc:.4e}  95% [{mc.low:.3e}, {mc.high:.3e}]")
pc = vv.collision_probability(r1, v1, c1, r2, v2, c2, hbr)
assert mc.low <= pc <= mc.high or mc.hits == 0
print(f"Alfano's maximum Pc = {vv.max_collision_probability(r1, v1, r2, v2, hbr, c1, c2):.4e}")

plot_encounter_plane(r1, v1, c1, r2, v2, c2, hbr)
plt.savefig(figure_path("conjunction_plane.png"), dpi=110, bbox_inches="tight")
plot_pc_vs_hbr(r1, v1, c1, r2, v2, c2, np.geomspace(1, 1000, 25))
plt.savefig(figure_path("conjunction_pc_hbr.png"), dpi=110, bbox_inches="tight")
