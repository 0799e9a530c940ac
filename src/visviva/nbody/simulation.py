"""The N-body :class:`Simulation`: particles, an integrator, and ``integrate(t)``.

The state lives in plain float64 arrays; :meth:`Simulation.integrate` hands them to ONE compiled
kernel call that takes every step between the current time and the last requested output time
(no Python per step). Output snapshots at many times come back as ``(T, N, 3)`` arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core import elements as _elements
from ..core import gravity as _gravity
from ..core import kepler as _kepler
from ..core import nbody_common as _nc
from ..core import status as _st
from ..errors import (
    Collision,
    InvalidInputError,
    InvalidStateError,
    ShapeError,
    StepSizeError,
    fmt_number,
    raise_for_status,
)
from . import forces as _forces
from .integrators import COORDINATES, INTEGRATORS, get_integrator, parse_coordinates
from .units import SimulationUnits

__all__ = ["Simulation", "Trajectory", "COLLISION_MODES"]

#: What happens when two particles touch (their radii overlap while approaching).
COLLISION_MODES = ("none", "halt", "merge", "bounce")

_PARALLEL_AUTO_N = _gravity.PARALLEL_MIN_N


def _scalar(arr, name) -> float:
    """A single float from a converted value, or a ShapeError saying what to pass."""
    arr = np.asarray(arr)
    if arr.size != 1:
        raise ShapeError(f"{name} must be a single number; got an array of shape {arr.shape}.")
    return float(arr.reshape(()))


def _positive_float(value, name, hint) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a finite number > 0 {hint}; got {fmt_number(value)}.") from exc
    if not (math.isfinite(x) and x > 0):
        raise InvalidInputError(f"{name} must be a finite number > 0 {hint}; got {fmt_number(value)}.")
    return x


def coincident_pairs(x, m, soft2, limit: int = 3) -> list:
    """Pairs ``(i, j)`` of particles at exactly the same position where at least one is massive
    and there is no softening (the point-mass force is infinite there); at most ``limit``."""
    if soft2 > 0 or x.shape[0] < 2:
        return []
    _, first, inverse = np.unique(x, axis=0, return_index=True, return_inverse=True)
    inverse = np.asarray(inverse).reshape(-1)
    pairs = []
    if len(first) == x.shape[0]:
        return pairs
    for g in np.flatnonzero(np.bincount(inverse) > 1):
        idx = np.flatnonzero(inverse == g)
        if np.count_nonzero(m[idx]) == 0:
            continue  # test particles only: they do not attract each other
        pairs.append((int(idx[0]), int(idx[1])))
        if len(pairs) >= limit:
            break
    return pairs


@dataclass
class Trajectory:
    """Snapshots returned by :meth:`Simulation.integrate` for an array of output times.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Output times (simulation units).
    positions, velocities : ndarray, shape (T, N, 3)
        Snapshots (simulation units). Particles removed by a merger are NaN afterwards.
    masses : ndarray, shape (N,)
        Masses at the start of the run.
    """

    t: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    masses: np.ndarray
    G: float = 1.0
    softening: float = 0.0

    def energy(self) -> np.ndarray:
        """Total energy at each snapshot, shape (T,) (simulation units).

        Raises
        ------
        InvalidStateError
            A snapshot where the energy is not finite: two massive particles at the same
            position without softening, or a particle removed by a merger.
        """
        out = np.empty(len(self.t))
        _gravity.energy_history(
            np.ascontiguousarray(self.positions),
            np.ascontiguousarray(self.velocities),
            self.masses,
            float(self.G),
            float(self.softening) ** 2,
            out,
        )
        bad = np.flatnonzero(~np.isfinite(out))
        if bad.size:
            k = int(bad[0])
            context = f"Trajectory.energy: at snapshot {k} (t = {fmt_number(self.t[k])})"
            removed = np.flatnonzero(np.isnan(self.positions[k]).any(axis=1))
            if removed.size:
                raise InvalidStateError(
                    f"{context} particle(s) {removed.tolist()} had been removed by a merger, so "
                    "the total energy of the snapshot is undefined. Use Simulation.energy(), "
                    "which tracks the energy lost in mergers (energy_offset), or sample the "
                    "trajectory before the merger."
                )
            pairs = coincident_pairs(self.positions[k], self.masses, float(self.softening) ** 2)
            where = f"particles {pairs[0]} share a position" if pairs else "the energy overflows"
            raise InvalidStateError(
                f"{context} {where}, so the potential energy is not finite ({bad.size} "
                "snapshot(s) in all). To fix: run with softening > 0, or give the particles "
                "radii with collision='merge'."
            )
        return out


class Simulation:
    """An N-body simulation.

    Parameters
    ----------
    integrator : str
        ``"ias15"`` (default; adaptive, machine precision), ``"whfast"`` or ``"leapfrog"``
        (symplectic, fixed ``dt``); see :mod:`visviva.nbody.integrators`.
    G : float
        Gravitational constant in simulation units (1 by default: N-body units). Ignored when
        ``units`` is given.
    dt : float or Quantity, optional
        Time step (required by the fixed-step integrators; IAS15's first guess).
    units : tuple of str, optional
        ``(length, time, mass)``, e.g. ``("au", "yr", "Msun")``: sets ``G`` and lets :meth:`add`
        take astropy Quantities.
    softening : float
        Plummer softening length (simulation units); 0 for none.
    parallel : bool, optional
        Use the multi-threaded gravity kernel; default: when N >= 512. Both kernels add the
        forces in the same order and give identical bits.
    collision : str
        ``"none"`` (default), ``"halt"`` (raise :class:`visviva.Collision`), ``"merge"``
        (conserving mass and momentum; the lost energy is tracked in ``energy_offset``) or
        ``"bounce"`` (hard spheres, impulse along the line of centres).
    restitution : float
        Coefficient of restitution of a bounce (1 = elastic).
    encounter_distance, exit_max_distance : float, optional
        Raise :class:`visviva.Encounter` when two particles come closer than the first, and
        :class:`visviva.Escape` when a particle goes farther from the origin than the second.
    epsilon : float
        IAS15 accuracy parameter (Rein & Spiegel 2015), 1e-9; finite and > 0.
    min_dt : float
        Smallest step IAS15 may take (>= 0); below it :class:`visviva.StepSizeError` is raised.
        A relative floor always applies too: a shrinking step below ``1e-15 max(|t|, time span
        of the integrate call)`` raises StepSizeError (a collapsing pair or a singular force
        would otherwise need ~forever), so a run never loops without end.
    corrector : int
        WHFast symplectic corrector order (0: none, 3, 5, 7), applied at the start and
        (inverted) at every output; not used while collisions/encounters/escapes are checked.
        Jacobi coordinates only.
    coordinates : str
        WHFast's splitting: ``"jacobi"`` (default; best for hierarchical systems) or
        ``"democratic_heliocentric"`` (heliocentric positions, barycentric velocities; Duncan,
        Levison & Lee 1998; REBOUND's ``"democraticheliocentric"`` is accepted too): see
        docs/nbody.md for when to use which.
    adaptive_mode : str
        IAS15 step-size control: ``"prs23"`` (default; Pham, Rein & Spiegel 2024, REBOUND's
        default) or ``"rs15"`` (Rein & Spiegel 2015's global criterion; ``"global"`` is an
        alias).
    exact_finish_time : bool
        Land exactly on requested times (default) or return the first step past them. Either
        way the integrator's own trajectory does not depend on the output times.

    Examples
    --------
    >>> import visviva as vv
    >>> sim = vv.Simulation(integrator="ias15")
    >>> sim.add(1.0)
    0
    >>> sim.add(1e-3, r=[1.0, 0.0, 0.0], v=[0.0, 1.0, 0.0])
    1
    >>> sim.integrate(10.0)
    >>> print(f"{sim.t:.1f}")
    10.0
    """

    def __init__(
        self,
        integrator: str = "ias15",
        G: float = 1.0,
        dt=None,
        *,
        units=None,
        softening: float = 0.0,
        parallel: bool | None = None,
        collision: str = "none",
        restitution: float = 1.0,
        encounter_distance: float | None = None,
        exit_max_distance: float | None = None,
        epsilon: float = 1e-9,
        min_dt: float = 0.0,
        corrector: int = 0,
        coordinates: str = "jacobi",
        exact_finish_time: bool = True,
        adaptive_mode: str = "prs23",
    ):
        self.units = None if units is None else SimulationUnits.parse(units)
        self._x = np.zeros((0, 3))
        self._v = np.zeros((0, 3))
        self._m = np.zeros(0)
        self._radius = np.zeros(0)
        self._fstate = np.zeros(_nc.N_FSTATE)
        self._istate = np.zeros(_nc.N_ISTATE, dtype=np.int64)
        self._istate[_nc.I_FRESH] = 1
        self._buf = None
        self._forces: list = []
        self.energy_offset = 0.0
        self.parallel = parallel
        self._integrator = get_integrator(integrator)
        G_value = self.units.G if self.units is not None else float(G)
        if not (math.isfinite(G_value) and G_value > 0):
            raise InvalidInputError(f"G must be a finite number > 0; got {fmt_number(G)}.")
        self._fstate[_nc.F_G] = G_value
        self.epsilon = epsilon
        self.min_dt = min_dt
        self.softening = softening
        self.dt = 0.0 if dt is None else dt
        self.collision = collision
        self.restitution = restitution
        self.encounter_distance = encounter_distance
        self.exit_max_distance = exit_max_distance
        self.corrector = corrector
        self.coordinates = coordinates
        self.exact_finish_time = exact_finish_time
        self.adaptive_mode = adaptive_mode

    # ---- configuration -------------------------------------------------------------------------
    @property
    def integrator(self) -> str:
        """Name of the integrator; assigning a new name resets its internal state."""
        return self._integrator.name

    @integrator.setter
    def integrator(self, name: str) -> None:
        self._integrator = get_integrator(name)
        self._buf = None
        self._istate[_nc.I_FRESH] = 1

    @property
    def integrator_info(self):
        """The registry entry (:class:`visviva.nbody.integrators.Integrator`)."""
        return self._integrator

    @property
    def G(self) -> float:
        """Gravitational constant in simulation units."""
        return float(self._fstate[_nc.F_G])

    @property
    def t(self) -> float:
        """Simulation time (simulation units)."""
        return float(self._fstate[_nc.F_T])

    @t.setter
    def t(self, value) -> None:
        self._fstate[_nc.F_T] = _scalar(self._time(value, "t"), "t")
        self._fstate[_nc.F_DT_REF] = 0.0  # restart the fixed-step clock here

    @property
    def steps_done(self) -> int:
        """Number of steps taken so far (accepted steps for IAS15)."""
        return int(self._istate[_nc.I_STEPS])

    @property
    def dt(self) -> float:
        """Time step (next step for IAS15)."""
        return float(self._fstate[_nc.F_DT])

    @dt.setter
    def dt(self, value) -> None:
        dt = _scalar(self._time(value, "dt"), "dt")
        if not math.isfinite(dt):
            raise InvalidInputError(f"dt must be finite; got {fmt_number(dt)}.")
        self._fstate[_nc.F_DT] = dt

    @property
    def softening(self) -> float:
        return math.sqrt(self._fstate[_nc.F_SOFT2])

    @softening.setter
    def softening(self, value) -> None:
        s = float(self._length(value, "softening"))
        if not (math.isfinite(s) and s >= 0):
            raise InvalidInputError(f"softening must be >= 0; got {fmt_number(value)}.")
        self._fstate[_nc.F_SOFT2] = s * s

    @property
    def epsilon(self) -> float:
        return float(self._fstate[_nc.F_EPSILON])

    @epsilon.setter
    def epsilon(self, value) -> None:
        eps = _positive_float(value, "epsilon", "(IAS15's accuracy parameter; e.g. 1e-9)")
        self._fstate[_nc.F_EPSILON] = eps

    @property
    def min_dt(self) -> float:
        """Smallest step IAS15 may take (0: only the relative floor applies)."""
        return float(self._fstate[_nc.F_MIN_DT])

    @min_dt.setter
    def min_dt(self, value) -> None:
        dt = _scalar(self._time(value, "min_dt"), "min_dt")
        if not (math.isfinite(dt) and dt >= 0):
            raise InvalidInputError(f"min_dt must be a finite number >= 0; got {fmt_number(value)}.")
        self._fstate[_nc.F_MIN_DT] = dt

    @property
    def collision(self) -> str:
        return self._collision

    @collision.setter
    def collision(self, mode: str) -> None:
        if mode is None:
            mode = "none"
        if mode not in COLLISION_MODES:
            raise InvalidInputError(f"collision must be one of {COLLISION_MODES}; got {mode!r}.")
        self._collision = mode
        self._istate[_nc.I_COLLISIONS] = 0 if mode == "none" else 1

    @property
    def restitution(self) -> float:
        return self._restitution

    @restitution.setter
    def restitution(self, value) -> None:
        value = float(value)
        if not 0.0 <= value <= 1.0:
            raise InvalidInputError(f"restitution must be in [0, 1]; got {fmt_number(value)}.")
        self._restitution = value

    @property
    def encounter_distance(self):
        d = self._fstate[_nc.F_ENCOUNTER]
        return None if d <= 0 else float(d)

    @encounter_distance.setter
    def encounter_distance(self, value) -> None:
        self._fstate[_nc.F_ENCOUNTER] = (
            0.0 if value is None else self._distance(value, "encounter_distance", allow_zero=True)
        )

    @property
    def exit_max_distance(self):
        d = self._fstate[_nc.F_EXIT]
        return None if d <= 0 else float(d)

    @exit_max_distance.setter
    def exit_max_distance(self, value) -> None:
        self._fstate[_nc.F_EXIT] = (
            0.0 if value is None else self._distance(value, "exit_max_distance", allow_zero=False)
        )

    def _distance(self, value, name, allow_zero):
        d = self._length(value, name)
        if not (d > 0 or (allow_zero and d == 0)):
            bound = ">= 0" if allow_zero else "> 0"
            raise InvalidInputError(
                f"{name} must be a distance {bound} (or None to switch the check off); "
                f"got {fmt_number(value)}."
            )
        return d

    @property
    def corrector(self) -> int:
        """WHFast symplectic corrector order: 0 (none), 3, 5 or 7."""
        return int(self._istate[_nc.I_CORRECTOR])

    @corrector.setter
    def corrector(self, order: int) -> None:
        order = int(order)
        if order not in (0, 3, 5, 7):
            raise InvalidInputError(f"corrector must be 0, 3, 5 or 7; got {order!r}.")
        if order != 0 and self.coordinates != "jacobi":
            raise InvalidInputError(
                f"corrector={order}: the symplectic correctors are derived for the Jacobi "
                f"splitting (Kepler + interaction) and do not apply to {self.coordinates!r} "
                "coordinates; use corrector=0, or coordinates='jacobi'."
            )
        self._istate[_nc.I_CORRECTOR] = order
        self._istate[_nc.I_FRESH] = 1

    @property
    def coordinates(self) -> str:
        """WHFast's coordinates: ``"jacobi"`` or ``"democratic_heliocentric"``; assigning resets
        the integrator's internal state (REBOUND's ``"democraticheliocentric"`` is accepted)."""
        code = int(self._istate[_nc.I_WH_COORDINATES])
        return next(k for k, v in COORDINATES.items() if v == code)

    @coordinates.setter
    def coordinates(self, name: str) -> None:
        key = parse_coordinates(name, self._integrator)
        if key != "jacobi" and self.corrector != 0:
            raise InvalidInputError(
                f"coordinates={name!r} with corrector={self.corrector}: the symplectic "
                "correctors apply to Jacobi coordinates only; set corrector=0 first."
            )
        self._istate[_nc.I_WH_COORDINATES] = COORDINATES[key]
        self._istate[_nc.I_FRESH] = 1

    @property
    def adaptive_mode(self) -> str:
        """IAS15 step-size control: ``"prs23"`` (Pham, Rein & Spiegel 2024; the default, as in
        REBOUND: about half the steps of ``"rs15"`` on planetary systems at the same round-off
        energy error) or ``"rs15"`` (Rein & Spiegel 2015's global ``max|b6| / max|a|``;
        ``"global"`` is accepted as an alias)."""
        return ("rs15", "prs23")[int(self._istate[_nc.I_ADAPTIVE_MODE])]

    @adaptive_mode.setter
    def adaptive_mode(self, mode: str) -> None:
        if mode not in ("prs23", "rs15", "global"):
            raise InvalidInputError(
                f"adaptive_mode must be 'prs23' (default) or 'rs15' (alias 'global'); got {mode!r}."
            )
        self._istate[_nc.I_ADAPTIVE_MODE] = 1 if mode == "prs23" else 0

    @property
    def exact_finish_time(self) -> bool:
        """True (default): land exactly on every requested time (with a shortened step of a copy
        of the integrator's state, so the trajectory never depends on the output times). False:
        return the state after the first step at or past each time."""
        return bool(self._istate[_nc.I_EXACT_FINISH])

    @exact_finish_time.setter
    def exact_finish_time(self, value: bool) -> None:
        self._istate[_nc.I_EXACT_FINISH] = 1 if value else 0

    # ---- unit helpers ----------------------------------------------------------------------------
    def _convert(self, value, kind, name):
        if hasattr(value, "unit"):
            if self.units is None:
                from ..errors import UnitsError

                raise UnitsError(
                    f"{name} is a Quantity but the simulation has no units: create it with "
                    "units=('au', 'yr', 'Msun') (any length, time, mass), or pass plain floats."
                )
            return getattr(self.units, f"{kind}_value")(value, name)
        try:
            arr = np.array(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"{name} must be a number or an array of numbers (simulation units, or a Quantity "
                f"when the simulation has units); got {fmt_number(value)}."
            ) from exc
        if not np.all(np.isfinite(arr)):
            raise InvalidInputError(f"{name} contains NaN or infinite values.")
        return arr

    def _length(self, value, name):
        return _scalar(self._convert(value, "length", name), name)

    def _time(self, value, name):
        return self._convert(value, "time", name)

    def _replace_state(self, attr, value, kind, name):
        """Replace the state array ``attr`` (``"_x"`` or ``"_v"``) by ``value`` of the same shape.

        Parameters
        ----------
        attr : str
            The attribute holding the array, shape (N, 3).
        value : array_like or Quantity
            The new values (simulation units, or a Quantity of ``kind`` with units).
        kind : str
            ``"length"`` or ``"speed"``: the conversion :meth:`_convert` applies.
        name : str
            The public name, for messages.

        The integrator restarts from the new state (its internal state is marked fresh).
        """
        current = getattr(self, attr)
        arr = np.ascontiguousarray(self._convert(value, kind, name), dtype=np.float64)
        if arr.shape != current.shape:
            raise ShapeError(f"{name} must have shape {current.shape}; got {arr.shape}.")
        setattr(self, attr, arr)
        self._istate[_nc.I_FRESH] = 1

    # ---- particles --------------------------------------------------------------------------------
    @property
    def N(self) -> int:
        """Number of particles."""
        return int(self._m.shape[0])

    @property
    def N_active(self) -> int:
        """Number of massive particles (the others are test particles)."""
        return int(np.count_nonzero(self._m))

    @property
    def positions(self) -> np.ndarray:
        """Positions, shape (N, 3), simulation units (a copy)."""
        return self._x.copy()

    @positions.setter
    def positions(self, value) -> None:
        self._replace_state("_x", value, "length", "positions")

    @property
    def velocities(self) -> np.ndarray:
        """Velocities, shape (N, 3), simulation units (a copy)."""
        return self._v.copy()

    @velocities.setter
    def velocities(self, value) -> None:
        self._replace_state("_v", value, "speed", "velocities")

    @property
    def masses(self) -> np.ndarray:
        """Masses, shape (N,), simulation units (a copy)."""
        return self._m.copy()

    @property
    def radii(self) -> np.ndarray:
        """Collision radii, shape (N,)."""
        return self._radius.copy()

    def add(self, m=0.0, r=None, v=None, *, radius=0.0, primary=None, a=None, e=0.0, inc=0.0,
            raan=0.0, argp=0.0, nu=None, mean_anomaly=None, p=None, M=None):
        """Add a particle from a state, or from orbital elements about a primary.

        Parameters
        ----------
        m : float or Quantity
            Mass (0 makes a test particle: it feels the others and pulls on nothing).
        r, v : array_like (3,) or Quantity
            Position and velocity (simulation units), default zero.
        radius : float or Quantity
            Collision radius.
        primary : int or "com", optional
            With elements: the particle index to orbit, or ``"com"``/``None`` for the centre of
            mass of all particles added so far (Jacobi-like, the default).
        a, e, inc, raan, argp, nu, mean_anomaly, p : float
            Semi-major axis (or semi-latus rectum ``p``), eccentricity, inclination, longitude of
            the ascending node, argument of periapsis (radians) and the true anomaly ``nu`` or
            ``mean_anomaly`` (radians; elliptic orbits). ``G (m_primary + m)`` is the two-body GM.
        M : float, optional
            Deprecated alias of ``mean_anomaly`` (it differed from the mass ``m`` only by case);
            removed in the next release.

        Returns
        -------
        int
            The index of the new particle.
        """
        if M is not None:
            from .._deprecation import warn_renamed

            warn_renamed("Simulation.add(M=...)", "Simulation.add(mean_anomaly=...)")
            if mean_anomaly is not None:
                raise InvalidInputError("give mean_anomaly only (M is its deprecated alias).")
            mean_anomaly = M
        m_val = _scalar(self._convert(m, "mass", "m"), "m")
        if not m_val >= 0:
            raise InvalidInputError(f"mass must be >= 0; got {fmt_number(m)}.")
        if a is not None or p is not None:
            if r is not None or v is not None:
                raise InvalidInputError("give either r, v or orbital elements, not both.")
            rr, vv = self._from_elements(m_val, primary, a, e, inc, raan, argp, nu, mean_anomaly, p)
        else:
            rr = np.zeros(3) if r is None else self._convert(r, "length", "r")
            vv = np.zeros(3) if v is None else self._convert(v, "speed", "v")
        rr = np.asarray(rr, dtype=np.float64).reshape(-1)
        vv = np.asarray(vv, dtype=np.float64).reshape(-1)
        if rr.shape != (3,) or vv.shape != (3,):
            raise ShapeError(f"r and v must have shape (3,); got {rr.shape} and {vv.shape}.")
        rad = self._length(radius, "radius")
        if not rad >= 0:
            raise InvalidInputError(f"radius must be >= 0; got {fmt_number(radius)}.")
        self._x = np.ascontiguousarray(np.vstack([self._x, rr]))
        self._v = np.ascontiguousarray(np.vstack([self._v, vv]))
        self._m = np.append(self._m, m_val)
        self._radius = np.append(self._radius, rad)
        self._particles_changed()
        return self.N - 1

    def _from_elements(self, m, primary, a, e, inc, raan, argp, nu, M, p):
        if self.N == 0:
            raise InvalidInputError("add a primary (a particle with mass) before adding by elements.")
        if primary is None or (isinstance(primary, str) and primary == "com"):
            mp = self._m.sum()
            xp = (self._m[:, None] * self._x).sum(0) / mp if mp > 0 else self._x.mean(0)
            vp = (self._m[:, None] * self._v).sum(0) / mp if mp > 0 else self._v.mean(0)
        else:
            i = int(primary)
            mp, xp, vp = self._m[i], self._x[i], self._v[i]
        gm = self.G * (mp + m)
        if not gm > 0:
            raise InvalidInputError("the primary and the particle have no mass: GM = 0.")
        e = float(e)
        if e < 0:
            raise InvalidInputError(f"e must be >= 0; got {fmt_number(e)}.")
        if p is None:
            a = float(self._length(a, "a"))
            if e == 1.0:
                raise InvalidInputError("a parabola has no semi-major axis: give p instead of a.")
            p = a * (1.0 - e * e)
        else:
            p = float(self._length(p, "p"))
        if not p > 0:
            raise InvalidInputError(f"the semi-latus rectum must be > 0 (a(1-e^2) > 0); got {fmt_number(p)}.")
        if nu is None:
            if M is None:
                nu = 0.0
            else:
                if e >= 1:
                    raise InvalidInputError("give nu (not mean_anomaly) for open orbits.")
                nu, status = _kepler.mean_to_true_anomaly(float(M), e)
                raise_for_status(np.array([status]), "mean to true anomaly", M=M, e=e)
        *state, status = _elements.coe_to_rv(
            p, e, float(inc), float(raan), float(argp), float(nu), gm
        )
        raise_for_status(np.array([status]), "orbital elements to state", p=p, e=e, nu=nu)
        return xp + np.array(state[:3]), vp + np.array(state[3:])

    def remove(self, index: int) -> None:
        """Remove particle ``index`` (later indices shift down by one)."""
        keep = np.ones(self.N, bool)
        keep[int(index)] = False
        self._x = np.ascontiguousarray(self._x[keep])
        self._v = np.ascontiguousarray(self._v[keep])
        self._m = self._m[keep].copy()
        self._radius = self._radius[keep].copy()
        self._particles_changed()

    def _particles_changed(self):
        self._buf = None
        self._istate[_nc.I_FRESH] = 1

    # ---- forces ---------------------------------------------------------------------------------
    @property
    def forces(self) -> tuple:
        """The additional forces (:class:`visviva.nbody.forces.Force`), in order."""
        return tuple(self._forces)

    def add_force(self, force, params=(), velocity_dependent=False):
        """Add a compiled force ``fn(t, positions, velocities, masses, params, acc)``.

        ``force`` is an ``@numba.njit`` function (with ``params`` and ``velocity_dependent``) or
        a :class:`visviva.nbody.forces.Force` (e.g. ``J2Force``, ``GeneralRelativity``).
        """
        if not isinstance(force, _forces.Force):
            force = _forces.Force(force, params, velocity_dependent)
        self._check_force(force)
        self._forces.append(force)
        self._fused = None
        return force

    def clear_forces(self) -> None:
        self._forces = []
        self._fused = None

    def _check_force(self, force):
        if force.velocity_dependent and not self._integrator.velocity_dependent_forces:
            able = sorted(k for k, i in INTEGRATORS.items() if i.velocity_dependent_forces)
            raise InvalidInputError(
                f"the force {force.name!r} depends on velocities, which the {self.integrator!r} "
                f"integrator cannot integrate (its splitting needs position-only forces); use "
                f"integrator={able[0]!r}"
                + (" or the position-only GeneralRelativityPotential" if "GR" in force.name else "")
                + "."
            )

    def _force_args(self):
        if not self._forces:
            return _gravity.no_force, np.zeros(1)
        for f in self._forces:
            self._check_force(f)
        params = [np.ascontiguousarray(f.parameters(self), dtype=np.float64) for f in self._forces]
        if getattr(self, "_fused", None) is None:
            fused = _forces.combine([f.fn for f in self._forces], [len(p) for p in params])
            try:
                fused.compile(_nc.FORCE_SIGNATURE)
            except Exception as exc:  # numba's typing errors, reported with what to do
                names = ", ".join(f.name for f in self._forces)
                raise InvalidInputError(
                    f"the additional force(s) {names} do not compile for the signature "
                    "fn(t: float, positions: (N,3) array, velocities: (N,3) array, masses: (N,) "
                    "array, params: (k,) array, acc: (N,3) array) -> None (add to acc in "
                    f"place, return nothing). numba said: {exc}"
                ) from exc
            self._fused = fused
        flat = np.ascontiguousarray(np.concatenate(params + [np.zeros(1)]))
        return self._fused, flat

    # ---- integration -----------------------------------------------------------------------------
    def _ensure_buf(self):
        n_buf = self._integrator.n_buf
        buf = self._buf
        if (buf is not None and self._integrator.name == "ias15" and buf.shape[0] == 75
                and buf.shape[1:] == (self.N, 3)):
            # saved before IAS15's scratch slot for the low parts of positions (slot 75) was
            # added: the slots in use are the same, so the run continues bit for bit
            self._buf = np.concatenate([buf, np.zeros((n_buf - 75, self.N, 3))])
        if self._buf is None or self._buf.shape != (n_buf, self.N, 3):
            self._buf = np.zeros((n_buf, self.N, 3))
            self._istate[_nc.I_FRESH] = 1

    def _use_parallel(self) -> bool:
        return bool(self.parallel) if self.parallel is not None else self.N >= _PARALLEL_AUTO_N

    def _initial_dt(self) -> float:
        """A first guess for IAS15 when no dt was given: 1e-3 of the shortest two-body time."""
        mi = np.flatnonzero(self._m)
        if len(mi) == 0:
            return 0.0
        x = self._x[:300]  # a sample keeps this cheap for large N
        d = np.linalg.norm(x[:, None, :] - self._x[None, mi[:300], :], axis=-1)
        msum = self._m[:300, None] + self._m[None, mi[:300]]
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = np.sqrt(d**3 / (self.G * msum))
        tau = tau[np.isfinite(tau) & (tau > 0)]
        return 1e-3 * float(tau.min()) if tau.size else 0.0

    def integrate(self, t, *, progress: bool = False):
        """Integrate to the absolute time ``t`` (or through an array of output times).

        Parameters
        ----------
        t : float, Quantity or array_like
            Absolute time(s), simulation units. Times must be monotonic in the direction of
            integration (backwards is allowed). Every output time is reached exactly.
        progress : bool
            Show a tqdm progress bar (the run is paused and resumed without changing a bit).

        Returns
        -------
        None or Trajectory
            ``None`` for a scalar ``t``; a :class:`Trajectory` with ``(T, N, 3)`` positions and
            velocities for an array of times.

        Raises
        ------
        Collision, Encounter, Escape
            When the corresponding event is switched on and happens; the simulation stays at
            the time of the event and can be continued.
        StepSizeError
            When IAS15's step falls below ``min_dt`` or the relative floor (see the class).
        InvalidStateError
            When massive particles sit at exactly the same position without softening, or a
            force gives NaN/infinite accelerations.
        """
        scalar = np.ndim(t) == 0
        times = np.ascontiguousarray(np.atleast_1d(self._time(t, "t")).astype(np.float64))
        if times.ndim != 1:
            raise ShapeError(f"t must be a number or a 1-D array of times; got shape {times.shape}.")
        if self.N == 0:
            raise InvalidInputError("the simulation has no particles: add some with sim.add(...).")
        self._check_not_coincident("integrate")
        steps = np.diff(np.concatenate([[self.t], times]))
        if not (np.all(steps >= 0) or np.all(steps <= 0)):
            raise InvalidInputError(
                "output times must be monotonic in one direction from the current time "
                f"t = {fmt_number(self.t)}; sort them (or integrate backwards in a separate call)."
            )
        info = self._integrator
        if info.needs_dt and self.dt == 0.0:
            raise InvalidInputError(
                f"the {info.name!r} integrator needs a time step: Simulation(..., dt=...) or "
                "sim.dt = ... (e.g. 1/20 of the shortest orbital period)."
            )
        if info.adaptive and self.dt == 0.0:
            self._fstate[_nc.F_DT] = self._initial_dt()
        T = len(times)
        out_x = np.full((T, self.N, 3), np.nan)
        out_v = np.full((T, self.N, 3), np.nan)
        masses0 = self._m.copy()
        alive = np.arange(self.N)  # original index of each current particle
        self._istate[_nc.I_NOUT] = 0
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=abs(times[-1] - self.t), unit="t", desc=f"{info.name}")
            t_start = self.t
        chunk_x = np.empty((T, self.N, 3))
        chunk_v = np.empty((T, self.N, 3))
        out_t = times.copy()
        if info.name == "whfast" and self._m[0] <= 0:
            raise InvalidInputError(
                f"WHFast needs particle 0 to be the massive central body ({self.coordinates} "
                "coordinates): add the star first."
            )
        try:
            while True:
                self._ensure_buf()
                fn, params = self._force_args()
                self._istate[_nc.I_PARALLEL] = 1 if self._use_parallel() else 0
                self._istate[_nc.I_VELOCITY_DEPENDENT] = int(
                    any(f.velocity_dependent for f in self._forces)
                )
                self._massive = _gravity.massive_indices(self._m)
                if progress:
                    self._istate[_nc.I_STOP_AT_STEP] = self._istate[_nc.I_STEPS] + 2000
                else:
                    self._istate[_nc.I_STOP_AT_STEP] = 0
                done0 = int(self._istate[_nc.I_NOUT])
                status = int(info.kernel()(
                    self._x, self._v, self._m, self._massive, self._radius, self._fstate,
                    self._istate, self._buf, self._gwork(), fn, params, times, out_t, chunk_x, chunk_v,
                ))
                done = int(self._istate[_nc.I_NOUT])
                if done > done0:
                    out_x[done0:done, alive] = chunk_x[done0:done]
                    out_v[done0:done, alive] = chunk_v[done0:done]
                if bar is not None:
                    bar.n = abs(self.t - t_start)
                    bar.refresh()
                if status == _st.OK:
                    if not (np.all(np.isfinite(self._x)) and np.all(np.isfinite(self._v))):
                        self._raise_non_finite()
                    break
                if status == _nc.PAUSED:
                    continue
                if status == _st.COLLISION and self.collision in ("merge", "bounce"):
                    i, j = int(self._istate[_nc.I_EVENT_A]), int(self._istate[_nc.I_EVENT_B])
                    from .collisions import resolve

                    removed = resolve(self, i, j)
                    if removed is not None:
                        alive = np.delete(alive, removed)
                        chunk_x = np.empty((T, self.N, 3))
                        chunk_v = np.empty((T, self.N, 3))
                    self._istate[_nc.I_FRESH] = 1
                    continue
                self._raise_event(status)
        finally:
            self._istate[_nc.I_STOP_AT_STEP] = 0
            if bar is not None:
                bar.close()
        if scalar:
            return None
        return Trajectory(out_t, out_x, out_v, masses0, self.G, self.softening)

    def _raise_non_finite(self):
        self._check_not_coincident(f"{self.integrator} integration")
        raise InvalidStateError(
            f"the {self.integrator} integration produced NaN or infinite accelerations, "
            f"positions or velocities (by t = {fmt_number(self.t)}): a force overflowed or was singular. "
            "To fix: check the additional forces, use a smaller dt, softening > 0, or collision "
            "detection (radius=..., collision='merge')."
        )

    def _check_not_coincident(self, what):
        """Raise InvalidStateError when massive particles share a position without softening."""
        pairs = coincident_pairs(self._x, self._m, self._fstate[_nc.F_SOFT2])
        if pairs:
            raise InvalidStateError(
                f"{what}: particles {pairs[0]} are at exactly the same position "
                f"{self._x[pairs[0][0]].tolist()} at t = {fmt_number(self.t)}, where the point-mass "
                "gravity (and the potential energy) is infinite. To fix: separate them, set "
                "softening > 0, or give them radii with collision='merge'."
            )

    def _gwork(self):
        w = getattr(self, "_gwork_arr", None)
        if w is None or w.shape[1] != self.N:
            w = self._gwork_arr = np.zeros((7, self.N))
        return w

    def _raise_event(self, status):
        from ..errors import STATUS_TABLE, Encounter, Escape

        a, b = int(self._istate[_nc.I_EVENT_A]), int(self._istate[_nc.I_EVENT_B])
        if status in (_st.COLLISION, _st.ENCOUNTER, _st.ESCAPE):
            cls = {_st.COLLISION: Collision, _st.ENCOUNTER: Encounter, _st.ESCAPE: Escape}[status]
            what = STATUS_TABLE[status][1]
            parts = (a,) if b < 0 else (a, b)
            raise cls(f"{what} at t = {fmt_number(self.t)}: particles {parts}. The simulation stopped "
                      "there and can be continued.", t=self.t, particles=parts)
        if status == _st.STEP_TOO_SMALL:
            self._check_not_coincident(f"{self.integrator} integration")
            floor = float(self._fstate[_nc.F_DT_FLOOR])
            failed = float(self._fstate[_nc.F_DT_FAILED])
            detail = (f" (proposed step {failed:.3g} < floor {floor:.3g})" if floor > 0 else "")
            raise StepSizeError(
                f"{self.integrator} integration stopped at t = {fmt_number(self.t)}: the adaptive step fell "
                f"below its floor{detail}, the larger of min_dt and 1e-15 times max(|t|, time "
                "span): the run could not finish. Particles are probably (nearly) colliding or a "
                "force is singular. To fix: give the particles radii and collision='merge' or "
                "'bounce' (or 'halt'), set softening > 0, separate the particles, or integrate a "
                "shorter span."
            )
        if status == _st.NON_FINITE:
            self._raise_non_finite()
        raise_for_status(np.array([status]), f"{self.integrator} integration to t")

    # ---- diagnostics -----------------------------------------------------------------------------
    def energy(self, include_offset: bool = True) -> float:
        """Total energy (kinetic plus potential, simulation units).

        With ``include_offset`` the energy removed by mergers and inelastic bounces
        (``energy_offset``) is added back, so that the sum stays constant.
        """
        self._check_not_coincident("energy")
        E = float(_gravity.energy(self._x, self._v, self._m, self.G, self._fstate[_nc.F_SOFT2]))
        return E + (self.energy_offset if include_offset else 0.0)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum ``sum m r x v`` about the origin, shape (3,)."""
        return (self._m[:, None] * np.cross(self._x, self._v)).sum(0)

    def momentum(self) -> np.ndarray:
        """Total linear momentum ``sum m v``, shape (3,)."""
        return (self._m[:, None] * self._v).sum(0)

    def center_of_mass(self) -> tuple[np.ndarray, np.ndarray]:
        """Position and velocity of the centre of mass, each shape (3,)."""
        M = self._m.sum()
        if M == 0:
            raise InvalidInputError("the particles have no mass: the centre of mass is undefined.")
        return (self._m[:, None] * self._x).sum(0) / M, (self._m[:, None] * self._v).sum(0) / M

    def move_to_com(self) -> None:
        """Shift to the centre-of-mass frame (position and velocity of the COM become zero)."""
        xc, vc = self.center_of_mass()
        self._x = np.ascontiguousarray(self._x - xc)
        self._v = np.ascontiguousarray(self._v - vc)
        self._istate[_nc.I_FRESH] = 1

    def copy(self) -> Simulation:
        """A deep copy (same state, same integrator internals)."""
        import copy

        new = copy.copy(self)
        for name in ("_x", "_v", "_m", "_radius", "_fstate", "_istate"):
            setattr(new, name, getattr(self, name).copy())
        new._buf = None if self._buf is None else self._buf.copy()
        new._forces = list(self._forces)
        new._gwork_arr = None
        return new

    def __repr__(self) -> str:
        return (f"<Simulation {self.integrator} N={self.N} (active {self.N_active}) "
                f"t={self.t:.6g} dt={self.dt:.6g} G={self.G:.6g}>")

    # ---- persistence and interop (defined in archive.py / interop.py) ------------------------------
    def save(self, path) -> None:
        """Write the complete state (integrator internals included) atomically to ``path``.

        A simulation loaded with :meth:`load` continues bit for bit. Format: see
        :mod:`visviva.nbody.archive`.
        """
        from .archive import save_simulation

        save_simulation(self, path)

    @classmethod
    def load(cls, path, forces=None) -> Simulation:
        """Read a simulation written by :meth:`save`; pass ``forces`` when user forces cannot be
        re-imported by name (functions defined in ``__main__``)."""
        from .archive import load_simulation

        return load_simulation(cls, path, forces=forces)

    def to_rebound(self):
        """A ``rebound.Simulation`` with the same particles, G, t, dt and integrator."""
        from .interop import to_rebound

        return to_rebound(self)

    @classmethod
    def from_rebound(cls, rsim, integrator=None) -> Simulation:
        """A visviva Simulation from a ``rebound.Simulation`` (particles, G, t, dt)."""
        from .interop import from_rebound

        return from_rebound(cls, rsim, integrator=integrator)
