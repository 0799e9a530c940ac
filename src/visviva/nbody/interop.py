"""Conversion to and from REBOUND (``pip install rebound``; tested with REBOUND 5.2).

Particles (mass, position, velocity, radius), ``G``, ``t`` and ``dt`` are copied exactly (the
same float64 values). The integrator is mapped by name (``leapfrog``, ``whfast``, ``ias15``), and
WHFast's coordinates with it (visviva's ``"jacobi"`` / ``"democratic_heliocentric"`` <-> REBOUND's
``"jacobi"`` / ``"democraticheliocentric"``; REBOUND's WHDS and barycentric WHFast have no visviva
counterpart and are refused); integrator internals (IAS15's b arrays, ...) are not transferred:
the first step in the other code starts fresh.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["to_rebound", "from_rebound"]

#: visviva's WHFast coordinates -> REBOUND's ``integrator.coordinates``.
_REBOUND_COORDINATES = {"jacobi": "jacobi", "democratic_heliocentric": "democraticheliocentric"}


def _rebound():
    try:
        import rebound
    except ImportError as exc:  # pragma: no cover - rebound is a test dependency
        raise ImportError(
            "REBOUND is not installed: pip install rebound (or the 'reference' extra)."
        ) from exc
    return rebound


def to_rebound(sim):
    """A ``rebound.Simulation`` with the particles, G, t, dt and integrator of ``sim``."""
    rebound = _rebound()
    r = rebound.Simulation()
    r.G = sim.G
    m, xs, vs, radii = sim.masses, sim.positions, sim.velocities, sim.radii
    for k in range(sim.N):
        x, v = xs[k], vs[k]
        r.add(m=float(m[k]), x=float(x[0]), y=float(x[1]), z=float(x[2]),
              vx=float(v[0]), vy=float(v[1]), vz=float(v[2]), r=float(radii[k]))
    r.t = sim.t
    r.integrator = sim.integrator
    if sim.integrator == "whfast":
        r.integrator.coordinates = _REBOUND_COORDINATES[sim.coordinates]
    if sim.dt != 0.0:
        r.dt = sim.dt
    if sim.softening > 0:
        r.softening = sim.softening
    if sim.N_active < sim.N and np.all(m[: sim.N_active] != 0):
        r.N_active = sim.N_active
    return r


def from_rebound(cls, rsim, integrator=None):
    """A visviva :class:`Simulation` from a ``rebound.Simulation``."""
    if not all(hasattr(rsim, a) for a in ("particles", "G", "integrator", "t", "dt")):
        raise InvalidInputError(
            f"from_rebound expects a rebound.Simulation; got {type(rsim).__name__} {rsim!r:.80}."
        )
    name = integrator or str(rsim.integrator)
    if name not in ("leapfrog", "whfast", "ias15"):
        raise InvalidInputError(
            f"REBOUND integrator {name!r} has no visviva counterpart; pass integrator='ias15', "
            "'whfast' or 'leapfrog'."
        )
    coordinates = "jacobi"
    if name == "whfast" and str(rsim.integrator) == "whfast":
        rebound_coordinates = str(rsim.integrator.coordinates).lower()
        back = {v: k for k, v in _REBOUND_COORDINATES.items()}
        if rebound_coordinates not in back:
            raise InvalidInputError(
                f"REBOUND's WHFast coordinates {rebound_coordinates!r} have no visviva "
                f"counterpart; set rsim.integrator.coordinates to one of {sorted(back)} first."
            )
        coordinates = back[rebound_coordinates]
    sim = cls(name, G=float(rsim.G), coordinates=coordinates)
    sim.softening = float(rsim.softening)
    n_active = rsim.N_active if rsim.N_active >= 0 else rsim.N
    for k, p in enumerate(rsim.particles):
        m = float(p.m) if k < n_active else 0.0
        sim.add(m, [p.x, p.y, p.z], [p.vx, p.vy, p.vz], radius=float(p.r))
    sim.t = float(rsim.t)
    sim.dt = float(rsim.dt)
    return sim
