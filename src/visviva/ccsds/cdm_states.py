"""The two objects of a CDM on one inertial frame: what a miss distance or a Pc needs.

CCSDS 508.0-B-1 lets each object's segment name its own ``REF_FRAME`` (section 3.5.1: e.g.
``EME2000`` for one object, ``ITRF`` for the other). A miss vector or a collision probability
combines both states and covariances, so both are first put on one inertial frame (GCRF):
a state on ITRF axes by the IAU 2006/2000A chain of :mod:`visviva.satellites.frames` at TCA
(with its Earth-rotation velocity term), a TEME state likewise, and each covariance rotated
from the message's RTN matrix with the RTN axes of the object's *GCRF* state (as NASA CARA's
``cdmobj_J2Kstatecov`` converts the state to J2000 first, then rotates the RTN covariance).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["states_on_one_frame", "COMMON_FRAMES", "check_states_against_summary",
           "refuse_earth_frame_off_earth"]

#: the frame the two objects are put on, by its CCSDS names (GCRF and ICRF name the GCRS's
#: axes, EME2000 those turned by the frame bias: docs/ccsds.md, "Frames")
COMMON_FRAMES = ("GCRF", "EME2000", "ICRF")


def _gcrs_state(obj, tca, source="<text>"):
    """(r km, v km/s) of a CDMObject on GCRS axes, from its REF_FRAME."""
    from astropy import units as u

    from ..satellites.frames import itrs_to_gcrs, teme_to_gcrs
    from .timeframes import to_gcrs_axes, visviva_frame

    kind = visviva_frame(obj.frame)
    r, v = obj.r.to_value(u.km), obj.v.to_value(u.km / u.s)
    if kind == "gcrs":  # (EME2000: the frame bias)
        return to_gcrs_axes(obj.frame, r, v)
    refuse_earth_frame_off_earth(obj, kind, source)
    if kind == "itrs":
        return itrs_to_gcrs(r, v, tca)
    if kind == "teme":
        return teme_to_gcrs(r, v, tca)
    raise InvalidInputError(
        f"REF_FRAME = {obj.frame!r} of {obj.name!r} is not a frame visviva can rotate to GCRF "
        "(EME2000, GCRF, ICRF, TEME or ITRF...); rotate its state and covariance_rtn (RTN, m, "
        "m/s) yourself, or correct REF_FRAME.")


def refuse_earth_frame_off_earth(obj, kind, source="<text>") -> None:
    """Refuse a CDMObject on ITRF or TEME axes (``kind``: its visviva frame) about another
    ``ORBIT_CENTER`` than the Earth: visviva turns those frames with the Earth."""
    if kind in ("itrs", "teme") and _centre(obj) != "EARTH":
        meta = obj.sections["metadata"]
        raise InvalidInputError(
            f"{source} line {meta.line_of('ORBIT_CENTER')}: ORBIT_CENTER = {_centre(obj)} of "
            f"{obj.name!r} with REF_FRAME = {obj.frame}, an Earth-fixed or Earth-equator frame "
            "that visviva rotates about the Earth only; give its state on inertial axes "
            "(EME2000, GCRF, ICRF) or correct ORBIT_CENTER.")


def _centre(obj) -> str:
    """``ORBIT_CENTER`` of a CDMObject (upper case; absent: ``EARTH``)."""
    return str(obj.sections["metadata"].get("ORBIT_CENTER") or "EARTH").strip().upper()


def _same_centre(msg) -> None:
    """Refuse two objects about different ``ORBIT_CENTER`` values: their states would be
    subtracted as if they had one origin."""
    c1, c2 = _centre(msg.object1), _centre(msg.object2)
    if c1 != c2:
        lines = [o.sections["metadata"].line_of("ORBIT_CENTER") for o in (msg.object1, msg.object2)]
        raise InvalidInputError(
            f"{msg.source}: OBJECT1's ORBIT_CENTER is {c1} (line {lines[0]}), OBJECT2's {c2} "
            f"(line {lines[1]}): the two states have different origins, which visviva does not "
            "translate; give both about one centre.")


def states_on_one_frame(msg, frame: str = "GCRF"):
    """Both objects' states and 6x6 covariances at TCA on one inertial frame.

    Parameters
    ----------
    msg : ConjunctionDataMessage
        The message (each object with its own ``REF_FRAME``).
    frame : {"GCRF", "EME2000", "ICRF"}
        The frame to put both on (GCRF and ICRF: the GCRS axes; EME2000: those rotated by the
        frame bias, :data:`~visviva.ccsds.timeframes.FRAME_BIAS`).

    Returns
    -------
    r1, v1, cov1, r2, v2, cov2
        Positions (Quantity, km), velocities (Quantity, km/s) and covariances (ndarray,
        m^2, m^2/s, m^2/s^2), what :func:`visviva.collision_probability` takes.

    Raises
    ------
    InvalidInputError
        Another ``frame``, a ``REF_FRAME`` visviva cannot rotate (e.g. ``EFG``), objects
        about different ``ORBIT_CENTER`` values (absent: ``EARTH``), or ``ITRF``/``TEME`` about
        another centre than the Earth.
    """
    from astropy import units as u

    from ..conjunctions.covariance import rtn_to_inertial

    if str(frame).strip().upper() not in COMMON_FRAMES:
        raise InvalidInputError(f"frame = {frame!r}: the objects are put on one inertial frame, "
                                f"one of {', '.join(COMMON_FRAMES)}.")
    _same_centre(msg)
    out = []
    tca = msg.tca
    from .timeframes import from_gcrs_axes

    for obj in (msg.object1, msg.object2):
        r, v = (np.asarray(x, dtype=np.float64) for x in _gcrs_state(obj, tca, msg.source))
        r, v = from_gcrs_axes(frame, r, v)  # (EME2000: the frame bias; RTN is physical)
        out += [r * u.km, v * (u.km / u.s),
                rtn_to_inertial(obj.covariance_rtn, r * u.km, v * (u.km / u.s))]
    return tuple(out)


#: how far the states' separation may stray from ``MISS_DISTANCE`` (and their relative speed
#: from ``RELATIVE_SPEED``) before the message is called inconsistent: the larger of an absolute
#: floor and a share of the stated value. The floors hold a TCA rounded to 1 ms (up to 7.5 m
#: along a 15 km/s relative velocity) and states rounded to 1 m; the shares, the messages that
#: round their summary. A unit slip (metres read as km), a sign or a digit gone wrong is
#: thousands of times larger.
MISS_TOLERANCE_M, MISS_SHARE = 100.0, 0.1
SPEED_TOLERANCE_M_S, SPEED_SHARE = 10.0, 0.1


def check_states_against_summary(msg) -> None:
    """Warn when the two objects' states at TCA contradict the message's own ``MISS_DISTANCE``
    or ``RELATIVE_SPEED`` (508.0-B-1 gives both from the same states).

    A coordinate written in metres without its ``[km]`` (read as km), or with a slipped digit or
    sign, put an object millions of km away: ``msg.probability(hbr)`` then returned 0 without a
    word while the message said 715 m. States on different frames are compared on GCRF
    (:func:`states_on_one_frame`); a ``REF_FRAME`` visviva cannot rotate is not compared.

    Parameters
    ----------
    msg : ConjunctionDataMessage
        The message just read.
    """
    import warnings

    from astropy import units as u

    from .timeframes import visviva_frame

    kinds = [visviva_frame(str(o.frame)) for o in (msg.object1, msg.object2)]
    if kinds[0] is not None and kinds[0] == kinds[1]:
        # one frame: a rotation keeps the separation, and the relative velocity to ~0.1 m/s
        r1, v1, r2, v2 = msg.object1.r, msg.object1.v, msg.object2.r, msg.object2.v
    elif None not in kinds:
        try:
            r1, v1, _, r2, v2, _ = states_on_one_frame(msg)
        except InvalidInputError:  # (centres it cannot combine: msg.states() says why)
            return
    else:
        return
    miss = float(np.linalg.norm((r1 - r2).to_value(u.m)))
    speed = float(np.linalg.norm((v1 - v2).to_value(u.m / u.s)))
    stated = [("MISS_DISTANCE", miss, msg.miss_distance.to_value(u.m), "m", MISS_TOLERANCE_M,
               MISS_SHARE)]
    if msg.relative_speed is not None:
        stated.append(("RELATIVE_SPEED", speed, msg.relative_speed.to_value(u.m / u.s), "m/s",
                       SPEED_TOLERANCE_M_S, SPEED_SHARE))
    for key, got, said, unit, floor, share in stated:
        if abs(got - said) > max(floor, share * said):
            where = msg.relative.line_of(key)
            lines = f", line {where}" if where else ""
            warnings.warn(
                f"{msg.source}{lines}: {key} = {said:g} {unit}, but the two objects' states at "
                f"TCA give {got:.6g} {unit}; one of them is wrong (a position written in m "
                "without [km] is read as km), and a Pc from these states describes another "
                "encounter. Check X, Y, Z, X_DOT, Y_DOT, Z_DOT of both objects and their units.",
                UserWarning, stacklevel=4)
