"""The figure-eight choreography of three equal masses (Chenciner & Montgomery 2000).

Integrates one period with IAS15 and prints how closely the bodies return (about 3e-8, set by the
8-digit initial data) and the energy error, and draws the orbit (nbody_figure_eight.png, or the
file given with ``--plot``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from _output import figure_path

import visviva as vv

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "figure_eight.json"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--plot", default=str(figure_path("nbody_figure_eight.png")))
    args = parser.parse_args(argv)
    d = json.loads(DATA.read_text())
    sim = vv.Simulation("ias15", G=d["G"])
    for m, r, v in zip(d["masses"], d["positions"], d["velocities"], strict=True):
        sim.add(m, r, v)
    x0, E0 = sim.positions, sim.energy()
    traj = sim.integrate(np.linspace(0.0, d["period"], 400)[1:])
    returned = np.abs(sim.positions - x0).max()
    energy_error = abs(sim.energy() / E0 - 1)
    print(f"return after one period: {returned:.1e}")
    print(f"relative energy error:   {energy_error:.1e}")
    assert returned < 1e-7 and energy_error < 1e-13
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 3.8))
        for k in range(3):
            # a choreography: the three bodies share one curve (drawn thick to thin to show it)
            ax.plot(traj.positions[:, k, 0], traj.positions[:, k, 1], lw=4.5 - 1.5 * k,
                    ls=("-", "--", ":")[k], label=f"body {k + 1} (m = {d['masses'][k]:g})")
            ax.plot(*x0[k, :2], "o", color=f"C{k}", ms=6)
        ax.set_aspect("equal")
        ax.set(xlabel="x (G = 1 units)", ylabel="y (G = 1 units)",
               title=f"Figure-eight choreography, one period T = {d['period']:.4f} (IAS15); "
               f"|dE/E| = {energy_error:.0e}")
        ax.title.set_fontsize(9)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.28), ncol=3, fontsize="small",
                  title="three bodies on one curve; dots: positions at t = 0",
                  title_fontsize="small")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)


if __name__ == "__main__":
    main()
