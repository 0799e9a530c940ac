"""Placing a particle from orbital elements about a primary (for :meth:`visviva.Simulation.add`).

Beside ``a`` (or ``p``), ``e, inc, raan, argp`` and ``nu`` (or ``mean_anomaly``), REBOUND's other
ways of giving the size, the pericentre and the position on the orbit are taken, under long
names (REBOUND's in brackets), with REBOUND's conventions (Murray & Dermott 1999, sec. 2.8):

* ``period`` (``P``): ``a = (GM P^2 / 4 pi^2)^(1/3)``, closed orbits;
* ``longitude_of_periapsis`` (``pomega``): ``raan + argp`` (prograde, cos inc > 0) or
  ``raan - argp`` (retrograde);
* ``mean_longitude`` (``l``): ``raan + argp + M`` or ``raan - argp - M``;
* ``true_longitude`` (``theta``): ``raan + argp + nu`` or ``raan - argp - nu``;
* ``time_of_periapsis`` (``T``): ``M = n (t - T)``, ``n = sqrt(GM / |a|^3)``, ``t`` the
  simulation's time (elliptic and hyperbolic orbits);
* ``eccentric_anomaly`` (``E``): ``tan(nu / 2) = sqrt((1 + e) / (1 - e)) tan(E / 2)``, and on a
  hyperbola (e > 1) the hyperbolic anomaly ``F``: ``tan(nu / 2) = sqrt((e + 1) / (e - 1))
  tanh(F / 2)``, as REBOUND 5.2.2's ``E_to_f`` takes ``E`` (Murray & Dermott 1999, eqs. 2.46;
  Battin 1999, sec. 4.4); refused on a parabola.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _units
from ..core import elements as _elements
from ..core import kepler as _kepler
from ..errors import InvalidInputError, fmt_number, raise_for_status
from .settings import convert, length, particle_index, scalar

__all__ = ["particle_state", "elements_to_state", "MORE_ELEMENTS"]

_ELEMENT_NAMES = ("e", "inc", "raan", "argp", "nu", "mean_anomaly")
#: The keywords of :meth:`visviva.Simulation.add` beyond its named ones (module docstring).
MORE_ELEMENTS = ("period", "longitude_of_periapsis", "mean_longitude", "true_longitude",
                 "time_of_periapsis", "eccentric_anomaly")
_REBOUND_NAMES = {"Omega": "raan", "omega": "argp", "f": "nu", "P": "period",
                  "pomega": "longitude_of_periapsis", "l": "mean_longitude",
                  "theta": "true_longitude", "T": "time_of_periapsis", "E": "eccentric_anomaly",
                  "x": "r", "y": "r", "z": "r", "vx": "v", "vy": "v", "vz": "v", "r": "radius"}


def particle_state(sim, m, r, v, primary, more, **elements):
    """The particle's position and velocity as given to :meth:`visviva.Simulation.add`: ``r``,
    ``v`` as they are (zero when None), or from the orbital ``elements`` (``a`` or ``p`` with
    ``e, inc, raan, argp, nu, mean_anomaly``, None when not given) and ``more`` (a dict of
    :data:`MORE_ELEMENTS`) about ``primary``."""
    unknown = [k for k in more if k not in MORE_ELEMENTS]
    if unknown:
        hints = [f"{k} (visviva: {_REBOUND_NAMES[k]})" for k in unknown if k in _REBOUND_NAMES]
        raise InvalidInputError(
            f"Simulation.add got unknown keyword(s) {', '.join(unknown)}"
            + (f"; REBOUND's names: {', '.join(hints)}" if hints else "")
            + ". Its elements are a or p or period, e, inc, raan, argp or longitude_of_periapsis, "
            "nu or mean_anomaly or mean_longitude or true_longitude or time_of_periapsis or "
            "eccentric_anomaly.")
    a, p = elements.pop("a"), elements.pop("p")
    given = [k for k in _ELEMENT_NAMES if elements[k] is not None] + list(more)
    if a is None and p is None and "period" not in more:
        if given or primary is not None:
            # they were ignored: the particle went to r (0 when not given) with v, in silence
            what = ", ".join(given + (["primary"] if primary is not None else []))
            raise InvalidInputError(
                f"{what} given without a semi-major axis a (or semi-latus rectum p, or period): give a "
                "(or p) to place the particle by orbital elements about the primary, or r and v "
                "alone for a Cartesian state (r, v are absolute: not relative to a primary).")
        return (np.zeros(3) if r is None else r), (np.zeros(3) if v is None else v)
    if r is not None or v is not None:
        raise InvalidInputError("give either r, v or orbital elements, not both.")
    el = {k: (0.0 if k in ("e", "inc", "raan") and val is None else val)
          for k, val in elements.items()}
    return elements_to_state(sim, m, primary, a, el["e"], el["inc"], el["raan"], el["argp"],
                             el["nu"], el["mean_anomaly"], p, more)


def _one_of(what, **given):
    """The one name of ``given`` whose value is not None (None when none), or a refusal."""
    names = [k for k, val in given.items() if val is not None]
    if len(names) > 1:
        raise InvalidInputError(f"give one {what}, not {' and '.join(names)}.")
    return names[0] if names else None


def elements_to_state(sim, m, primary, a, e, inc, raan, argp, nu, M, p, more=None):
    """Position and velocity (simulation units) of a particle of mass ``m`` on the orbit given
    by the elements about ``primary`` (an index, or None/"com" for the centre of mass of the
    particles added so far); arguments as in :meth:`visviva.Simulation.add`."""
    more = more or {}
    masses, x, v = sim.masses, sim.positions, sim.velocities
    if sim.N == 0:
        raise InvalidInputError("add a primary (a particle with mass) before adding by elements.")
    if primary is None or (isinstance(primary, str) and primary == "com"):
        mp = masses.sum()
        xp = (masses[:, None] * x).sum(0) / mp if mp > 0 else x.mean(0)
        vp = (masses[:, None] * v).sum(0) / mp if mp > 0 else v.mean(0)
    else:
        i = (particle_index(sim, primary, "primary") if isinstance(primary, str)  # a name
             else _primary_index(primary, sim.N))
        mp, xp, vp = masses[i], x[i], v[i]
    gm = sim.G * (mp + m)
    if not gm > 0:
        raise InvalidInputError("the primary and the particle have no mass: GM = 0.")
    e = scalar(_units.to_array(e, "dimensionless", "e"), "e")
    inc, raan = _angle(inc, "inc"), _angle(raan, "raan")
    prograde = math.cos(inc) > 0.0  # REBOUND's test for the longitudes' sign
    if _one_of("argument of periapsis", argp=argp,
               longitude_of_periapsis=more.get("longitude_of_periapsis")) is None:
        argp = 0.0
    elif argp is None:
        pomega = _angle(more["longitude_of_periapsis"], "longitude_of_periapsis")
        argp = pomega - raan if prograde else raan - pomega
    argp = _angle(argp, "argp")
    anomaly = _one_of("position on the orbit", nu=nu, mean_anomaly=M,
                      **{k: more.get(k) for k in MORE_ELEMENTS[2:]})
    if a is not None and p is not None:  # p used to win silently over a different a
        raise InvalidInputError(
            f"give the semi-major axis a or the semi-latus rectum p, not both (a = "
            f"{fmt_number(a)}, p = {fmt_number(p)}; p = a (1 - e^2)).")
    size = _one_of("size of the orbit", a=a, p=p, period=more.get("period"))
    if e < 0:
        raise InvalidInputError(f"e must be >= 0; got {fmt_number(e)}.")
    if size == "period":
        period = scalar(convert(sim, more["period"], "time", "period"), "period")
        if not (period > 0 and e < 1):
            raise InvalidInputError(
                f"a period must be > 0 and belongs to a closed orbit (e < 1); got period = "
                f"{fmt_number(period)}, e = {fmt_number(e)}: give a (< 0 for e > 1) or p.")
        a = (gm * period * period / (4.0 * math.pi**2)) ** (1.0 / 3.0)
    if size in ("a", "period"):
        a = float(length(sim, a, "a"))
        if e == 1.0:
            raise InvalidInputError("a parabola has no semi-major axis: give p instead of a.")
        p = a * (1.0 - e * e)
    else:
        p = float(length(sim, p, "p"))
    if not p > 0:
        raise InvalidInputError(f"the semi-latus rectum must be > 0 (a(1-e^2) > 0); got {fmt_number(p)}.")
    if anomaly in ("mean_longitude", "true_longitude"):
        lon = _angle(more[anomaly], anomaly)
        value = lon - raan - argp if prograde else raan - argp - lon
        nu, M = (value, None) if anomaly == "true_longitude" else (None, value)
    elif anomaly == "time_of_periapsis":
        if e == 1.0:
            raise InvalidInputError("give nu (not time_of_periapsis) for a parabolic orbit (e = 1).")
        T = sim.time_value(more[anomaly], anomaly)
        M = math.sqrt(gm / abs(p / (1.0 - e * e)) ** 3) * (sim.t - T)
    elif anomaly == "eccentric_anomaly":  # E, or on a hyperbola F (REBOUND's E_to_f)
        if e == 1.0:
            raise InvalidInputError("give nu (not eccentric_anomaly) for a parabolic orbit (e = 1).")
        E = _angle(more[anomaly], anomaly)
        nu, status = (_kepler.true_from_eccentric(E, e) if e < 1.0
                      else _kepler.true_from_hyperbolic(E, e))
        raise_for_status(np.array([status]), "eccentric to true anomaly", E=E, e=e)
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
