"""The N-body :class:`Simulation`: particles, an integrator, and ``integrate(t)``.

The state lives in plain float64 arrays owned by one
:class:`~visviva.nbody.state.SimulationState`; :meth:`Simulation.integrate` hands them to ONE
compiled kernel call that takes every step between the current time and the last requested output
time (no Python per step). Output snapshots at many times come back as ``(T, N, 3)`` arrays
(:class:`~visviva.nbody.trajectory.Trajectory`). The settings are
:class:`~visviva.nbody.settings.Setting` descriptors, one line each in the class body.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import gravity as _gravity
from ..core import nbody_common as _nc
from ..core import status as _st
from ..core._jit import interpreted
from ..errors import InvalidInputError, InvalidStateError, ShapeError, fmt_number
from . import chaos as _chaos
from . import events as _events
from . import forces as _forces
from . import settings as _s
from . import step_check as _step_check
from . import tier as _tier
from .gpu import check_backend
from .integrators import INTEGRATORS, few_bodies, get_integrator
from .orbits import OrbitReadback
from .placement import particle_state
from .settings import COLLISION_MODES, Setting
from .state import SimulationState
from .trajectory import Recording, Trajectory
from .units import SimulationUnits

__all__ = ["Simulation", "Trajectory", "COLLISION_MODES"]

_PARALLEL_AUTO_N = _gravity.PARALLEL_MIN_N


class Simulation(_chaos.ChaosIndicators, OrbitReadback):
    """An N-body simulation (chaos indicators: :meth:`init_megno`, :meth:`megno`, :meth:`lyapunov`;
    osculating elements: :meth:`orbits`).

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
        ``(length, time, mass)``, e.g. ``("au", "yr", "Msun")``: sets ``G`` (so give one of
        ``G`` and ``units``, not both) and lets :meth:`add` take astropy Quantities.
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
    backend : str
        ``"cpu"`` (default) or ``"cuda"``: the direct summation on an NVIDIA GPU, for every
        integrator (:mod:`visviva.nbody.gpu`; raises :class:`visviva.errors.BackendUnavailableError`
        saying what is missing without a GPU or numba-cuda).

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
        backend: str = "cpu",
    ):
        self.units = None if units is None else SimulationUnits.parse(units)
        self._state = SimulationState.empty()
        self._forces: list = []
        self._fused = None
        self.parallel = parallel
        self._integrator = get_integrator(integrator)
        self.backend = check_backend(backend, self._integrator.name)
        if self.units is not None and not (isinstance(G, int | float) and G == 1.0):
            raise InvalidInputError(
                f"give G or units, not both: units={units!r} set G = {self.units.G:.10g} "
                f"(in those units), which would silently replace G = {G!r}."
            )
        G_value = self.units.G if self.units is not None else float(G)
        if not (math.isfinite(G_value) and G_value > 0):
            raise InvalidInputError(f"G must be a finite number > 0; got {fmt_number(G)}.")
        self._state.fstate[_nc.F_G] = G_value
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

    @classmethod
    def from_state(cls, state, integrator: str, *, units=None, parallel=None,
                   forces=()) -> Simulation:
        """A simulation that owns ``state`` (a :class:`~visviva.nbody.state.SimulationState`,
        taken over, not copied), for ``integrator`` with ``units`` (a
        :class:`~visviva.nbody.units.SimulationUnits` or None), ``parallel`` and ``forces`` as in
        the constructor: the friend constructor of the archive and ensembles. It continues from
        ``state`` bit for bit."""
        sim = cls.__new__(cls)
        Simulation.__init__(sim, integrator)  # a CPU simulation: set sim.backend to change
        sim.units = units
        sim.parallel = parallel
        sim._state = state
        sim._forces = list(forces)
        return sim

    def state_arrays(self) -> dict:
        """The state's arrays under their archive keys (``x, v, m, radius, fstate, istate`` and
        ``buf`` once integrated): the live arrays, not copies (see :mod:`visviva.nbody.snapshot`)."""
        return self._state.arrays()

    # ---- settings: each one slot of the state (see visviva.nbody.settings) ------------------------
    G = Setting("fstate", _nc.F_G, decode=float,
                doc="Gravitational constant in simulation units (read-only).")
    steps_done = Setting("istate", _nc.I_STEPS, decode=int,
                         doc="Number of steps taken so far (accepted steps for IAS15).")
    dt = Setting("fstate", _nc.F_DT, decode=float, encode=_s.time_scalar,
                 doc="Time step (next step for IAS15).")
    softening = Setting("fstate", _nc.F_SOFT2, decode=math.sqrt, encode=_s.softening_squared,
                        doc="Plummer softening length (simulation units); 0 for none.")
    epsilon = Setting("fstate", _nc.F_EPSILON, decode=float, encode=_s.epsilon,
                      doc="IAS15 accuracy parameter (Rein & Spiegel 2015), finite and > 0.")
    min_dt = Setting("fstate", _nc.F_MIN_DT, decode=float, encode=_s.nonnegative_time,
                     doc="Smallest step IAS15 may take (0: only the relative floor applies).")
    restitution = Setting("restitution", encode=_s.restitution,
                          doc="Coefficient of restitution of a bounce (1 = elastic), in [0, 1].")
    energy_offset = Setting("energy_offset", encode=_s.energy_offset,
                            doc="Energy removed by mergers and inelastic bounces (added back by "
                            ":meth:`energy`).")
    encounter_distance = Setting(
        "fstate", _nc.F_ENCOUNTER, decode=_s.off_when_zero, encode=_s.distance_or_off,
        doc="Raise :class:`visviva.Encounter` when two particles come closer (None: off).")
    exit_max_distance = Setting(
        "fstate", _nc.F_EXIT, decode=_s.off_when_zero, encode=_s.positive_distance_or_off,
        doc="Raise :class:`visviva.Escape` when a particle goes farther from the origin "
        "(None: off).")
    corrector = Setting("istate", _nc.I_CORRECTOR, decode=int, encode=_s.corrector, fresh=True,
                        doc="WHFast symplectic corrector order: 0 (none), 3, 5 or 7.")
    coordinates = Setting(
        "istate", _nc.I_WH_COORDINATES, decode=_s.coordinates_name, encode=_s.coordinates,
        fresh=True,
        doc="WHFast's coordinates: ``\"jacobi\"`` or ``\"democratic_heliocentric\"``; assigning "
        "resets the integrator's internal state (REBOUND's ``\"democraticheliocentric\"`` is "
        "accepted).")
    adaptive_mode = Setting(
        "istate", _nc.I_ADAPTIVE_MODE, decode=lambda c: ("rs15", "prs23")[int(c)],
        encode=_s.adaptive_mode,
        doc="IAS15 step-size control: ``\"prs23\"`` (Pham, Rein & Spiegel 2024; the default, as "
        "in REBOUND: about half the steps of ``\"rs15\"`` on planetary systems at the same "
        "round-off energy error) or ``\"rs15\"`` (Rein & Spiegel 2015's global "
        "``max|b6| / max|a|``; ``\"global\"`` is accepted as an alias).")
    exact_finish_time = Setting(
        "istate", _nc.I_EXACT_FINISH, decode=bool, encode=_s.flag,
        doc="True (default): land exactly on every requested time (with a shortened step of a "
        "copy of the integrator's state, so the trajectory never depends on the output times). "
        "False: return the state after the first step at or past each time.")

    @property
    def integrator(self) -> str:
        """Name of the integrator; assigning a new name resets its internal state."""
        return self._integrator.name

    @integrator.setter
    def integrator(self, name: str) -> None:
        self._integrator = get_integrator(name)
        self._state.particles_changed()

    @property
    def integrator_info(self):
        """The registry entry (:class:`visviva.nbody.integrators.Integrator`)."""
        return self._integrator

    @property
    def t(self) -> float:
        """Simulation time (simulation units)."""
        return float(self._state.fstate[_nc.F_T])

    @t.setter
    def t(self, value) -> None:
        self._state.fstate[_nc.F_T] = _s.scalar(_s.convert(self, value, "time", "t"), "t")
        self._state.fstate[_nc.F_DT_REF] = 0.0  # restart the fixed-step clock here

    @property
    def collision(self) -> str:
        """Collision mode: one of :data:`COLLISION_MODES`."""
        return self._state.collision

    @collision.setter
    def collision(self, mode: str) -> None:
        if mode is None:
            mode = "none"
        if mode not in COLLISION_MODES:
            raise InvalidInputError(f"collision must be one of {COLLISION_MODES}; got {mode!r}.")
        self._state.collision = mode
        self._state.istate[_nc.I_COLLISIONS] = 0 if mode == "none" else 1

    # ---- unit helpers ----------------------------------------------------------------------------
    def time_value(self, value, name: str = "t") -> float:
        """One time (a float in simulation units, or a Quantity of time when the simulation has
        units) as a float in simulation units; ``name`` says what it is in error messages."""
        return _s.scalar(_s.convert(self, value, "time", name), name)

    def _replace_state(self, key, value, kind, name):
        """Replace ``x`` or ``v`` (``key``) by ``value`` (simulation units or a Quantity of
        ``kind``) of the same shape; the integrator restarts from the new state."""
        current = getattr(self._state, key)
        arr = np.ascontiguousarray(_s.convert(self, value, kind, name), dtype=np.float64)
        if arr.shape != current.shape:
            raise ShapeError(f"{name} must have shape {current.shape}; got {arr.shape}.")
        self._state.replace(key, arr)

    # ---- particles --------------------------------------------------------------------------------
    @property
    def N(self) -> int:
        """Number of particles."""
        return int(self._state.m.shape[0])

    @property
    def N_active(self) -> int:
        """Number of massive particles (the others are test particles)."""
        return int(np.count_nonzero(self._state.m))

    @N_active.setter
    def N_active(self, value) -> None:  # REBOUND's sim.N_active = k: a bare AttributeError here
        raise InvalidInputError(
            f"N_active = {value!r}: visviva's test particles are the particles with m = 0 (in any "
            "order), so N_active is read-only: sim.set_particle(i, m=0.0) makes particle i one.")

    @property
    def positions(self) -> np.ndarray:
        """Positions, shape (N, 3), simulation units (a copy)."""
        return self._state.x.copy()

    @positions.setter
    def positions(self, value) -> None:
        self._replace_state("x", value, "length", "positions")

    @property
    def velocities(self) -> np.ndarray:
        """Velocities, shape (N, 3), simulation units (a copy)."""
        return self._state.v.copy()

    @velocities.setter
    def velocities(self, value) -> None:
        self._replace_state("v", value, "speed", "velocities")

    @property
    def masses(self) -> np.ndarray:
        """Masses, shape (N,), simulation units (a copy)."""
        return self._state.m.copy()

    @property
    def radii(self) -> np.ndarray:
        """Collision radii, shape (N,)."""
        return self._state.radius.copy()

    def add(self, m=0.0, r=None, v=None, *, radius=0.0, primary=None, a=None, e=None, inc=None,
            raan=None, argp=None, nu=None, mean_anomaly=None, p=None, M=None, **more):
        """Add a particle from a state, or from orbital elements about a primary.

        Parameters
        ----------
        m : float or Quantity
            Mass (0 makes a test particle: it feels the others and pulls on nothing).
        r, v : array_like (3,) or Quantity
            Position and velocity (simulation units), default zero.
        radius : float or Quantity
            Collision radius.
        primary : int, str or "com", optional
            With elements: the particle index (or name in ``names``) to orbit, or ``"com"``/``None`` for the centre of
            mass of all particles added so far (Jacobi-like, the default).
        a, e, inc, raan, argp, nu, mean_anomaly, p : float
            Semi-major axis (or semi-latus rectum ``p``; ``a < 0`` with ``e > 1`` for a
            hyperbola, ``p`` for a parabola), eccentricity, inclination, longitude of the
            ascending node, argument of periapsis (radians; each 0 when not given) and the true
            anomaly ``nu`` or ``mean_anomaly`` (radians; hyperbolic: ``e sinh F - F``). ``G
            (m_primary + m)`` is the two-body GM. Elements (or ``primary``) without ``a`` or
            ``p`` raise :class:`~visviva.InvalidInputError`, as do elements beside ``r``/``v``.
        **more
            REBOUND's other elements under long names: ``period`` (for ``a``),
            ``longitude_of_periapsis`` (for ``argp``), ``mean_longitude``, ``true_longitude``,
            ``time_of_periapsis`` or ``eccentric_anomaly`` (for ``nu``; hyperbolic: ``F``);
            see :mod:`visviva.nbody.placement`.
        M : float, optional
            Deprecated alias of ``mean_anomaly`` (it differed from the mass ``m`` only by case);
            removed in the next release.

        Returns
        -------
        int
            The index of the new particle (named ``""`` in ``sim.names`` when the simulation
            has names, as :func:`~visviva.nbody.solar_system` gives it).
        """
        if M is not None:
            from .._deprecation import warn_renamed

            warn_renamed("Simulation.add(M=...)", "Simulation.add(mean_anomaly=...)")
            if mean_anomaly is not None:
                raise InvalidInputError("give mean_anomaly only (M is its deprecated alias).")
            mean_anomaly = M
        m_val = _s.mass(self, m)
        rr, vv = particle_state(self, m_val, r, v, primary, more, a=a, e=e, inc=inc, raan=raan,
                                argp=argp, nu=nu, mean_anomaly=mean_anomaly, p=p)
        rr, vv = _s.vector3(self, rr, "length", "r"), _s.vector3(self, vv, "speed", "v")
        self._state.append(rr, vv, m_val, _s.radius(self, radius))
        if getattr(self, "names", None) is not None:  # solar_system's labels stay aligned: the
            self.names = [*self.names, ""]  # new one unnamed (a new list: a copy's unchanged)
        return self.N - 1

    def remove(self, index: int, *, merged_into: int | None = None) -> None:
        """Remove particle ``index`` (or the one of that name in ``names``): later indices, a
        force's primary and ``names`` shift down by one (removing a primary raises unless
        ``merged_into``, numbered as now, gets it)."""
        _forces.follow_removal(self._forces, *(k := _s.removal(self, index, merged_into)))
        self._state.remove(k := k[0])
        if getattr(self, "names", None) is not None:  # solar_system's labels (a new list:
            self.names = self.names[:k] + self.names[k + 1:]  # a copy's are not changed)

    def set_particle(self, index: int, *, m=None, r=None, v=None, radius=None) -> None:
        """Change the mass ``m``, position ``r`` (3,), velocity ``v`` (3,) or collision
        ``radius`` of particle ``index`` in place (simulation units, or Quantities as in
        :meth:`add`, checked as there); the integrator restarts from the changed state (as
        after a collision)."""
        k = _s.particle_index(self, index)
        self._state.set_particle(
            k, m=None if m is None else _s.mass(self, m),
            r=None if r is None else _s.vector3(self, r, "length", "r"),
            v=None if v is None else _s.vector3(self, v, "speed", "v"),
            radius=None if radius is None else _s.radius(self, radius))

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
        self._forces, self._fused = [], None

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
    def _use_parallel(self) -> bool:
        return bool(self.parallel) if self.parallel is not None else self.N >= _PARALLEL_AUTO_N

    def begin_run(self, t) -> np.ndarray:
        """Check a run to the time(s) ``t`` can start, set up what it needs once, and return the
        output times (float64 array, simulation units). Friend interface (docs/design.md): the
        ensembles and the GPU backend run kernels between :meth:`begin_run`,
        :meth:`kernel_inputs` and :meth:`after_kernel`; users call :meth:`integrate`."""
        times = np.ascontiguousarray(np.atleast_1d(_s.convert(self, t, "time", "t")).astype(np.float64))
        if times.ndim != 1:
            raise ShapeError(f"t must be a number or a 1-D array of times; got shape {times.shape}.")
        if self.N == 0:
            raise InvalidInputError("the simulation has no particles: add some with sim.add(...).")
        _events.check_not_coincident(self._state, "integrate")
        _chaos.check_run(self)
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
        if info.name == "whfast" and self._state.m[0] <= 0:
            raise InvalidInputError(
                f"WHFast needs particle 0 to be the massive central body ({self.coordinates} "
                "coordinates): add the star first.")
        if info.needs_dt:  # a step too short for the run, or too long for the orbits
            _step_check.check_step(self, times)
        if info.adaptive and self.dt == 0.0:
            self._state.fstate[_nc.F_DT] = _step_check.initial_dt(self)
        self._state.istate[_nc.I_NOUT] = 0
        return times

    def kernel_inputs(self, parallel: bool | None = None):
        """Make the state ready for one kernel call; returns the fused force, its parameters and
        the indices of the massive particles (friend interface, see :meth:`begin_run`).
        ``parallel`` overrides the choice of gravity kernel (both give the same bits)."""
        st = self._state
        st.ensure_buf(self._integrator.n_buf + _chaos.extra_slots(self))
        fn, params = self._force_args()
        use_parallel = self._use_parallel() if parallel is None else parallel
        st.istate[_nc.I_PARALLEL] = 1 if use_parallel else 0
        st.istate[_nc.I_VELOCITY_DEPENDENT] = int(any(f.velocity_dependent for f in self._forces))
        st.massive = _gravity.massive_indices(st.m)
        st.work()
        return fn, params, st.massive

    def adopt_arrays(self, arrays: dict, massive) -> None:
        """Hold ``arrays`` (the keys of :meth:`state_arrays`, views into an ensemble's packed
        arrays holding this simulation's values) as the state's arrays (friend interface, see
        :meth:`begin_run`; :mod:`visviva.nbody.ensemble_pack`)."""
        self._state.adopt(*(arrays[k] for k in ("x", "v", "m", "radius", "fstate", "istate",
                                                  "buf")), massive)

    def after_kernel(self, status: int, removed=None) -> bool:
        """Act on a kernel's status code: True when the run is done, False to call the kernel
        again (after a pause or a resolved merger/bounce, ``removed(index)`` called with the
        index a merger removed); events raise (friend interface, see :meth:`begin_run`)."""
        st = self._state
        if status == _st.OK:
            if not (np.all(np.isfinite(st.x)) and np.all(np.isfinite(st.v))):
                _events.raise_non_finite(self._state, self.integrator)
            return True
        if status == _nc.PAUSED:
            return False
        if status == _st.COLLISION and self.collision in ("merge", "bounce"):
            from .collisions import resolve
            i, j = int(st.istate[_nc.I_EVENT_A]), int(st.istate[_nc.I_EVENT_B])
            gone = resolve(self, i, j)
            st.mark_fresh()
            if gone is not None and removed is not None:
                removed(gone)
            return False
        _events.raise_event(self._state, status, self.integrator)

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
            force gives NaN/infinite accelerations; the simulation is then left as it was
            before the call.
        """
        if self.backend == "cuda":
            from .gpu import integrate_simulation
            return integrate_simulation(self, t, progress=progress)
        scalar, st = np.ndim(t) == 0, self._state
        saved = st.copy()  # taken back when the run breaks (a few us; ~1 % of a call)
        times = self.begin_run(t)
        info = self._integrator
        try:
            with Recording(self, times, progress) as rec:
                while True:
                    fn, params, _ = self.kernel_inputs()
                    done0 = rec.before_call()
                    few = few_bodies(st.istate, st.massive)
                    args = (st.x, st.v, st.m, st.massive, st.radius, st.fstate, st.istate,
                            st.buf, st.gwork, fn, params, times, rec.out_t, rec.chunk_x,
                            rec.chunk_v)
                    status = None
                    slow = _tier.interpreted_kernel(info, few, st.istate, st.fstate,
                                                    len(st.massive))
                    if slow is not None:  # a cold first run: the interpreter tier (tier.py)
                        status = _tier.run_slice(slow, args[:9] + (interpreted(fn),) + args[10:],
                                                 st.istate, int(st.istate[_nc.I_STOP_AT_STEP]))
                    if status is None:
                        status = int(info.kernel(few, st.istate, st.fstate)(*args))
                    if rec.after_call(status, done0):
                        break
        except InvalidStateError as exc:
            # NaN/inf values: what is left mixes times (WHFast: t unchanged, positions moved on)
            # or is NaN; the state before the call is the last one that is right
            st.restore(saved)
            raise InvalidStateError(
                f"{exc} The simulation is left as it was before this call, at t = "
                f"{fmt_number(self.t)}.") from None
        return None if scalar else rec.trajectory()

    # ---- diagnostics -----------------------------------------------------------------------------
    def energy(self, include_offset: bool = True) -> float:
        """Total energy (kinetic plus potential, simulation units).

        With ``include_offset`` the energy removed by mergers and inelastic bounces
        (``energy_offset``) is added back, so that the sum stays constant.
        """
        _events.check_not_coincident(self._state, "energy")
        E = float(_gravity.energy(self._state.x, self._state.v, self._state.m, self.G, self._state.fstate[_nc.F_SOFT2]))
        return E + (self.energy_offset if include_offset else 0.0)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum ``sum m r x v`` about the origin, shape (3,)."""
        return (self._state.m[:, None] * np.cross(self._state.x, self._state.v)).sum(0)

    def momentum(self) -> np.ndarray:
        """Total linear momentum ``sum m v``, shape (3,)."""
        return (self._state.m[:, None] * self._state.v).sum(0)

    def center_of_mass(self) -> tuple[np.ndarray, np.ndarray]:
        """Position and velocity of the centre of mass, each shape (3,)."""
        M = self._state.m.sum()
        if M == 0:
            raise InvalidInputError("the particles have no mass: the centre of mass is undefined.")
        return (self._state.m[:, None] * self._state.x).sum(0) / M, (self._state.m[:, None] * self._state.v).sum(0) / M

    def move_to_com(self) -> None:
        """Shift to the centre-of-mass frame (position and velocity of the COM become zero)."""
        xc, vc = self.center_of_mass()
        self._state.replace("x", self._state.x - xc)
        self._state.replace("v", self._state.v - vc)

    def copy(self) -> Simulation:
        """A deep copy (same state, same integrator internals, copies of the forces: changing a
        copy's force parameters leaves this simulation's alone)."""
        import copy
        new = copy.copy(self)
        new._state = self._state.copy()
        new._forces = [f.copy() for f in self._forces]  # shared, a copy's change was everyone's
        return new

    def __getstate__(self):  # the fused force is a compiled closure: rebuilt after unpickling
        return {**self.__dict__, "_fused": None}

    def __repr__(self) -> str:
        return (f"<Simulation {self.integrator} N={self.N} (active {self.N_active}) "
                f"t={self.t:.6g} dt={self.dt:.6g} G={self.G:.6g}>")

    # ---- persistence and interop (defined in snapshot.py / interop.py) ------------------------------
    def save(self, path) -> None:
        """Write the complete state (integrator internals included) atomically to ``path``; a
        simulation loaded with :meth:`load` continues bit for bit (:mod:`visviva.nbody.snapshot`)."""
        from .snapshot import save_simulation

        save_simulation(self, path)

    @classmethod
    def load(cls, path, forces=None) -> Simulation:
        """Read a simulation written by :meth:`save`; pass ``forces`` when user forces cannot be
        re-imported by name (functions defined in ``__main__``)."""
        from .snapshot import load_simulation

        return load_simulation(cls, path, forces=forces)

    def to_rebound(self):
        """A ``rebound.Simulation`` with the same particles, G, t, dt, integrator and settings.

        Warns about what REBOUND cannot carry (additional forces, an inelastic bounce); see
        :mod:`visviva.nbody.interop`.
        """
        from .interop import to_rebound

        return to_rebound(self)

    @classmethod
    def from_rebound(cls, rsim, integrator=None) -> Simulation:
        """A visviva Simulation from a ``rebound.Simulation`` (particles, G, t, dt, settings).

        Settings without a visviva counterpart raise :class:`~visviva.InvalidInputError`; see
        :mod:`visviva.nbody.interop`.
        """
        from .interop import from_rebound

        return from_rebound(cls, rsim, integrator=integrator)
