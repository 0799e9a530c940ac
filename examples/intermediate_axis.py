"""The intermediate-axis (tennis racket, Dzhanibekov) instability.

A box with edges 1 x 2 x 3 has three different principal moments. Spun about the axis of the
smallest or the largest moment, with a tiny wobble, it keeps spinning steadily; spun about the
intermediate axis it flips over and back periodically. Euler's equations are integrated together
with the attitude quaternion; the angular momentum in space and the kinetic energy stay constant
throughout, so the flips are not a numerical artefact.

Run: python examples/intermediate_axis.py   (writes intermediate_axis.png)
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

from visviva import mechanics as mech

I_box = mech.inertia_box(1.0, 1.0, 2.0, 3.0)  # kg, m
moments, axes = mech.principal_axes(I_box)
print("principal moments (kg m^2):", np.array2string(moments, precision=4))

t = np.linspace(0, 40, 801)  # s
wobble = 1e-3
runs = {}
for i, name in enumerate(["smallest", "intermediate", "largest"]):
    w0 = np.full(3, wobble)
    w0[i] = 1.0  # rad/s about principal axis i
    runs[name] = mech.integrate_rigid_body(moments, w0, t)

for name, tr in runs.items():
    dL = np.max(np.linalg.norm(tr.angular_momentum - tr.angular_momentum[0], axis=1))
    dE = np.ptp(tr.rotational_energy)
    print(f"{name:>12}: spin component min {tr.omega[:, list(runs).index(name)].min():+.3f} rad/s,"
          f" |L - L0| <= {dL:.1e}, energy spread {dE:.1e}")
    assert dL < 1e-8 and dE < 1e-8
assert runs["intermediate"].omega[:, 1].min() < -0.9  # it flips
assert runs["smallest"].omega[:, 0].min() > 0.99 and runs["largest"].omega[:, 2].min() > 0.99

fig, axs = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
for ax, (name, tr) in zip(axs, runs.items(), strict=True):
    for c in range(3):
        ax.plot(t, tr.omega[:, c], label=f"omega_{c + 1}")
    ax.set(ylabel="rad/s", title=f"spin about the {name}-moment axis")
axs[0].legend(loc="right", fontsize=8)
axs[-1].set_xlabel("t (s)")
fig.suptitle("Intermediate-axis theorem: only the middle axis is unstable")
fig.tight_layout()
fig.savefig(figure_path("intermediate_axis.png"), dpi=110)
print("wrote", figure_path("intermediate_axis.png"))
