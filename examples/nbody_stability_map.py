"""A stability map of a two-planet system, run as one ensemble (``vv.Ensemble``).

A Jupiter-mass planet on a circular orbit at a = 1 and a second planet of mass m2 at a2, for a
grid of (a2, m2): 15 x 8 = 120 systems, each integrated with WHFast for 300 inner orbits in one
ensemble call per output time. The indicator is the largest relative energy error seen (WHFast's
energy error stays at ~1e-7 for regular orbits and jumps by orders of magnitude at close
encounters), and systems whose outer planet leaves r = 10 are marked unstable. Gladman (1993)'s
Hill criterion, a2 - a1 > 2 sqrt(3) R_H with the mutual Hill radius
R_H = ((m1 + m2) / 3)**(1/3) (a1 + a2) / 2, separates the two regions: the script checks that the
map agrees with it away from the boundary and draws it (nbody_stability_map.png, or ``--plot``).

Beside it, the chaos indicator MEGNO (``init_megno``; Cincotta & Simo 2000) of the same grid, with
the leapfrog integrator (MEGNO needs IAS15 or leapfrog): about 2 for quasi-periodic systems,
growing with time for chaotic ones (a second ensemble: each member carries its tangent vector).
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from _output import figure_path

import visviva as vv

M1 = 1e-3


def system(a2, m2, integrator="whfast"):
    sim = vv.Simulation(integrator, dt=2 * np.pi / 40, exit_max_distance=10.0)
    sim.add(1.0)
    sim.add(M1, a=1.0, primary=0)
    sim.add(m2, a=a2, mean_anomaly=np.pi, inc=0.01, primary=None)
    sim.move_to_com()
    if integrator == "leapfrog":
        sim.dt = 2 * np.pi / 100
        sim.init_megno(seed=1)
    return sim


def megno_map(A, Mm, t_end):
    """MEGNO of every system at ``t_end`` (an escaped system: its value when it left)."""
    ens = vv.Ensemble.from_simulations([system(a, m, "leapfrog")
                                        for a, m in zip(A.ravel(), Mm.ravel(), strict=True)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", vv.errors.StepSizeWarning)
        try:
            ens.integrate(t_end)
        except vv.Escape:  # the others reached t_end; the escaped ones keep their MEGNO
            pass
    report_step_warnings(caught, "leapfrog")
    return ens.megno().reshape(A.shape)


def report_step_warnings(caught, integrator):
    """A map expects close encounters in its unstable members: the fixed step's warnings about
    them (vv.errors.StepSizeWarning, naming the members) are recorded and counted here rather
    than printed one by one; any other warning is shown as usual."""
    steps = [w for w in caught if issubclass(w.category, vv.errors.StepSizeWarning)]
    for w in caught:
        if w not in steps:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if steps:
        print(f"{integrator}: {len(steps)} step warning(s): members in a close encounter or "
              "plunge the fixed step cannot follow (near Gladman's limit; IAS15 resolves them)")


def gladman_separation(a2, m2):
    """(a2 - a1) in units of 2 sqrt(3) mutual Hill radii: > 1 is Hill stable."""
    hill = ((M1 + m2) / 3) ** (1 / 3) * (1.0 + a2) / 2
    return (a2 - 1.0) / (2 * np.sqrt(3) * hill)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--plot", default=str(figure_path("nbody_stability_map.png")))
    args = parser.parse_args(argv)
    a2 = np.linspace(1.15, 1.85, 15)
    m2 = np.geomspace(1e-4, 3e-3, 8)
    A, Mm = np.meshgrid(a2, m2, indexing="ij")
    ens = vv.Ensemble.from_simulations([system(a, m) for a, m in zip(A.ravel(), Mm.ravel(),
                                                                      strict=True)])
    E0 = ens.energy()
    worst = np.zeros(len(ens))
    escaped = np.zeros(len(ens), bool)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", vv.errors.StepSizeWarning)
        for t in np.linspace(0, 300 * 2 * np.pi, 31)[1:]:
            try:
                ens.integrate(t)
            except vv.Escape as exc:  # the others reached t; remember who left
                escaped[exc.members] = True
            worst = np.maximum(worst, np.abs(ens.energy() / E0 - 1))
    report_step_warnings(caught, "WHFast")
    indicator = np.where(escaped, 1.0, worst).reshape(A.shape)
    unstable = indicator > 1e-4
    separation = gladman_separation(A, Mm)
    print(f"{len(ens)} systems; unstable: {unstable.sum()}")
    print(f"Hill stable by > 30 %, regular here:   {(~unstable[separation > 1.3]).mean():.0%}")
    print(f"Hill unstable by > 30 %, chaotic here: {unstable[separation < 0.7].mean():.0%}")
    assert (~unstable[separation > 1.3]).mean() > 0.9
    assert unstable[separation < 0.7].mean() > 0.9
    megno = megno_map(A, Mm, 300 * 2 * np.pi)
    chaotic = megno > 3.0
    print(f"MEGNO: Hill stable by > 30 %, <Y> < 3: {(~chaotic[separation > 1.3]).mean():.0%}; "
          f"Hill unstable by > 30 %, <Y> > 3: {chaotic[separation < 0.7].mean():.0%}")
    assert (~chaotic[separation > 1.3]).mean() > 0.9
    assert chaotic[separation < 0.7].mean() > 0.9
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
        panels = ((np.log10(np.maximum(indicator, 1e-16)), "magma", None,
                   "log10 max |dE/E| (WHFast, 300 orbits)"),
                  (np.clip(megno, 0.0, 10.0), "viridis", (0.0, 10.0),
                   "MEGNO <Y> (leapfrog, 300 orbits; 2: regular)"))
        for ax, (values, cmap, limits, title) in zip(axes, panels, strict=True):
            mesh = ax.pcolormesh(a2, m2, values.T, shading="nearest", cmap=cmap,
                                 vmin=None if limits is None else limits[0],
                                 vmax=None if limits is None else limits[1])
            ax.contour(a2, m2, separation.T, levels=[1.0], colors="cyan")
            ax.set_yscale("log")
            ax.set_xlabel("a2 (a1 = 1)")
            ax.set_ylabel("m2 (M_star)")
            ax.set_title(title + "; cyan: Gladman's Hill limit", fontsize=9)
            fig.colorbar(mesh, ax=ax)
        fig.savefig(args.plot, dpi=110, bbox_inches="tight")
        print(f"figure: {args.plot}")


if __name__ == "__main__":
    main()
