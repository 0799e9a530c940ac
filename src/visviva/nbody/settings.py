"""The settings of a :class:`visviva.Simulation`, each one slot of its state.

A setting is a :class:`Setting` descriptor: where its value lives in the simulation's
:class:`~visviva.nbody.state.SimulationState` (a slot of ``fstate``/``istate`` or a field), how a
user value is checked and converted (``encode``, which raises a clear error), how the stored value
reads back (``decode``), and whether a change restarts the integrator's internal state. The
class body of :class:`~visviva.Simulation` lists them one line each.

The unit helpers (:func:`convert`, :func:`length`, :func:`scalar`) turn a float or an astropy
Quantity into simulation units with the simulation's :class:`~visviva.nbody.units.SimulationUnits`.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInputError, ShapeError, fmt_number
from .integrators import COORDINATES, parse_coordinates

__all__ = ["Setting", "convert", "length", "scalar", "COLLISION_MODES"]

#: What happens when two particles touch (their radii overlap while approaching).
COLLISION_MODES = ("none", "halt", "merge", "bounce")


def scalar(arr, name) -> float:
    """A single float from a converted value, or a ShapeError saying what to pass."""
    arr = np.asarray(arr)
    if arr.size != 1:
        raise ShapeError(f"{name} must be a single number; got an array of shape {arr.shape}.")
    return float(arr.reshape(()))


def convert(sim, value, kind, name):
    """``value`` (a number, an array or a Quantity of ``kind``) in simulation units, finite."""
    if kind == "time" and type(value).__name__ == "TimeDelta":  # a duration, as a Quantity
        value = value.to("s")
    if hasattr(value, "unit"):
        if sim.units is None:
            from ..errors import UnitsError

            raise UnitsError(
                f"{name} is a Quantity but the simulation has no units: create it with "
                "units=('au', 'yr', 'Msun') (any length, time, mass), or pass plain floats."
            )
        return getattr(sim.units, f"{kind}_value")(value, name)
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


def length(sim, value, name) -> float:
    """One length in simulation units."""
    return scalar(convert(sim, value, "length", name), name)


def mass(sim, value, name="m") -> float:
    """One mass in simulation units, finite and >= 0 (0: a test particle)."""
    m = scalar(convert(sim, value, "mass", name), name)
    if not m >= 0:
        raise InvalidInputError(f"mass must be >= 0; got {fmt_number(value)}.")
    return m


def vector3(sim, value, kind, name) -> np.ndarray:
    """A position (``kind="length"``) or velocity (``"speed"``) of shape (3,), simulation units."""
    arr = np.asarray(convert(sim, value, kind, name), dtype=np.float64).reshape(-1)
    if arr.shape != (3,):
        raise ShapeError(f"{name} must have shape (3,); got {arr.shape}.")
    return arr


def radius(sim, value, name="radius") -> float:
    """A collision radius in simulation units, >= 0."""
    rad = length(sim, value, name)
    if not rad >= 0:
        raise InvalidInputError(f"{name} must be >= 0; got {fmt_number(value)}.")
    return rad


def particle_index(sim, index, role: str = "") -> int:
    """``index`` as the index of an existing particle of ``sim`` (negative counts from the end),
    or a particle's name in ``sim.names`` (REBOUND's ``sim.remove(hash="jupiter")``); ``role``
    (e.g. ``"primary"``) starts the message of a name not found."""
    if isinstance(index, str):
        names = getattr(sim, "names", None) or []
        found = [k for k, name in enumerate(names) if name and name == index]
        if len(found) != 1:
            what = (f"{len(found)} particles are named {index!r} (indices {found})" if found
                    else f"no particle is named {index!r}")
            raise InvalidInputError(
                f"{role + ': ' if role else ''}{what}; the names are {[n for n in names if n]}: give an index instead.")
        return found[0]
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise InvalidInputError(
            f"a particle index must be an integer; got {index!r} (a {type(index).__name__}).")
    n = sim.N
    if not -n <= index < n:
        raise IndexError(f"particle {index} is out of range: the simulation has {n} particle(s).")
    return int(index) % n


def removal(sim, index, merged_into) -> tuple:
    """``(k, j)`` for ``sim.remove(index, merged_into=...)``: the index ``k`` of the particle to
    remove, and ``merged_into`` (another particle, numbered before the removal) in the
    numbering after it, which the forces keep (None stays None)."""
    k = particle_index(sim, index)
    if merged_into is None:
        return k, None
    j = particle_index(sim, merged_into)
    if j == k:
        raise InvalidInputError(
            f"merged_into = {merged_into!r} is the particle being removed (index {k}); name "
            "the particle it went into.")
    return k, j - (j > k)


class Setting:
    """A simulation setting stored in the simulation's state object.

    Parameters
    ----------
    where : str
        ``"fstate"`` or ``"istate"`` (then ``index`` is the slot) or the name of a field of
        :class:`~visviva.nbody.state.SimulationState`.
    index : int, optional
        The slot in ``fstate``/``istate``.
    doc : str
        The docstring users see.
    decode : callable, optional
        Stored value -> what the attribute returns (default: unchanged).
    encode : callable, optional
        ``encode(sim, value, name)`` -> the value to store, raising on bad input; None makes the
        setting read-only.
    fresh : bool
        A change makes the integrator rebuild its internal state.
    """

    def __init__(self, where, index=None, *, doc="", decode=None, encode=None, fresh=False):
        self.where = where
        self.index = index
        self.decode = decode
        self.encode = encode
        self.fresh = fresh
        self.__doc__ = doc

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, sim, owner=None):
        if sim is None:
            return self
        value = getattr(sim._state, self.where)
        if self.index is not None:
            value = value[self.index]
        return value if self.decode is None else self.decode(value)

    def __set__(self, sim, value):
        if self.encode is None:
            raise AttributeError(f"Simulation.{self.name} is read-only.")
        stored = self.encode(sim, value, self.name)
        state = sim._state
        if self.index is None:
            setattr(state, self.where, stored)
        else:
            getattr(state, self.where)[self.index] = stored
        if self.fresh:
            state.mark_fresh()


# ---- encoders: user value -> stored value, with the error that says what to pass -----------------
def time_scalar(sim, value, name) -> float:
    """A finite time (or time step) in simulation units."""
    dt = scalar(convert(sim, value, "time", name), name)
    if not math.isfinite(dt):
        raise InvalidInputError(f"{name} must be finite; got {fmt_number(dt)}.")
    return dt


def nonnegative_time(sim, value, name) -> float:
    dt = time_scalar(sim, value, name)
    if not dt >= 0:
        raise InvalidInputError(f"{name} must be a finite number >= 0; got {fmt_number(value)}.")
    return dt


def softening_squared(sim, value, name) -> float:
    s = float(length(sim, value, name))
    if not (math.isfinite(s) and s >= 0):
        raise InvalidInputError(f"{name} must be >= 0; got {fmt_number(value)}.")
    return s * s


def epsilon(sim, value, name) -> float:
    hint = "(IAS15's accuracy parameter; e.g. 1e-9)"
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a finite number > 0 {hint}; got {fmt_number(value)}.") from exc
    if not (math.isfinite(x) and x > 0):
        raise InvalidInputError(f"{name} must be a finite number > 0 {hint}; got {fmt_number(value)}.")
    return x


def _distance(sim, value, name, allow_zero):
    if value is None:
        return 0.0
    d = length(sim, value, name)
    if not (d > 0 or (allow_zero and d == 0)):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidInputError(
            f"{name} must be a distance {bound} (or None to switch the check off); got {fmt_number(value)}."
        )
    return d


def distance_or_off(sim, value, name) -> float:
    """A distance >= 0, or None (stored as 0: the check is off)."""
    return _distance(sim, value, name, allow_zero=True)


def positive_distance_or_off(sim, value, name) -> float:
    """A distance > 0, or None (stored as 0: the check is off)."""
    return _distance(sim, value, name, allow_zero=False)


def off_when_zero(d):
    return None if d <= 0 else float(d)


def restitution(sim, value, name) -> float:
    value = float(value)
    if not 0.0 <= value <= 1.0:
        raise InvalidInputError(f"{name} must be in [0, 1]; got {fmt_number(value)}.")
    return value


def corrector(sim, order, name) -> int:
    if isinstance(order, bool) or order not in (0, 3, 5, 7):  # 3.5 was truncated to 3
        raise InvalidInputError(f"corrector must be 0, 3, 5 or 7; got {order!r}.")
    order = int(order)
    if order != 0 and sim.coordinates != "jacobi":
        raise InvalidInputError(
            f"corrector={order}: the symplectic correctors are derived for the Jacobi "
            f"splitting (Kepler + interaction) and do not apply to {sim.coordinates!r} "
            "coordinates; use corrector=0, or coordinates='jacobi'."
        )
    return order


def coordinates(sim, name, _name) -> int:
    key = parse_coordinates(name, sim.integrator_info)
    if key != "jacobi" and sim.corrector != 0:
        raise InvalidInputError(
            f"coordinates={name!r} with corrector={sim.corrector}: the symplectic "
            "correctors apply to Jacobi coordinates only; set corrector=0 first."
        )
    return COORDINATES[key]


def coordinates_name(code) -> str:
    return next(k for k, v in COORDINATES.items() if v == int(code))


def adaptive_mode(sim, mode, name) -> int:
    if mode not in ("prs23", "rs15", "global"):
        raise InvalidInputError(
            f"adaptive_mode must be 'prs23' (default) or 'rs15' (alias 'global'); got {mode!r}."
        )
    return 1 if mode == "prs23" else 0


def flag(sim, value, name) -> int:
    return 1 if value else 0


def energy_offset(sim, value, name) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a finite number; got {fmt_number(value)}.") from exc
    if not math.isfinite(value):  # NaN would hide in energy()
        raise InvalidInputError(f"{name} must be a finite number; got {fmt_number(value)}.")
    return value

