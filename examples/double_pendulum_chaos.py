"""Chaos in the double pendulum: sensitive dependence on initial conditions.

The equations of motion come from the Lagrangian with sympy's LagrangesMethod and are compiled to
a fast numeric right-hand side. Two pendulums start 1e-9 rad apart; energy stays conserved to
~1e-10 in each, yet their separation grows exponentially (a straight line on the log plot) until
the two motions are unrelated.

Run: python examples/double_pendulum_chaos.py   (writes double_pendulum_chaos.png)
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

from visviva import mechanics as mech

system = mech.double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81)  # kg, m, m/s^2
print("Euler-Lagrange equation for theta1 (= 0):", system.equations[0])

t = np.linspace(0, 20, 2001)  # s
a = system.simulate([2.0, 2.0], [0.0, 0.0], t, rtol=1e-12, atol=1e-12)
b = system.simulate([2.0 + 1e-9, 2.0], [0.0, 0.0], t, rtol=1e-12, atol=1e-12)

drift = np.max(np.abs(a.energy - a.energy[0])) / abs(a.energy[0])
separation = np.hypot(a.q[:, 0] - b.q[:, 0], a.q[:, 1] - b.q[:, 1])
grow = separation[(t > 0.5) & (t < 6)]
rate = np.polyfit(t[(t > 0.5) & (t < 6)], np.log(grow), 1)[0]
print(f"relative energy drift over 20 s: {drift:.1e}")
print(f"separation grew from 1e-9 to {separation.max():.2f} rad; "
      f"rough Lyapunov exponent {rate:.2f} 1/s")
assert drift < 1e-9
assert separation.max() > 1e5 * 1e-9

fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
ax1.plot(t, a.q[:, 1], label="theta2, pendulum A")
ax1.plot(t, b.q[:, 1], "--", label="theta2, pendulum B (theta1 + 1e-9 rad)")
ax1.set(ylabel="theta2 (rad)", title="Two double pendulums that start 1e-9 rad apart")
ax1.legend(loc="upper left", fontsize=8)
ax2.semilogy(t, separation)
ax2.set(xlabel="t (s)", ylabel="separation in (theta1, theta2) (rad)")
fig.tight_layout()
fig.savefig(figure_path("double_pendulum_chaos.png"), dpi=110)
print("wrote", figure_path("double_pendulum_chaos.png"))
