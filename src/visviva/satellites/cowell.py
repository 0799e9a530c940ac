"""Cowell's method: numerical propagation of a satellite under perturbations.

>>> import visviva as vv
>>> from astropy import units as u
>>> import numpy as np
>>> state = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 5.0, 5.8] * u.km / u.s, vv.EARTH)
>>> out = vv.propagate_cowell(state, np.linspace(0, 1, 5) * u.day, [vv.J2(vv.EARTH)])
>>> out.r.shape
(5, 3)

The first call compiles the integrator (a few seconds, cached on disk afterwards).
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .. import constants as c
from .._units import (
    advance_epoch,
    require_finite,
    require_usable_time,
    seconds_since,
    to_array,
    to_quantity,
    to_vector,
)
from ..bodies import EARTH, SUN
from ..core import force_block as fb
from ..core.cowell import WORK_ROWS, integrate_cowell, rhs_kind
from ..core.perturbations import FORCE_SIZE, VALLADO_EXPONENTIAL_TABLE
from ..errors import InvalidInputError, ShapeError, fmt_number, raise_for_status
from .burn_segments import burn_schedule
from .cowell_batch import propagate_batch, raise_budget
from .dop853 import dop853_tableau, integration_tolerances
from .events import Event, EventRecord, event_capacity
from .lunar_shadow import warn_earth_shadow
from .perturbations import (
    AtmosphericDrag,
    Perturbation,
    SolarRadiationPressure,
    SphericalHarmonics,
    ThirdBody,
    Zonal,
    earth_pole_table,
    ellipsoid_radius_of,
    flattening_of,
)
from .relativity import Relativity
from .satellite_states import require_gcrs
from .surface import batch_impact, check_single, watched_body, with_surface

__all__ = ["propagate_cowell", "CowellResult", "ForceModel", "central_body", "output_offsets_s"]

#: Default tolerances: with rtol = 1e-12 the error after one day of LEO is ~0.2 mm
#: (docs/cowell.md); atol in km and km/s.
DEFAULT_RTOL = 1e-12
DEFAULT_ATOL = 1e-12
#: Ephemeris grid step for the Hermite tables, s.
EPHEMERIS_STEP_S = 3600.0


def _all_instances(items, cls, what, hint):
    """``items`` as a list, after checking that each is a ``cls``.

    Parameters
    ----------
    items : iterable
        The user's perturbations or events.
    cls : type
        The class each must be an instance of.
    what : str
        What one item is called in the message (``"a perturbation"``).
    hint : str
        The classes to use instead, for the message.

    Raises
    ------
    InvalidInputError
        On the first item that is not a ``cls``.
    """
    items = list(items)
    for item in items:
        if isinstance(item, type) and issubclass(item, cls):  # vv.J2 for vv.J2(vv.EARTH)
            raise InvalidInputError(f"the class {item.__name__} was given, not {what}: call it "
                                    f"(e.g. vv.{item.__name__}(...)) and pass the instance.")
        if not isinstance(item, cls):
            raise InvalidInputError(f"{item!r} is not {what}; use {hint}.")
    return items


def perturbation_list(perturbations, *, allow_none: bool = False):
    """The ``perturbations`` argument as an iterable of perturbations, or an InvalidInputError.

    Parameters
    ----------
    perturbations : Perturbation, list of Perturbation or None
        One perturbation (wrapped in a list), or an iterable of them (returned as given);
        None only where ``allow_none`` (then ``[]``).
    allow_none : bool
        Whether None means "no perturbations" (the message then says so).

    Returns
    -------
    list or iterable of Perturbation
    """
    if allow_none and perturbations is None:
        return []
    if isinstance(perturbations, Perturbation):
        return [perturbations]
    if isinstance(perturbations, str | bytes) or not hasattr(perturbations, "__iter__"):
        expected = ("None, [] or a list such as" if allow_none
                    else "a list of perturbations, e.g.")
        raise InvalidInputError(
            f"perturbations must be {expected} [vv.J2(vv.EARTH)]; got {perturbations!r}."
        )
    return perturbations


def _check_combination(perturbations, central):
    """Refuse combinations the force block cannot hold (one gravity field, one drag, one SRP,
    each third body once and not the central body)."""
    zonals = [p for p in perturbations if isinstance(p, Zonal)]
    if len(zonals) > 1:
        raise InvalidInputError(
            f"give one zonal model, not {zonals}: Zonal(body, n) already includes J2..Jn."
        )
    harmonics = [p for p in perturbations if isinstance(p, SphericalHarmonics)]
    if harmonics and (zonals or len(harmonics) > 1):
        raise InvalidInputError(
            "give one gravity field: SphericalHarmonics already includes the zonal terms, "
            "so do not add J2 or Zonal to it."
        )
    for kind in (AtmosphericDrag, SolarRadiationPressure, Relativity):
        if sum(isinstance(p, kind) for p in perturbations) > 1:
            raise InvalidInputError(f"give at most one {kind.__name__}.")
    names = [p.body.name for p in perturbations if isinstance(p, ThirdBody)]
    if len(set(names)) != len(names):
        raise InvalidInputError(f"a third body is listed twice: {names}.")
    if central.name in names:
        raise InvalidInputError(f"{central.name} is the central body, not a third body.")


def central_body(gm_km3_s2, perturbations):
    """The central body: the one the perturbations name (refused when the state's GM is, to
    0.1 %, that of another known body), else the known body whose GM the state has, else the
    Earth. A GM of no known body (a custom or scaled one) is left to the caller."""
    from ..bodies import BODIES

    gm = float(gm_km3_s2)
    same = [b for b in BODIES.values() if abs(gm / b.gm_km3_s2 - 1.0) <= 1e-3]
    named = next((p for p in perturbations if p.central_body is not None), None)
    if named is None:
        return same[0] if same else EARTH
    body = named.central_body
    if same and body.name not in {b.name for b in same}:
        raise InvalidInputError(
            f"{named!r} refers to {body.name} as the central body, but the state's gm = "
            f"{gm:.10g} km3/s2 is {same[0].name}'s, not {body.name}'s. Build the state around "
            f"{body.name} (gm=vv.{body.name.upper()}) or give the perturbations of the body the "
            "state orbits."
        )
    return body


class ForceModel:
    """The perturbations assembled into the flat arrays of :mod:`visviva.core.perturbations`.

    The model writes the slots of the central body and of the shared ephemeris tables
    (:data:`SHARED_PARAMETERS`); every perturbation writes its own slots
    (:meth:`~visviva.satellites.perturbations.Perturbation.pack`). The layout of the block is
    :mod:`visviva.core.force_block`.
    """

    #: slots written here, not by a perturbation
    SHARED_PARAMETERS = ("GM", "RADIUS", "ROTATION_RATE", "FLATTENING", "SUN_RADIUS", "AU",
                         "SUN_ROW", "EPH_T0", "EPH_STEP", "EPH_N", "POLE",
                         "ELLIPSOID_RADIUS")

    def __init__(self, gm_km3_s2, perturbations, events=(), epoch=None, span_s=(0.0, 0.0)):
        self.gm_km3_s2 = gm_km3_s2
        self.epoch = epoch
        self.span_s = (float(span_s[0]), float(span_s[1]))
        self.force = np.zeros(FORCE_SIZE)
        self.force[fb.GM] = gm_km3_s2
        self.force[fb.SUN_ROW] = -1.0
        self.zonal = np.zeros(3)
        self.atm = VALLADO_EXPONENTIAL_TABLE.copy()
        self.sh = np.zeros((2, 3, 3))
        perturbations = _all_instances(
            perturbations, Perturbation, "a perturbation",
            "vv.J2, vv.Zonal, vv.AtmosphericDrag, vv.ThirdBody, vv.SolarRadiationPressure, vv.Relativity",
        )
        centrals = {p.central_body.name for p in perturbations if p.central_body is not None}
        if len(centrals) > 1:
            raise InvalidInputError(
                f"the perturbations refer to different central bodies ({sorted(centrals)}); "
                "use one central body for every perturbation."
            )
        central = central_body(gm_km3_s2, perturbations)
        self.central_body = central
        self.force[fb.RADIUS] = central.radius_km
        self.force[fb.FLATTENING] = flattening_of(central)
        self.force[fb.ELLIPSOID_RADIUS] = ellipsoid_radius_of(central)
        rot = central.rotation_rate
        self.force[fb.ROTATION_RATE] = 0.0 if rot is None else float(rot.to_value(u.rad / u.s))
        if central.name == "earth" and any(isinstance(p, SphericalHarmonics) for p in perturbations):
            # a full field turns with the Earth rotation angle: WGS-84's rounded 7.292115e-5
            # rad/s left it 0.62" behind astropy's ITRS in 30 days, 5.5" in 180 (audit56)
            self.force[fb.ROTATION_RATE] = c.EARTH_ROTATION_ANGLE_RATE_RAD_S
        self.force[fb.SUN_RADIUS] = SUN.radius_km
        self.force[fb.AU] = c.AU_KM
        _check_combination(perturbations, central)

        third = [p.body for p in perturbations if isinstance(p, ThirdBody)]
        names = [b.name for b in third]
        gms = [b.gm_km3_s2 for b in third]
        table_names = list(names)
        need_sun = any(getattr(p, "needs_sun", False) for p in perturbations) or any(
            getattr(e, "needs_sun", False) for e in events
        )
        if need_sun:
            if "sun" not in table_names:
                table_names.append("sun")
                gms.append(SUN.gm_km3_s2)
            self.force[fb.SUN_ROW] = table_names.index("sun")
        if table_names:
            if epoch is None:
                raise InvalidInputError(
                    "third bodies, solar radiation pressure, NRLMSIS drag and eclipse events need the "
                    "state's "
                    "epoch: build the state with epoch=Time('2024-01-01T00:00:00', scale='utc')."
                )
            if central.name not in ("earth", "moon", "sun"):
                raise InvalidInputError(
                    f"third-body positions are tabulated relative to the Earth, Moon or Sun, "
                    f"not {central.name}."
                )
            from .ephemeris import tabulate

            t0, step, er, ev = tabulate(
                table_names, epoch, span_s[0], span_s[1], EPHEMERIS_STEP_S, central.name
            )
            self.force[fb.EPH_T0] = t0
            self.force[fb.EPH_STEP] = step
            self.force[fb.EPH_N] = er.shape[1]
            self.eph_r, self.eph_v = er, ev
        else:
            self.force[fb.EPH_STEP] = 1.0
            self.force[fb.EPH_N] = 2
            self.eph_r = np.zeros((0, 2, 3))
            self.eph_v = np.zeros((0, 2, 3))
        if any(getattr(e, "equator", "frame") == "of date" for e in events) and (
                epoch is None or central.name != "earth"):
            raise InvalidInputError(
                "node events on the equator 'of date' need an Earth-centred state with an epoch "
                "(the Earth's pole of date); use equator='frame' (the state's xy plane)."
            )
        if epoch is not None and central.name == "earth" and any(
            getattr(p, "uses_pole", False) for p in (*perturbations, *events)
        ):  # one table of the Earth's pole for every force and event that turns with it
            t0, step, knots = earth_pole_table(epoch, *self.span_s)
            self.force[fb.POLE:fb.POLE + 4] = (t0, step, len(knots), FORCE_SIZE)
            self.force = np.concatenate([self.force, knots.ravel()])
        # else the frame's z axis: no epoch, or another body, whose pole visviva does not know
        for p in perturbations:
            p.pack(self)
        self.eph_gm = np.asarray(gms, dtype=np.float64)
        self.zonal = np.ascontiguousarray(self.zonal, dtype=np.float64)

    def arrays(self):
        return self.force, self.zonal, self.atm, self.eph_r, self.eph_v, self.eph_gm, self.sh

    def acceleration(self, t_s, r_km, v_km_s):
        """Total acceleration (km/s^2) at times ``t_s`` for states (N, 3): for tests and plots."""
        from ..core.perturbations import cowell_rhs_array

        y = np.ascontiguousarray(np.concatenate([r_km, v_km_s], axis=-1).reshape(-1, 6))
        t = np.ascontiguousarray(np.broadcast_to(t_s, y.shape[:1]), dtype=np.float64)
        return cowell_rhs_array(t, y, *self.arrays())[:, 3:]


class CowellResult:
    """The outcome of :func:`propagate_cowell`.

    Attributes
    ----------
    t : Quantity (T,)
        Output times from the initial epoch, s (only those reached before a terminal event).
    r, v : Quantity (T, 3)
        Positions (km) and velocities (km/s); shape (3,) for a scalar time; (N, T, 3) for N
        states.
    epoch : astropy Time or None
        The initial epoch.
    events : list of EventRecord
        Events in the order they happened.
    terminated : bool
        Whether a terminal event (re-entry) stopped the propagation early.
    t_final : Quantity
        The last time integrated to: the forward end, or for a run with only negative
        output times the backward end (where a terminal event stopped the run, its time).
    n_steps, n_evaluations : int
        Accepted steps and right-hand-side evaluations.
    burns : list of BurnRecord
        Only for a run with ``maneuvers`` (``[]`` for an empty list): what each burn did
        (:mod:`visviva.satellites.burns`).
    final_mass : Quantity or None
        Only for a run with ``maneuvers``: the mass after the last burn that knows it, kg.
    """

    def __init__(self, t, r, v, gm, epoch, events, terminated, t_final, n_steps, nfev, scalar):
        self.t = t
        self.r = r
        self.v = v
        self.gm = gm
        self.epoch = epoch
        self.events = events
        self.terminated = terminated
        self.t_final = t_final
        self.n_steps = n_steps
        self.n_evaluations = nfev
        self._scalar = scalar

    @classmethod
    def _from_arrays(cls, t_s, y, gm, epoch, events, terminated, t_final_s, n_steps, nfev,
                     scalar):
        """Wrap the integrator's raw output in Quantities.

        Parameters
        ----------
        t_s : float or ndarray (T,)
            Output times from the epoch, s.
        y : ndarray (..., 6)
            States at those times: position (km) then velocity (km/s) on the last axis.
        gm, epoch, events, terminated, n_steps, nfev, scalar
            As in the constructor.
        t_final_s : float
            The last time integrated to, s.

        Returns
        -------
        CowellResult
        """
        return cls(
            to_quantity(t_s, "time"),
            to_quantity(np.ascontiguousarray(y[..., :3]), "length"),
            to_quantity(np.ascontiguousarray(y[..., 3:]), "speed"),
            gm,
            epoch,
            events,
            terminated,
            t_final_s * u.s,
            n_steps,
            nfev,
            scalar,
        )

    @property
    def times(self):
        """Absolute output times (astropy Time), or None when the state had no epoch."""
        return None if self.epoch is None else advance_epoch(self.epoch, self.t.to_value(u.s))

    def to_states(self):
        """The outputs as :class:`visviva.StateVectors` (shape (T,))."""
        from ..states import StateVectors

        epoch = self.times
        return StateVectors(self.r, self.v, self.gm * u.km**3 / u.s**2, epoch=epoch)

    def events_named(self, name: str, what: str | None = None) -> list:
        """Events with this name (and crossing ``what``, e.g. ``"entry"``)."""
        return [e for e in self.events if e.name == name and (what is None or e.what == what)]

    def __len__(self):
        return 1 if self._scalar else len(self.t)

    def __repr__(self):
        stop = ", terminated" if self.terminated else ""
        return (
            f"CowellResult({len(self)} times, {len(self.events)} events, "
            f"{self.n_steps} steps{stop})"
        )


def output_offsets_s(t, epoch):
    """Output times ``t`` (time Quantity or astropy Time) as float64 s from ``epoch``."""
    from astropy.time import Time

    if isinstance(t, Time):
        if epoch is None:
            raise InvalidInputError(
                "t is an astropy Time but the state has no epoch; build the state with "
                "epoch=..., or pass t as offsets from the initial state (e.g. 3600 * u.s)."
            )
        require_usable_time(t, "t")
        return seconds_since(t, epoch)  # TT seconds; advance_epoch (times) is its inverse
    return to_array(t, "time", "t")


#: CPU seconds per step of an interpreted Cowell run (core/tier.py), first guess (measured 0.6
#: ms for two-body + J2); updated from each interpreted run.
_INTERPRETED_STEP_S = {"s": 1e-3}


def _integrate(args: tuple, info: np.ndarray) -> int:
    """``integrate_cowell(*args)``; on a fresh install, interpreted first (:mod:`visviva.core.tier`).

    A Cowell run cannot pause and resume bit for bit, so the interpreted run gets a step cap
    that the process's interpreter budget affords; a run that reaches it is dropped (its arrays
    restored) and the machine code runs it from the start. ``info`` is the kernel's info array
    (``info[2]``: steps done)."""
    import time

    from ..core import tier

    max_steps = int(args[6])
    cap = min(max_steps, int(tier.budget_left() / _INTERPRETED_STEP_S["s"]))
    if cap < 50 or tier.in_memory(integrate_cowell):  # not worth it, or tier off, or warm
        return integrate_cowell(*args)
    fn = tier.interpreted_if_cold(integrate_cowell,
                                  tuple(integrate_cowell.typeof_pyval(a) for a in args))
    if fn is None:
        return integrate_cowell(*args)
    t0 = time.process_time()

    def finished(status) -> bool:  # (before the arrays are restored)
        steps = int(info[2])
        if steps > 0:
            _INTERPRETED_STEP_S["s"] = max((time.process_time() - t0) / steps, 1e-5)
        return cap == max_steps or status == 0 or steps < cap

    ok, status = tier.run_guarded(fn, args[:6] + (cap,) + args[7:], accept=finished)
    if ok:
        return int(status)
    return integrate_cowell(*args)


def _run(y0, t_out, t_end, model, rtol, atol, h_max, max_steps, ev, ev_tol):
    A, B, C, E3, E5, D = dop853_tableau()
    kinds, params, dirs, terms = ev
    cap = event_capacity(y0, t_end, float(model.force[fb.GM]), len(kinds))
    while True:
        y_out = np.zeros((t_out.shape[0], 6))
        ev_t = np.zeros(cap)
        ev_y = np.zeros((cap, 6))
        ev_which = np.zeros(cap)
        info = np.zeros(6)
        status = _integrate((
            y0, t_out, t_end, rtol, atol, h_max, max_steps, *model.arrays(),
            kinds, params, dirs, terms, ev_tol, A, B, C, E3, E5, D,
            y_out, ev_t, ev_y, ev_which, info, rhs_kind(model.force, kinds),
            np.zeros((WORK_ROWS, 6)),
        ), info)  # fmt: skip
        n_found = int(info[1])
        if n_found <= cap:
            break
        cap = 2 * n_found
    written = int(info[0])
    return status, y_out[:written], ev_t[:n_found], ev_y[:n_found], ev_which[:n_found], info


def propagate_cowell(
    state,
    t,
    perturbations=(),
    *,
    events=(),
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    max_step=None,
    max_steps: int = 10_000_000,
    maneuvers=None,
):
    """Propagate a state numerically with perturbations (Cowell's method).

    Parameters
    ----------
    state : StateVectors
        One initial state (``r``, ``v`` of shape (3,)) or N states sharing GM and epoch
        (shape (N, 3): integrated in parallel, results of shape (N, T, 3), no events) about the
        central body; ``state.gm`` is the central GM. Its ``epoch`` is needed for third bodies,
        SRP, NRLMSIS drag, spherical harmonics and eclipses.
    t : Quantity or astropy Time
        Output times: offsets from the state's epoch (time Quantity, scalar or 1-D, strictly
        increasing, any sign) or absolute astropy Times.
    perturbations : list of Perturbation
        Any of :class:`~visviva.J2`, :class:`~visviva.Zonal`, :class:`~visviva.AtmosphericDrag`,
        :class:`~visviva.ThirdBody`, :class:`~visviva.SolarRadiationPressure`,
        :class:`~visviva.Relativity`. The central
        body is the one they name (J2, drag, SRP's shadow), else the known body whose GM the
        state has (third bodies are then tabulated relative to it), else the Earth; a state
        whose GM is another known body's than the one they name is refused.
    events : list of Event
        :class:`~visviva.satellites.Eclipse`, :class:`~visviva.satellites.ReEntry`,
        :class:`~visviva.satellites.AltitudeCrossing`, :class:`~visviva.satellites.AscendingNode`,
        :class:`~visviva.satellites.Apsides` ...
    rtol, atol : float
        Local error tolerances of the integrator (atol in km and km/s). The defaults keep the
        error after one day of LEO near 0.2 mm, also with SRP and a shadow (steps end at the
        shadow boundaries; docs/cowell.md, "Shadow boundaries").
    max_step : Quantity, optional
        Largest step size.
    max_steps : int
        Step budget (raises :class:`~visviva.StepSizeError` beyond).
    maneuvers : list of ImpulsiveBurn or FiniteBurn, optional
        Burns (docs/cowell.md, "Manoeuvres"), the same for every state of a batch: the run is
        split at each burn's start and end; burns before the epoch are crossed backwards by
        negative output times (the state given is after them and before any burn at the
        epoch). A state read from an OPM with manoeuvres is refused without it
        (``maneuvers=opm.burns()``, or ``[]`` for none).

    Returns
    -------
    CowellResult
        ``.t``, ``.r``, ``.v`` at the requested times (up to a terminal event), ``.events``;
        with burns also ``.burns`` (:class:`~visviva.satellites.burns.BurnRecord`) and
        ``.final_mass``.

    Notes
    -----
    Cowell's method integrates r'' = -GM r/|r|^3 + a_p(t, r, v) directly (Vallado 2013,
    sec. 8.4; Montenbruck & Gill 2000, sec. 4.1). The integrator is Dormand & Prince's DOP853,
    an explicit Runge-Kutta method of order 8 with embedded 5th/3rd-order error estimates and a
    7th-degree dense output (Hairer, Norsett & Wanner 1993, sec. II.10), compiled together with
    the force model so the whole run is one compiled call; all output times come from the
    dense output of a single integration.
    """
    if not hasattr(state, "r") or not hasattr(state, "v") or not hasattr(state, "gm"):
        raise InvalidInputError(
            "state must be a vv.StateVectors (with .r, .v, .gm); build one with "
            "vv.StateVectors(r, v, vv.EARTH)."
        )
    require_gcrs(state, "propagate_cowell")
    r0 = to_vector(state.r, "length", "state.r")
    v0 = to_vector(state.v, "speed", "state.v")
    if r0.shape != v0.shape or r0.ndim > 2:
        raise ShapeError(
            f"propagate_cowell takes one state (r and v of shape (3,)) or N states (N, 3); got "
            f"{r0.shape} and {v0.shape}. Reshape the states to (N, 3)."
        )
    batch = r0.ndim == 2
    gm_all = np.ravel(to_array(state.gm, "gm", "state.gm"))
    gm = float(gm_all[0]) if gm_all.size else float("nan")
    if not gm > 0 or np.any(gm_all != gm):
        raise InvalidInputError(
            "the states' GM must be > 0 and the same for every state (e.g. vv.EARTH.gm)."
        )
    if np.any(np.linalg.norm(r0, axis=-1) == 0):
        raise InvalidInputError("an initial position is zero; give non-zero positions.")
    epoch = getattr(state, "epoch", None)
    if epoch is not None and not epoch.isscalar:
        if np.any((epoch - epoch.ravel()[0]).to_value(u.s) != 0):
            raise InvalidInputError(
                "a batch of states must share one epoch; propagate groups with equal epochs."
            )
        epoch = epoch.ravel()[0]
    offsets = output_offsets_s(t, epoch)
    scalar = offsets.ndim == 0
    offsets = np.atleast_1d(offsets)
    if offsets.ndim != 1:
        raise ShapeError(f"t must be a scalar or a 1-D array of times; got shape {offsets.shape}.")
    if offsets.size == 0:
        raise InvalidInputError(
            "t is empty: give at least one output time (e.g. np.linspace(0, 1, 10) * u.day)."
        )
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps <= 0:
        raise InvalidInputError(f"max_steps must be an integer > 0; got {fmt_number(max_steps)}.")
    perturbations = perturbation_list(perturbations)
    if isinstance(events, Event):
        events = [events]
    require_finite(offsets, "t")
    if offsets.size > 1 and np.any(np.diff(offsets) <= 0):
        i = int(np.flatnonzero(np.diff(offsets) <= 0)[0])
        raise InvalidInputError(
            f"the output times must be strictly increasing; t[{i + 1}] = {offsets[i + 1]} s "
            f"comes after t[{i}] = {offsets[i]} s. Sort them (np.sort) and remove duplicates."
        )
    rtol, atol = integration_tolerances(rtol, atol)
    h_max = np.inf
    if max_step is not None:
        h_max = float(to_array(max_step, "time", "max_step"))
        if not h_max > 0:
            raise InvalidInputError("max_step must be > 0.")
    events = _all_instances(
        events, Event, "an event",
        "vv.satellites.Eclipse(), ReEntry(), AltitudeCrossing(...), AscendingNode(), Apsides()",
    )
    span = (min(0.0, offsets[0]), max(0.0, offsets[-1]))
    if batch and events:
        raise InvalidInputError(
            "events are found for one state at a time; loop over the states (state[i]) to get "
            "their events, or drop events=... for the batch."
        )
    schedule = burn_schedule(maneuvers, state, epoch)
    model = ForceModel(gm, perturbations, events, epoch, span)
    warn_earth_shadow(model, events, r0, v0)  # about the Moon, the Earth's shadow is left out
    body = watched_body(gm, perturbations, r0)  # the surface bounds a perturbed run
    if batch:
        y0 = np.ascontiguousarray(np.concatenate([r0, v0], axis=1))
        y_all, n_steps, nfev, impact = propagate_batch(
            y0, offsets, span, model, rtol, atol, h_max, max_steps, schedule, body is not None)
        t_all = offsets
        if scalar:
            y_all, t_all = y_all[:, 0], offsets[0]
        result = CowellResult._from_arrays(t_all, y_all, gm, epoch, [], False,
                                           float(offsets[-1] if offsets[-1] >= 0 else
                                                 offsets[0]), n_steps, nfev, scalar)
        if schedule is not None:
            schedule.annotate(result)
        if impact is not None:
            raise batch_impact(body, impact[0], impact[1], result)
        return result
    events = with_surface(events, body)
    ev = (
        np.array([e.kind for e in events], dtype=np.int64),
        np.array([e.param for e in events], dtype=np.float64),
        np.array([e.direction for e in events], dtype=np.int64),
        np.array([e.terminal for e in events], dtype=np.int64),
    )
    y0 = np.concatenate([r0, v0])
    ev_tol = 1e-6

    pieces_y, pieces_t, records = [], [], []
    n_steps = nfev = 0
    terminated = False
    t_final = 0.0
    back = offsets[offsets < 0][::-1]
    fwd = offsets[offsets >= 0]
    for part, t_end in ((back, span[0]), (fwd, span[1])):
        if t_end == 0.0 and part.size == 0:
            continue
        run = schedule.run(_run) if schedule else _run
        status, y_out, ev_t, ev_y, ev_which, info = run(
            y0, np.ascontiguousarray(part), t_end, model, rtol, atol, h_max, max_steps, ev, ev_tol
        )
        if status != 0 and int(info[2]) >= max_steps:
            raise_budget(max_steps, info[4], "")
        raise_for_status(
            np.int64(status),
            f"Cowell propagation stopped at t = {info[4]:.6f} s after {int(info[2])} steps",
        )
        n_steps += int(info[2])
        nfev += int(info[3])
        stopped = int(info[5]) >= 0
        part = part[: len(y_out)]
        if t_end < 0:  # back to increasing time
            y_out, part = y_out[::-1], part[::-1]
        pieces_y.append(y_out)
        pieces_t.append(part)
        # the records' Quantities: three conversions per run, rows indexed per event (a
        # conversion per event cost 25 us, 2.3 ms for 90 eclipse crossings in a LEO day)
        tq, rq, vq = ev_t * u.s, to_quantity(ev_y[:, :3].copy(), "length"), to_quantity(
            ev_y[:, 3:].copy(), "speed")
        for k, wk in enumerate(ev_which):
            e = events[int(abs(wk)) - 1]
            records.append(EventRecord(e.name, e.label(np.sign(wk)), tq[k], rq[k], vq[k],
                                       bool(e.terminal)))
        if stopped:
            terminated = True
            t_final = info[4]
            if t_end >= 0:
                break
        elif t_end >= 0 or fwd.size == 0:  # the forward end, else a backward-only run's
            t_final = info[4]
    y_all = np.concatenate(pieces_y) if pieces_y else np.zeros((0, 6))
    t_all = np.concatenate(pieces_t) if pieces_t else np.zeros(0)
    records.sort(key=lambda rec: rec.t.value)
    if scalar and len(t_all) == 1:
        y_all, t_all = y_all[0], t_all[0]
    result = CowellResult._from_arrays(
        t_all, y_all, gm, epoch, records, terminated, t_final, n_steps, nfev, scalar
    )
    if schedule is not None:
        schedule.annotate(result)
    return check_single(result, body)
