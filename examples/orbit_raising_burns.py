"""Orbit raising with finite burns: a 400 km -> 800 km Hohmann transfer flown with a 400 N engine.

A 1000 kg spacecraft (Isp 300 s) on a 400 km circular orbit (51.6 deg, J2) raises its orbit to
800 km with two along-track burns (TNW frame) centred on the Hohmann impulse points. Each burn
lasts as long as the rocket equation needs for the Hohmann Δv; the same manoeuvre flown as two
impulses is propagated beside it. The finite burns spend their propellant over minutes, so the
orbit they reach differs slightly from the impulsive one (the "finite-burn loss").

Run: python examples/orbit_raising_burns.py   (writes orbit_raising_burns.png)
"""

import matplotlib

matplotlib.use("Agg")
import astropy.units as u
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

import visviva as vv
from visviva.satellites import hohmann_delta_v
from visviva.satellites.burns import STANDARD_GRAVITY_M_S2

R_E = vv.EARTH.radius_km
r1, r2 = R_E + 400.0, R_E + 800.0
state = vv.KeplerianElements.from_semi_major_axis(r1 * u.km, 0.0, 51.6 * u.deg, 0.0, 0.0, 0.0,
                                                  vv.EARTH).to_state()
dv1, dv2, tof = hohmann_delta_v(r1 * u.km, r2 * u.km, vv.EARTH)
thrust, isp, m0 = 400.0, 300.0, 1000.0  # N, s, kg
ve = isp * STANDARD_GRAVITY_M_S2 / 1e3  # km/s
mdot = thrust / (isp * STANDARD_GRAVITY_M_S2)  # kg/s

t1 = 1800.0  # s, middle of the first burn
t2 = t1 + tof.to_value(u.s)
m_mid = m0 * np.exp(-dv1.value / ve)
d1 = (m0 - m_mid) / mdot  # burn durations from the rocket equation
d2 = (m_mid - m_mid * np.exp(-dv2.value / ve)) / mdot
finite = [vv.FiniteBurn((t1 - d1 / 2) * u.s, d1 * u.s, [1, 0, 0], "TNW", thrust=thrust * u.N,
                        mass=m0 * u.kg, isp=isp * u.s),
          vv.FiniteBurn((t2 - d2 / 2) * u.s, d2 * u.s, [1, 0, 0], "TNW", thrust=thrust * u.N,
                        mass=m_mid * u.kg, isp=isp * u.s)]
impulses = [vv.ImpulsiveBurn(t1 * u.s, [dv1.value, 0, 0] * u.km / u.s, "TNW"),
            vv.ImpulsiveBurn(t2 * u.s, [dv2.value, 0, 0] * u.km / u.s, "TNW")]

t = np.linspace(0.0, t2 + 2 * 6000.0, 600) * u.s
forces = [vv.J2(vv.EARTH)]
out_f = vv.propagate_cowell(state, t, forces, maneuvers=finite)
out_i = vv.propagate_cowell(state, t, forces, maneuvers=impulses)

total = sum(rec.delta_v.to_value(u.m / u.s) for rec in out_f.burns)
print(f"Hohmann Δv {1e3 * (dv1 + dv2).value:.2f} m/s; the finite burns gave {total:.2f} m/s "
      f"in {d1:.0f} s + {d2:.0f} s")
print(f"mass {m0:.0f} kg -> {out_f.final_mass.to_value(u.kg):.2f} kg")
alt_f = np.linalg.norm(out_f.r.to_value(u.km), axis=1) - R_E
alt_i = np.linalg.norm(out_i.r.to_value(u.km), axis=1) - R_E
after = t.to_value(u.s) > t2 + d2
print(f"largest altitude difference finite - impulsive after the transfer: "
      f"{np.abs(alt_f[after] - alt_i[after]).max() * 1e3:.0f} m")
print(f"altitude after the transfer: finite {alt_f[after].min():.1f}-{alt_f[after].max():.1f} km, "
      f"impulsive {alt_i[after].min():.1f}-{alt_i[after].max():.1f} km")
assert abs(total - 1e3 * (dv1 + dv2).value) < 1e-6
assert abs(out_f.final_mass.to_value(u.kg) - m0 * np.exp(-(dv1 + dv2).value / ve)) < 1e-9
assert np.all(np.abs(alt_i[after] - 800.0) < 15.0)  # J2 makes the circle ripple
assert np.all(np.abs(alt_f[after] - alt_i[after]) < 1.0)  # km: the finite-burn loss is small

fig, ax = plt.subplots(figsize=(7, 4))
hours = t.to_value(u.h)
ax.plot(hours, alt_i, label="two impulses")
ax.plot(hours, alt_f, "--", label=f"two finite burns ({thrust:.0f} N, Isp {isp:.0f} s)")
for start, end in ((t1 - d1 / 2, t1 + d1 / 2), (t2 - d2 / 2, t2 + d2 / 2)):
    ax.axvspan(start / 3600, end / 3600, color="0.85")
ax.set(xlabel="time (h)", ylabel="altitude (km)", title="Hohmann transfer 400 -> 800 km, with J2")
ax.legend()
fig.tight_layout()
fig.savefig(figure_path("orbit_raising_burns.png"), dpi=120)
