"""Conversion to and from REBOUND (``pip install rebound``; tested with REBOUND 5.2).

Particles (mass, position, velocity, radius), ``G``, ``t`` and ``dt`` are copied exactly (the
same float64 values). The units travel by name (``sim.units`` <-> REBOUND's ``sim.units``:
``("au", "yr", "Msun")`` <-> ``("au", "yr", "msun")``, ...), ``G`` staying the copied value;
a REBOUND unit astropy has no name for (``yr2pi``, ``mmars``) becomes a scaled unit
(``"5022642.89091303 s"``) with REBOUND's value, and a visviva unit REBOUND has no name for
leaves the REBOUND copy without units, with a warning. The integrator is mapped by name (``leapfrog``, ``whfast``, ``ias15``), and
WHFast's coordinates with it (visviva's ``"jacobi"`` / ``"democratic_heliocentric"`` <-> REBOUND's
``"jacobi"`` / ``"democraticheliocentric"``; REBOUND's WHDS and barycentric WHFast have no visviva
counterpart and are refused). The integrator settings that both codes have travel too: WHFast's
``corrector`` (0, 3, 5, 7; REBOUND's 11 and 17 are refused), IAS15's ``epsilon`` (REBOUND's
``epsilon = 0``, fixed steps, is refused), ``adaptive_mode`` (``"prs23"`` <-> ``"prs23"``,
``"rs15"`` <-> ``"global"``; REBOUND's ``"individual"`` and ``"aarseth85"`` are refused) and
``min_dt`` (a floor in both; visviva raises :class:`~visviva.StepSizeError` at it where REBOUND
keeps stepping), ``exact_finish_time``, ``softening``, ``encounter_distance`` <-> REBOUND's
``exit_min_distance`` and ``exit_max_distance``. ``collision="halt"``/``"merge"``/``"bounce"``
become REBOUND's direct detection with the ``"halt"``/``"merge"``/``"hardsphere"`` resolver.
What cannot travel is said, not dropped in silence: ``to_rebound`` warns about additional forces,
inelastic bounces and a MEGNO state, ``from_rebound`` about variational particles, about
REBOUND's collision detection (its resolver function cannot be read back) and its additional forces and timestep modifications (a callback or
REBOUNDx: the copy integrates gravity alone), and refuses massive test particles that pull
(``testparticle_type = 1``) and ``gravity = "none"``.
The particles' names (``sim.names``, as :func:`~visviva.nbody.solar_system` sets them) travel
as REBOUND's particle names (``particle.name``, so ``rsim.particles["earth"]`` finds them) and
come back into ``sim.names`` (``""`` for a particle REBOUND has no name for); a REBOUND without
``particle.name`` (older versions) gets them as hashes, which cannot be read back.
Integrator internals (IAS15's b arrays, ...) are not transferred: the first step in the other
code starts fresh.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core.nbody_common import I_MEGNO
from ..errors import InvalidInputError

__all__ = ["to_rebound", "from_rebound"]

#: visviva's WHFast coordinates -> REBOUND's ``integrator.coordinates``.
_REBOUND_COORDINATES = {"jacobi": "jacobi", "democratic_heliocentric": "democraticheliocentric"}
#: visviva's IAS15 ``adaptive_mode`` -> REBOUND's.
_REBOUND_ADAPTIVE = {"prs23": "prs23", "rs15": "global"}
#: visviva's ``collision`` -> REBOUND's ``collision_resolve`` (with ``collision = "direct"``).
_REBOUND_RESOLVE = {"halt": "halt", "merge": "merge", "bounce": "hardsphere"}


#: visviva's (astropy's) unit names -> REBOUND's.
_REBOUND_UNITS = {"m": "m", "cm": "cm", "km": "km", "au": "au", "pc": "pc", "s": "s", "h": "hr",
                  "day": "day", "yr": "yr", "kyr": "kyr", "Myr": "myr", "Gyr": "gyr", "kg": "kg",
                  "g": "g", "Msun": "msun", "Mearth": "mearth", "Mjup": "mjupiter"}
#: REBOUND's other spellings of the same units.
_REBOUND_ALIASES = {"aus": "au", "parsec": "pc", "d": "day", "days": "day", "year": "yr",
                    "years": "yr", "yrs": "yr", "jyr": "yr", "gram": "g", "solarmass": "Msun",
                    "sunmass": "Msun", "msolar": "Msun"}


def _units_from_rebound(rsim):
    """visviva unit names for REBOUND's ``rsim.units`` (None when REBOUND has none)."""
    from rebound import units as ru

    units = rsim.units
    names = [units.get(k) for k in ("length", "time", "mass")]
    if any(n is None for n in names):
        return None
    back = {v: k for k, v in _REBOUND_UNITS.items()} | _REBOUND_ALIASES
    tables = ((ru.lengths_SI, "m"), (ru.times_SI, "s"), (ru.masses_SI, "kg"))
    return tuple(back.get(n) or f"{table[n]!r} {si}"
                 for n, (table, si) in zip(names, tables, strict=True))


def _units_to_rebound(sim, r):
    """Set REBOUND's units on ``r`` from ``sim.units`` (before G and the particles)."""
    from rebound import units as ru

    if sim.units is None:
        return
    names = []
    for name, table, scale in ((sim.units.length, ru.lengths_SI, sim.units.length_km * 1e3),
                               (sim.units.time, ru.times_SI, sim.units.time_s),
                               (sim.units.mass, ru.masses_SI, sim.units.mass_kg)):
        match = _REBOUND_UNITS.get(name) or next(
            (k for k, v in table.items() if abs(v - scale) <= 1e-12 * scale), None)
        names.append(match)
    if None in names:
        warnings.warn(f"to_rebound: REBOUND has no name for the units {sim.units.as_tuple()}; "
                      "the copy has the same G but no units.", UserWarning, stacklevel=3)
        return
    r.units = tuple(names)


def _from_rebound(table: dict, value, what: str, attribute: str) -> str:
    """The visviva name of REBOUND's setting ``value`` in ``table`` (visviva -> REBOUND names),
    or :class:`~visviva.errors.InvalidInputError` naming what to set in REBOUND."""
    back = {v: k for k, v in table.items()}
    name = str(value).lower()
    if name not in back:
        raise InvalidInputError(
            f"REBOUND's {what} {name!r} has no visviva counterpart; set "
            f"rsim.integrator.{attribute} to one of {sorted(back)} first."
        )
    return back[name]


#: REBOUND 5.2.2's WHFast with softening converges to neither its IAS15 with the same softening
#: nor without it (a star with companions of 0.5 and 0.1 at a = 0.3 and 2, softening 0.2, t = 5:
#: 4.9 from the softened IAS15 run), while visviva's converges to the softened IAS15 at 2nd order.
_WHFAST_SOFTENING = ("REBOUND's WHFast does not soften the dynamics as its IAS15 does (measured: "
                     "it converges to neither the softened nor the unsoftened trajectory)")


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
    _units_to_rebound(sim, r)
    r.G = sim.G
    m, xs, vs, radii = sim.masses, sim.positions, sim.velocities, sim.radii
    for k in range(sim.N):
        x, v = xs[k], vs[k]
        r.add(m=float(m[k]), x=float(x[0]), y=float(x[1]), z=float(x[2]),
              vx=float(v[0]), vy=float(v[1]), vz=float(v[2]), r=float(radii[k]))
    _names_to_rebound(getattr(sim, "names", None), r)
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
    _settings_to_rebound(sim, r)
    return r


def _names_to_rebound(names, r):
    """``sim.names`` as the names of the REBOUND particles (hashes in a REBOUND without names);
    ``""`` (no name) is skipped."""
    if not names:
        return
    has_names = isinstance(getattr(type(r.particles[0]), "name", None), property)
    for k, name in enumerate(names[: r.N]):
        if name:
            if has_names:
                r.particles[k].name = str(name)
            else:  # pragma: no cover - older REBOUND: a hash, which cannot be read back
                r.particles[k].hash = str(name)


def _names_from_rebound(rsim):
    """The REBOUND particles' names as a list for ``sim.names`` (``""`` where a particle has
    none), or None when none has a name (or REBOUND keeps only hashes)."""
    names = [getattr(p, "name", None) or "" for p in rsim.particles]
    return names if any(names) else None


def _settings_to_rebound(sim, r):
    """The integrator, event and collision settings of ``sim`` on the REBOUND copy ``r``."""
    if sim.integrator == "whfast":
        r.integrator.corrector = int(sim.corrector)
    elif sim.integrator == "ias15":
        r.integrator.epsilon = float(sim.epsilon)
        r.integrator.adaptive_mode = _REBOUND_ADAPTIVE[sim.adaptive_mode]
        r.integrator.min_dt = float(sim.min_dt)
    r.exact_finish_time = int(bool(sim.exact_finish_time))
    if sim.encounter_distance is not None:
        r.exit_min_distance = float(sim.encounter_distance)
    if sim.exit_max_distance is not None:
        r.exit_max_distance = float(sim.exit_max_distance)
    lost = []
    if sim.collision != "none":
        r.collision = "direct"
        r.collision_resolve = _REBOUND_RESOLVE[sim.collision]
        if sim.collision == "bounce" and sim.restitution != 1.0:
            lost.append(f"the collision restitution {sim.restitution} (REBOUND's hard spheres "
                         "bounce elastically unless given a coefficient_of_restitution function)")
    if sim.forces:
        lost.append(f"{len(sim.forces)} additional force(s) (REBOUND needs REBOUNDx or its "
                    "additional_forces callback for them)")
    if sim.integrator == "whfast" and sim.softening > 0:
        lost.append(f"the Plummer softening in WHFast ({_WHFAST_SOFTENING})")
    if lost:
        warnings.warn("to_rebound: the REBOUND copy does not carry " + " and ".join(lost)
                      + ", so it integrates different dynamics.", UserWarning, stacklevel=3)
    if int(sim.state_arrays()["istate"][I_MEGNO]) == 1:
        warnings.warn("to_rebound: the REBOUND copy does not carry the MEGNO state (tangent "
                      "vector and sums): call init_megno() on it and set its variational "
                      "particles (rsim.var_config[0].particles) to sim.tangent_vector to start "
                      "it there.", UserWarning, stacklevel=3)


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
        coordinates = _from_rebound(_REBOUND_COORDINATES, rsim.integrator.coordinates,
                                    "WHFast coordinates", "coordinates")
    sim = cls(name, G=float(rsim.G), coordinates=coordinates)
    units = _units_from_rebound(rsim)
    if units is not None:  # G stays REBOUND's value; the units let add() take Quantities
        from .units import SimulationUnits

        sim.units = SimulationUnits.parse(units)
    sim.softening = float(rsim.softening)
    if name == "whfast" and sim.softening > 0:
        warnings.warn(f"from_rebound: {_WHFAST_SOFTENING}; the visviva copy, softened "
                      "throughout, integrates different dynamics.", UserWarning, stacklevel=3)
    _check_dynamics(rsim)
    n_active = rsim.N_active if rsim.N_active >= 0 else rsim.N
    if n_active < rsim.N and int(rsim.testparticle_type) != 0 and any(
        float(p.m) != 0.0 for p in rsim.particles[n_active:]
    ):
        raise InvalidInputError(
            "from_rebound: the REBOUND simulation has massive test particles that pull the "
            "active ones (testparticle_type = 1), which visviva does not have; set "
            "rsim.testparticle_type = 0 (they then feel but do not pull, as visviva's test "
            "particles) or make them active (rsim.N_active = -1)."
        )
    if str(rsim.integrator) == name:
        _settings_from_rebound(rsim, sim)
    for k, p in enumerate(rsim.particles):
        m = float(p.m) if k < n_active else 0.0
        sim.add(m, [p.x, p.y, p.z], [p.vx, p.vy, p.vz], radius=float(p.r))
    sim.t = float(rsim.t)
    sim.dt = float(rsim.dt)
    if (names := _names_from_rebound(rsim)) is not None:
        sim.names = names
    return sim


def _check_dynamics(rsim):
    """Refuse REBOUND's ``gravity = "none"`` and warn about its additional forces and
    per-step modifications (a Python callback, REBOUNDx): none of them can be read back, and the
    visviva copy would integrate Newtonian gravity alone without a word."""
    if str(rsim.gravity).lower() == "none":
        raise InvalidInputError(
            "from_rebound: the REBOUND simulation has gravity = 'none' (no mutual gravity), "
            "which visviva does not have: every visviva integrator adds Newtonian gravity. Set "
            "rsim.gravity = 'basic' first if that is what you mean."
        )
    hooks = [name for name, field in (("additional forces", "_additional_forces"),
                                      ("pre-timestep modifications", "_pre_timestep_modifications"),
                                      ("post-timestep modifications", "_post_timestep_modifications"))
             if bool(getattr(rsim, field, None))]
    if int(getattr(rsim, "N_var", 0)) > 0:
        warnings.warn(
            f"from_rebound: the REBOUND simulation's {int(rsim.N_var)} variational particles "
            "(init_megno, add_variation) are not carried over, nor its MEGNO sums: call "
            "sim.init_megno(delta=...) on the visviva copy (delta: the variational particles' "
            "(x, y, z, vx, vy, vz) rows) to start MEGNO there.", UserWarning, stacklevel=4)
    if hooks:
        warnings.warn(
            "from_rebound: the REBOUND simulation has " + " and ".join(hooks) + " (a Python "
            "callback or REBOUNDx), which cannot be read back: the visviva copy integrates "
            "gravity alone, i.e. different dynamics. Add the forces to the copy with "
            "sim.add_force (J2Force, GeneralRelativity, ... or your own numba.njit force).",
            UserWarning, stacklevel=4,
        )


def _settings_from_rebound(rsim, sim):
    """The integrator, event and collision settings of the REBOUND simulation ``rsim``."""
    if sim.integrator == "whfast":
        corrector = int(rsim.integrator.corrector)
        if corrector not in (0, 3, 5, 7):
            raise InvalidInputError(
                f"REBOUND's WHFast corrector {corrector} has no visviva counterpart (0, 3, 5 "
                "or 7); set rsim.integrator.corrector to one of them first."
            )
        sim.corrector = corrector
    elif sim.integrator == "ias15":
        epsilon = float(rsim.integrator.epsilon)
        if not epsilon > 0:
            raise InvalidInputError(
                f"REBOUND's IAS15 epsilon = {epsilon} (fixed steps of dt) has no visviva "
                "counterpart: set rsim.integrator.epsilon > 0 (e.g. 1e-9) first."
            )
        sim.epsilon = epsilon
        sim.adaptive_mode = _from_rebound(_REBOUND_ADAPTIVE, rsim.integrator.adaptive_mode,
                                          "IAS15 adaptive_mode", "adaptive_mode")
        sim.min_dt = float(rsim.integrator.min_dt)
    sim.exact_finish_time = bool(rsim.exact_finish_time)
    if float(rsim.exit_min_distance) > 0:
        sim.encounter_distance = float(rsim.exit_min_distance)
    if float(rsim.exit_max_distance) > 0:
        sim.exit_max_distance = float(rsim.exit_max_distance)
    if str(rsim.collision).lower() != "none":
        warnings.warn(
            f"from_rebound: REBOUND's collision detection ({str(rsim.collision)!r}) is not "
            "carried over (its resolver function cannot be read back): set sim.collision to "
            "'halt', 'merge' or 'bounce' (and the particles' radii) on the visviva copy.",
            UserWarning, stacklevel=3,
        )
