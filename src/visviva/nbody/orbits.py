"""Osculating orbital elements of a simulation's particles: REBOUND's ``sim.orbits()``.

:meth:`OrbitReadback.orbits` (a base class of :class:`~visviva.Simulation`) reads the elements
back the way :meth:`~visviva.Simulation.add` places a particle, so that
``sim.add(m, primary=..., **el.elements(k))`` puts the particle back where it was:

* ``primary=None`` (default), **Jacobi elements**: particle ``i`` (1 .. N-1) about the centre of
  mass of particles ``0 .. i-1``, with ``GM = G (m_0 + ... + m_i)`` (REBOUND's ``sim.orbits()``
  and ``particle.orbit()`` defaults).
* ``primary=k`` (an index), **elements about particle k** (heliocentric for the star, k = 0):
  every other particle, with ``GM = G (m_k + m_i)`` (REBOUND's
  ``sim.orbits(primary=sim.particles[k])``).

The two-body conversion is :func:`visviva.core.elements.rv_to_coe_array` (Vallado 2013,
Algorithm 9) and :func:`visviva.core.kepler_arrays.true_to_mean_array`; undefined angles follow
docs/conventions.md (circular: ``argp = 0``; equatorial: ``raan = 0``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core import elements as _elements
from ..core import kepler_arrays as _ka
from ..errors import InvalidInputError, raise_for_status
from .settings import particle_index

__all__ = ["Orbits", "OrbitReadback", "orbits"]

_FIELDS = ("a", "e", "inc", "raan", "argp", "nu", "mean_anomaly", "p")


@dataclass(frozen=True)
class Orbits:
    """Osculating elements of particles about their primaries (arrays of one row per particle).

    Attributes
    ----------
    index : ndarray of int
        The particle of each row.
    primary : int or None
        The primary (a particle index), or None for Jacobi elements.
    a, p : ndarray
        Semi-major axis (negative for a hyperbola, infinite for a parabola) and semi-latus
        rectum, simulation units of length.
    e, inc, raan, argp, nu, mean_anomaly : ndarray
        Eccentricity; inclination in [0, pi], longitude of the ascending node and argument of
        periapsis in [0, 2 pi), true anomaly in (-pi, pi] and mean anomaly (elliptic
        ``E - e sin E`` in (-pi, pi]; hyperbolic ``e sinh F - F``; parabolic ``D + D^3/3``), rad.
    gm : ndarray
        The two-body ``G (m_primary + m)`` of each row.
    period : ndarray
        ``2 pi sqrt(a^3 / GM)``, simulation units of time; infinite for open orbits (e >= 1).
    """

    index: np.ndarray
    primary: int | None
    a: np.ndarray
    e: np.ndarray
    inc: np.ndarray
    raan: np.ndarray
    argp: np.ndarray
    nu: np.ndarray
    mean_anomaly: np.ndarray
    p: np.ndarray
    gm: np.ndarray
    period: np.ndarray

    def __len__(self) -> int:
        return len(self.index)

    def elements(self, particle: int) -> dict:
        """The elements of ``particle`` (a particle index) as keywords of
        :meth:`visviva.Simulation.add` (``p`` for a parabola, ``a`` otherwise; ``nu``)."""
        rows = np.flatnonzero(self.index == particle)
        if len(rows) == 0:
            raise InvalidInputError(
                f"particle {particle!r} has no row here (rows: particles "
                f"{self.index.tolist()}; the primary and, for Jacobi elements, particle 0 "
                "have none).")
        k = int(rows[0])
        out = {name: float(getattr(self, name)[k]) for name in ("e", "inc", "raan", "argp", "nu")}
        size = "p" if out["e"] == 1.0 else "a"
        return {size: float(getattr(self, size)[k]), **out}


def orbits(sim, primary=None) -> Orbits:
    """The osculating elements of ``sim``'s particles (see the module and
    :meth:`OrbitReadback.orbits`)."""
    x, v, m, n = sim.positions, sim.velocities, sim.masses, sim.N
    if primary is None:
        index = np.arange(1, n)
        cm = np.cumsum(m)[:-1]  # mass of particles 0 .. i-1, for i = 1 .. N-1
        mx, mv = np.cumsum(m[:, None] * x, 0)[:-1], np.cumsum(m[:, None] * v, 0)[:-1]
        count = np.arange(1, n)[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):  # no mass inside: the mean
            xp = np.where(cm[:, None] > 0, mx / cm[:, None], np.cumsum(x, 0)[:-1] / count)
            vp = np.where(cm[:, None] > 0, mv / cm[:, None], np.cumsum(v, 0)[:-1] / count)
        mp = cm
    else:
        if isinstance(primary, str):  # a particle's name (sim.names)
            primary = particle_index(sim, primary, "primary")
        elif isinstance(primary, bool) or not isinstance(primary, int | np.integer) or not (
                -n <= primary < n):
            raise InvalidInputError(
                f"primary must be a particle index (an integer in [{-n}, {n})) or name, or None "
                f"for Jacobi elements; got {primary!r}.")
        primary = int(primary) % n
        index = np.delete(np.arange(n), primary)
        xp, vp, mp = x[primary], v[primary], m[primary]
    if len(index) == 0:
        raise InvalidInputError("orbits needs at least two particles.")
    gm = np.ascontiguousarray(sim.G * (mp + m[index]), dtype=np.float64)
    if not np.all(gm > 0):
        k = int(index[np.flatnonzero(~(gm > 0))[0]])
        raise InvalidInputError(
            f"particle {k} and its primary have no mass (GM = 0): its orbit is undefined; use "
            "primary= a massive particle.")
    r = np.ascontiguousarray(x[index] - xp)
    w = np.ascontiguousarray(v[index] - vp)
    p, e, inc, raan, argp, nu, status = _elements.empty_elements(len(index))
    _elements.rv_to_coe_array(r, w, gm, p, e, inc, raan, argp, nu, status)
    raise_for_status(status, "orbits (state about the primary -> elements)", particle=index,
                     r=np.linalg.norm(r, axis=1))
    M, status = np.empty(len(index)), np.empty(len(index), dtype=np.int64)
    _ka.true_to_mean_array(nu, e, M, status)
    raise_for_status(status, "orbits (true -> mean anomaly)", particle=index, e=e, nu=nu)
    with np.errstate(divide="ignore"):
        a = np.where(e == 1.0, np.inf, p / (1.0 - e * e))
        period = np.where(e < 1.0, 2.0 * math.pi * np.sqrt(np.abs(a) ** 3 / gm), np.inf)
    return Orbits(index, primary, a, e, inc, raan, argp, nu, M, p, gm, period)


class OrbitReadback:
    """The :meth:`orbits` method of :class:`visviva.Simulation` (REBOUND's ``sim.orbits()``)."""

    def orbits(self, primary=None) -> Orbits:
        """Osculating orbital elements of the particles (simulation units, radians).

        Parameters
        ----------
        primary : int or str, optional
            None (default): Jacobi elements, particle ``i`` (1 .. N-1) about the centre of mass
            of particles ``0 .. i-1`` with ``GM = G (m_0 + ... + m_i)``, as REBOUND's
            ``sim.orbits()``. An index ``k``: every other particle about particle ``k`` with
            ``GM = G (m_k + m_i)`` (``k = 0``: heliocentric elements), or a name in ``names``.

        Returns
        -------
        Orbits
            Arrays ``a, e, inc, raan, argp, nu, mean_anomaly, p, gm, period`` with one row per
            particle (``index``); ``orbits().elements(i)`` gives the keywords of :meth:`add`
            that put particle ``i`` back (with the same ``primary``).

        Raises
        ------
        InvalidInputError
            A particle without mass about a primary without mass (GM = 0).
        InvalidStateError
            A particle on its primary or moving radially (no orbital plane), naming it.

        Notes
        -----
        Vallado (2013), *Fundamentals of Astrodynamics and Applications*, Algorithm 9; the
        same elements as REBOUND 5.2.2's to round-off (docs/nbody.md).
        """
        return orbits(self, primary)
