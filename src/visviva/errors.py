"""Typed exceptions and the one table that maps kernel status codes to them.

Kernels signal, wrappers raise: a compiled kernel writes an integer status per item (see
:mod:`visviva.core.status`); the public wrapper calls :func:`raise_for_status` once on the whole
status array, which raises the exception listed here for the first failing item, with a message
that says what went wrong, where, and what to do instead.
"""

from __future__ import annotations

import threading

import numpy as np

from .core import status as _st

__all__ = [
    "VisvivaError",
    "InvalidInputError",
    "UnitsError",  # noqa: F822 (module __getattr__)
    "ShapeError",
    "InvalidStateError",
    "InvalidElementsError",
    "MissingFileError",
    "ConvergenceError",
    "DomainError",
    "NBodyEvent",
    "Collision",
    "Encounter",
    "Escape",
    "StepSizeError",
    "StepSizeWarning",
    "BackendUnavailableError",
    "SurfaceImpact",
    "EarthOrientationWarning",
    "TrackingDataWarning",
    "ChanAccuracyWarning",
    "Pc2dAccuracyWarning",
    "Pc3dAccuracyWarning",
    "Pc3dWindowWarning",
    "ImplausibleVelocityWarning",
    "SubsurfacePerigeeWarning",
    "StaleElementSetWarning",
    "DecayedObjectWarning",
    "raise_for_status",
    "raise_for_result",
    "require_finite_result",
    "fmt_number",
    "fmt_first",
]


def fmt_number(x) -> str:
    """A number (or array) as a person writes it, for error messages.

    numpy scalars print as the number (``7000.0``, ``-0.1``, ``nan``), never as
    ``np.float64(7000.0)``; 0-d arrays likewise; arrays as a list; anything else as ``repr``.

    Parameters
    ----------
    x : number, numpy scalar or array_like
        The value to show.

    Returns
    -------
    str
    """
    if isinstance(x, (bool, np.bool_)):
        return repr(bool(x))
    try:
        arr = np.asarray(x)
    except Exception:  # pragma: no cover - exotic objects
        return repr(x)
    if arr.dtype.kind not in "biufc":
        return repr(x)
    if arr.ndim == 0:
        return repr(arr.item())
    return repr(arr.tolist()) if arr.size <= 6 else np.array2string(arr, separator=", ",
                                                                      threshold=6)


def fmt_first(items, k: int = 5, sep: str = ", ") -> str:
    """The first ``k`` of ``items`` (strings) joined by ``sep``, then ``" and N more"`` when
    there are more, for messages that name what is wrong without listing thousands.

    Parameters
    ----------
    items : sequence of str
        What to name, in order.
    k : int
        How many to show.
    sep : str
        The separator.

    Returns
    -------
    str
    """
    items = list(items)
    more = f" and {len(items) - k} more" if len(items) > k else ""
    return sep.join(items[:k]) + more


class VisvivaError(Exception):
    """Base class of every error visviva raises on purpose."""


class InvalidInputError(VisvivaError, ValueError):
    """An argument has a value that cannot be used (NaN, inf, negative GM, e < 0, ...)."""


def _define_units_error():
    # astropy.units costs ~0.1 s to import, and calls with plain numbers never need it: the class
    # is defined on first access (module __getattr__ below), deriving from astropy's UnitsError
    from astropy.units import UnitsError as _AstropyUnitsError

    class UnitsError(InvalidInputError, _AstropyUnitsError):
        """A value is missing its unit or has a unit of the wrong physical type.

        Also an ``astropy.units.UnitsError``, so ``except u.UnitsError`` catches it.
        """

    UnitsError.__qualname__ = "UnitsError"
    UnitsError.__module__ = __name__
    return UnitsError


_UNITS_ERROR_LOCK = threading.Lock()


def __getattr__(name):
    # PEP 562: UnitsError is created on first access (see _define_units_error)
    if name == "UnitsError":
        with _UNITS_ERROR_LOCK:
            if "UnitsError" not in globals():
                globals()["UnitsError"] = _define_units_error()
        return globals()["UnitsError"]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class ShapeError(InvalidInputError):
    """Arrays have shapes that do not fit (xyz must be on the last axis, length 3)."""


class InvalidStateError(InvalidInputError):
    """A state vector cannot be converted (radial motion, body at the attractor, ...)."""


class InvalidElementsError(InvalidInputError):
    """A set of orbital elements is inconsistent or out of range."""


class DomainError(InvalidInputError):
    """An input lies outside the mathematical domain of the function."""


class MissingFileError(InvalidInputError, FileNotFoundError):
    """A file to read does not exist; the message names the path and says what to do.

    Also a ``FileNotFoundError`` (what ``open`` and skyfield's loaders raise), so code that
    catches that keeps working; ``filename`` is the path and ``errno`` is ``ENOENT``.
    """

    def __init__(self, path, todo: str):
        import errno
        import os

        path = os.fspath(path)
        where = "" if os.path.isabs(path) else f" (relative to {os.getcwd()!r})"
        self.message = f"{path!r}: no such file{where}; {todo}"
        super().__init__(self.message)
        self.errno, self.strerror, self.filename = errno.ENOENT, "No such file", path
        self._todo = todo

    def __str__(self):  # (OSError's own would print "[Errno 2] No such file: path" only)
        return self.message

    def __reduce__(self):
        return type(self), (self.filename, self._todo)


class ConvergenceError(VisvivaError, ArithmeticError):
    """An iterative solver did not converge to machine precision."""


class StepSizeError(ConvergenceError):
    """An adaptive integrator needed a step smaller than it can take."""


class BackendUnavailableError(VisvivaError, RuntimeError):
    """A compute backend was asked for that this machine or installation cannot provide (for
    example ``backend="cuda"`` without an NVIDIA GPU or without numba-cuda); the message says
    what is missing."""


class SurfaceImpact(VisvivaError, RuntimeError):
    """A propagated trajectory reached the surface of its central body, below which the force
    model (gravity field, atmosphere) means nothing.

    Attributes
    ----------
    t : Quantity
        Time of the impact from the initial epoch, s (for a batch: the first output time found
        below the surface).
    state : int or None
        For a batch of states: the index of the first state that went below the surface.
    result : CowellResult
        The propagation up to the impact (one state) or the whole batch as integrated: nothing
        computed is lost.
    """

    def __init__(self, message: str, t=None, state=None, result=None):
        super().__init__(message)
        self.t = t
        self.state = state
        self.result = result

    def __reduce__(self):  # keep the attributes across processes (Dask workers)
        return type(self), (str(self), self.t, self.state, self.result)


class NBodyEvent(VisvivaError):
    """Base class of the events that halt an N-body integration.

    Attributes
    ----------
    t : float
        Simulation time at which the event was detected.
    particles : tuple of int
        Indices of the particles involved.
    """

    def __init__(self, message: str, t: float = float("nan"), particles: tuple = ()):
        super().__init__(message)
        self.t = t
        self.particles = tuple(particles)


class Collision(NBodyEvent):
    """Two particles touched (their radii overlap) and the collision mode is ``"halt"``."""


class Encounter(NBodyEvent):
    """Two particles came closer than the simulation's encounter distance."""


class Escape(NBodyEvent):
    """A particle went beyond the simulation's escape radius."""


class EarthOrientationWarning(UserWarning):
    """A time lies outside the Earth-orientation (IERS) table, so UT1 and the pole are guessed.

    Past the table's end (the installed Bulletin A predictions, about a year after the
    ``astropy-iers-data`` release) UT1 - UTC is held at its last value and the pole at the
    50-year mean; before 1962 UT1 - UTC is held at its first value. The message names the date
    and the size of the possible error (UT1 drifts 0.1-1 s a year: 0.05-0.5 km along the
    equator). Earth-fixed (ITRS) positions, geodetic coordinates, look angles and passes at
    such times carry that error; inertial (GCRS, TEME) results do not. See
    docs/conventions.md, "Earth orientation".
    """


class TrackingDataWarning(UserWarning):
    """Tracking data were read but not used: a CCSDS TDM's keywords that visviva does not
    model (frequencies, phase counts, media, clocks, signal strength ...), or metadata the
    caller asked to ignore. The message lists each keyword and how many lines it had; the
    data stay in the :class:`~visviva.TDM` object.
    """


class ChanAccuracyWarning(UserWarning):
    """``collision_probability(method="chan")``: Chan's equivalent-area series is more than
    10 % from the exact 2-D (Foster) integral of the same encounter plane (an elongated
    covariance, or a hard-body radius not small beside the minor sigma). The message gives
    both values; use ``method="foster"``.
    """



class Pc2dAccuracyWarning(UserWarning):
    """``collision_probability(method="foster", "chan" or "monte_carlo")``: the states are not
    at TCA (``r1 - r2`` has a component along the relative velocity) and the 2-D value with the
    miss ``|r1 - r2|`` (CARA's convention) is more than 10 % from the value with the miss at the
    straight-line TCA; give the states at TCA. Or the encounter is not short (NASA
    CARA's usage-violation indicators: it lasts more than 1 % of the orbital period, or lies
    that far from TCA), and the 2-D encounter-plane value is more than 10 % from Hall's 3D-Nc
    (``method="pc3d_hall"``, CARA's ``Pc3D_Hall``) of the same conjunction: slow encounters
    (GEO pairs drifting past each other, formation flight) where the straight-line relative
    motion of the 2-D methods does not hold. The message gives both values; use
    ``method="pc3d_hall"``.
    """


class Pc3dAccuracyWarning(UserWarning):
    """``collision_probability(method="3d")``: the 3-D flux integral is more than 10 % from
    Hall's 3D-Nc (``method="pc3d_hall"``, NASA CARA's ``Pc3D_Hall``) over the same time span (a
    slow or curved encounter, where the crossings of the plane normal to the relative velocity
    and the linearly propagated Cartesian covariances do not describe the collision rate). The
    message gives both values; use ``method="pc3d_hall"``.
    """


class Pc3dWindowWarning(UserWarning):
    """``collision_probability(method="pc3d_hall")`` with its default window (this conjunction:
    the conjunction segment about TCA): the collision rate is still appreciable at an end of the
    segment, so the encounter does not end there (orbits flown in formation, where the rate
    barely changes over an orbit) and the expected number of collisions depends on the time
    span. The message gives the window used and the rate there; pass ``window=(t_a, t_b)``.
    """


class StaleElementSetWarning(UserWarning):
    """A pass or event search (``find_passes``, ``GroundStation.find_events``) or a
    :class:`~visviva.Satellite` propagation (``teme``, ``gcrs``, ``itrs``, ``geodetic``; once
    per call) runs SGP4 more than 30 days from an element set's epoch (before or after the
    window). SGP4's along-track
    error grows by kilometres a day in low orbit, so rise and set times drift by minutes and
    passes appear or vanish: a 2024 TLE over a 2026 window can give no pass at all. The message
    says how many element sets and how far; use element sets from near the window.
    """


class SubsurfacePerigeeWarning(UserWarning):
    """An SGP4 element set (TLE or OMM) whose mean perigee ``a (1 - e)`` lies below the Earth's
    surface: sgp4 accepts it, flags only the times when the satellite is below one Earth radius
    (error 6, "decayed") and propagates the rest of the orbit without a word. The last element
    sets of re-entering objects can be like this (the SGP4 verification set's 28872), so the
    set is kept; a mistyped one (an eccentricity or a mean motion in the wrong columns) is the
    other cause. The message names the element set's line, the perigee and what to check.
    """


class StepSizeWarning(UserWarning):
    """A fixed-step N-body integrator (WHFast, leapfrog) whose step is too long for the orbits it
    follows: the step beyond a fraction of the shortest pericentre timescale, or two bodies
    within a few mutual Hill radii (a moon, a binary, a close encounter) that WHFast leaves to
    its interaction kick. Raised at the start of a call and, once per run, when a state written
    during the run meets the same criteria (members named in ensembles). The states after it
    are not to be trusted; the message says which step would do, or to use IAS15. A stability
    map expects some (its unstable members): filter or record this class there.
    """


class DecayedObjectWarning(UserWarning):
    """An element set (an OMM record, as Space-Track's GP data has them) whose ``DECAY_DATE``
    says that the object re-entered: SGP4 still gives positions after that date, of an object
    that no longer exists (it flags only the times its own model has decayed). Space-Track's
    ``gp`` class and its histories keep the last sets of decayed objects unless the query asks
    for ``DECAY_DATE/null-val``. The message names the objects and their dates.
    """


class PhaseRoundingWarning(UserWarning):
    """A two-body propagation so long that rounding alone moves the body along its orbit.

    The phase n dt of an elliptic orbit carries a relative error of ~eps = 2.2e-16 (from the
    rounding of dt and of the period that r0, v0 and gm give), so the position is off by
    ~eps n |dt| of the orbit's size: 60-digit checks of a LEO orbit give 5.8e-12 km per
    revolution, 5.8 km after 1e12 revolutions, 6e3 km (anywhere on the orbit) after 1e15.
    :func:`visviva.propagate_kepler` warns when eps n |dt| exceeds 1e-3 rad (~7e11 revolutions);
    the message gives the estimate in km. The returned state stays on the right conic.
    """


class ImplausibleVelocityWarning(UserWarning):
    """A state's speed is far above the escape speed at its radius: more than 100 km/s and more
    than ten times the escape speed sqrt(2 mu / r) (Earth: > ~110 km/s in low orbit, where any bound
    orbit has v < 11.2 km/s). The usual cause is velocities in m/s given where km/s are read
    (plain numbers, or ``[7500, ...] * u.km / u.s``), which makes a LEO state look hyperbolic
    with e ~ 1e6. The state is kept (a hyperbolic flyby is legitimate); the message names the
    first such state. Check the velocity's unit.
    """


#: status code -> (exception class, what happened, what to do). The single table of the project.
STATUS_TABLE: dict[int, tuple[type[Exception], str, str]] = {
    _st.NO_CONVERGENCE: (
        ConvergenceError,
        "the iterative solver did not reach machine precision",
        "report the input values as a bug; they are printed above",
    ),
    _st.BAD_ECCENTRICITY: (
        DomainError,
        "the eccentricity is outside this solver's domain",
        "use solve_kepler for 0 <= e < 1, solve_kepler_hyperbolic for e > 1, "
        "and mean_to_true/true_to_mean for any e >= 0 (including e = 1)",
    ),
    _st.RADIAL_ORBIT: (
        InvalidStateError,
        "the angular momentum r x v is zero (radial, rectilinear motion), so the orbital plane "
        "and the angles are undefined",
        "propagate radial states with StateVectors.propagate, which handles them, or perturb v "
        "off the radial direction",
    ),
    _st.NON_FINITE: (
        InvalidInputError,
        "a value is NaN or infinite",
        "remove or fill the NaN/inf entries before calling",
    ),
    _st.ZERO_POSITION: (
        InvalidStateError,
        "the position vector has zero length (the body sits on the attractor)",
        "give a non-zero position",
    ),
    _st.BAD_GM: (
        InvalidInputError,
        "the gravitational parameter GM is not strictly positive",
        "pass GM > 0 (e.g. vv.EARTH.gm)",
    ),
    _st.BAD_SEMI_LATUS_RECTUM: (
        InvalidElementsError,
        "the semi-latus rectum p is not strictly positive",
        "pass p > 0; a radial orbit (p = 0) has no classical elements",
    ),
    _st.UNREACHABLE_ANOMALY: (
        InvalidElementsError,
        "the true anomaly lies on or beyond the asymptote of the open orbit "
        "(|nu| >= arccos(-1/e)), which no body reaches",
        "choose |nu| < arccos(-1/e) for e >= 1",
    ),
    _st.HITS_ATTRACTOR: (
        InvalidStateError,
        "the requested time lies beyond the body's collision with the attractor on a radial orbit",
        "propagate to times before the collision",
    ),
    _st.DOMAIN: (
        DomainError,
        "an input lies outside the function's domain",
        "check the documented domain of each argument",
    ),
    _st.ENCOUNTER: (Encounter, "a close encounter occurred", "catch vv.Encounter to handle it"),
    _st.ESCAPE: (Escape, "a particle escaped", "catch vv.Escape to handle it"),
    _st.COLLISION: (
        Collision,
        "two particles collided",
        "catch vv.Collision, or choose collision='merge' or 'bounce'",
    ),
    _st.STEP_TOO_SMALL: (
        StepSizeError,
        "the adaptive step size fell below its floor",
        "check the force for a singularity or a collision, or soften the potential",
    ),
    _st.EQUINOCTIAL_SINGULAR: (
        DomainError,
        "the modified equinoctial elements are singular for this orbit (h and k are infinite "
        "at i = pi with the retrograde factor I = +1, and at i = 0 with I = -1)",
        "use retrograde=True (I = -1) for retrograde orbits near i = pi, retrograde=False near i = 0",
    ),
    _st.OVERFLOW: (
        DomainError,
        "the result overflows float64 (its magnitude would exceed ~1.8e308) although the inputs "
        "are finite",
        "use inputs of smaller magnitude (e.g. other units, or a smaller anomaly / speed)",
    ),
}


def raise_for_status(status, context: str = "", **inputs) -> None:
    """Raise the typed exception for the first non-OK entry of a kernel's status array.

    Parameters
    ----------
    status : int or array_like of int
        Status codes from a kernel, one per item (``0`` means OK).
    context : str
        What was being computed, e.g. ``"state vectors -> elements"``; starts the message.
    **inputs : array_like
        Arrays of the same shape as ``status`` (after broadcasting); the values at the first
        failing index are quoted in the message so the user can find the bad item.

    Raises
    ------
    VisvivaError
        The subclass given by :data:`STATUS_TABLE` for the first failing status.
    """
    status = np.asarray(status)
    if not status.any():
        return
    flat = status.ravel()
    first = int(np.flatnonzero(flat)[0])
    code = int(flat[first])
    index = np.unravel_index(first, status.shape) if status.ndim else ()
    n_bad = int(np.count_nonzero(flat))
    exc, what, todo = STATUS_TABLE.get(
        code, (VisvivaError, f"unknown status code {code}", "report this as a bug")
    )
    where = f" at index {tuple(int(i) for i in index)}" if status.ndim else ""
    quoted = []
    for name, arr in inputs.items():
        arr = np.asarray(arr)
        try:
            value = np.broadcast_to(arr, status.shape + arr.shape[status.ndim :])[index]
        except ValueError:
            continue
        quoted.append(f"{name}={np.array2string(np.asarray(value), precision=17)}")
    more = f" ({n_bad} of {flat.size} items failed)" if flat.size > 1 else ""
    prefix = f"{context}: " if context else ""
    values = f" [{', '.join(quoted)}]" if quoted else ""
    raise exc(f"{prefix}{what}{where}{more}{values}. To fix: {todo}.")


def require_finite_result(context: str, outputs, shape: tuple, **inputs) -> None:
    """Raise DomainError (status OVERFLOW) where a computed output is NaN or infinite.

    ``outputs`` are arrays of shape ``shape`` or ``shape + (3,)``; ``inputs`` are quoted in the
    message. Called after the kernels reported OK, so a non-finite value here means float64
    overflow of a finite input (kernels and wrappers never hand out NaN/inf silently).
    """
    bad = None
    for out in outputs:
        out = np.asarray(out)
        # fast pass: one NaN or inf makes the sum non-finite (a finite sum proves all finite);
        # only a sum that overflowed or a real non-finite value takes the elementwise pass
        if np.isfinite(np.sum(out)) or np.all(np.isfinite(out)):
            continue
        nf = ~np.isfinite(out)
        while nf.ndim > len(shape):
            nf = nf.any(axis=-1)
        nf = np.broadcast_to(nf, shape)
        bad = nf if bad is None else (bad | nf)
    if bad is None:
        return
    raise_for_status(np.where(bad, _st.OVERFLOW, _st.OK), context, **inputs)


def raise_for_result(
    context: str,
    status: np.ndarray,
    outputs,
    shape: tuple,
    inputs: dict,
    result_context: str | None = None,
    result_inputs: dict | None = None,
) -> None:
    """Raise for a kernel's status array, then for non-finite outputs.

    The two checks every conversion makes after its one kernel call: :func:`raise_for_status`
    on ``status`` (reshaped to ``shape``), then :func:`require_finite_result` on ``outputs``.

    Parameters
    ----------
    context : str
        What was computed, quoted in the error message.
    status : ndarray of int
        The kernel's status codes, ``shape`` items (flat or shaped).
    outputs : sequence of ndarray
        The kernel's results, each of shape ``shape`` or ``shape + (3,)``.
    shape : tuple
        Leading shape of the batch.
    inputs : dict of str to ndarray
        Inputs quoted in the messages (canonical units: km, km/s, s, rad).
    result_context, result_inputs : str or dict, optional
        Other context or inputs for the message about non-finite outputs (default: the same);
        ``result_context`` also heads the message when the kernel itself reported ``OVERFLOW``
        first (an intermediate such as |r|^2 beyond float64).
    """
    status = status.reshape(shape)
    if result_context is not None and status.any():
        flat = status.ravel()
        if flat[np.flatnonzero(flat)[0]] == _st.OVERFLOW:
            context = result_context
    raise_for_status(status, context, **inputs)
    require_finite_result(
        context if result_context is None else result_context,
        outputs,
        shape,
        **(inputs if result_inputs is None else result_inputs),
    )
