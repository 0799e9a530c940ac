"""Resolving collisions between two particles (called when the kernel reports one).

Detection happens in the compiled loop (:func:`visviva.core.nbody_common.check_events`): after a
step, two particles collide when their distance is below the sum of their radii while they
approach each other. The integration stops there, and the simulation's ``collision`` mode decides:

``"halt"``
    raise :class:`visviva.Collision` (the simulation stays at the time of the collision).
``"merge"``
    replace the pair by one particle at their centre of mass with their total mass, momentum and
    volume (``R = (R_i**3 + R_j**3)**(1/3)``); the energy lost is added to ``energy_offset`` so
    that ``energy()`` stays constant.
``"bounce"``
    hard spheres: the impulse ``J = -(1 + e) mu (v_rel . n) n`` along the line of centres
    ``n`` (``mu`` the reduced mass, ``e`` the restitution) changes the velocities; the kinetic
    energy lost, ``(1 - e**2) mu (v_rel . n)**2 / 2``, goes to ``energy_offset``.

Reference: Goldstein, Poole & Safko, *Classical Mechanics*, 3rd ed., sec. 3.10; Rein & Liu (2012)
A&A 537, A128 (collision handling in N-body codes).
"""

from __future__ import annotations

import numpy as np

__all__ = ["resolve", "merge", "bounce"]


def merge(sim, i: int, j: int) -> int:
    """Merge particles ``i`` and ``j`` into ``min(i, j)``; returns the removed index."""
    i, j = min(i, j), max(i, j)
    E0 = sim.energy(include_offset=False)
    mi, mj = sim._m[i], sim._m[j]
    M = mi + mj
    if M > 0:
        x = (mi * sim._x[i] + mj * sim._x[j]) / M
        v = (mi * sim._v[i] + mj * sim._v[j]) / M
    else:
        x = 0.5 * (sim._x[i] + sim._x[j])
        v = 0.5 * (sim._v[i] + sim._v[j])
    sim._x[i] = x
    sim._v[i] = v
    sim._m[i] = M
    sim._radius[i] = np.cbrt(sim._radius[i] ** 3 + sim._radius[j] ** 3)
    sim.remove(j)
    sim.energy_offset += E0 - sim.energy(include_offset=False)
    return j


def bounce(sim, i: int, j: int) -> None:
    """Hard-sphere bounce of ``i`` and ``j`` with the simulation's restitution."""
    e = sim.restitution
    d = sim._x[j] - sim._x[i]
    n = d / np.linalg.norm(d)
    mi, mj = sim._m[i], sim._m[j]
    vn = float(np.dot(sim._v[j] - sim._v[i], n))  # < 0: approaching
    E0 = sim.energy(include_offset=False)
    if mi > 0 and mj > 0:
        mu = mi * mj / (mi + mj)
        J = -(1.0 + e) * mu * vn
        sim._v[i] -= (J / mi) * n
        sim._v[j] += (J / mj) * n
    elif mi > 0:  # j is a test particle: reflects off i
        sim._v[j] -= (1.0 + e) * vn * n
    elif mj > 0:
        sim._v[i] += (1.0 + e) * vn * n
    else:  # two test particles: equal masses
        sim._v[i] += 0.5 * (1.0 + e) * vn * n
        sim._v[j] -= 0.5 * (1.0 + e) * vn * n
    sim.energy_offset += E0 - sim.energy(include_offset=False)


def resolve(sim, i: int, j: int):
    """Apply the simulation's collision mode to the pair; returns the removed index or None."""
    if sim.collision == "merge":
        return merge(sim, i, j)
    bounce(sim, i, j)
    return None
