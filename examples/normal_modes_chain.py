"""Normal modes of a chain of masses and springs between two walls.

Eight equal masses m joined by nine equal springs k have the frequencies
omega_j = 2 sqrt(k/m) sin(j pi / 18): we check `normal_modes` against that formula, then make
one mass heavier: it barely moves in the high modes, which live on the light segments. A motion started in a
single mode stays in it (we integrate Newton's equations to check), because the modes are
independent oscillators: q(t) = a_j cos(omega_j t).

Run: python examples/normal_modes_chain.py   (writes normal_modes_chain.png)
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _output import figure_path

from visviva import mechanics as mech

n, m, k = 8, 0.5, 20.0  # kg, N/m
M, K = mech.chain_matrices(np.full(n, m), np.full(n + 1, k))
omega, modes = mech.normal_modes(M, K)
j = np.arange(1, n + 1)
exact = 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1)))
print("omega (rad/s):", np.array2string(omega, precision=4))
print(f"largest difference from 2 sqrt(k/m) sin(j pi / 2(n+1)): {np.max(np.abs(omega - exact)):.1e}")
assert np.allclose(omega, exact, rtol=1e-12)
assert np.allclose(modes.T @ M @ modes, np.eye(n), atol=1e-12)  # M-orthonormal

# start in mode 3 and integrate: the shape is kept, only the amplitude oscillates
mode = modes[:, 2]
t = np.linspace(0, 4 * 2 * np.pi / omega[2], 200)
tr = mech.solve_particles(lambda t, x, v: -(K @ x[:, 0])[:, None], np.full(n, m),
                          0.01 * mode[:, None], np.zeros((n, 1)), t)
expected = 0.01 * np.outer(np.cos(omega[2] * t), mode)
print(f"mode 3 stays a mode: max deviation {np.max(np.abs(tr.r[:, :, 0] - expected)):.1e} m")
assert np.allclose(tr.r[:, :, 0], expected, atol=1e-9)

# a heavy mass in the middle of the chain
masses = np.full(n, m)
masses[3] = 10 * m
omega_h, modes_h = mech.normal_modes(*mech.chain_matrices(masses, np.full(n + 1, k)))

fig, axes = plt.subplots(1, 2, figsize=(10, 5), sharey=True)
x = np.arange(n + 2)
for ax, w, shapes, title in ((axes[0], omega, modes, "uniform chain"),
                             (axes[1], omega_h, modes_h, "mass 4 is 10x heavier")):
    for i in range(n):
        shape = np.concatenate([[0], shapes[:, i], [0]])  # the walls do not move
        shape = shape / np.max(np.abs(shape))
        ax.plot(x, i + 0.4 * shape, "o-", ms=4)
        ax.text(n + 1.3, i, f"{w[i]:.2f} rad/s", va="center", fontsize=8)
    ax.set(title=title, xlabel="position in the chain (walls at 0 and 9)", xlim=(-0.5, n + 3.5))
axes[0].set_ylabel("mode number - 1 (offset), shape scaled to 0.4")
fig.suptitle("Normal modes: columns of modes with modes.T @ M @ modes = I")
fig.tight_layout()
fig.savefig(figure_path("normal_modes_chain.png"), dpi=110)
print("wrote", figure_path("normal_modes_chain.png"))
