"""Manoeuvres inside a Cowell propagation: impulsive and finite burns.

An :class:`ImpulsiveBurn` changes the velocity at one epoch by a Δv given in an inertial frame
or in a local orbital frame evaluated at the burn's state (RTN, TNW, VNB: axes defined in
:mod:`visviva.core.local_frames`). A :class:`FiniteBurn` thrusts over an interval along a
direction held fixed in such a frame while the frame turns with the orbit (as GMAT's
FiniteBurn and Orekit's ConstantThrustManeuver do), with a thrust F and a mass flow
(a = F / m(t), m(t) = m0 - mdot (t - t0)) or a constant acceleration.

:func:`visviva.propagate_cowell` takes them as ``maneuvers=[...]`` and splits the integration at
every burn's start and end, so no step crosses a jump of the force.

>>> import numpy as np
>>> import visviva as vv
>>> from astropy import units as u
>>> v_circ = np.sqrt(vv.EARTH.gm_km3_s2 / 6678.0)
>>> leo = vv.StateVectors([6678.0, 0, 0] * u.km, [0, v_circ, 0] * u.km / u.s, vv.EARTH)
>>> dv1, dv2, tof = vv.satellites.hohmann_delta_v(6678 * u.km, 42164 * u.km, vv.EARTH)
>>> burns = [vv.ImpulsiveBurn(0 * u.s, [dv1.value, 0, 0] * u.km / u.s, "TNW"),
...          vv.ImpulsiveBurn(tof, [dv2.value, 0, 0] * u.km / u.s, "TNW")]
>>> out = vv.propagate_cowell(leo, tof + 1 * u.h, maneuvers=burns)
>>> print(f"{np.linalg.norm(out.r.to_value(u.km)):.1f} km")
42164.0 km
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from astropy import units as u

from .._units import require_positive, require_usable_time, to_array, to_quantity, to_vector
from ..core import force_block as fb
from ..core.local_frames import FRAME_CODES, INERTIAL, local_axes
from ..errors import InvalidInputError, InvalidStateError

__all__ = ["ImpulsiveBurn", "FiniteBurn", "BurnRecord", "STANDARD_GRAVITY_M_S2", "frame_code",
           "burn_schedule", "refuse_pending"]

#: Standard gravity g0 (m/s^2) of the rocket equation's Isp (CGPM 1901).
STANDARD_GRAVITY_M_S2 = 9.80665
#: Inertial frame names a burn accepts: the GCRS and the CCSDS names visviva reads as GCRS
#: (:mod:`visviva.ccsds.timeframes`; they differ by the 23 mas frame bias at most).
INERTIAL_NAMES = ("GCRS", "GCRF", "EME2000", "ICRF")


def frame_code(frame) -> int:
    """The code of a burn's frame name (:mod:`visviva.core.local_frames`).

    Parameters
    ----------
    frame : str
        ``"RTN"`` (also ``"RSW"``, ``"RIC"``, ``"QSW"``), ``"TNW"``, ``"VNB"`` (local,
        evaluated at the burn's state) or an inertial name: ``"GCRS"``, ``"GCRF"``,
        ``"EME2000"``, ``"ICRF"`` (case-insensitive). Vallado's NTW and the LVLH frames, whose
        axes differ between tools, are refused.

    Returns
    -------
    int

    Raises
    ------
    InvalidInputError
        For any other name (it is named in the message).
    """
    name = str(frame).strip().upper() if isinstance(frame, str) else None
    if name in FRAME_CODES:
        return FRAME_CODES[name]
    if name in INERTIAL_NAMES:
        return INERTIAL
    raise InvalidInputError(
        f"burn frame {frame!r} is not supported; use one of {', '.join(FRAME_CODES)} (local, "
        f"at the burn's state) or {', '.join(INERTIAL_NAMES)} (inertial). Rotate a Δv given "
        "in another frame (TEME, ITRF ...) to the GCRS first."
    )


def _when(value, name):
    """An astropy Time, or a time offset in s (float): where a burn starts."""
    from astropy.time import Time

    if isinstance(value, Time):
        if not value.isscalar:
            raise InvalidInputError(f"{name} must be one epoch; got shape {value.shape}.")
        require_usable_time(value, name)
        return value
    arr = to_array(value, "time", name)
    if arr.ndim != 0:
        raise InvalidInputError(f"{name} must be one time; got shape {arr.shape}.")
    return float(arr)


def _one(value, kind, name) -> np.ndarray:
    """One value (0-d array) of ``kind`` in visviva's unit: a burn has one thrust, mass ..."""
    arr = to_array(value, kind, name)
    if arr.ndim != 0:
        raise InvalidInputError(
            f"{name} must be one value; got shape {arr.shape}. A burn has one {name}: build "
            "one burn per value.")
    return arr


def _describe(when) -> str:
    return f"{when:g} s" if isinstance(when, float) else when.isot


class _Burn:
    """What impulsive and finite burns share: when they start, and in which frame."""

    start: object
    frame: str
    code: int

    def start_offset_s(self, epoch) -> float:
        """The start, s after ``epoch`` (the initial state's; None when it has none)."""
        if isinstance(self.start, float):
            return self.start
        if epoch is None:
            raise InvalidInputError(
                f"{self!r} starts at an absolute epoch but the state has no epoch; build the "
                "state with epoch=..., or give the burn's start as an offset (e.g. 600 * u.s)."
            )
        from .frames import offline_iers

        with offline_iers():  # UT1 needs the installed IERS table, never a download
            return float((self.start.tt - epoch.tt).to_value(u.s))


class ImpulsiveBurn(_Burn):
    """An instantaneous velocity change at one epoch.

    Parameters
    ----------
    epoch : astropy.time.Time or Quantity
        When: an absolute epoch, or an offset (time Quantity, >= 0) from the initial state's
        epoch.
    delta_v : Quantity (3,)
        The Δv (speed), components along the axes of ``frame``.
    frame : str
        ``"RTN"`` (radial, transverse, normal), ``"TNW"`` (along the velocity, in-plane normal
        N = W x T, orbit normal), ``"VNB"`` (velocity, orbit normal, binormal V x N), evaluated
        at the state just before the burn; or inertial: ``"GCRS"`` (default), ``"GCRF"``,
        ``"EME2000"``, ``"ICRF"``. Axes: :mod:`visviva.core.local_frames`.
    delta_mass : Quantity, optional
        Mass change (kg, <= 0) the burn costs, if known (an OPM's ``MAN_DELTA_MASS``): reported
        on the result, not used by the dynamics.
    mass : Quantity, optional
        Spacecraft mass before the burn (kg, > 0): with ``delta_mass``, the result reports the
        masses before and after.

    Notes
    -----
    The state at the burn's epoch is reported after the burn (velocity continuous from the
    right): an output time equal to the epoch gives v + Δv.
    """

    def __init__(self, epoch, delta_v, frame: str = "GCRS", *, delta_mass=None, mass=None):
        self.start = _when(epoch, "epoch")
        dv = to_vector(delta_v, "speed", "delta_v")
        if dv.shape != (3,):
            raise InvalidInputError(f"delta_v must have shape (3,); got {dv.shape}.")
        self.delta_v = to_quantity(dv, "speed")
        self._dv = dv
        self.code = frame_code(frame)
        self.frame = frame.strip().upper()
        self.delta_mass = None
        if delta_mass is not None:
            dm = to_array(delta_mass, "mass", "delta_mass")
            if dm.ndim != 0 or dm > 0:
                raise InvalidInputError(f"delta_mass must be one mass <= 0 kg; got {dm}.")
            self.delta_mass = float(dm) * u.kg
        self.mass = None
        if mass is not None:
            m = to_array(mass, "mass", "mass")
            require_positive(m, "mass")
            if m.ndim != 0 or (self.delta_mass is not None and not m + dm > 0):
                raise InvalidInputError(
                    f"mass must be one mass > 0 kg that the burn does not exhaust; got {m} kg "
                    f"with delta_mass = {self.delta_mass}.")
            self.mass = float(m) * u.kg

    @property
    def end(self):
        """The same as the start (an impulse takes no time)."""
        return self.start

    def delta_v_inertial(self, r_km, v_km_s) -> np.ndarray:
        """The Δv on inertial axes (km/s) for the state (r, v) just before the burn.

        Parameters
        ----------
        r_km : ndarray (..., 3)
            Position(s), km.
        v_km_s : ndarray (..., 3)
            Velocity(ies), km/s.

        Returns
        -------
        ndarray (..., 3)
            km/s: ``M.T @ delta_v`` with ``M`` the local axes (rows), or ``delta_v`` itself.
        """
        if self.code == INERTIAL:
            return np.broadcast_to(self._dv, np.shape(r_km)).copy()
        dv = self._dv @ local_axes(r_km, v_km_s, self.code)
        if not np.all(np.isfinite(dv)):
            raise InvalidStateError(
                f"the {self.frame} frame of {self!r} is undefined at r = {r_km}, v = {v_km_s} "
                "km/s (r x v = 0 or v = 0): give the Δv in GCRS."
            )
        return dv

    def __repr__(self):
        dv = ", ".join(f"{x:.6g}" for x in self._dv)
        return f"ImpulsiveBurn({_describe(self.start)}, [{dv}] km/s {self.frame})"


class FiniteBurn(_Burn):
    """Thrust over an interval, along a direction fixed in an inertial or local frame.

    Give either ``thrust`` and ``mass`` (with ``isp`` or ``mass_flow`` for a mass that falls;
    neither: the mass stays ``mass``), or a constant ``acceleration``.

    Parameters
    ----------
    start : astropy.time.Time or Quantity
        Ignition: an absolute epoch, or an offset (time Quantity, >= 0) from the state's epoch.
    duration : Quantity
        Burn time (> 0; a burn of no duration is an :class:`ImpulsiveBurn`).
    direction : array_like (3,)
        Thrust direction (any non-zero length; normalised), components along the axes of
        ``frame``; held fixed in that frame while the frame turns with the state.
    frame : str
        As for :class:`ImpulsiveBurn` (``"RTN"``, ``"TNW"``, ``"VNB"``, ``"GCRS"`` ...).
    thrust : Quantity, optional
        Thrust F (force, > 0), e.g. ``400 * u.N``.
    mass : Quantity, optional
        Spacecraft mass at ignition (kg, > 0); needed with ``thrust``.
    isp : Quantity, optional
        Specific impulse (time, > 0): mass flow mdot = F / (Isp g0).
    mass_flow : Quantity, optional
        Mass flow mdot (mass / time, >= 0), instead of ``isp``.
    acceleration : Quantity, optional
        Constant acceleration magnitude (> 0), instead of thrust and mass.

    Notes
    -----
    The acceleration is a(t) = F / m(t) u with m(t) = m0 - mdot (t - t0); for a burn held along
    a fixed inertial direction its integral is the rocket equation's
    Δv = (F / mdot) ln(m0 / m1) = Isp g0 ln(m0 / m1) (Tsiolkovsky; Curtis 2014, sec. 11.3), and
    ``F duration / m0`` without mass flow. The force is part of the compiled force model
    (:func:`visviva.core.perturbations.accel_thrust`).
    """

    #: names (:mod:`visviva.core.force_block`) of the parameter-block slots a burn writes
    PARAMETERS = ("THRUST_ON", "THRUST_ACCEL", "THRUST_MASS_RATE", "THRUST_FRAME",
                  "THRUST_DIRECTION")

    def __init__(self, start, duration, direction, frame: str = "GCRS", *, thrust=None,
                 mass=None, isp=None, mass_flow=None, acceleration=None):
        self.start = _when(start, "start")
        dt = _one(duration, "time", "duration")
        if not dt > 0:
            raise InvalidInputError(
                f"a finite burn lasts > 0 s; got duration = {float(dt)} s. For an instantaneous "
                "Δv use vv.ImpulsiveBurn(epoch, delta_v, frame)."
            )
        self.duration_s = float(dt)
        d = np.asarray(to_array(direction, "dimensionless", "direction"), dtype=np.float64)
        if d.shape != (3,) or not np.linalg.norm(d) > 0:
            raise InvalidInputError(
                f"direction must be a non-zero vector of shape (3,); got {d.tolist()}."
            )
        self.direction = d / np.linalg.norm(d)
        self.code = frame_code(frame)
        self.frame = frame.strip().upper()
        if acceleration is not None:
            if any(x is not None for x in (thrust, mass, isp, mass_flow)):
                raise InvalidInputError(
                    "give either acceleration=..., or thrust=... and mass=... (with isp or "
                    "mass_flow), not both."
                )
            acc = _one(acceleration, "accel", "acceleration")
            require_positive(acc, "acceleration")
            self.accel0_km_s2, self.mass_rate, self.mass_kg, self.mdot_kg_s = float(acc), 0.0, None, 0.0
            return
        if thrust is None or mass is None:
            raise InvalidInputError(
                "a finite burn needs thrust=... and mass=... (e.g. thrust=400 * u.N, "
                "mass=1000 * u.kg, isp=300 * u.s), or a constant acceleration=...."
            )
        f_n = _one(thrust, "force", "thrust")
        m0 = _one(mass, "mass", "mass")
        require_positive(f_n, "thrust")
        require_positive(m0, "mass")
        if isp is not None and mass_flow is not None:
            raise InvalidInputError("give isp or mass_flow, not both.")
        mdot = 0.0
        if isp is not None:
            isp_s = _one(isp, "time", "isp")
            require_positive(isp_s, "isp")
            mdot = float(f_n) / (float(isp_s) * STANDARD_GRAVITY_M_S2)
        elif mass_flow is not None:
            mdot_arr = _one(mass_flow, "mass_flow", "mass_flow")
            require_positive(mdot_arr, "mass_flow", strict=False)
            mdot = float(mdot_arr)
        m_end = float(m0) - mdot * self.duration_s
        if not m_end > 0:
            raise InvalidInputError(
                f"the burn consumes more than the spacecraft's mass: {float(m0):g} kg at "
                f"{mdot:.6g} kg/s is gone after {float(m0) / mdot:.6g} s, before the "
                f"{self.duration_s:g} s burn ends. Shorten the burn or check thrust, isp, mass."
            )
        self.mass_kg, self.mdot_kg_s = float(m0), mdot
        self.accel0_km_s2 = float(f_n) / float(m0) / 1000.0
        self.mass_rate = mdot / float(m0)

    @property
    def thrust(self):
        """Thrust F (N), or None for a burn given by its acceleration."""
        return None if self.mass_kg is None else self.accel0_km_s2 * 1000.0 * self.mass_kg * u.N

    @property
    def final_mass(self):
        """Mass at cut-off (kg), or None for a burn given by its acceleration."""
        return None if self.mass_kg is None else self.mass_at(self.duration_s) * u.kg

    def mass_at(self, t_s: float) -> float:
        """Mass (kg) ``t_s`` seconds after ignition (None for a burn given by acceleration)."""
        return None if self.mass_kg is None else self.mass_kg - self.mdot_kg_s * t_s

    def delta_v_after(self, t_s: float) -> float:
        """The integral of |a| (km/s) over the first ``t_s`` seconds: the rocket equation."""
        k = self.mass_rate * t_s
        if k == 0.0:
            return self.accel0_km_s2 * t_s
        return -self.accel0_km_s2 / self.mass_rate * math.log1p(-k)

    @property
    def ideal_delta_v(self):
        """|Δv| of the whole burn (km/s): Isp g0 ln(m0 / m1), or a duration."""
        return self.delta_v_after(self.duration_s) * u.km / u.s

    def pack(self, force, t_s: float = 0.0) -> None:
        """Write the thrust slots of the force block for a run whose t = 0 is ``t_s`` after
        ignition (thrust a = F / m(t_s) there, mass rate mdot / m(t_s)).

        Parameters
        ----------
        force : ndarray (FORCE_SIZE,)
            The block, written in place.
        t_s : float
            s from ignition to the run's t = 0.
        """
        scale = 1.0 - self.mass_rate * t_s
        force[fb.THRUST_ON] = 1.0
        force[fb.THRUST_ACCEL] = self.accel0_km_s2 / scale
        force[fb.THRUST_MASS_RATE] = self.mass_rate / scale
        force[fb.THRUST_FRAME] = float(self.code)
        force[fb.THRUST_DIRECTION:fb.THRUST_DIRECTION + 3] = self.direction

    def __repr__(self):
        how = (f"{self.accel0_km_s2 * 1e3:.6g} m/s2" if self.mass_kg is None
               else f"{self.thrust.value:.6g} N, {self.mass_kg:.6g} kg, "
                    f"{self.mdot_kg_s:.6g} kg/s")
        d = ", ".join(f"{x:.6g}" for x in self.direction)
        return (f"FiniteBurn({_describe(self.start)}, {self.duration_s:g} s, [{d}] "
                f"{self.frame}, {how})")


@dataclass(frozen=True)
class BurnRecord:
    """What a burn did in a propagation (``CowellResult.burns``).

    Attributes
    ----------
    burn : ImpulsiveBurn or FiniteBurn
        The burn.
    t_start, t_end : Quantity
        When it started and ended (s from the initial epoch); a finite burn that the run did
        not finish (last output time, terminal event) ends early.
    delta_v : Quantity
        |Δv| applied (km/s): the impulse's, or the integral of the thrust acceleration.
    delta_v_inertial : Quantity (3,) or None
        The impulse on inertial axes (km/s); None for a finite burn.
    mass_before, mass_after : Quantity or None
        Spacecraft mass (kg) at ignition and cut-off, when the burn knows it.
    complete : bool
        Whether the whole burn was executed.
    """

    burn: object
    t_start: object
    t_end: object
    delta_v: object
    delta_v_inertial: object
    mass_before: object
    mass_after: object
    complete: bool


#: A burn's start or end this close to an output time (s) is taken at that time: offsets from
#: astropy Times round at 1e-12 s, which must not move an output to the other side of a burn.
SNAP_S = 1e-6


class _Schedule:
    """The burns of one run, ordered, with the log of what they did."""

    def __init__(self, items):
        self.items = items  # (start_s, end_s, burn), by start
        self.records = []

    def __bool__(self) -> bool:
        """Whether there is any burn (an empty schedule runs as no schedule)."""
        return bool(self.items)

    def snap(self, t_out) -> None:
        """Move burn starts and ends within :data:`SNAP_S` of an output time onto it (a finite
        burn whose start and end would meet keeps its duration)."""
        t_out = np.asarray(t_out, dtype=np.float64)
        if t_out.size == 0:
            return

        def near(x):
            k = int(np.searchsorted(t_out, x))
            close = [t_out[j] for j in (k - 1, k) if 0 <= j < t_out.size]
            best = min(close, key=lambda c: abs(c - x))
            return float(best) if abs(best - x) <= SNAP_S else x

        def both(a, b):  # a finite burn never shrinks to nothing: then it moves as a whole
            a1, b1 = near(a), near(b)
            return (a1, b1) if b1 > a1 or a == b else (a1, a1 + (b - a))

        self.items = [(*both(a, b), m) for a, b, m in self.items]

    def check_state(self, t: float, y) -> None:
        """Refuse a finite burn in a local frame that starts where the frame is undefined
        (``y``: one state (6,) or N states (N, 6))."""
        for start, _, burn in self.items:
            if isinstance(burn, FiniteBurn) and start == t and burn.code != INERTIAL:
                if not np.all(np.isfinite(local_axes(y[..., :3], y[..., 3:], burn.code))):
                    raise InvalidStateError(
                        f"the {burn.frame} frame of {burn!r} is undefined at its start (r x v = 0 "
                        "or v = 0): give its direction in GCRS."
                    )

    def breakpoints(self, t_last: float) -> list:
        """0, the burns' starts and ends up to ``t_last``, and ``t_last``, sorted, unique."""
        pts = {0.0, t_last}
        for a, b, _ in self.items:
            pts.update(x for x in (a, b) if x <= t_last)
        return sorted(pts)

    def segment_model(self, model, a: float, b: float):
        """The force model of the segment [a, b) (s from the epoch): its time origin at a, the
        thrust of the finite burn that is on over it."""
        force = fb.with_time_origin(model.force, a)
        for start, end, burn in self.items:
            if isinstance(burn, FiniteBurn) and start <= a < end:
                burn.pack(force, a - start)
        return _SegmentModel(force, model)

    def impulses_at(self, t: float) -> list:
        return [b for a, _, b in self.items if a == t and isinstance(b, ImpulsiveBurn)]

    def log_impulse(self, burn, t, dv):
        n = np.linalg.norm(dv, axis=-1)
        after = (None if burn.mass is None else
                 burn.mass + (0.0 * u.kg if burn.delta_mass is None else burn.delta_mass))
        self.records.append(BurnRecord(burn, t * u.s, t * u.s, n * u.km / u.s,
                                       to_quantity(dv, "speed"), burn.mass, after, True))

    def log_finite(self, t_reached: float):
        """Record the finite burns started before ``t_reached`` (s), cut there if unfinished."""
        for start, end, burn in self.items:
            if isinstance(burn, FiniteBurn) and start < t_reached:
                stop = min(end, t_reached)
                m0, m1 = burn.mass_at(0.0), burn.mass_at(stop - start)
                self.records.append(BurnRecord(
                    burn, start * u.s, stop * u.s, burn.delta_v_after(stop - start) * u.km / u.s,
                    None, None if m0 is None else m0 * u.kg, None if m1 is None else m1 * u.kg,
                    stop == end))

    def run(self, run_one):
        """A function with the signature and outputs of ``cowell._run`` that integrates the
        forward leg segment by segment."""
        from .burn_segments import run_segments

        def run(*args):
            return run_segments(self, run_one, *args)

        return run

    def run_many(self, run_many):
        """The same for N states and ``cowell._run_many``."""
        from .burn_segments import run_segments_many

        def run(*args):
            return run_segments_many(self, run_many, *args)

        return run

    def annotate(self, result) -> None:
        """Set ``result.burns`` (records by start) and ``result.final_mass``."""
        records = sorted(self.records, key=lambda r: r.t_start.value)
        result.burns = records
        masses = [r.mass_after for r in records if r.mass_after is not None]
        result.final_mass = masses[-1] if masses else None


class _SegmentModel:
    """A force model whose block is replaced (``.force``, ``.arrays()``) for one segment."""

    def __init__(self, force, model):
        self.force = force
        self._model = model

    def arrays(self):
        return (self.force,) + self._model.arrays()[1:]


#: What an OPM's state carries when its message has manoeuvres (see :meth:`OPM.state`).
PENDING_ATTRIBUTE = "_pending_maneuvers"


def refuse_pending(state, what: str, remedy: str = "Propagate it with opm.propagate(t, "
                   "perturbations), which applies them.") -> None:
    """Refuse a state read from an OPM with manoeuvres where ``what`` would ignore them.

    Parameters
    ----------
    state : StateVectors
        The state (an OPM's :attr:`~visviva.ccsds.opm.OPM.state` says how many manoeuvres its
        message has).
    what : str
        The function that cannot apply manoeuvres, for the message.
    remedy : str
        What to do instead.

    Raises
    ------
    InvalidInputError
        When the state carries manoeuvres.
    """
    pending = getattr(state, PENDING_ATTRIBUTE, None)
    if pending:
        raise InvalidInputError(
            f"this state comes from an OPM with {pending} manoeuvre(s), which {what} would "
            f"ignore. {remedy}"
        )


def burn_schedule(maneuvers, state, epoch):
    """Check ``maneuvers`` of :func:`visviva.propagate_cowell` and order them.

    Parameters
    ----------
    maneuvers : None or iterable of ImpulsiveBurn / FiniteBurn
        As given (None: the default).
    state : StateVectors
        The initial state (an OPM's state says how many manoeuvres its message has).
    epoch : astropy.time.Time or None
        The state's epoch.

    Returns
    -------
    _Schedule or None
        None without ``maneuvers``; an empty (false) schedule for an empty list.
    """
    if maneuvers is None:
        refuse_pending(state, "propagate_cowell", "Pass maneuvers=opm.burns() to apply them (or "
                       "call opm.propagate(t, perturbations)), or maneuvers=[] to propagate "
                       "without.")
        return None
    if isinstance(maneuvers, _Burn):
        maneuvers = [maneuvers]
    maneuvers = list(maneuvers)
    if not maneuvers:
        return _Schedule([])  # nothing to split at; the result reports no burns
    for m in maneuvers:
        if not isinstance(m, _Burn):
            raise InvalidInputError(
                f"{m!r} is not a burn; give vv.ImpulsiveBurn(...) or vv.FiniteBurn(...) (an "
                "OPM's manoeuvres: opm.burns())."
            )
    items = []
    for m in maneuvers:
        a = m.start_offset_s(epoch)
        if not math.isfinite(a) or a < 0:
            raise InvalidInputError(
                f"{m!r} starts {a:g} s before the state's epoch. Burns are applied forward in "
                "time only (a local-frame Δv needs the state before the burn): start from a "
                "state at or before the first burn."
            )
        items.append((a, a + getattr(m, "duration_s", 0.0), m))
    items.sort(key=lambda x: x[0])
    for i, (a, b, m) in enumerate(items):
        if not isinstance(m, FiniteBurn):
            continue
        for j, (c, d, other) in enumerate(items):
            if j == i:
                continue
            inside = a < c < b if isinstance(other, ImpulsiveBurn) else (c < b and a < d)
            if inside:
                raise InvalidInputError(
                    f"{other!r} overlaps {m!r}; burns must not overlap (an impulse may sit at a "
                    "finite burn's start or end)."
                )
    return _Schedule(items)
