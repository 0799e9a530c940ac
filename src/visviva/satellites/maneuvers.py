"""Impulsive manoeuvres: Hohmann, bi-elliptic, plane change, phasing and Lambert transfers.

A :class:`Maneuver` is a sequence of impulses (time after the start, Δv vector); ``apply``
coasts on the two-body conic between impulses and returns the state just after the last one;
``burns()`` gives them to :func:`visviva.propagate_cowell` (``maneuvers=``) to fly them under
perturbations.

>>> import visviva as vv
>>> from astropy import units as u
>>> leo = vv.StateVectors([6678.0, 0, 0] * u.km, [0, 7.7258, 0] * u.km / u.s, vv.EARTH)
>>> man = vv.satellites.Maneuver.hohmann(leo, 42164 * u.km)
>>> print(f"{man.total_delta_v.to_value(u.km / u.s):.3f} km/s in {man.duration.to(u.h):.2f}")
3.893 km/s in 5.28 h
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from astropy import units as u

from .._units import (
    broadcast_or_raise,
    require_positive,
    seconds_since,
    to_array,
    to_quantity,
    to_vector,
)
from ..errors import DomainError, InvalidInputError, InvalidStateError
from .maneuver_checks import (
    arc_min_radius,
    inclination_change,
    known_body,
    refuse_below_surface,
)

__all__ = [
    "Impulse",
    "Maneuver",
    "hohmann_delta_v",
    "bielliptic_delta_v",
    "plane_change_delta_v",
]


def _one_value(value, kind, name):
    """A scalar in the canonical unit of ``kind``; InvalidInputError for an array."""
    arr = to_array(value, kind, name)
    if arr.ndim != 0:
        raise InvalidInputError(
            f"{name} must be one value here (a Maneuver is one transfer); got shape "
            f"{arr.shape}. For many transfers use hohmann_delta_v / bielliptic_delta_v, "
            "which broadcast."
        )
    return float(arr)


def _chaser_sense(chaser, target) -> bool:
    """lambert's ``prograde`` flag for the transfer that turns the way ``chaser`` moves.

    lambert's True is the transfer with h_z > 0; here the short way is wanted when r1 x r2 lies
    on the side of the chaser's r x v, the long way otherwise, expressed in that flag (True is
    the short way when (r1 x r2)_z >= 0, the long way when it is < 0).
    """
    r1 = to_vector(chaser.r, "length", "state_from.r")
    r2 = to_vector(target.r, "length", "target r")
    normal = np.cross(r1, r2)
    short = bool(np.dot(normal, np.cross(r1, to_vector(chaser.v, "speed", "state_from.v"))) >= 0)
    return short == bool(normal[2] >= 0)


def _check_inclination(r, v, di, what):
    """Refuse a change ``di`` (rad) that takes the inclination of (r, v) outside 0-180 deg."""
    h = np.cross(r, v)
    inc = float(np.arccos(np.clip(h[2] / np.linalg.norm(h), -1.0, 1.0)))
    if not -1e-12 <= inc + di <= np.pi + 1e-12:
        flown = np.rad2deg(abs(inc + di) if inc + di < 0 else 2 * np.pi - (inc + di))
        raise InvalidInputError(
            f"{what}: the orbit's inclination is {np.rad2deg(inc):.6g} deg, so a change of "
            f"{np.rad2deg(di):.6g} deg would take it to {np.rad2deg(inc + di):.6g} deg, outside "
            f"0-180 deg (the plane would turn through the equator: {flown:.6g} deg with the node "
            "moved by 180 deg). A positive delta_inc raises the inclination, a negative one "
            "lowers it; give the change that reaches the inclination wanted."
        )
    return inc


def _turned(r, v, di):
    """``v`` turned about ``r`` so that, at a node, the inclination changes by ``di`` (rad).

    Rodrigues' rotation of v about r_hat by di turns h = r x v about r_hat by di too: at the
    ascending node a positive di raises the inclination, at the descending node it lowers it,
    so there the rotation turns the other way (it lowered it silently: +10 deg at the
    descending node of a 30 deg orbit gave 20 deg). The half of the orbit is told by the node
    line's projection r . n (n = z x h; >= 0 also for equatorial orbits).
    """
    k = r / np.linalg.norm(r)
    h = np.cross(r, v)
    node = np.array([-h[1], h[0], 0.0])  # z x h, towards the ascending node
    th = -di if np.dot(k, node) < 0 else di
    return v * np.cos(th) + np.cross(k, v) * np.sin(th) + k * np.dot(k, v) * (1 - np.cos(th))


#: Relative difference of radii below which Maneuver.hohmann has nothing to transfer
_SAME_RADIUS = 1e-9


def hohmann_delta_v(r1, r2, gm):
    """Δv of the two burns and the transfer time of a Hohmann transfer between circles.

    Δv1 = sqrt(mu/r1) (sqrt(2 r2/(r1 + r2)) - 1), Δv2 = sqrt(mu/r2) (1 - sqrt(2 r1/(r1 + r2))),
    t = pi sqrt((r1 + r2)^3 / (8 mu)) (Vallado 2013, Algorithm 36; Curtis 2014, sec. 6.2).
    Signed: negative burns slow down (for r2 < r1).

    Parameters
    ----------
    r1, r2 : Quantity, length
        Radii of the initial and final circular orbits (> 0; from the centre, not altitudes:
        radii inside a known attractor are refused); broadcast together.
    gm : Quantity (km^3/s^2) or Body
        Gravitational parameter of the attractor (> 0). A Body, or the GM of one of
        :data:`visviva.bodies.BODIES` to 0.1 %, gives the radius below which r1 and r2 are
        refused.

    Returns
    -------
    dv1, dv2 : Quantity, km/s
    tof : Quantity, s

    Raises
    ------
    InvalidInputError
        Non-positive radii or gm; a radius inside the attractor (an altitude given for a
        radius: Maneuver.hohmann from 6678 km to "500 km" gave 15.12 km/s instead of
        0.113 km/s to 6878 km, silently).
    """
    a = to_array(r1, "length", "r1")
    b = to_array(r2, "length", "r2")
    mu = to_array(gm, "gm", "gm")
    if np.any(a <= 0) or np.any(b <= 0) or np.any(mu <= 0):
        raise InvalidInputError("r1, r2 and gm must be > 0.")
    broadcast_or_raise("hohmann_delta_v", r1=a, r2=b, gm=mu)
    refuse_below_surface(gm, mu, r1=a, r2=b)
    dv1 = np.sqrt(mu / a) * (np.sqrt(2 * b / (a + b)) - 1)
    dv2 = np.sqrt(mu / b) * (1 - np.sqrt(2 * a / (a + b)))
    tof = np.pi * np.sqrt((a + b) ** 3 / (8 * mu))
    return to_quantity(dv1, "speed"), to_quantity(dv2, "speed"), to_quantity(tof, "time")


def bielliptic_delta_v(r1, rb, r2, gm):
    """Δv of the three burns and the total time of a bi-elliptic transfer via radius ``rb``.

    Two Hohmann half-ellipses r1 -> rb and rb -> r2 (Vallado 2013, Algorithm 37).

    Parameters
    ----------
    r1, rb, r2 : Quantity, length
        Initial, intermediate and final radii (> 0, rb >= r1 and r2; from the centre: radii
        inside a known attractor are refused, as in :func:`hohmann_delta_v`); broadcast
        together.
    gm : Quantity (km^3/s^2) or Body
        Gravitational parameter of the attractor (> 0).

    Returns
    -------
    dv1, dv2, dv3 : Quantity, km/s (signed along the velocity)
    tof : Quantity, s
    """
    a = to_array(r1, "length", "r1")
    m = to_array(rb, "length", "rb")
    b = to_array(r2, "length", "r2")
    mu = to_array(gm, "gm", "gm")
    for arr, name in ((a, "r1"), (b, "r2"), (mu, "gm")):
        require_positive(arr, name)
    broadcast_or_raise("bielliptic_delta_v", r1=a, rb=m, r2=b, gm=mu)
    if np.any(m < np.maximum(a, b)):
        raise InvalidInputError("the intermediate radius rb must be >= r1 and r2.")
    refuse_below_surface(gm, mu, r1=a, r2=b)
    a1 = 0.5 * (a + m)
    a2 = 0.5 * (m + b)
    dv1 = np.sqrt(2 * mu / a - mu / a1) - np.sqrt(mu / a)
    dv2 = np.sqrt(2 * mu / m - mu / a2) - np.sqrt(2 * mu / m - mu / a1)
    dv3 = np.sqrt(mu / b) - np.sqrt(2 * mu / b - mu / a2)
    tof = np.pi * (np.sqrt(a1**3 / mu) + np.sqrt(a2**3 / mu))
    q = lambda x: to_quantity(x, "speed")  # noqa: E731
    return q(dv1), q(dv2), q(dv3), to_quantity(tof, "time")


def plane_change_delta_v(speed, delta_inc):
    """Δv = 2 v sin(Δi/2) of a pure plane change at speed v (Vallado 2013, eq. 6-23).

    Parameters
    ----------
    speed : Quantity, speed
        Speed at the burn (>= 0).
    delta_inc : Quantity or float
        Change of inclination (angle; rad for plain floats, which must not exceed pi: a plain
        60 is refused as degrees without their unit); broadcasts against ``speed``.

    Returns
    -------
    Quantity, km/s
        The Δv magnitude.
    """
    v = to_array(speed, "speed", "speed")
    di = inclination_change(delta_inc)
    require_positive(v, "speed", strict=False)
    broadcast_or_raise("plane_change_delta_v", speed=v, delta_inc=di)
    return to_quantity(2 * v * np.abs(np.sin(di / 2)), "speed")


@dataclass(frozen=True)
class Impulse:
    """One impulsive burn: ``t`` after the start of the manoeuvre, ``dv`` (3,) inertial."""

    t: u.Quantity
    dv: u.Quantity


class Maneuver:
    """A sequence of impulses applied to a state, with two-body coasts in between.

    Parameters
    ----------
    impulses : list of Impulse or (t, dv) pairs
        Times from the start (non-decreasing Quantities) and Δv vectors (Quantity (3,), km/s).
    """

    def __init__(self, impulses):
        items = []
        usage = (
            "a Maneuver takes a list of vv.satellites.Impulse(t, dv) or (t, dv) pairs, e.g. "
            "Maneuver([(0 * u.s, [0, 0.1, 0] * u.km / u.s)])"
        )
        if isinstance(impulses, Impulse):
            impulses = [impulses]
        if isinstance(impulses, str | bytes) or not hasattr(impulses, "__iter__"):
            raise InvalidInputError(f"{usage}; got {impulses!r}.")
        for imp in impulses:
            if isinstance(imp, Impulse):
                t, dv = imp.t, imp.dv
            else:
                if isinstance(imp, str | bytes) or not hasattr(imp, "__len__") or len(imp) != 2:
                    raise InvalidInputError(f"{usage}; got the item {imp!r}.")
                t, dv = imp
            t_s = _one_value(t, "time", "impulse time")
            dv_v = to_vector(dv, "speed", "impulse dv")
            if dv_v.shape != (3,):
                raise InvalidInputError("each impulse dv must be one (3,) vector.")
            items.append((t_s, dv_v))
        if not items:
            raise InvalidInputError("a manoeuvre needs at least one impulse.")
        times = [t for t, _ in items]
        if any(b < a for a, b in zip(times, times[1:], strict=False)) or times[0] < 0:
            raise InvalidInputError("impulse times must be >= 0 and non-decreasing.")
        self._items = items
        self.frame = None

    @property
    def frame(self):
        """The frame of the states the plan was made from (``"gcrs"``, ``"teme"``, ``"itrs"``,
        an OEM's ``"TOD"`` ...), or None (plain states: taken as GCRS); its Δv are vectors of
        that frame."""
        return self._frame

    @frame.setter
    def frame(self, value):
        self._frame = None if value is None else str(value)

    def _planned_from(self, *states):
        """This plan, labelled with the frame of the ``states`` it was made from."""
        from .satellite_states import frame_of

        for state in states:
            frame = frame_of(state)
            if frame is not None:
                self.frame = frame
        return self

    @property
    def impulses(self) -> list:
        return [Impulse(t * u.s, to_quantity(dv, "speed")) for t, dv in self._items]

    @property
    def total_delta_v(self):
        """Sum of the impulse magnitudes, km/s."""
        return sum(np.linalg.norm(dv) for _, dv in self._items) * (u.km / u.s)

    @property
    def duration(self):
        """Time from the first to the last impulse, s."""
        return (self._items[-1][0] - self._items[0][0]) * u.s

    def apply(self, state):
        """Coast and burn through the impulses; the state just after the last impulse.

        The returned state's epoch (if any) is advanced to the time of the last impulse; satellite
        states (``sat.teme(t)``, ``sat.gcrs(t)``) keep their frame, and states in a frame visviva
        cannot rotate (an OEM or OPM in ``REF_FRAME = TOD``) stay marked as such.

        Raises
        ------
        InvalidInputError
            ITRS states (the coasts are Kepler motion, which does not hold in a rotating frame)
            and an OPM's states with manoeuvres (the plan would fly through them).
        """
        from .._containers import carry_frame_mark
        from ..states import StateVectors
        from .satellite_states import require_kepler_frame, with_frame

        require_kepler_frame(state, "Maneuver.apply")
        t_prev = 0.0
        cur = state
        for t, dv in self._items:
            if t > t_prev:
                cur = cur.propagate((t - t_prev) * u.s)
            cur = StateVectors(cur.r, cur.v + dv * (u.km / u.s), cur.gm, epoch=cur.epoch)
            t_prev = t
        return with_frame(carry_frame_mark(state, cur), getattr(state, "frame", None))

    def burns(self) -> list:
        """The impulses as :class:`~visviva.satellites.burns.ImpulsiveBurn` (inertial Δv, times
        from the state's epoch), for :func:`visviva.propagate_cowell` (``maneuvers=``): the same
        manoeuvre flown under perturbations instead of on two-body coasts.

        Returns
        -------
        list of ImpulsiveBurn

        Raises
        ------
        InvalidInputError
            The plan was made from states in another frame than the GCRS (``sat.teme(t)``,
            ITRS, an OEM in TOD): its Δv are vectors of that frame, which the GCRS run would
            take for GCRS vectors (TEME and GCRS axes differ by ~0.3 degrees in 2024).
        """
        from .burns import ImpulsiveBurn

        if self.frame not in (None, "gcrs"):
            raise InvalidInputError(
                f"this Maneuver was planned from {self.frame.upper()} states, so its Δv are "
                f"{self.frame.upper()} vectors; propagate_cowell works in the GCRS and would take "
                "them for GCRS ones. Plan it from GCRS states (e.g. Maneuver.hohmann(sat.gcrs(t), "
                "...)) and propagate those."
            )
        return [ImpulsiveBurn(t * u.s, to_quantity(dv, "speed"), "GCRS") for t, dv in self._items]

    def then(self, other, coast=0.0 * u.s):
        """This manoeuvre followed by ``other``: a sequence (phasing, then a transfer ...).

        ``other`` is planned from the state this one leaves, ``self.apply(state)``, carried on
        by ``coast`` (>= 0); its impulse times are shifted by this one's last impulse time plus
        ``coast``, so ``a.then(b, coast).apply(state)`` equals ``b.apply(a.apply(state)
        .propagate(coast))``. Plans made from states of different frames are refused.
        """
        if not isinstance(other, Maneuver):
            raise InvalidInputError(f"Maneuver.then takes a Maneuver; got {type(other).__name__}.")
        wait = _one_value(coast, "time", "coast")
        if not wait >= 0:
            raise InvalidInputError(f"coast must be >= 0 s; got {wait:g} s.")
        if None not in (self.frame, other.frame) and self.frame != other.frame:
            raise InvalidInputError(
                f"Maneuver.then: this plan is in {self.frame.upper()}, the next in "
                f"{other.frame.upper()}; plan both from states of one frame.")
        start = self._items[-1][0] + wait
        out = Maneuver([(t * u.s, dv * (u.km / u.s)) for t, dv in self._items]
                       + [((start + t) * u.s, dv * (u.km / u.s)) for t, dv in other._items])
        out.frame = self.frame if self.frame is not None else other.frame
        return out

    def __repr__(self):
        return (
            f"Maneuver({len(self._items)} impulses, {self.total_delta_v:.6f}, {self.duration:.1f})"
        )

    # ------------------------------------------------------------------ constructors

    @staticmethod
    def _circular(state, what):
        r = to_vector(state.r, "length", "state.r")
        v = to_vector(state.v, "speed", "state.v")
        if r.shape != (3,):
            raise InvalidInputError(f"{what} takes one state (shape (3,)).")
        mu = float(to_array(state.gm, "gm", "state.gm"))
        rn = np.linalg.norm(r)
        if (
            abs(np.dot(r, v)) > 1e-3 * rn * np.linalg.norm(v)
            or abs(np.dot(v, v) - mu / rn) > 2e-3 * mu / rn
        ):
            raise InvalidStateError(
                f"{what} starts from a circular orbit; this state is not circular to 1e-3 "
                "(|r.v| or |v^2 - mu/r| too large). Use Maneuver.lambert for general transfers."
            )
        return r, v, mu, rn

    @classmethod
    def hohmann(cls, state, r_final, delta_inc=0.0):
        """Hohmann transfer from the circular orbit of ``state`` to radius ``r_final``.

        Where ``r_final`` is the state's radius (to 1e-9, 7 um in LEO) there is nothing to
        transfer: the manoeuvre is one impulse at t = 0 that sets the speed to the circular
        one (zero for an exactly circular state), of duration 0, rather than two zero burns half
        a period apart (whose ``apply`` carried the state half an orbit on for nothing).

        With ``delta_inc`` (angle; rad for plain floats; positive raises the inclination) the
        inclination changes too, split between the two burns at the cheapest ratio
        (:func:`~visviva.satellites.combined_maneuvers.hohmann_plane_change_delta_v`: LEO to
        GEO with -28.5 deg turns 2.2 deg at the first burn, 4.2314 km/s in all against 4.2560
        km/s with the whole turn at the second). The burns are on the line of nodes, so the
        state must be at a node (|sin u| <= 1e-6 for the argument of latitude u; any point of
        an equatorial orbit); elsewhere it is refused, since the turn would change the
        inclination by less and move the node (propagate to the node first, e.g. with the
        ``AscendingNode`` event).
        """
        r, v, mu, r1 = cls._circular(state, "Maneuver.hohmann")
        r2 = _one_value(r_final, "length", "r_final")
        di = _one_value(inclination_change(delta_inc), "angle", "delta_inc")
        dv1, dv2, tof = hohmann_delta_v(r1 * u.km, r2 * u.km, mu * u.km**3 / u.s**2)
        v_hat = v / np.linalg.norm(v)
        kms = u.km / u.s
        if di != 0.0:
            return cls._hohmann_turning(state, r, v, mu, r1, r2, di)._planned_from(state)
        # the first burn starts from the actual speed (exact for a nearly circular start)
        dv1 = (np.sqrt(mu / r1) + dv1.value - np.linalg.norm(v)) * kms
        if abs(r2 - r1) <= _SAME_RADIUS * r1:  # no transfer: the speed trim alone, at once
            return cls([(0 * u.s, dv1.value * v_hat * kms)])._planned_from(state)
        # at the far apsis the velocity is antiparallel to the initial one
        return cls(
            [
                (0 * u.s, dv1.value * v_hat * kms),
                (tof, -dv2.value * v_hat * kms),
            ]
        )._planned_from(state)

    @classmethod
    def _hohmann_turning(cls, state, r, v, mu, r1, r2, di):
        """The two burns of a Hohmann transfer that also turns the plane by ``di`` (rad)."""
        from .combined_maneuvers import hohmann_plane_change_delta_v

        h = np.cross(r, v)
        sin_inc = np.hypot(h[0], h[1]) / np.linalg.norm(h)
        if abs(r[2]) > 1e-6 * r1 * sin_inc:
            raise InvalidStateError(
                "Maneuver.hohmann with delta_inc burns on the line of nodes, but this state is "
                f"{np.rad2deg(np.arcsin(min(1.0, abs(r[2]) / (r1 * sin_inc)))):.6g} deg of "
                "argument of latitude from a node: the turn would change the inclination by "
                "less and move the node. Propagate the state to a node first (e.g. "
                "propagate_cowell with the AscendingNode event), or plan the plane change "
                "apart (Maneuver.plane_change).")
        _check_inclination(r, v, di, "Maneuver.hohmann")
        kms = u.km / u.s
        v_hat = v / np.linalg.norm(v)
        if abs(r2 - r1) <= _SAME_RADIUS * r1:  # no transfer: trim and turn at once
            return cls([(0 * u.s, (_turned(r, np.sqrt(mu / r1) * v_hat, di) - v) * kms)])
        gm = mu * u.km**3 / u.s**2
        _, _, di1, di2, tof = hohmann_plane_change_delta_v(r1 * u.km, r2 * u.km, di, gm)
        di1, di2 = float(di1.to_value(u.rad)), float(di2.to_value(u.rad))
        a_t = 0.5 * (r1 + r2)
        # first burn: from the actual velocity onto the transfer ellipse, turned by di1
        v_t1 = _turned(r, np.sqrt(mu * (2 / r1 - 1 / a_t)) * v_hat, di1)
        # second burn, half an ellipse later at the opposite node: circular, turned by di2
        r_b = -r2 * r / r1
        v_t2 = -np.sqrt(mu * (2 / r2 - 1 / a_t)) * v_t1 / np.linalg.norm(v_t1)
        v_c2 = _turned(r_b, np.sqrt(mu / r2) * v_t2 / np.linalg.norm(v_t2), di2)
        return cls([(0 * u.s, (v_t1 - v) * kms), (tof, (v_c2 - v_t2) * kms)])

    @classmethod
    def bielliptic(cls, state, r_intermediate, r_final):
        """Bi-elliptic transfer via ``r_intermediate`` from a circular orbit to ``r_final``."""
        r, v, mu, r1 = cls._circular(state, "Maneuver.bielliptic")
        rb = _one_value(r_intermediate, "length", "r_intermediate")
        r2 = _one_value(r_final, "length", "r_final")
        gm = mu * u.km**3 / u.s**2
        dv1, dv2, dv3, _ = bielliptic_delta_v(r1 * u.km, rb * u.km, r2 * u.km, gm)
        t1 = np.pi * np.sqrt((0.5 * (r1 + rb)) ** 3 / mu)
        t2 = np.pi * np.sqrt((0.5 * (rb + r2)) ** 3 / mu)
        v_hat = v / np.linalg.norm(v)
        kms = u.km / u.s
        # as in hohmann: the first burn starts from the actual speed
        dv1 = np.sqrt(mu / r1) + dv1.value - np.linalg.norm(v)
        return cls(
            [
                (0 * u.s, dv1 * v_hat * kms),
                (t1 * u.s, -dv2.value * v_hat * kms),
                ((t1 + t2) * u.s, dv3.value * v_hat * kms),
            ]
        )._planned_from(state)

    @classmethod
    def plane_change(cls, state, delta_inc):
        """Rotate the velocity about the position vector so the inclination changes by ``delta_inc``.

        Applied at either node this changes the inclination by ``delta_inc`` (positive raises
        it) and leaves the node where it is, at the cost 2 v sin(Δi/2) for a horizontal
        velocity (Vallado 2013, eq. 6-23). The sense of the rotation is chosen by the half of
        the orbit the state is on: about +r on the ascending half (the node line's projection
        r . n >= 0, n = z x h; also for equatorial orbits), about -r on the descending half.
        Away from the nodes the same rotation tilts the plane about r: the inclination changes
        by less and the node moves (at the highest latitude only the node moves).

        Raises
        ------
        InvalidInputError
            An inclination i + Δi below 0 or above 180 deg (e.g. -10 deg from an equatorial
            orbit): the rotation would carry the plane through the equator and the result
            would be |i + Δi| with the node turned by 180 deg, a raise asked as a fall
            (-10 deg from 0 gave 10 deg; +10 deg from 175 gave 175 deg, the node turned).
        """
        r = to_vector(state.r, "length", "state.r")
        v = to_vector(state.v, "speed", "state.v")
        if r.shape != (3,) or v.shape != (3,):
            raise InvalidInputError(
                f"Maneuver.plane_change takes one state (shape (3,)); got r {r.shape}."
            )
        di = _one_value(inclination_change(delta_inc), "angle", "delta_inc")
        _check_inclination(r, v, di, "Maneuver.plane_change")
        v_new = _turned(r, v, di)
        return cls([(0 * u.s, (v_new - v) * (u.km / u.s))])._planned_from(state)

    @classmethod
    def phasing(cls, state, phase_angle, revolutions=1):
        """Move along the orbit by ``phase_angle`` in ``revolutions`` laps of a phasing orbit.

        A burn along the velocity puts the spacecraft on a phasing orbit of period
        T_ph = T (1 - Δφ / (2 π k)) through the same point; after k = ``revolutions`` laps it
        is back there, and the opposite burn restores the original velocity. The spacecraft is
        then on its old orbit Δφ ahead (in mean anomaly: the angle itself on a circle) of
        where it would have been: a positive ``phase_angle`` catches up with a target ahead
        (a lower, faster phasing orbit), a negative one falls back (Curtis 2014, sec. 6.6;
        Vallado 2013, Algorithm 44).

        Parameters
        ----------
        state : StateVectors
            One bound state (shape (3,)); the first burn is at it.
        phase_angle : Quantity or float
            Δφ, angle (rad for plain floats, whose magnitude must not exceed 2 pi: a plain 30
            is refused as degrees without their unit); |Δφ| < 2 π k.
        revolutions : int
            k >= 1, laps of the phasing orbit (more laps: a smaller Δv, a longer wait).

        Returns
        -------
        Maneuver
            Two impulses, Δv1 = v_ph - v along the velocity at 0 and -Δv1 at k T_ph.

        Raises
        ------
        InvalidInputError
            ``revolutions`` not an integer >= 1 (0 laps cannot change the phase); |Δφ| >= 2 π k
            (no phasing period), or a phasing orbit that is unbound or whose periapsis lies
            inside a known attractor (more revolutions lower the Δv and keep it higher).
        """
        r = to_vector(state.r, "length", "state.r")
        v = to_vector(state.v, "speed", "state.v")
        if r.shape != (3,) or v.shape != (3,):
            raise InvalidInputError(
                f"Maneuver.phasing takes one state (shape (3,)); got r {r.shape}.")
        if (isinstance(revolutions, bool) or not isinstance(revolutions, int | np.integer)
                or revolutions < 1):
            raise InvalidInputError(
                f"revolutions must be an integer >= 1 (laps of the phasing orbit); got "
                f"{revolutions!r}. The phase changes only over whole laps of the phasing orbit.")
        k = int(revolutions)
        phi = _one_value(inclination_change(phase_angle, "phase_angle", 2 * np.pi), "angle",
                         "phase_angle")
        mu = float(to_array(state.gm, "gm", "state.gm"))
        rn, speed = float(np.linalg.norm(r)), float(np.linalg.norm(v))
        energy = 0.5 * speed**2 - mu / rn
        if not energy < 0:
            raise InvalidStateError(
                "Maneuver.phasing needs a bound orbit (specific energy < 0); this state's is "
                f"{energy:.6g} km^2/s^2.")
        period = 2 * np.pi * np.sqrt((-mu / (2 * energy)) ** 3 / mu)
        if not abs(phi) < 2 * np.pi * k:
            raise InvalidInputError(
                f"a phase change of {np.rad2deg(phi):.6g} deg needs more than {k} "
                "revolution(s): |phase_angle| < 360 deg x revolutions.")
        t_ph = period * (1 - phi / (2 * np.pi * k))
        a_ph = (mu * (t_ph / (2 * np.pi)) ** 2) ** (1 / 3)
        v_ph2 = mu * (2 / rn - 1 / a_ph)
        body = known_body(state.gm, mu)
        if v_ph2 > 0:
            h = np.linalg.norm(np.cross(r, v)) / speed * np.sqrt(v_ph2)
            periapsis = a_ph * (1 - np.sqrt(max(0.0, 1 - h * h / (mu * a_ph))))
        if not v_ph2 > 0 or (body is not None and periapsis < body.radius_km):
            where = ("does not pass through the state" if not v_ph2 > 0 else
                     f"has its periapsis {periapsis:.6g} km from the centre, inside "
                     f"{body.name} (radius {body.radius_km:.6g} km)")
            raise InvalidInputError(
                f"the phasing orbit for {np.rad2deg(phi):.6g} deg in {k} revolution(s) (a = "
                f"{a_ph:.6g} km) {where}: give more revolutions.")
        dv1 = (np.sqrt(v_ph2) - speed) * v / speed
        kms = u.km / u.s
        return cls([(0 * u.s, dv1 * kms), (k * t_ph * u.s, -dv1 * kms)])._planned_from(state)

    @classmethod
    def lambert(cls, state_from, state_to, tof, **lambert_kwargs):
        """Two-impulse rendezvous: leave ``state_from`` now, meet ``state_to`` after ``tof``.

        ``state_to`` is the target's state at the start; it is propagated by ``tof`` on its
        own conic. When both states carry epochs, the target is first carried from its epoch to
        the chaser's (the start). Both must orbit the same attractor (equal GM). Extra keywords
        go to :func:`visviva.lambert` (revolutions, branch, method, prograde). Without
        ``prograde`` the transfer turns the way the chaser moves (its angular momentum and the
        transfer's point to the same side of the plane of r1 and r2): lambert's own default
        (h_z > 0) sent a chaser on a retrograde orbit, e.g. sun-synchronous, the other way
        round (29.7 km/s instead of 1.9 km/s at 98 deg, silently).
        """
        from .lambert_solvers import lambert

        if lambert_kwargs.get("on_failure", "raise") != "raise":
            raise InvalidInputError(
                "Maneuver.lambert plans burns from the solution, so a failed transfer must raise: "
                f"drop on_failure={lambert_kwargs['on_failure']!r} (it is for vv.lambert batches)."
            )
        mu_from = to_array(state_from.gm, "gm", "state_from.gm")
        mu_to = to_array(state_to.gm, "gm", "state_to.gm")
        if not np.allclose(mu_from, mu_to, rtol=1e-12, atol=0.0):
            raise InvalidInputError(
                f"Maneuver.lambert needs the chaser and the target about the same attractor; "
                f"their GM differ ({float(np.max(mu_from))} and {float(np.max(mu_to))} km^3/s^2)."
            )
        from .satellite_states import frame_of

        # framed states and those marked with a frame visviva cannot rotate (TOD) must agree
        frames = tuple(frame_of(s) for s in (state_from, state_to))
        if None not in frames and frames[0].lower() != frames[1].lower():
            raise InvalidInputError(
                f"Maneuver.lambert: the chaser is in {frames[0].upper()}, the target in "
                f"{frames[1].upper()}; give both in one frame (e.g. sat.gcrs(t) for both)."
            )
        coast = to_array(tof, "time", "tof")
        if state_from.epoch is not None and state_to.epoch is not None:
            coast = coast + seconds_since(state_from.epoch, state_to.epoch)
        target = state_to.propagate(coast * u.s)
        if "prograde" not in lambert_kwargs and np.shape(state_from.r) == (3,):
            lambert_kwargs["prograde"] = _chaser_sense(state_from, target)
        v1, v2 = lambert(state_from.r, target.r, tof, state_from.gm, **lambert_kwargs)
        _refuse_arc_inside(state_from, target, v1, v2, tof, lambert_kwargs.get("revolutions", 0))
        return cls([(0 * u.s, v1 - state_from.v), (tof, target.v - v2)])._planned_from(
            state_from, state_to)


def _refuse_arc_inside(state_from, target, v1, v2, tof, revolutions) -> None:
    """Refuse a Lambert arc that passes inside a known attractor (:func:`known_body`): the
    conic is exact, but nothing flies it (audit53: 7000 km to 7000 km 150 deg ahead in 3000 s
    planned 3.92 km/s on an arc through the Earth, periapsis 2909 km, silently)."""
    mu = float(to_array(state_from.gm, "gm", "state_from.gm"))
    body = known_body(state_from.gm, mu)
    if body is None or np.shape(v1) != (3,):
        return
    r1 = to_vector(state_from.r, "length", "state_from.r")
    r2 = to_vector(target.r, "length", "target r")
    low = arc_min_radius(r1, to_vector(v1, "speed", "v1"), r2, to_vector(v2, "speed", "v2"), mu,
                         int(revolutions))
    if low < body.radius_km:
        raise DomainError(
            f"Maneuver.lambert: the transfer arc in tof = {float(to_array(tof, 'time', 'tof')):g}"
            f" s passes {low:.6g} km from the centre of {body.name}, inside it (radius "
            f"{body.radius_km:.6g} km): nothing can fly it. Give a longer tof, the other way "
            "round (prograde=...), or revolutions=..., or go by an intermediate point.")
