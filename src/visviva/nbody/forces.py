"""Additional forces compiled into the integrator loop.

A force is a compiled function with the signature

    force(t, positions, velocities, masses, params, acc) -> None

that ADDS accelerations to ``acc`` (shape (N, 3)); ``params`` is a float64 array of its
parameters. Write it with ``@numba.njit`` and hand it to the simulation::

    @numba.njit
    def drag(t, x, v, m, params, acc):
        for i in range(x.shape[0]):
            for c in range(3):
                acc[i, c] -= params[0] * v[i, c]

    sim.add_force(drag, params=[1e-3], velocity_dependent=True)

The integrator kernels take the force as a first-class function (one machine code for every
force, cached on disk), so no Python runs per step. Several forces are fused into one compiled
function. Integrators that cannot take velocity-dependent forces (``leapfrog``, ``whfast``) refuse
them with a message naming the ones that can.

Built-in forces written the same way: :class:`J2Force` (oblateness of a primary),
:class:`GeneralRelativity` (1PN, single dominant mass, velocity-dependent),
:class:`GeneralRelativityPotential` (the position-only Nobili-Roxburgh potential, usable with
symplectic integrators) and :class:`LinearDrag`.
"""

from __future__ import annotations

import copy
import importlib
import math

import numpy as np

from ..constants import C_KM_S
from ..core._jit import inline_kernel, kernel
from ..core.relativity import schwarzschild
from ..errors import InvalidInputError, fmt_number
from . import settings as _s

__all__ = [
    "Force",
    "J2Force",
    "GeneralRelativity",
    "GeneralRelativityPotential",
    "LinearDrag",
    "combine",
    "follow_removal",
    "force_key",
]


class Force:
    """A compiled additional force and its parameters.

    Parameters
    ----------
    fn : numba dispatcher
        ``fn(t, positions, velocities, masses, params, acc)`` adding accelerations to ``acc``.
    params : array_like of float
        Its parameters (simulation units), passed as a float64 array.
    velocity_dependent : bool
        Whether ``fn`` reads the velocities (only IAS15 can integrate such forces).
    name : str
        Label for messages.
    """

    def __init__(self, fn, params=(), velocity_dependent=False, name=None):
        if not hasattr(fn, "py_func"):
            raise InvalidInputError(
                "a force must be a compiled function: decorate it with @numba.njit "
                "(signature fn(t, positions, velocities, masses, params, acc))."
            )
        self.fn = fn
        self.params = np.ascontiguousarray(np.atleast_1d(np.asarray(params, dtype=np.float64)))
        self.velocity_dependent = bool(velocity_dependent)
        self.name = name or getattr(fn, "__name__", "force")

    def parameters(self, sim) -> np.ndarray:
        """The parameter array for ``sim`` (built-ins compute theirs from the simulation)."""
        return self.params

    def spec(self) -> dict:
        """What :meth:`visviva.Simulation.save` stores to rebuild this force."""
        return {
            "class": f"{type(self).__module__}:{type(self).__qualname__}",
            "fn": f"{self.fn.py_func.__module__}:{self.fn.py_func.__qualname__}",
            "params": self.params.tolist(),
            "velocity_dependent": self.velocity_dependent,
            "name": self.name,
            "init": self._init_args(),
        }

    def _init_args(self):
        """The constructor arguments that rebuild this force as it is NOW (its attributes may
        have been changed since it was made), JSON-ready; None: rebuild from ``fn`` and
        ``params``. Quantities are stored as ``{"value": ..., "unit": ...}``."""
        return None

    def particle_removed(self, index: int, merged_into: int | None = None) -> None:
        """Follow the removal of particle ``index`` (later indices shift down by one; a merger
        passes the particle it went into). A plain force knows no particle indices: a user's
        force whose parameters name particles must be updated by its owner, or override this
        method (:meth:`visviva.Simulation.remove` warns while one does not)."""

    def copy(self) -> Force:
        """An independent copy (its own parameter array): changing the copy's parameters or
        attributes leaves this force alone (:meth:`visviva.Simulation.copy` copies its forces)."""
        new = copy.copy(self)
        new.params = self.params.copy()
        return new

    @staticmethod
    def from_spec(spec) -> Force:
        cls_mod, cls_name = spec["class"].split(":")
        cls = getattr(importlib.import_module(cls_mod), cls_name)
        if spec.get("init") is not None and cls is not Force:
            return cls(**{k: _decode(v) for k, v in spec["init"].items()})
        mod, name = spec["fn"].split(":")
        if "<locals>" in name or mod == "__main__":
            raise ImportError(name)
        fn = importlib.import_module(mod)
        for part in name.split("."):
            fn = getattr(fn, part)
        return Force(fn, spec["params"], spec["velocity_dependent"], spec["name"])

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, velocity_dependent={self.velocity_dependent})"


def _encode(value):
    """A constructor argument for JSON: a Quantity as ``{"value", "unit"}``, else a float."""
    if hasattr(value, "unit"):
        return {"value": float(value.value), "unit": value.unit.to_string()}
    return float(value)


def _decode(value):
    """The inverse of :func:`_encode`."""
    if isinstance(value, dict) and set(value) == {"value", "unit"}:
        from astropy import units as u

        return float(value["value"]) * u.Unit(value["unit"])
    return value


def combine(fns, sizes, jit=None):
    """Fuse several compiled forces into one compiled function with concatenated parameters.

    The fused function is a closure over the forces, compiled with visviva's numba flags except
    the on-disk cache (closures cannot be cached; compiling it takes a fraction of a second), or
    with ``jit`` when given (``numba.cuda.jit(device=True)`` fuses the forces' device twins for
    the GPU ensembles: :mod:`visviva.nbody.gpu_forces`).
    """
    import numba

    from ..core._jit import _FLAGS

    if len(fns) == 1:
        return fns[0]
    head, rest = fns[0], combine(fns[1:], sizes[1:], jit)
    split = int(sizes[0])

    def both(t, x, v, m, params, acc):
        head(t, x, v, m, params[:split], acc)
        rest(t, x, v, m, params[split:], acc)

    return (jit or numba.njit(**{**_FLAGS, "cache": False}))(both)


def force_key(sim) -> tuple:
    """What identifies ``sim``'s additional forces for one compiled call over several
    simulations: each force's compiled function and the length of its parameters.

    Members with equal keys share one fused force (:func:`combine` bakes the split of the
    concatenated parameters into the fused function), so the lengths belong to the key: two
    members with the same functions but parameters of different lengths need two calls.
    """
    return tuple((id(f.fn), len(f.parameters(sim))) for f in sim.forces)


# ---- built-in forces -----------------------------------------------------------------------------


@inline_kernel
def _about_primary(pair, x, v, m, p, acc, c0, c1, c2):
    """Add a force of the primary ``p`` on every other particle, and its reaction on ``p``.

    Parameters
    ----------
    pair : compiled function
        ``pair(dx, dy, dz, dvx, dvy, dvz, c0, c1, c2) -> (ax, ay, az)``: the acceleration of a
        particle at relative position ``d`` and relative velocity ``dv`` (simulation units).
    x, v : ndarray, shape (N, 3)
        Positions and velocities (simulation units).
    m : ndarray, shape (N,)
        Masses (simulation units).
    p : int
        Index of the primary.
    acc : ndarray, shape (N, 3)
        Accelerations (simulation units), updated in place.
    c0, c1, c2 : float
        Constants handed to ``pair``.

    Notes
    -----
    ``acc[i] += a_i`` and ``acc[p] -= (m_i / m_p) a_i`` for ``i != p``, so that the total momentum
    is conserved (Newton's third law); a massless primary feels nothing.
    """
    for i in range(x.shape[0]):
        if i == p:
            continue
        ax, ay, az = pair(x[i, 0] - x[p, 0], x[i, 1] - x[p, 1], x[i, 2] - x[p, 2],
                          v[i, 0] - v[p, 0], v[i, 1] - v[p, 1], v[i, 2] - v[p, 2], c0, c1, c2)
        acc[i, 0] += ax
        acc[i, 1] += ay
        acc[i, 2] += az
        if m[p] != 0.0:
            q = m[i] / m[p]
            acc[p, 0] -= q * ax
            acc[p, 1] -= q * ay
            acc[p, 2] -= q * az


@inline_kernel
def _j2_pair(dx, dy, dz, dvx, dvy, dvz, j2, gm, R):
    """J2 acceleration at ``d`` from a primary of ``gm``, radius ``R`` (see :class:`J2Force`)."""
    r2 = dx * dx + dy * dy + dz * dz
    r = math.sqrt(r2)
    k = -1.5 * j2 * gm * R * R / (r2 * r2 * r)
    z2 = 5.0 * dz * dz / r2
    return k * dx * (1.0 - z2), k * dy * (1.0 - z2), k * dz * (3.0 - z2)


@kernel
def j2_force(t, x, v, m, params, acc):
    """J2 of particle ``params[1]`` (pole along z): params = [G, index, J2, R]."""
    p = int(params[1])
    _about_primary(_j2_pair, x, v, m, p, acc, params[2], params[0] * m[p], params[3])


@inline_kernel
def _gr_pair(dx, dy, dz, dvx, dvy, dvz, mu, c2, unused):
    """1PN acceleration at ``d``, ``dv`` (see :class:`GeneralRelativity`); ``c2 = c**2``."""
    return schwarzschild(dx, dy, dz, dvx, dvy, dvz, mu, c2)


@kernel
def gr_force(t, x, v, m, params, acc):
    """1PN correction of a dominant mass ``params[1]``: params = [G, index, c]."""
    p = int(params[1])
    _about_primary(_gr_pair, x, v, m, p, acc, params[0] * m[p], params[2] * params[2], 0.0)


@inline_kernel
def _gr_potential_pair(dx, dy, dz, dvx, dvy, dvz, mu, c2, unused):
    """Nobili-Roxburgh acceleration ``-6 mu**2 d / (c2 r**4)`` at ``d``; ``c2 = c**2``."""
    r2 = dx * dx + dy * dy + dz * dz
    k = -6.0 * mu * mu / (c2 * r2 * r2)
    return k * dx, k * dy, k * dz


@kernel
def gr_potential_force(t, x, v, m, params, acc):
    """Nobili-Roxburgh potential -3 (G M)**2 / (c r)**2 of mass ``params[1]``: [G, index, c]."""
    p = int(params[1])
    _about_primary(_gr_potential_pair, x, v, m, p, acc, params[0] * m[p], params[2] * params[2],
                   0.0)


@kernel
def linear_drag_force(t, x, v, m, params, acc):
    """a_i -= gamma v_i for every particle: params = [gamma]."""
    g = params[0]
    for i in range(x.shape[0]):
        acc[i, 0] -= g * v[i, 0]
        acc[i, 1] -= g * v[i, 1]
        acc[i, 2] -= g * v[i, 2]


def _positive(sim, value, kind: str, what: str) -> float:
    """``value`` (simulation units, or a Quantity of ``kind`` when the simulation has units) as
    a finite float > 0, or an InvalidInputError naming ``what`` (a zero radius or ``c`` made
    the force vanish or blow up, and a negative one squared to a positive one in silence)."""
    x = _s.scalar(_s.convert(sim, value, kind, what), what)
    if not (math.isfinite(x) and x > 0):
        raise InvalidInputError(f"{what} must be finite and > 0; got {fmt_number(x)}.")
    return x


def _speed_of_light(sim, c):
    if c is not None:
        return _positive(sim, c, "speed", "the speed of light c")
    if sim.units is None:
        raise InvalidInputError(
            "the speed of light in simulation units is unknown: pass c=... or create the "
            "Simulation with units=(length, time, mass)."
        )
    return C_KM_S / (sim.units.length_km / sim.units.time_s)


def _primary_index(sim, force) -> int:
    """The primary of ``force`` (a :class:`J2Force` or relativistic force) as an index of a
    massive particle of ``sim``, checked: the kernels do not check indices, so a primary out of
    range read another particle's or unallocated memory, and a massless one added nothing."""
    p = force.primary
    if not 0 <= p < sim.N:
        raise InvalidInputError(
            f"the {force.name} force's primary is particle {p}, but the simulation has {sim.N} "
            f"particle(s) (indices 0 to {sim.N - 1}): set force.primary to the index of the "
            "body it belongs to.")
    if not sim.masses[p] > 0:
        raise InvalidInputError(
            f"the {force.name} force's primary, particle {p}, has no mass, so the force would be "
            "zero: set force.primary to the index of the massive body it belongs to.")
    return p


class _OfPrimary(Force):
    """A force of one particle, ``self.primary``, whose index follows removals and mergers."""

    primary: int

    def particle_removed(self, index, merged_into=None):
        if self.primary == index:
            if merged_into is None:
                raise InvalidInputError(
                    f"particle {index} is the primary of the {self.name} force: remove that "
                    "force first (sim.clear_forces(), then add the others again), or point it "
                    "at another body (force.primary = ...).")
            self.primary = int(merged_into)
        elif self.primary > index:
            self.primary -= 1


def follow_removal(forces, index: int, merged_into: int | None = None, *,
                   stacklevel: int = 2) -> None:
    """Let every force follow the removal of particle ``index`` (``merged_into``: the particle
    a merger put it into); a force that would lose its body raises before any force changes.

    Forces that do not override :meth:`Force.particle_removed` (a user's plain ``Force``) cannot
    follow: one RuntimeWarning names them, since parameters naming particle indices above
    ``index`` now point at the next particle (``stacklevel``: where the warning points; 2:
    the caller of :meth:`visviva.Simulation.remove`)."""
    if merged_into is None:
        for force in forces:
            if getattr(force, "primary", None) == index:
                force.particle_removed(index)  # raises, saying what to do
    for force in forces:
        force.particle_removed(index, merged_into)
    blind = [f.name for f in forces if type(f).particle_removed is Force.particle_removed]
    if blind:
        import warnings

        warnings.warn(
            f"particle {index} was removed and the indices above it shifted down by one, but "
            f"the force(s) {', '.join(repr(n) for n in blind)} cannot follow (a Force that does "
            "not override particle_removed): if their params name particle indices, update "
            "them (force.params), or subclass Force and override particle_removed(index, "
            "merged_into) to renumber them.", RuntimeWarning, stacklevel=stacklevel + 1)


class J2Force(_OfPrimary):
    """Oblateness (J2) of particle ``primary``, pole along the z axis (an N-body force).

    Not to be confused with :class:`visviva.J2`, the Cowell perturbation of a satellite's orbit.
    ``visviva.nbody.J2`` is a deprecated alias of this class (one release).

    ``a = -(3/2) J2 G M R**2 / r**5 [x (1 - 5 z**2/r**2), y (1 - 5 z**2/r**2),
    z (3 - 5 z**2/r**2)]`` relative to the primary; the primary feels the reaction (momentum is
    conserved). Reference: Vallado (2013) eq. 8-37. ``radius`` in simulation units or a Quantity.
    """

    def __init__(self, primary, j2, radius):
        super().__init__(j2_force, (), False, "J2")
        if radius is None:  # files saved before 2026-11-27 stored a Quantity radius as null
            raise InvalidInputError(
                "J2Force needs the primary's equatorial radius (simulation units or a "
                "Quantity); got None. For a file saved with a Quantity radius by an older "
                "visviva, pass the force again: Simulation.load(path, forces=[J2Force(...)]).")
        self.primary, self.j2, self.radius = int(primary), float(j2), radius
        if not math.isfinite(self.j2):
            raise InvalidInputError(f"J2Force: j2 must be a finite number; got {j2!r}.")

    def _init_args(self):
        return {"primary": int(self.primary), "j2": float(self.j2),
                "radius": _encode(self.radius)}

    def parameters(self, sim):
        return np.array([sim.G, _primary_index(sim, self), self.j2,
                         _positive(sim, self.radius, "length", "the J2Force radius")])


class _Relativistic(_OfPrimary):
    """A relativistic correction of the mass ``primary``; ``c`` in simulation units or None.

    Parameters
    ----------
    primary : int
        Index of the dominant mass.
    c : float or Quantity, optional
        Speed of light in simulation units (or a Quantity of speed); derived from the
        simulation's units when None.
    """

    _kernel = _velocity_dependent = _label = None  # set by each subclass

    def __init__(self, primary=0, c=None):
        super().__init__(type(self)._kernel, (), self._velocity_dependent, self._label)
        self.primary, self.c = int(primary), c

    def _init_args(self):
        return {"primary": int(self.primary), "c": None if self.c is None else _encode(self.c)}

    def parameters(self, sim):
        return np.array([sim.G, _primary_index(sim, self), _speed_of_light(sim, self.c)])


class GeneralRelativity(_Relativistic):
    """First post-Newtonian correction of a dominant mass (velocity-dependent; IAS15 only).

    ``a = G M / (c**2 r**3) [(4 G M / r - v**2) r + 4 (r . v) v]`` with ``r, v`` relative to the
    primary (Anderson et al. 1975; the single-body 1PN approximation used for Mercury's 43"/cy).
    """

    _kernel, _velocity_dependent, _label = gr_force, True, "GR (1PN)"


class GeneralRelativityPotential(_Relativistic):
    """Nobili & Roxburgh (1986) potential ``-3 (G M)**2 / (c r)**2``: positions only.

    Reproduces the 1PN perihelion precession ``6 pi G M / (c**2 a (1 - e**2))`` per orbit and is
    usable with the symplectic integrators.
    """

    _kernel, _velocity_dependent, _label = gr_potential_force, False, "GR potential"


class LinearDrag(Force):
    """Linear drag ``a = -gamma v`` on every particle (velocity-dependent; IAS15 only)."""

    def __init__(self, gamma):
        if not math.isfinite(float(gamma)):  # a NaN run otherwise, blamed on the integration
            raise InvalidInputError(f"LinearDrag: gamma must be a finite number; got {gamma!r}.")
        super().__init__(linear_drag_force, (float(gamma),), True, "linear drag")

    def _init_args(self):
        return {"gamma": float(self.params[0])}

    def particle_removed(self, index, merged_into=None):
        """Nothing to renumber: the drag acts on every particle alike."""


def __getattr__(name):
    # the old name, kept for one release (and for files saved with it)
    if name == "J2":
        from .._deprecation import deprecated_alias

        return deprecated_alias("visviva.nbody.J2", "visviva.nbody.J2Force", J2Force)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
