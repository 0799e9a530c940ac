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
    m, x, v, radius = sim.masses, sim.positions, sim.velocities, sim.radii
    mi, mj = m[i], m[j]
    M = mi + mj
    if M > 0:
        xm = (mi * x[i] + mj * x[j]) / M
        vm = (mi * v[i] + mj * v[j]) / M
    else:
        xm = 0.5 * (x[i] + x[j])
        vm = 0.5 * (v[i] + v[j])
    sim.set_particle(i, m=M, r=xm, v=vm, radius=np.cbrt(radius[i] ** 3 + radius[j] ** 3))
    sim.remove(j, merged_into=i)  # a force of j's (J2, GR) now belongs to the merged body
    sim.energy_offset += E0 - sim.energy(include_offset=False)
    return j


def bounce(sim, i: int, j: int) -> None:
    """Hard-sphere bounce of ``i`` and ``j`` with the simulation's restitution."""
    e = sim.restitution
    m, x, v = sim.masses, sim.positions, sim.velocities
    d = x[j] - x[i]
    n = d / np.linalg.norm(d)
    mi, mj = m[i], m[j]
    vn = float(np.dot(v[j] - v[i], n))  # < 0: approaching
    E0 = sim.energy(include_offset=False)
    vi, vj = v[i].copy(), v[j].copy()
    if mi > 0 and mj > 0:
        mu = mi * mj / (mi + mj)
        J = -(1.0 + e) * mu * vn
        vi -= (J / mi) * n
        vj += (J / mj) * n
    elif mi > 0:  # j is a test particle: reflects off i
        vj -= (1.0 + e) * vn * n
    elif mj > 0:
        vi += (1.0 + e) * vn * n
    else:  # two test particles: equal masses
        vi += 0.5 * (1.0 + e) * vn * n
        vj -= 0.5 * (1.0 + e) * vn * n
    sim.set_particle(i, v=vi)
    sim.set_particle(j, v=vj)
    sim.energy_offset += E0 - sim.energy(include_offset=False)


def resolve(sim, i: int, j: int):
    """Apply the simulation's collision mode to the pair; returns the removed index or None."""
    if sim.collision == "merge":
        return merge(sim, i, j)
    bounce(sim, i, j)
    return None
