"""Fit SGP4 mean elements (a TLE / OMM) to a state history by differential correction.

A TLE holds *mean* elements that only SGP4 turns into positions; the osculating elements of a
state are not them (the J2 short-period terms alone move a LEO position by kilometres). The
elements that make SGP4 reproduce a given trajectory best are found here by weighted least
squares on the TEME positions and velocities over the whole arc (Vallado & Crawford 2008,
"SGP4 orbit determination", AIAA 2008-6770).

>>> import numpy as np, visviva as vv
>>> from astropy import units as u
>>> iss = vv.Satellite.from_tle(
...     "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
...     "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")
>>> states = iss.gcrs(np.linspace(0, 1, 50) * u.day).to_state_vectors()
>>> fitted = vv.fit_tle(states, satnum=25544)
>>> print(f"{fitted.fit.rms_position_km * 1e3 < 1.0}")
True
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import ConvergenceError, InvalidInputError, ShapeError
from ..satellites.catalog_numbers import CATALOGUE_MAX
from ..satellites.tle_checks import MAX_SGP4_RADIUS_KM
from ..satellites.tle_export import epoch_text
from ..satellites.utc_days import time_to_utc_days
from .tle_correction import BSTAR_EFFECT_KM, BSTAR_STEP_MAX, staged_correct, warn_far_states
from .tle_elements import (
    GM_WGS72,
    classical,
    elements_to_fields,
    ephemeris_identity,
    epoch_days,
    initial_elements,
    initial_identity,
    is_retrograde,
    propagable_start,
    sgp4_states,
    warn_other_object,
)

__all__ = ["fit_tle", "fit_tle_arrays", "states_and_times", "TLEFit"]

_MIN_PER_DAY = 1440.0


class TLEFit:
    """Diagnostics of :func:`fit_tle`, attached to the returned satellite as ``.fit``.

    Attributes
    ----------
    rms_position_km : float
        RMS of the position differences between SGP4 and the given states, km.
    max_position_km : float
        Largest position difference, km.
    rms_velocity_km_s : float
        RMS of the velocity differences, km/s.
    iterations : int
        Differential-correction iterations used.
    history : list of dict
        Per iteration: ``iteration``, ``rms_position_km``, ``damping``.
    n_states : int
        Number of states fitted.
    fields : dict
        The fitted element set as OMM fields at full float precision (what
        :meth:`~visviva.Satellite.from_omm` takes).
    sigma_bstar : float or None
        Formal 1-sigma of the fitted B* (1/earth radii), the residuals taken as the noise;
        None when B* was held.
    excluded : ndarray of int
        Indices of the states left out of the fit: far off the set that fits the others (see
        :func:`fit_tle`'s warnings); usually empty.
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def __repr__(self):
        return (f"TLEFit(rms {self.rms_position_km * 1e3:.3g} m, max "
                f"{self.max_position_km * 1e3:.3g} m, {self.iterations} iterations)")  # fmt: skip


def _frame_of(states, frame):
    """The frame of a state history: its own (``sat.teme(t)`` knows it) or ``frame``."""
    from ..satellites.satellite_states import FRAMES, frame_of

    own = frame_of(states)  # (plain states may carry one: TEME, or a REF_FRAME such as TOD)
    if own is not None and own not in FRAMES:
        raise InvalidInputError(
            f"the states are in REF_FRAME = {own} (they say so), a frame visviva cannot rotate "
            "to TEME; give the states in GCRF/EME2000/ICRF, TEME or ITRF.")
    if own is None:
        return "gcrs" if frame is None else frame
    if frame is not None and frame != own:
        raise InvalidInputError(
            f"the states are in {str(own).upper()} (they say so) but frame={frame!r} was given: "
            "leave frame out to fit them in their own frame, or pass states in that frame."
        )
    return own


def states_and_times(states, times, frame):
    """The arrays of a state history in any form :func:`fit_tle` accepts.

    Parameters
    ----------
    states : StateVectors, CowellResult or OEM ephemeris
        As for :func:`fit_tle`.
    times : astropy Time (N,) or None
        Times when ``states`` carries none.
    frame : {"gcrs", "teme"} or None
        Frame of a ``StateVectors`` input; None: the states' own ``frame`` (satellite states
        such as ``sat.teme(t)`` know it; an ephemeris names its own), else GCRS.

    Returns
    -------
    r_km : ndarray (N, 3)
        Positions, km.
    v_km_s : ndarray (N, 3)
        Velocities, km/s.
    times : astropy Time (N,)
        Their times.
    frame : str
        ``"gcrs"``, ``"teme"`` or ``"itrs"``.
    """
    from astropy.time import Time

    from .._units import to_vector

    src = states
    if hasattr(src, "segments") and times is not None:
        raise InvalidInputError(
            "times= is for StateVectors without their own times; an ephemeris carries its "
            "states' times: leave times out.")
    if hasattr(src, "segments"):  # an OEM ephemeris (duck-typed)
        rs, vs, ts = [], [], []
        frames = set()
        for seg in src.segments:
            name = str(getattr(seg, "frame", "GCRF")).strip().upper()
            vf = getattr(seg, "visviva_frame", None)
            if vf is None:
                raise InvalidInputError(
                    f"the ephemeris has REF_FRAME = {name}, a frame visviva cannot rotate to "
                    "TEME; give the states in GCRF/EME2000/ICRF, TEME or ITRF."
                )
            center = str(getattr(seg, "center", "EARTH")).strip().upper()
            if center != "EARTH":
                raise InvalidInputError(
                    f"the ephemeris has CENTER_NAME = {center}; SGP4 mean elements describe "
                    "Earth orbits: give geocentric states (CENTER_NAME = EARTH)."
                )
            st = seg.states
            rs.append(to_vector(st.r, "length", "segment.states.r"))
            vs.append(to_vector(st.v, "speed", "segment.states.v"))
            ts.append(seg.times)
            frames.add(vf)
        if not rs:
            raise InvalidInputError("the ephemeris has no segments; nothing to fit.")
        if len(frames) > 1:
            raise InvalidInputError(f"the ephemeris mixes frames {sorted(frames)}; fit one frame.")
        from astropy.time import Time as _T

        from ..satellites.frames import offline_iers

        with offline_iers():  # a UT1 file needs the installed IERS table, never a download
            utc = [t.utc for t in ts]
        t_all = _T(np.concatenate([t.jd1 for t in utc]), np.concatenate([t.jd2 for t in utc]),
                   format="jd", scale="utc")  # fmt: skip
        r, v = np.concatenate(rs), np.concatenate(vs)
        return r, v, t_all, frames.pop()
    if hasattr(src, "to_states") and hasattr(src, "t"):  # a CowellResult
        if src.epoch is None:
            raise InvalidInputError(
                "the CowellResult has no epoch: propagate a state built with epoch=Time(...)."
            )
        src = src.to_states()
    if not (hasattr(src, "r") and hasattr(src, "v")):
        raise InvalidInputError(
            "states must be a vv.StateVectors (GCRS, epoch array = times), a CowellResult or an "
            f"OEM ephemeris with .segments; got {type(states).__name__}."
        )
    frame = _frame_of(src, frame)
    _require_earth(src)
    r = to_vector(src.r, "length", "states.r")
    v = to_vector(src.v, "speed", "states.v")
    if r.ndim != 2:
        raise ShapeError(f"states must be a history of shape (N, 3); got {r.shape}.")
    own = getattr(src, "epoch", None)
    if times is not None and own is not None and not own.isscalar:
        # audit20: times= replaced the states' own times without a word (a shifted history)
        gap = _largest_gap_s(own, times) if isinstance(times, Time) else np.inf
        if not gap <= 1e-6:
            raise InvalidInputError(
                f"the states carry their own times (an epoch array) and times= differs from "
                f"them (by up to {gap:.6g} s): give the times once, leave times= out.")
    if times is None:
        times = own
        if times is None or times.isscalar:
            raise InvalidInputError(
                "the states' times are unknown: give StateVectors whose epoch is a Time array "
                "(one per state), or pass times=Time([...])."
            )
    if not isinstance(times, Time) or times.shape != (r.shape[0],):
        raise ShapeError(f"times must be an astropy Time of shape ({r.shape[0]},).")
    return r, v, times, frame


def _largest_gap_s(a, b):
    """Largest |a - b| in seconds of two Time arrays (inf when their shapes differ)."""
    if a.shape != b.shape:
        return np.inf
    from ..satellites.frames import offline_iers

    with offline_iers():  # times in UT1 need the installed IERS table, never a download
        return float(np.max(np.abs((a.tt - b.tt).sec), initial=0.0))


def satellite_from_fields(fields):
    """A Satellite from fitted OMM fields (a blank OBJECT_ID leaves the designator blank)."""
    from ..satellites.tle import Satellite

    blank = not fields.get("OBJECT_ID")
    sat = Satellite.from_omm({**fields, "OBJECT_ID": fields.get("OBJECT_ID") or "UNKNOWN"})
    if blank:
        sat.satrec.intldesg = ""
    return sat


def _fill_unused_fields(sat, fields, initial):
    """The fitted satellite with the fields SGP4 ignores filled in ``fields`` and rebuilt:
    ``MEAN_MOTION_DOT`` from its own mean motion, ``REV_AT_EPOCH`` carried from ``initial``."""
    from ..satellites.tle_checks import SGP4Error
    from ..satellites.tle_fields import mean_motion_dot, revolutions_between

    fields["MEAN_MOTION_DOT"] = mean_motion_dot(sat.satrec)
    if initial is not None:
        try:
            crossings, _ = revolutions_between(initial, sat)
        except SGP4Error as exc:  # a set that decays before the midpoint: keep the fit
            warnings.warn(f"the revolution number was not carried from initial (left 0): "
                          f"{exc}", RuntimeWarning, stacklevel=4)
        else:
            rev = int(initial.satrec.revnum) + crossings
            fields["REV_AT_EPOCH"] = rev if rev >= 0 else rev % 100000  # a wrapped 5-digit field
    return satellite_from_fields(fields)


def fit_tle(states, times=None, satnum=99999, fit_bstar=True, bstar=None, *, epoch=None,
            frame=None, name=None, object_id=None, initial=None, max_iterations=50,
            tol=1e-8):  # fmt: skip
    """SGP4 mean elements (and B*) whose propagation best reproduces a state history.

    Parameters
    ----------
    states : StateVectors, CowellResult or OEM ephemeris
        The states to fit: a :class:`~visviva.StateVectors` of shape (N,) whose ``epoch`` is
        the Time array of the states (in its own frame when it has one, as ``sat.teme(t)``,
        ``sat.gcrs(t)`` and ``sat.itrs(t)`` do; else GCRS unless ``frame="teme"``), a
        :class:`~visviva.satellites.CowellResult` (GCRS), or an ephemeris with ``.segments``
        (each with ``.times``, ``.states`` and ``.frame``; TEME, ITRF or GCRS/EME2000/ICRF).
    times : astropy Time (N,), optional
        Times of the states, when ``states`` carries none.
    satnum : int
        Catalogue number of the new element set, 1 .. 999,999,999 (``to_tle()`` writes alpha-5
        above 99,999 and refuses numbers above 339,999, which only an OMM can carry). With
        ``initial`` and the default 99999: ``initial``'s number.
    fit_bstar : bool
        Fit the drag term B* too (default); otherwise it is held at ``bstar``.
    bstar : float, optional
        B* in 1/earth radii: the held value, or the first guess when fitted. Default:
        ``initial``'s B*, else 0 (before audit49 always 0: ``initial=old, fit_bstar=False``
        held B* at 0, not at the old set's value).
    epoch : astropy Time, optional
        Epoch of the element set (default: the first state's time), rounded to the
        microsecond as an OMM stores it.
    frame : {"gcrs", "teme"} or None
        Frame of a ``StateVectors`` input; None (default): the states' own frame when they
        know it (satellite states), else GCRS. A frame that contradicts the states' own is
        refused.
    name : str, optional
        Object name of the new element set (default: ``initial``'s, else an OEM's
        ``OBJECT_NAME``).
    object_id : str, optional
        International designator (``"1998-067A"``; default: ``initial``'s, else an OEM's
        ``OBJECT_ID`` when it is one); blank in the TLE when not given.
    initial : Satellite, optional
        An earlier (or later) element set of the same object, e.g. the TLE or OMM the states
        were propagated from: the new set carries its revolution number forward (see Notes)
        and takes its catalogue number, name, designator and B* where ``satnum``, ``name``,
        ``object_id`` and ``bstar`` are not given. Without it ``REV_AT_EPOCH`` is 0 (unknown).
    max_iterations : int
        Differential-correction iterations allowed.
    tol : float
        Converged when a step lowers the weighted sum of squares by less than this fraction,
        or the position RMS is below 0.1 mm.

    Returns
    -------
    Satellite
        Built from the fitted OMM fields (full float precision; ``to_tle()`` rounds to the
        TLE's columns); its ``fit`` attribute is a :class:`TLEFit` with the residuals.

    Raises
    ------
    InvalidInputError
        Fewer than 4 states (7 with B*), times not strictly increasing, an unbound orbit.
    ConvergenceError
        The correction did not converge (``history`` attribute holds the iterations), or the
        best element set still misses the states by more than 1% of the orbit's radius (not
        one free Earth orbit: a manoeuvre, a re-entry, a wrong frame or unit).

    Warns
    -----
    RuntimeWarning
        B* was fitted but the states do not determine it (its formal 1-sigma, ``fit.sigma_bstar``,
        exceeds 1e-4 1/earth radii and half its value): an arc too short for drag to show. Or
        the revolution number carried from ``initial`` may be off (the two sets disagree along
        track, or drag over the gap between them is large: see
        :func:`visviva.satellites.tle_fields.revolutions_between`). Or a few states (at most
        a fifth) are over 10 times the median residual and 1 km off the fitted set: SGP4's
        own jump where a deep-space orbit's perturbed inclination crosses 0.2 rad, a
        manoeuvre or a bad state; they are named, and left out of the fit when the others
        then fit better (``fit.excluded``). States across SGP4's jump that a refit without
        them brings back are not warned about.

    Notes
    -----
    The unknowns are the mean motion n, the equinoctial elements (e cos(w + W), e sin(w + W),
    tan(i/2) cos W, tan(i/2) sin W) and the mean longitude M + w + W (Broucke & Cefola 1972;
    for a retrograde orbit tan((pi - i)/2) and w - W), non-singular at e = 0 and i = 0 as
    geostationary sets have them, and B*. The first
    guess is the osculating state at the epoch (the "naive" TLE). Each Levenberg-Marquardt
    step solves the weighted least-squares problem on the TEME position and velocity
    differences (velocities weighted by 1/n, so that both count in km) with partials from
    forward differences of SGP4 itself (SGP4 has no variational equations;
    Vallado & Crawford 2008). GCRS states are rotated to TEME with astropy
    (:func:`visviva.satellites.frames.transform_matrices`). On states that SGP4 itself
    generated, the fit recovers the trajectory to well below a metre.

    The fields SGP4 does not use are filled as a published element set has them
    (:mod:`visviva.satellites.tle_fields`): ``MEAN_MOTION_DOT`` (the TLE's ndot/2, rev/day**2)
    is half the rate of change of the fitted set's SGP4 mean motion at its epoch (the drag the
    fitted B* implies; same sign and magnitude as the published field of real TLEs), and
    ``REV_AT_EPOCH`` is ``initial``'s plus the ascending-node crossings between the two epochs,
    counted from SGP4's mean argument of latitude. ``MEAN_MOTION_DDOT`` is 0, as in nearly
    every published set. Propagation does not depend on them.
    """
    if frame is not None:
        from ..satellites.frames import frame_name

        frame = frame_name(frame, ("gcrs", "teme"))
    r, v, t, frame = states_and_times(states, times, frame)
    name, object_id = ephemeris_identity(states, name, object_id, initial)
    return fit_tle_arrays(r, v, t, frame, satnum, fit_bstar, bstar, epoch=epoch, name=name,
                          object_id=object_id, initial=initial, max_iterations=max_iterations,
                          tol=tol)


def fit_tle_arrays(r_km, v_km_s, times, frame, satnum=99999, fit_bstar=True, bstar=None, *,
                   epoch=None, name=None, object_id=None, initial=None, max_iterations=50,
                   tol=1e-8):  # fmt: skip
    """:func:`fit_tle` on plain arrays: what it calls once it has read its input.

    For callers that hold the states as arrays already (``fit_tle_batch`` ships them to Dask
    workers this way: a few flat arrays pickle far cheaper than astropy objects).

    Parameters
    ----------
    r_km : ndarray, shape (N, 3)
        Positions, km.
    v_km_s : ndarray, shape (N, 3)
        Velocities, km/s.
    times : astropy Time, shape (N,)
        Their times (strictly increasing).
    frame : {"gcrs", "teme", "itrs"}
        Frame of the states.
    satnum : int
        Catalogue number of the new element set.
    fit_bstar : bool
        Fit B* too.
    bstar : float, optional
        B* in 1/earth radii (held, or the first guess; default ``initial``'s, else 0).
    epoch : astropy Time, optional
        Epoch of the element set (default: the first time).
    name : str, optional
        Object name.
    object_id : str, optional
        International designator.
    initial : Satellite, optional
        An element set of the same object (revolution number, and defaults for the number,
        name, designator and B*; see :func:`fit_tle`).
    max_iterations : int
        Iterations allowed.
    tol : float
        Relative decrease of the sum of squares that ends the iteration.

    Returns
    -------
    Satellite
        With its ``fit`` report (see :func:`fit_tle`).

    Raises
    ------
    InvalidInputError
        Too few states, times not increasing, an unbound orbit, a bad argument.
    ConvergenceError
        The correction did not converge.
    """
    from astropy.time import Time

    from ..satellites.frames import frame_name, transform_matrices

    frame = frame_name(frame)
    r = np.asarray(r_km, dtype=np.float64)
    v = np.asarray(v_km_s, dtype=np.float64)
    t = times
    if r.ndim != 2 or r.shape[1] != 3 or v.shape != r.shape or not isinstance(t, Time) or (
            t.shape != (r.shape[0],)):
        raise ShapeError(
            f"fit_tle_arrays needs r and v of shape (N, 3) and times of shape (N,); got "
            f"{r.shape}, {v.shape} and {getattr(t, 'shape', None)}.")
    n = r.shape[0]
    need = 4 if not fit_bstar else 7
    if n < need:
        raise InvalidInputError(
            f"{n} state(s) cannot fix {6 + bool(fit_bstar)} mean elements; give at least {need} "
            "states spread over at least one orbit."
        )
    from ..satellites.frames import offline_iers

    with offline_iers():  # times in UT1 need the installed IERS table, never a download
        tt = t.tt
    secs = (tt.jd1 - tt.jd1[0]) * 86400.0 + (tt.jd2 - tt.jd2[0]) * 86400.0
    if np.any(np.diff(secs) <= 0):
        i = int(np.flatnonzero(np.diff(secs) <= 0)[0]) + 1
        raise InvalidInputError(
            f"the state times must increase strictly; state {i} is not after state {i - 1}. Sort "
            "them and remove duplicates."
        )
    satnum, name, object_id, bstar = initial_identity(initial, satnum, name, object_id, bstar)
    try:
        bstar_ok = math.isfinite(float(bstar))
    except (TypeError, ValueError):
        bstar_ok = False
    if not bstar_ok:
        raise InvalidInputError(
            f"bstar must be a finite number (1/earth radii, as in a TLE); got {bstar!r}.")
    if not (isinstance(satnum, int | np.integer) and not isinstance(satnum, bool)
            and 0 < satnum <= CATALOGUE_MAX):
        raise InvalidInputError(
            f"satnum must be a catalogue number, an integer in 1..{CATALOGUE_MAX}; got "
            f"{satnum!r}.")
    far = np.linalg.norm(r, axis=1) > MAX_SGP4_RADIUS_KM
    if far.any():  # (SGP4's own positions that far are refused: tle_elements.sgp4_states)
        k = int(np.flatnonzero(far)[0])
        raise InvalidInputError(
            f"state {k} lies {float(np.linalg.norm(r[k])):.4g} km from the geocentre, beyond "
            f"{MAX_SGP4_RADIUS_KM:.0e} km: no Earth orbit, no element set SGP4 could fit. Check "
            "the units (metres given as km?) and the centre (heliocentric states?).")
    if frame != "teme":
        m = transform_matrices(t, frame, "teme")
        y = np.einsum("nij,nj->ni", m, np.concatenate([r, v], axis=1))
        r, v = y[:, :3], y[:, 3:]
    ep = t[0] if epoch is None else epoch
    if not isinstance(ep, Time) or not ep.isscalar:
        raise InvalidInputError("epoch must be one astropy Time.")
    # the epoch as an OMM string to the microsecond, on sgp4's clock (a leap second reads as
    # the first second of the next day: sgp4 cannot name it)
    epoch_str = epoch_text(*(float(x) for x in time_to_utc_days(ep)))
    ep_exact = Time(epoch_str, scale="utc")
    jd, fr = time_to_utc_days(t)  # sgp4's UTC days of 86,400 s
    # first guess: the osculating state nearest the epoch, moved to the epoch on a two-body arc
    ep_tt = ep_exact.tt
    from_epoch = (tt.jd1 - ep_tt.jd1) * 86400.0 + (tt.jd2 - ep_tt.jd2) * 86400.0
    k = int(np.argmin(np.abs(from_epoch)))
    r0, v0 = r[k], v[k]
    dt = -float(from_epoch[k])
    if dt != 0.0:
        from ..core.universal import propagate_scalar

        out = propagate_scalar(*r0, *v0, GM_WGS72, dt)
        r0, v0 = np.array(out[1:4]), np.array(out[4:7])
    retro = is_retrograde(r0, v0)
    p = initial_elements(r0, v0, float(bstar), retro)
    free = np.arange(7 if fit_bstar else 6)
    w_v = 1.0 / (p[0] / 60.0)  # s: velocity residuals weighted by 1/n
    target = np.concatenate([r, v * w_v], axis=1).ravel()

    days = epoch_days(epoch_str)

    def resid(pp):
        out = sgp4_states(pp, days, satnum, jd, fr, retro)
        if out is None:
            return None
        return target - np.concatenate([out[0], out[1] * w_v], axis=1).ravel()

    p, z = propagable_start(p, resid)  # (else at a lower e: SGP4-VER 23333 over 12 h)
    if z is None:
        raise InvalidInputError(
            f"SGP4 cannot propagate the first guess (e = {math.hypot(p[1], p[2]):.4g}, "
            f"period {2 * math.pi / p[0]:.6g} min; nor at e = 0.95 ... 0.6) over the given "
            "times: a decaying orbit, or one beyond SGP4's range (e < 0.99, positions within "
            "1e6 km); fit a shorter arc or give another epoch=."
        )
    # the states a converged fit misses by far more than the rest (across SGP4's own jump at
    # i = 0.2 rad, or bad states) are refitted without (audit33; tle_correction)
    size = float(np.mean(np.linalg.norm(r, axis=1)))
    # a fit that fails or ends over 0.1 % of the radius off is tried again from the fits of
    # widening windows about the epoch (B* of a low-perigee HEO over days; tle_correction)
    fit, left_out, far = staged_correct(
        p, z, resid, free, n, need, max_iterations, tol, from_epoch,
        lambda c: not c.converged or _rms_kept(c.z, n) > 0.1 * MAX_RMS_FRACTION * size)
    p, z, cost, history = fit.p, fit.z, fit.cost, fit.history
    converged, stalled, gain, J, live = fit.converged, fit.stalled, fit.gain, fit.J, fit.live
    rms_final = _rms_kept(z, n, far)
    if converged and rms_final <= MAX_RMS_FRACTION * size:
        pass
    elif rms_final <= MAX_RMS_FRACTION * size:
        why = (f"stopped at iteration {len(history)}: no step lowers the misfit though the "
               f"linear model promises {gain / max(cost, 1e-300):.0%} of it" if stalled else
               f"did not converge in {max_iterations} iterations")
        err = ConvergenceError(f"the TLE fit {why} (position RMS {rms_final:.4g} km). "
                               + _advice(history, stalled, p, retro))
        err.history = history
        raise err
    else:
        err = ConvergenceError(
            f"SGP4 cannot reproduce these states: the best element set misses them by "
            f"{rms_final:.4g} km RMS ({rms_final / size:.1%} of the orbit's radius). Check "
            "that they are one free Earth orbit (no manoeuvre, no re-entry), their frame "
            "(frame=) and units, or fit a shorter arc."
        )
        err.history = history
        raise err
    sigma_bstar = _sigma_bstar(J, cost, fit_bstar, live)
    if sigma_bstar is not None and sigma_bstar > max(1e-4, 0.5 * abs(p[6])):
        how = (f"fitted {p[6]:.3g} +- {sigma_bstar:.2g} 1/earth radii (1 sigma, from the "
               "residuals)" if math.isfinite(sigma_bstar) else
               f"no B* up to {BSTAR_STEP_MAX:g} moves them by {BSTAR_EFFECT_KM * 1e6:g} mm, "
               f"so it was held at its first guess, {p[6]:.3g} 1/earth radii (sigma_bstar = "
               "inf)")
        warnings.warn(
            f"B* is not determined by these states: {how}; drag needs a longer arc to show. "
            "Hold it with fit_bstar=False, bstar=<a known value>.", RuntimeWarning, stacklevel=3)
    if far.size:
        warn_far_states(z, n, far, left_out, secs / 60.0)
    _warn_near_equatorial(p, retro, rms_final)
    fields = elements_to_fields(p, epoch_str, satnum, name, object_id or "UNKNOWN", retro)
    if not object_id:
        fields["OBJECT_ID"] = ""
    sat = _fill_unused_fields(satellite_from_fields(fields), fields, initial)
    warn_other_object(initial, sat)
    dr = z.reshape(n, 6)[:, :3]
    dv = z.reshape(n, 6)[:, 3:] / w_v
    sat.fit = TLEFit(
        rms_position_km=float(np.sqrt(np.mean(np.sum(dr**2, axis=1)))),
        max_position_km=float(np.max(np.linalg.norm(dr, axis=1))),
        rms_velocity_km_s=float(np.sqrt(np.mean(np.sum(dv**2, axis=1)))),
        iterations=len(history),
        history=history,
        n_states=n,
        fields=fields,
        sigma_bstar=sigma_bstar,
        excluded=left_out,
    )
    return sat


def _rms_kept(z, n, far=()):
    """Position RMS (km) of the residuals ``z`` of ``n`` states without the states ``far``."""
    return float(np.sqrt(np.mean(np.sum(np.delete(z.reshape(n, 6), far, 0)[:, :3] ** 2, 1))))


#: largest position RMS of a fit, as a fraction of the orbit's mean radius, before fit_tle
#: reports that SGP4 cannot reproduce the states (good fits are ~1e-4 of it or far less)
MAX_RMS_FRACTION = 0.01


#: below this inclination (rad; 0.1 deg) a deep-space fit that runs out of iterations is told
#: why (SDP4's near-equatorial fold, :func:`_advice`)
NEAR_EQUATORIAL = math.radians(0.1)


def _advice(history, stalled, p, retro) -> str:
    """What to do about a fit that did not converge: raise ``max_iterations`` when the misfit
    was still falling steadily, and why when the orbit is a near-equatorial deep-space one.

    SDP4 adds its lunisolar inclination periodics to the mean inclination vector in Lyddane's
    form below 0.2 rad (Hoots & Roehrich 1980; Vallado et al. 2006, AIAA 2006-6753); where they
    are about as large as the inclination itself, nearby mean inclination vectors give nearly
    the same positions and the correction crawls along a curved valley (measured: a GEO at
    0.015 deg, 40 states over half a day: 58 iterations, 1 day 34, 2 days 19; at 0.005 or
    0.05 deg 6-7; SGP4-VER 28626 at 0.0019 deg over 2 days: 175 in all, the last stage 90,
    to 9e-8 km, where a grid of mean inclination vectors 1e-5 about the truth moves the
    positions by 1 to 5 km, depending on the direction, not in proportion). B* is not the cause
    there: unseen, it is held, and ``fit_bstar=False`` takes as many iterations.
    """
    rms = [h["rms_position_km"] for h in history]
    span = min(10, len(rms) - 1)
    falling = not stalled and span > 0 and rms[-1] < 0.9 * rms[-1 - span] and all(
        b <= a for a, b in zip(rms[-1 - span:-1], rms[-span:], strict=True))
    if falling:
        text = (f"The misfit was still falling (position RMS {rms[-1 - span]:.3g} -> "
                f"{rms[-1]:.3g} km over the last {span} iterations): raise max_iterations "
                f"(e.g. max_iterations={2 * len(history)}), or fit a longer arc.")
    else:
        text = ("Fit a shorter arc, give an epoch inside the arc, or raise max_iterations.")
    n, _, _, inc, _, _, _ = classical(p, retro)
    if 2 * math.pi / n >= 225.0 and min(inc, math.pi - inc) < NEAR_EQUATORIAL:
        text += (f" The orbit is near-equatorial (i = {math.degrees(inc):.3g} deg) and deep-"
                 "space (SDP4): where its lunisolar inclination periodics are about as large as "
                 "the inclination, the positions bend with the mean inclination vector and "
                 "the fit crawls along a curved valley (SGP4-VER 28626 over 2 days: 175 "
                 "iterations in all, max_iterations=200). B* is not the cause (held when the "
                 "states do not see it; fit_bstar=False does not help).")
    return text


def _warn_near_equatorial(p, retro, rms_km):
    """RuntimeWarning for a deep-space fit under ``NEAR_EQUATORIAL`` that misses the states by
    over a metre RMS: SDP4's mean inclination vector is ill-determined there, and the fit may
    have settled on a false minimum (SGP4-VER 28626, i = 0.0019 deg, half a day of its own
    states: fitted i = 0.023 deg, 28 m RMS, 77 m at worst, "converged"; started within
    0.001 deg of the truth it finds it, from 0.01 deg it crawls). Measured in tlefit2."""
    n, _, _, inc, _, _, _ = classical(p, retro)
    if 2 * math.pi / n >= 225.0 and min(inc, math.pi - inc) < NEAR_EQUATORIAL and rms_km > 1e-3:
        warnings.warn(
            f"the fitted deep-space set is near-equatorial (i = {math.degrees(inc):.3g} deg) "
            f"and misses the states by {rms_km * 1e3:.3g} m RMS: below 0.1 deg SDP4's lunisolar "
            "periodics are as large as the inclination and its mean inclination and node are "
            "ill-determined, so the fit may be a false minimum: check its inclination and node "
            "against a published element set of the object before trusting them.",
            RuntimeWarning, stacklevel=4)


def _sigma_bstar(J, cost, fit_bstar, live):
    """Formal standard deviation of a fitted B* (1/earth radii), residuals as the noise scale.

    P = s^2 (J^T J)^-1 with s^2 = cost / (m - k), the weighted sum of squares per degree of
    freedom; None when B* was held, inf when the states do not see it at all (``live``: the
    columns of J that are not zero to rounding; B* is the last).
    """
    if not fit_bstar:
        return None
    if not live[-1]:
        return math.inf
    m, k = J.shape
    s2 = cost / max(m - k, 1)
    # columns scaled to unit length first: the mean motion's column is ~1e9 times B*'s, and
    # the pseudo-inverse of the unscaled J^T J cut B*'s direction off as rounding (a deep-space
    # B* 6e-4 off the truth was given +- 5e-19; audit31)
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    try:
        cov = np.linalg.pinv((J / scale).T @ (J / scale)) / np.outer(scale, scale)
    except np.linalg.LinAlgError:
        return math.inf
    return float(math.sqrt(max(s2 * cov[-1, -1], 0.0)))


def _require_earth(states) -> None:
    """Refuse states about another body (their gm): SGP4 mean elements are Earth orbits, and a
    Moon-centred StateVectors was fitted as if geocentric without a word (an OEM about another
    CENTER_NAME, and fit_orbit's first guess, are refused the same way)."""
    from .._units import to_array
    from ..satellites.cowell import central_body

    gm = getattr(states, "gm", None)
    if gm is None:
        return
    gm = float(np.ravel(to_array(gm, "gm", "states.gm"))[0])
    body = central_body(gm, [])
    if body.name != "earth":
        raise InvalidInputError(
            f"the states' gm = {gm:.10g} km3/s2 is the {body.name.capitalize()}'s; SGP4 mean "
            "elements describe Earth orbits: give geocentric GCRS states (gm=vv.EARTH), "
            f"converted from the {body.name.capitalize()}-centred ones.")
