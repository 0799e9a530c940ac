"""A warning when WHFast's fixed step is too long for the orbits it integrates.

WHFast solves each Kepler drift exactly, so the step only has to resolve the interaction between
the bodies; but with a step beyond a fraction of the shortest orbital period the map stops
following the interaction. Measured (a star with planets of 1e-3 at a = 1 and 1.6, e = 0.1 and
0.05, 100 time units, against IAS15): largest position error 8e-4, 3e-3, 1.5e-2 at
``dt = P/40, P/20, P/10`` of the inner period ``P``, then 0.26 at ``P/5``, 0.5 at ``P/3`` and
``P/2`` and 2.3 at ``0.9 P`` (the orbits' size: the planets are elsewhere), while the relative
energy error stays at 1e-3 .. 1.5e-2 and looks acceptable. The integrator goes on (a user may
want it), with a :class:`UserWarning` once the step exceeds :data:`MAX_STEP_FRACTION` of the
shortest period.

The periods are those of the osculating two-body orbits of the splitting: in Jacobi coordinates
each body about the centre of mass of the bodies before it (the mass inside it plus its own); in
democratic heliocentric coordinates each body about particle 0. Unbound orbits have no period
and are skipped. Jacobi WHFast integrates two bodies exactly at any step, so it is checked from
three particles on. Reference: Wisdom & Holman (1991), Rein & Tamayo (2015), sec. 2; Wisdom
(2015), AJ 150, 127 (step-size resonances).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..core import nbody_common as _nc
from ..errors import fmt_number

__all__ = ["MAX_STEP_FRACTION", "shortest_period", "check_step"]

#: A WHFast step longer than this fraction of the shortest orbital period is warned about.
MAX_STEP_FRACTION = 0.2


def shortest_period(x, v, m, G: float, jacobi: bool = True) -> float:
    """The shortest osculating orbital period of the splitting (``inf`` when none is bound).

    Parameters
    ----------
    x, v : ndarray, shape (N, 3)
        Positions and velocities (simulation units).
    m : ndarray, shape (N,)
        Masses; particle 0 is the central body.
    G : float
        Gravitational constant.
    jacobi : bool
        Jacobi (each body about the bodies before it) or heliocentric (each about particle 0).
    """
    if jacobi:
        mass = np.cumsum(m)  # mass[i - 1]: inside body i
        mx, mv = np.cumsum(m[:, None] * x, axis=0), np.cumsum(m[:, None] * v, axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            inner_x, inner_v = mx[:-1] / mass[:-1, None], mv[:-1] / mass[:-1, None]
        r, w, gm = x[1:] - inner_x, v[1:] - inner_v, G * mass[1:]
    else:
        r, w, gm = x[1:] - x[0], v[1:] - v[0], G * (m[0] + m[1:])
    d = np.linalg.norm(r, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        energy = 0.5 * np.einsum("ij,ij->i", w, w) - gm / d  # per unit mass
        period = 2.0 * math.pi * gm / (-2.0 * energy) ** 1.5
    bound = np.isfinite(period) & (energy < 0) & (gm > 0)
    return float(period[bound].min()) if bound.any() else math.inf


def check_step(sim) -> None:
    """Warn when ``sim`` (a WHFast :class:`~visviva.Simulation`) steps longer than
    :data:`MAX_STEP_FRACTION` of its shortest orbital period."""
    jacobi = sim.coordinates == "jacobi"
    key = (sim.dt, sim.N, jacobi)  # checked again when these or the particles change
    if sim.state_arrays()["istate"][_nc.I_FRESH] == 0 and getattr(sim, "_step_checked",
                                                                    None) == key:
        return
    sim._step_checked = key
    if sim.N < (3 if jacobi else 2):
        return
    period = shortest_period(sim.positions, sim.velocities, sim.masses, sim.G, jacobi)
    if abs(sim.dt) > MAX_STEP_FRACTION * period:
        warnings.warn(
            f"WHFast's step dt = {fmt_number(sim.dt)} is {abs(sim.dt) / period:.2g} of the "
            f"shortest orbital period ({fmt_number(period)}, {sim.coordinates} coordinates): "
            f"beyond {MAX_STEP_FRACTION:g} of it the positions are wrong by up to the orbits' "
            "size while the energy error can stay small. Use dt of about 1/20 of the shortest "
            "period (or IAS15).", UserWarning, stacklevel=4)
