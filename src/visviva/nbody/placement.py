"""Placing a particle from orbital elements about a primary (for :meth:`visviva.Simulation.add`)."""

from __future__ import annotations

import numpy as np

from .. import _units
from ..core import elements as _elements
from ..core import kepler as _kepler
from ..errors import InvalidInputError, fmt_number, raise_for_status
from .settings import length, particle_index, scalar

__all__ = ["particle_state", "elements_to_state"]

_ELEMENT_NAMES = ("e", "inc", "raan", "argp", "nu", "mean_anomaly")


def particle_state(sim, m, r, v, primary, **elements):
    """The particle's position and velocity as given to :meth:`visviva.Simulation.add`: ``r``,
    ``v`` as they are (zero when None), or from the orbital ``elements`` (``a`` or ``p`` with
    ``e, inc, raan, argp, nu, mean_anomaly``, None when not given) about ``primary``."""
    a, p = elements.pop("a"), elements.pop("p")
    given = [k for k in _ELEMENT_NAMES if elements[k] is not None]
    if a is None and p is None:
        if given or primary is not None:
            # they were ignored: the particle went to r (0 when not given) with v, in silence
            what = ", ".join(given + (["primary"] if primary is not None else []))
            raise InvalidInputError(
                f"{what} given without a semi-major axis a (or semi-latus rectum p): give a "
                "(or p) to place the particle by orbital elements about the primary, or r and v "
                "alone for a Cartesian state (r, v are absolute: not relative to a primary).")
        return (np.zeros(3) if r is None else r), (np.zeros(3) if v is None else v)
    if r is not None or v is not None:
        raise InvalidInputError("give either r, v or orbital elements, not both.")
    el = {k: (0.0 if k in ("e", "inc", "raan", "argp") and val is None else val)
          for k, val in elements.items()}
    return elements_to_state(sim, m, primary, a, el["e"], el["inc"], el["raan"], el["argp"],
                             el["nu"], el["mean_anomaly"], p)


def elements_to_state(sim, m, primary, a, e, inc, raan, argp, nu, M, p):
    """Position and velocity (simulation units) of a particle of mass ``m`` on the orbit given
    by the elements about ``primary`` (an index, or None/"com" for the centre of mass of the
    particles added so far); arguments as in :meth:`visviva.Simulation.add`."""
    masses, x, v = sim.masses, sim.positions, sim.velocities
    if sim.N == 0:
        raise InvalidInputError("add a primary (a particle with mass) before adding by elements.")
    if primary is None or (isinstance(primary, str) and primary == "com"):
        mp = masses.sum()
        xp = (masses[:, None] * x).sum(0) / mp if mp > 0 else x.mean(0)
        vp = (masses[:, None] * v).sum(0) / mp if mp > 0 else v.mean(0)
    else:
        i = (particle_index(sim, primary) if isinstance(primary, str)  # a name
             else _primary_index(primary, sim.N))
        mp, xp, vp = masses[i], x[i], v[i]
    gm = sim.G * (mp + m)
    if not gm > 0:
        raise InvalidInputError("the primary and the particle have no mass: GM = 0.")
    e = scalar(_units.to_array(e, "dimensionless", "e"), "e")
    inc, raan, argp = (_angle(val, name) for val, name in ((inc, "inc"), (raan, "raan"), (argp, "argp")))
    if nu is not None and M is not None:
        raise InvalidInputError("give the true anomaly nu or the mean_anomaly, not both.")
    if a is not None and p is not None:  # p used to win silently over a different a
        raise InvalidInputError(
            f"give the semi-major axis a or the semi-latus rectum p, not both (a = "
            f"{fmt_number(a)}, p = {fmt_number(p)}; p = a (1 - e^2)).")
    if e < 0:
        raise InvalidInputError(f"e must be >= 0; got {fmt_number(e)}.")
    if p is None:
        a = float(length(sim, a, "a"))
        if e == 1.0:
            raise InvalidInputError("a parabola has no semi-major axis: give p instead of a.")
        p = a * (1.0 - e * e)
    else:
        p = float(length(sim, p, "p"))
    if not p > 0:
        raise InvalidInputError(f"the semi-latus rectum must be > 0 (a(1-e^2) > 0); got {fmt_number(p)}.")
    if nu is None:
        if M is None:
            nu = 0.0
        else:
            if e == 1:  # the parabola's "mean anomaly" has more than one convention
                raise InvalidInputError("give nu (not mean_anomaly) for a parabolic orbit (e = 1).")
            M = _angle(M, "mean_anomaly")  # hyperbolic: M = e sinh F - F, as in REBOUND
            nu, status = _kepler.mean_to_true_anomaly(M, e)
            raise_for_status(np.array([status]), "mean to true anomaly", M=M, e=e)
    else:
        nu = _angle(nu, "nu")
    *state, status = _elements.coe_to_rv(p, e, inc, raan, argp, float(nu), gm)
    raise_for_status(np.array([status]), "orbital elements to state", p=p, e=e, nu=nu)
    return xp + np.array(state[:3]), vp + np.array(state[3:])



def _angle(value, name) -> float:
    """One angle in radians: a plain number (radians) or an angle Quantity."""
    return scalar(_units.to_array(value, "angle", name), name)


def _primary_index(primary, n) -> int:
    """``primary`` as an index into the ``n`` particles (negative counts from the end)."""
    if isinstance(primary, bool) or not isinstance(primary, int | np.integer) or not -n <= primary < n:
        raise InvalidInputError(
            f"primary must be the index of a particle added before (an integer in [{-n}, {n})), "
            f'or "com"/None for the centre of mass; got {primary!r}.'
        )
    return int(primary) % n
