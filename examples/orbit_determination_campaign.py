"""Orbit determination from a simulated tracking campaign, then a TLE for the result.

Two ground stations measure range (1 cm), range rate (10 um/s) and azimuth/elevation (0.01 deg)
of a low satellite whenever it is 10 deg above their horizon, for four hours; the satellite moves
under J2. From a deliberately poor first guess (10 km, 10 m/s off) the batch least-squares fit
finds the orbit; we check that its error is consistent with its covariance and that the
normalised residuals look like unit Gaussian noise. Then SGP4 mean elements are fitted to a day
of the estimated orbit, and compared with the "naive" TLE made from the osculating elements.

Run: python examples/orbit_determination_campaign.py   (writes orbit_determination.png)
"""

import matplotlib

matplotlib.use("Agg")
import astropy.units as u
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path
from astropy.time import Time

import visviva as vv
from visviva.od.tle_elements import naive_fields
from visviva.satellites.frames import transform_matrices

epoch = Time("2024-03-01T00:00:00", scale="utc")
truth = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.0, 5.7] * u.km / u.s,
                        vv.EARTH, epoch=epoch)
forces = [vv.J2(vv.EARTH)]
stations = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km, name="Colorado"),
            vv.GroundStation(-30 * u.deg, 20 * u.deg, 0.3 * u.km, name="Karoo")]

# -- the campaign -------------------------------------------------------------------------------
grid = epoch + np.arange(0, 4 * 3600, 30) * u.s
obs = vv.od.simulate_tracking(truth, stations, grid, forces, seed=7)
print(obs)

# -- the fit from a poor guess ------------------------------------------------------------------
guess = vv.StateVectors(truth.r + [10.0, -5.0, 5.0] * u.km,
                        truth.v + [0.01, 0.0, -0.01] * u.km / u.s, vv.EARTH, epoch=epoch)
fit = vv.fit_orbit(obs, guess, forces)
err = np.r_[(fit.state.r - truth.r).to_value(u.km), (fit.state.v - truth.v).to_value(u.km / u.s)]
nees = err @ np.linalg.solve(fit.covariance, err)
print(f"{fit}; RMS by kind: " + ", ".join(f"{k} {v:.2f}" for k, v in fit.rms_by_kind.items()))
print(f"position error {np.linalg.norm(err[:3]) * 1e3:.2f} m, normalised error^2 {nees:.2f} "
      "(chi-square, 6 dof: 99.9 % below 22.5)")
for h in fit.history:
    print(f"  iteration {h['iteration']:2d}: RMS {h['rms']:12.4g}, correction {h['correction']:.3g}")
assert 0.8 < fit.rms < 1.2
assert nees < 22.5

# -- a TLE for the estimate ---------------------------------------------------------------------
day = vv.propagate_cowell(fit.state, np.linspace(0, 1, 97) * u.day, forces)
sat = vv.fit_tle(day, satnum=99001, name="DEMO")
states = day.to_states()
m = transform_matrices(states.epoch[:1], "gcrs", "teme")[0]
y0 = m @ np.r_[states.r[0].to_value(u.km), states.v[0].to_value(u.km / u.s)]
naive = vv.Satellite.from_omm(naive_fields(y0[:3], y0[3:], states.epoch[0].utc.isot))
hours = day.t.to_value(u.h)
d_fit = np.linalg.norm(sat.gcrs(states.epoch).r.to_value(u.km) - states.r.to_value(u.km), axis=1)
d_naive = np.linalg.norm(naive.gcrs(states.epoch).r.to_value(u.km) - states.r.to_value(u.km),
                         axis=1)
print(*sat.to_tle(), sep="\n")
print(f"SGP4 vs ephemeris over a day: fitted TLE max {d_fit.max():.3f} km, "
      f"naive TLE max {d_naive.max():.1f} km")
assert d_fit.max() < 0.05 * d_naive.max()

# -- figure -------------------------------------------------------------------------------------
fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7))
t_min = (obs.times - epoch).to_value(u.min)
for k, marker in (("range", "o"), ("range_rate", "s"), ("azel", "^")):
    sel = obs.kinds == k
    ax1.plot(t_min[sel], fit.normalized_residuals[sel, 0], marker, ms=3, label=k)
ax1.set_xlabel("minutes from epoch")
ax1.set_ylabel("residual / sigma")
ax1.set_title(f"normalised residuals (RMS {fit.rms:.2f})")
ax1.legend()
ax2.semilogy(hours, d_naive, label="naive TLE (osculating elements)")
ax2.semilogy(hours, np.maximum(d_fit, 1e-6), label="fitted TLE (vv.fit_tle)")
ax2.set_xlabel("hours")
ax2.set_ylabel("SGP4 - ephemeris, km")
ax2.legend()
fig.tight_layout()
fig.savefig(figure_path("orbit_determination.png"), dpi=100)
