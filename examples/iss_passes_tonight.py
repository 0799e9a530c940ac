"""When can I see the ISS tonight, and where do I point?

Finds the passes of the ISS over Cambridge (UK) in one day, keeps those that are visible to the
eye (satellite in sunlight, Sun below -6 deg at the site), checks every rise and set against
the look angles (elevation exactly at the threshold, rising then setting), prints the pointing
and the 145.825 MHz Doppler along the best pass, and draws its sky chart.

Run: python examples/iss_passes_tonight.py   (writes iss_passes_tonight.png)
"""

import astropy.units as u
import numpy as np
from _output import figure_path
from astropy.time import Time

import visviva as vv
from visviva.ground import plot_sky_track

line1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009"
line2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"
iss = vv.Satellite.from_tle(line1, line2, name="ISS (ZARYA)")
home = vv.GroundStation(52.2053 * u.deg, 0.1218 * u.deg, 20 * u.m, name="Cambridge")
t0 = Time("2024-01-01T12:00:00", scale="utc")
el_min = 10 * u.deg

passes = vv.find_passes(iss, home, t0, t0 + 1 * u.day, min_elevation=el_min,
                        standard_magnitude=-1.8)
print(f"{len(passes)} passes above {el_min}; visible ones:")
visible = passes[passes["visible"]]
for p in visible:
    print(f"  rise {p['rise_time'].isot[11:19]} az {p['rise_azimuth'].to_value(u.deg):5.1f}  "
          f"max {p['max_elevation'].to_value(u.deg):4.1f} deg at "
          f"{p['culmination_time'].isot[11:19]}  set {p['set_time'].isot[11:19]}  "
          f"mag {p['magnitude'].to_value(u.mag):+.1f}")
assert len(visible) >= 1

# every rise and set sits on the threshold, rising then setting
times, kinds = home.find_events(iss, t0, t0 + 1 * u.day, el_min)
look = home.look(iss, times)
cross = kinds != 1
assert np.allclose(look.elevation[cross].to_value(u.deg), el_min.to_value(u.deg), atol=1e-6)
assert (look.elevation_rate[kinds == 0] > 0).all() and (look.elevation_rate[kinds == 2] < 0).all()

best = visible[np.argmax(visible["max_elevation"])]
t = best["rise_time"] + np.linspace(0, 1, 7) * (best["set_time"] - best["rise_time"])
track = home.look(iss, t, frequency=145.825 * u.MHz)
print("pointing and Doppler along the best visible pass:")
for ti, a, e, d in zip(t, track.azimuth, track.elevation, track.doppler, strict=True):
    print(f"  {ti.isot[11:19]}  az {a.to_value(u.deg):6.1f}  el {e.to_value(u.deg):5.1f}  "
          f"Doppler {d.to_value(u.kHz):+6.2f} kHz")
assert track.doppler[0] > 0 * u.Hz > track.doppler[-1]  # approaching high, receding low

fig = plot_sky_track(home, iss, best["rise_time"], best["set_time"], min_elevation=el_min)
fig.savefig(figure_path("iss_passes_tonight.png"), dpi=100)
