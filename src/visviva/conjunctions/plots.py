"""Pictures of a conjunction: the encounter plane, and Pc against the hard-body radius."""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["plot_encounter_plane", "plot_pc_vs_hbr"]


def plot_encounter_plane(r1, v1, cov1, r2, v2, cov2, hard_body_radius, ax=None, sigmas=(1, 3)):
    """Draw the encounter plane: combined covariance ellipses, hard-body circle, miss vector.

    Parameters
    ----------
    r1, v1, r2, v2 : array_like, shape (3,)
        States at TCA (m, m/s; Quantities accepted).
    cov1, cov2 : array_like, shape (6, 6) or (3, 3)
        Covariances (m^2 ...).
    hard_body_radius : Quantity or float
        Combined radius (plain: m).
    ax : matplotlib Axes, optional
        Where to draw (a new figure otherwise).
    sigmas : sequence of float
        The ellipses to draw, in standard deviations.

    Returns
    -------
    matplotlib.axes.Axes
        Axes in metres; the primary at the origin of the plane, the secondary's mean offset is
        the miss vector.
    """
    import matplotlib.pyplot as plt

    from .covariance import encounter_plane
    from .probability import collision_probability, encounter_inputs

    a = encounter_inputs(r1, v1, cov1, r2, v2, cov2, hard_body_radius)
    plane = encounter_plane(*a[:6], a[6])
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 5))
    w, vecs = np.linalg.eigh(plane.covariance)
    t = np.linspace(0, 2 * np.pi, 361)
    unit = np.stack([np.cos(t), np.sin(t)])
    mx, mz = plane.miss
    for k in sigmas:
        pts = vecs @ (np.sqrt(np.maximum(w, 0))[:, None] * unit) * k
        ax.plot(mx + pts[0], mz + pts[1], lw=1, label=f"{k} sigma combined covariance")
    hbr = a[6]
    ax.plot(hbr * np.cos(t), hbr * np.sin(t), color="k", lw=1.5, label="hard-body circle")
    ax.annotate("", xy=(mx, mz), xytext=(0, 0), arrowprops={"arrowstyle": "->", "color": "C3"})
    ax.plot([mx], [mz], "o", color="C3", label=f"miss {np.hypot(mx, mz):.1f} m")
    pc = collision_probability(*a[:6], hbr)
    ax.set_title(f"encounter plane, Pc = {pc:.3e}")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_pc_vs_hbr(r1, v1, cov1, r2, v2, cov2, radii, ax=None, methods=("foster", "chan")):
    """Plot Pc against the hard-body radius for one conjunction.

    Parameters
    ----------
    r1, v1, r2, v2 : array_like, shape (3,)
        States at TCA (m, m/s; Quantities accepted).
    cov1, cov2 : array_like
        Covariances (m^2 ...).
    radii : array_like or Quantity
        Hard-body radii (plain: m).
    ax : matplotlib Axes, optional
        Where to draw.
    methods : sequence of str
        Methods of :func:`~visviva.collision_probability` to draw.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    from ..errors import ChanAccuracyWarning, Pc2dAccuracyWarning, Pc3dAccuracyWarning
    from .probability import collision_probability, si_value

    radii = np.atleast_1d(si_value(radii, "m", "radii"))
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    for m in methods:
        with warnings.catch_warnings():  # the plot itself shows how far the methods differ
            warnings.simplefilter("ignore", ChanAccuracyWarning)
            warnings.simplefilter("ignore", Pc3dAccuracyWarning)
            warnings.simplefilter("ignore", Pc2dAccuracyWarning)
            pc = [collision_probability(r1, v1, cov1, r2, v2, cov2, float(h), method=m)
                  for h in radii]
        ax.loglog(radii, pc, label=m)
    ax.set_xlabel("hard-body radius (m)")
    ax.set_ylabel("Pc")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return ax
