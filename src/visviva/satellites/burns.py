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

from .._containers import PENDING_MANEUVERS_ATTRIBUTE, refuse_pending
from .._units import require_positive, require_usable_time, to_array, to_quantity, to_vector
from ..core import force_block as fb
from ..core.local_frames import FRAME_CODES, INERTIAL, RTN, local_axes
from ..errors import InvalidInputError, InvalidStateError

__all__ = ["ImpulsiveBurn", "FiniteBurn", "BurnRecord", "STANDARD_GRAVITY_M_S2", "frame_code",
           "refuse_pending"]

#: Standard gravity g0 (m/s^2) of the rocket equation's Isp (CGPM 1901).
STANDARD_GRAVITY_M_S2 = 9.80665
#: Inertial frame names a burn accepts: the GCRS and the CCSDS names of its axes. EME2000 (J2000)
#: is refused (:data:`~visviva.core.local_frames.EME2000_NOTE`): it differs by the 23 mas frame
#: bias, which a burn does not apply (an OPM's ``MAN_REF_FRAME = EME2000`` is turned by
#: :meth:`visviva.ccsds.opm.OPM.burns`).
INERTIAL_NAMES = ("GCRS", "GCRF", "ICRF")


def frame_code(frame) -> int:
    """The code of a burn's frame name (:mod:`visviva.core.local_frames`).

    Parameters
    ----------
    frame : str
        ``"RTN"`` (also ``"RSW"``, ``"RIC"``, ``"QSW"``), ``"TNW"``, ``"VNB"`` (local,
        evaluated at the burn's state) or an inertial name: ``"GCRS"``, ``"GCRF"``,
        ``"ICRF"`` (case-insensitive). Vallado's NTW and the LVLH frames, whose axes differ
        between tools, are refused, and so is ``"EME2000"`` (``"J2000"``): its axes differ from
        the GCRS by the 23 mas frame bias (turn the Δv first:
        ``visviva.ccsds.timeframes.to_gcrs_axes("EME2000", dv)``).

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
    if name in ("EME2000", "J2000"):
        from ..core.local_frames import EME2000_NOTE

        raise InvalidInputError(f"burn frame {frame!r}: {EME2000_NOTE}, and give frame='GCRS'.")
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
        ``"ICRF"`` (``"EME2000"`` is refused: turn its Δv to the GCRS axes with
        ``visviva.ccsds.timeframes.to_gcrs_axes``). Axes: :mod:`visviva.core.local_frames`.
    delta_mass : Quantity, optional
        Mass change (kg, <= 0) the burn costs, if known (an OPM's ``MAN_DELTA_MASS``).
    mass : Quantity, optional
        Spacecraft mass before the burn (kg, > 0): with ``delta_mass``, the result reports the
        masses before and after, and drag and SRP follow the mass
        (:mod:`visviva.satellites.burn_mass`).
    delta_v_covariance : Quantity or array_like (3, 3), optional
        The execution error: covariance of the Δv actually flown about ``delta_v``, on the
        axes of ``frame`` (speed^2, e.g. ``np.diag([1e-4, 1e-4, 1e-4]) * (u.m / u.s)**2``;
        plain numbers are km^2/s^2). :func:`~visviva.propagate_covariance` and
        :func:`~visviva.filter_orbit` add it to the velocity covariance at the burn.
    magnitude_sigma : Quantity or float, optional
        Instead of ``delta_v_covariance``: 1-sigma of the Δv's magnitude as a fraction of
        |Δv| (dimensionless, e.g. ``1 * u.percent`` or 0.01; GMAT's and ODTK's
        proportional error).
    pointing_sigma : Quantity, optional
        With or without ``magnitude_sigma``: 1-sigma of the pointing error of the Δv's
        direction on each of the two axes across it (angle, e.g. ``0.5 * u.deg``).

    Notes
    -----
    The state at the burn's epoch is reported after the burn (velocity continuous from the
    right): an output time equal to the epoch gives v + Δv.

    The execution error from ``magnitude_sigma`` s_m and ``pointing_sigma`` s_p is the
    linearised Gates model (Gates 1963, JPL TR 32-504): with u = Δv / |Δv|,
    C = (s_m |Δv|)^2 u u^T + (s_p |Δv|)^2 (I - u u^T), on the burn's own axes.
    """

    def __init__(self, epoch, delta_v, frame: str = "GCRS", *, delta_mass=None, mass=None,
                 delta_v_covariance=None, magnitude_sigma=None, pointing_sigma=None):
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
        self.execution_covariance = _execution_covariance(dv, delta_v_covariance,
                                                          magnitude_sigma, pointing_sigma)

    def with_delta_v(self, delta_v_km_s):
        """The same burn (epoch, frame, masses, execution error) with another Δv (km/s on
        its axes): what a fit that estimates the Δv flies at each iteration."""
        import copy

        out = copy.copy(self)
        out._dv = np.array(delta_v_km_s, dtype=np.float64).reshape(3)
        out.delta_v = to_quantity(out._dv.copy(), "speed")
        return out

    @property
    def delta_v_km_s(self) -> np.ndarray:
        """The Δv as plain numbers, km/s on the axes of ``frame`` (a copy)."""
        return self._dv.copy()

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

    def pre_burn_velocity(self, r_km, v_after_km_s) -> np.ndarray:
        """The velocity just before the burn, given the one just after (a backward run).

        Parameters
        ----------
        r_km : ndarray (..., 3)
            Position(s) at the burn, km.
        v_after_km_s : ndarray (..., 3)
            Velocity(ies) just after the burn, km/s.

        Returns
        -------
        ndarray (..., 3)
            km/s: the v- with ``v- + delta_v_inertial(r, v-) = v+``, so that the burn flown
            forward from it gives ``v_after`` back (to round-off).

        Raises
        ------
        InvalidStateError
            No pre-burn state is found (the local frame undefined, or a Δv so large against
            the speed that the equation has no solution near v+ - Δv): give the Δv in GCRS.

        Notes
        -----
        The local frame of a burn is that of the state before it (GMAT, Orekit), and RTN's N,
        TNW and VNB depend on the velocity, so v- solves v- + M(r, v-)^T Δv = v+. Newton's
        method from v+ - M(r, v+)^T Δv with a central-difference Jacobian (I + d(M^T Δv)/dv,
        near I for |Δv| << |v|), to |residual| <= 1e-15 |v+|; inertial Δv: v- = v+ - Δv; a Δv
        along the velocity alone (TNW's T, VNB's V): v- = v+ (|v+| - Δv) / |v+|. Where the
        frame turns fast with the velocity (|d(M^T Δv)/dv| > 1/2 at the root: a Δv comparable
        to the speed, or to the transverse speed in RTN) several pre-burn states can give the
        same v+ and the burn is refused.
        """
        r = np.asarray(r_km, dtype=np.float64)
        v1 = np.asarray(v_after_km_s, dtype=np.float64)
        if self.code == INERTIAL:
            return v1 - self._dv
        speed = np.linalg.norm(v1, axis=-1, keepdims=True)
        if self.code != RTN and self._dv[1] == 0.0 and self._dv[2] == 0.0 and np.all(
                speed > -self._dv[0]):  # along the velocity: v- = v+ (|v+| - dv) / |v+|
            return v1 * ((speed - self._dv[0]) / speed)

        def residual(v):
            with np.errstate(invalid="ignore", divide="ignore"):
                return v + self._dv @ local_axes(r, v, self.code) - v1

        v = v1 - (self._dv @ local_axes(r, v1, self.code))
        scale = np.linalg.norm(v1, axis=-1, keepdims=True)
        for _ in range(30):
            f = residual(v)
            size = np.linalg.norm(f, axis=-1, keepdims=True)
            if not np.all(np.isfinite(f)):
                break
            h = 1e-7 * scale
            jac = np.stack([(residual(v + h * e) - residual(v - h * e)) / (2.0 * h)
                            for e in np.eye(3)], axis=-1)  # (..., 3, 3): columns d f / d v_k
            if not np.all(np.isfinite(jac)):
                break
            step = np.linalg.solve(jac, f[..., None])[..., 0]
            if np.all(size <= 1e-15 * scale) or (np.all(
                    np.linalg.norm(step, axis=-1, keepdims=True) <= 1e-16 * scale) and np.all(
                    size <= 1e-13 * scale)):  # converged, or round-off: no step changes v
                # one root only where the frame turns slowly: |d(M^T Δv)/dv| <= 1/2 there
                if np.all(np.linalg.norm(jac - np.eye(3), ord=2, axis=(-2, -1)) <= 0.5):
                    return v if np.all(size <= 1e-15 * scale) else v - step
                break
            v = v - step
        raise InvalidStateError(
            f"no state before {self!r} gives r = {r}, v = {v1} km/s after it (the {self.frame} "
            "frame undefined there, or a Δv so large against the speed that several states "
            "before the burn give this one): give the Δv in GCRS to cross this burn backwards "
            "(a forward run's out.burns[k].delta_v_inertial)."
        )

    def __repr__(self):
        dv = ", ".join(f"{x:.6g}" for x in self._dv)
        return f"ImpulsiveBurn({_describe(self.start)}, [{dv}] km/s {self.frame})"


def _execution_covariance(dv, covariance, magnitude_sigma, pointing_sigma):
    """The 3 x 3 execution covariance (km^2/s^2, the burn's axes) of :class:`ImpulsiveBurn`,
    or None."""
    if covariance is not None:
        if magnitude_sigma is not None or pointing_sigma is not None:
            raise InvalidInputError(
                "give delta_v_covariance or magnitude_sigma/pointing_sigma, not both.")
        from .._covariance import require_psd
        from .._units import is_quantity

        try:
            c = np.array(covariance.to_value((u.km / u.s) ** 2) if is_quantity(covariance)
                         else covariance, dtype=np.float64)
        except u.UnitConversionError:
            raise InvalidInputError(
                f"delta_v_covariance must be in speed^2 (e.g. (u.m / u.s)**2); got "
                f"{covariance.unit}.") from None
        if c.shape != (3, 3):
            raise InvalidInputError(
                f"delta_v_covariance must be a finite 3 x 3 matrix (the Δv's axes, km^2/s^2); "
                f"got shape {c.shape}.")
        if not np.all(np.isfinite(c)):
            raise InvalidInputError(
                "delta_v_covariance has NaN or infinite entries; give a finite 3 x 3 matrix "
                "(the Δv's axes, km^2/s^2).")
        if not np.allclose(c, c.T, rtol=0.0, atol=1e-8 * np.max(np.abs(c))):
            raise InvalidInputError("delta_v_covariance is not symmetric.")
        c = 0.5 * (c + c.T)
        require_psd(c, "delta_v_covariance")
        return c
    if magnitude_sigma is None and pointing_sigma is None:
        return None
    n = float(np.linalg.norm(dv))
    if n == 0.0:
        raise InvalidInputError(
            "magnitude_sigma and pointing_sigma are relative to a Δv of zero; give "
            "delta_v_covariance (km^2/s^2) instead.")
    u_hat = dv / n
    out = np.zeros((3, 3))
    if magnitude_sigma is not None:
        sm = to_array(magnitude_sigma, "dimensionless", "magnitude_sigma", allow_plain=True)
        if np.ndim(sm) != 0 or not (np.isfinite(sm) and sm >= 0):
            raise InvalidInputError(f"magnitude_sigma must be one fraction >= 0 of |Δv| (e.g. "
                                    f"0.01 or 1 * u.percent); got {magnitude_sigma!r}.")
        out += (float(sm) * n) ** 2 * np.outer(u_hat, u_hat)
    if pointing_sigma is not None:
        sp = to_array(pointing_sigma, "angle", "pointing_sigma")
        if np.ndim(sp) != 0 or not (np.isfinite(sp) and sp >= 0):
            raise InvalidInputError(f"pointing_sigma must be one angle >= 0 (e.g. 0.5 * u.deg); "
                                    f"got {pointing_sigma!r}.")
        out += (float(sp) * n) ** 2 * (np.eye(3) - np.outer(u_hat, u_hat))
    return out


#: Specific impulse (s) of a typical bipropellant engine, for the size of the warning's example
_TYPICAL_ISP_S = 300.0


def _warn_constant_mass(f_n, m0_kg, duration_s) -> None:
    """One UserWarning for a burn with thrust and mass but neither isp nor mass_flow: its mass
    stays m0, so its Δv is F T / m0, below what any engine spending propellant gives."""
    import warnings

    dv = f_n * duration_s / m0_kg
    mdot = f_n / (_TYPICAL_ISP_S * STANDARD_GRAVITY_M_S2)
    m1 = m0_kg - mdot * duration_s
    if m1 > 0:
        real = _TYPICAL_ISP_S * STANDARD_GRAVITY_M_S2 * math.log(m0_kg / m1)
        size = (f"; at Isp {_TYPICAL_ISP_S:g} s it would spend {mdot * duration_s:.4g} kg and give "
                f"{real:.4g} m/s, {100 * (real / dv - 1):.2g} % more")
    else:
        size = f"; at Isp {_TYPICAL_ISP_S:g} s it would spend more than the whole {m0_kg:g} kg"
    warnings.warn(
        f"FiniteBurn with thrust and mass but neither isp nor mass_flow: the mass stays "
        f"{m0_kg:g} kg through the {duration_s:g} s burn, which gives Δv = F T / m0 = "
        f"{dv:.4g} m/s{size}. Give isp=... (or mass_flow=...) to spend the propellant, or "
        "mass_flow=0 * u.kg / u.s for a constant mass on purpose (no warning).",
        UserWarning, stacklevel=3)


class FiniteBurn(_Burn):
    """Thrust over an interval, along a direction fixed in an inertial or local frame.

    Give either ``thrust`` and ``mass`` (with ``isp`` or ``mass_flow`` for a mass that falls;
    neither: the mass stays ``mass``, with a ``UserWarning``; ``mass_flow=0 * u.kg / u.s`` keeps
    it constant without one), or a constant ``acceleration``.

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
        Spacecraft mass at ignition (kg, > 0); needed with ``thrust``. Drag and SRP follow the
        mass the burn spends (:mod:`visviva.satellites.burn_mass`).
    isp : Quantity, optional
        Specific impulse (time, > 0): mass flow mdot = F / (Isp g0).
    mass_flow : Quantity, optional
        Mass flow mdot (mass / time, >= 0), instead of ``isp``. Without either the mass stays
        constant and a ``UserWarning`` says so (400 N on 1000 kg for 30 min: 720 m/s against
        826 m/s at Isp 300 s, 13 % short); give 0 to keep it constant on purpose.
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
        if isp is None and mass_flow is None:
            _warn_constant_mass(float(f_n), float(m0), self.duration_s)
        if isp is not None:
            if isinstance(isp, u.Quantity) and isp.unit.is_equivalent(u.m / u.s):
                from ..errors import UnitsError

                raise UnitsError(
                    f"isp is a specific impulse in seconds; got a speed, {isp}. For an "
                    "effective exhaust speed c give isp=c / (9.80665 * u.m / u.s**2) (here "
                    f"{(isp / (STANDARD_GRAVITY_M_S2 * u.m / u.s**2)).to(u.s):.6g}), or "
                    "mass_flow=thrust / c.")
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
    backward : bool
        Whether the run crossed it backwards in time (from a state after it to outputs before
        it). The other fields still describe the burn forwards in time, as it happened to the
        spacecraft: ``t_start < t_end``, ``mass_before`` before ignition, the Δv added to the
        velocity; a finite burn cut by the run is the part between the cut and its end.
    """

    burn: object
    t_start: object
    t_end: object
    delta_v: object
    delta_v_inertial: object
    mass_before: object
    mass_after: object
    complete: bool
    backward: bool = False


#: What an OPM's state carries when its message has manoeuvres (see :meth:`OPM.state`); kept by
#: indexing and conversions (:func:`visviva._containers.carry_marks`).
PENDING_ATTRIBUTE = PENDING_MANEUVERS_ATTRIBUTE
