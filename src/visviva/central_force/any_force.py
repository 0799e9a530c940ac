"""Any central force: potentials, effective potential, turning points, Bertrand and Binet.

The potential V(r) or the force F(r) per unit mass is a Python callable (see
:mod:`visviva.central_force`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from astropy import units as u

from .._units import (
    broadcast_or_raise,
    to_array,
    to_quantity,
)
from ..errors import DomainError, InvalidInputError, ShapeError, UnitsError, fmt_number
from ._inputs import (
    _callable,
    _finite_result,
    _gm,
    _positive,
    _positive_array,
    _real,
)


def kepler_potential(gm):
    """The Newtonian potential per unit mass :math:`V(r) = -\\mu / r` as a callable.

    Parameters
    ----------
    gm : Quantity (km3 / s2), Body, or float
        With a Quantity or Body the callable takes Quantity ``r``; with a float it takes floats
        in the same consistent units.
    """
    if isinstance(gm, u.Quantity) or hasattr(gm, "gm"):
        gm_q = to_quantity(_gm(gm), "gm")
        return lambda r: -gm_q / r
    gm = _real(gm, "gm")
    if not gm > 0:
        raise InvalidInputError("gm must be > 0.")
    return lambda r: -gm / r


def power_law_force(k, n):
    """The attractive power-law force per unit mass :math:`F(r) = -k r^n` as a callable.

    ``n = -2`` is gravity, ``n = 1`` the isotropic harmonic oscillator (Hooke): the two forces
    whose bound orbits are all closed (Bertrand's theorem). Plain numbers, consistent units.

    Parameters
    ----------
    k : float
        Strength (> 0 for attraction).
    n : float
        Exponent.
    """
    k, n = _real(k, "k"), _real(n, "n")
    return lambda r: -k * r**n


def _split_units(r, h):
    """Decide the unit mode of a (r, h) pair: both Quantities or both plain."""
    r_is_q, h_is_q = isinstance(r, u.Quantity), isinstance(h, u.Quantity)
    if r_is_q != h_is_q:
        raise UnitsError(
            "give r and h both as Quantities (e.g. r in km, h in km2 / s) or both as plain "
            "numbers in one consistent unit system."
        )
    return r_is_q


def _call_potential(potential, r):
    """``potential(r)`` for a whole array ``r``; a callable written for scalars is named."""
    try:
        return potential(r)
    except (TypeError, ValueError) as exc:
        if np.ndim(r) == 0:
            raise
        raise InvalidInputError(
            f"potential(r) failed on an array of radii ({type(exc).__name__}: {exc}): it must be "
            "vectorised (numpy operations, e.g. lambda r: -mu / r, not math.sqrt or float(r)). "
            "Wrap a scalar function with numpy.vectorize."
        ) from exc


def effective_potential(r, h, potential):
    """Effective potential of radial motion :math:`V_{eff}(r) = h^2/(2r^2) + V(r)` per unit mass.

    Parameters
    ----------
    r : Quantity (length) or array_like
        Radii (> 0).
    h : Quantity (km2 / s) or float
        Specific angular momentum.
    potential : callable
        ``V(r)`` per unit mass, vectorised: called once with the whole ``r`` array (as a Quantity
        when ``r`` is one, and then returning a Quantity of specific energy).

    Returns
    -------
    Quantity (km2 / s2) or ndarray
        The effective potential at each radius.

    Notes
    -----
    The radial equation of a particle in a central potential is
    :math:`\\ddot r = -dV_{eff}/dr`; the orbit is bounded between the turning points where
    :math:`V_{eff}(r) = \\varepsilon` (Goldstein sec. 3.3).

    Examples
    --------
    >>> from visviva.central_force import effective_potential, kepler_potential
    >>> print(effective_potential(1.0, 1.0, kepler_potential(1.0)))  # minimum of V_eff at r = h^2/mu
    -0.5
    """
    _callable(potential, "potential")
    if _split_units(r, h):
        r_km = _positive_array(r, "length", "r")
        h_c = to_array(h, "spec_angmom", "h")
        V = to_array(_call_potential(potential, to_quantity(r_km, "length")), "spec_energy",
                     "potential(r)")
        broadcast_or_raise("effective_potential", r=r_km, h=h_c, V=V)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            out = 0.5 * (h_c / r_km) ** 2 + V  # (h/r)^2: h^2 and r^2 may underflow
        return to_quantity(_finite_result(out, "effective_potential"), "spec_energy")
    r = _positive(to_array(r, "length", "r", allow_plain=True), "r")
    h = to_array(h, "length", "h", allow_plain=True)
    V = _call_potential(potential, r)
    if isinstance(V, u.Quantity):
        raise UnitsError(
            f"potential(r) returned a Quantity (unit '{V.unit}') for plain-number radii: a "
            "potential built from Quantities (e.g. kepler_potential(vv.EARTH)) needs r and h as "
            "Quantities too (r in km, h in km2 / s, the energy in km2 / s2); or build it from "
            "plain numbers (kepler_potential(398600.4418)) in one consistent unit system."
        )
    V = to_array(V, "length", "potential(r)", allow_plain=True)
    broadcast_or_raise("effective_potential", r=r, h=h, V=V)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        out = 0.5 * (h / r) ** 2 + V  # (h/r)^2: h^2 and r^2 may under/overflow alone
    _finite_result(out, "effective_potential")
    return out if out.ndim else float(out)


def turning_points(energy, h, potential, r_min, r_max, n_grid=4000):
    """Radii where :math:`V_{eff}(r) = \\varepsilon`: the apsides of the orbit (ascending).

    Parameters
    ----------
    energy : Quantity (km2 / s2) or float
        Specific energy of the orbit.
    h : Quantity (km2 / s) or float
        Specific angular momentum.
    potential : callable
        ``V(r)`` per unit mass (see :func:`effective_potential`).
    r_min, r_max : Quantity (length) or float
        The interval searched, ``0 < r_min < r_max``.
    n_grid : int
        Points of the logarithmic scan that brackets the roots before Brent's method refines them
        to machine precision. Two roots closer together than the grid spacing are found by
        locating the extremum of :math:`V_{eff}` between them (the bottom of a well, the top of a
        barrier); more than two within one grid cell can be missed.

    Returns
    -------
    Quantity (km) or ndarray
        The turning points found, ascending; empty when the energy is everywhere below or above
        the effective potential in the interval.
    """
    from scipy.optimize import brentq, minimize_scalar

    _callable(potential, "potential")
    if isinstance(n_grid, bool) or not isinstance(n_grid, int | np.integer) or n_grid < 2:
        raise InvalidInputError(f"n_grid must be an integer >= 2; got {fmt_number(n_grid)}.")
    quantity = isinstance(energy, u.Quantity)
    if quantity:
        E = float(to_array(energy, "spec_energy", "energy"))
        lo, hi = float(to_array(r_min, "length", "r_min")), float(to_array(r_max, "length", "r_max"))
        h_q = to_quantity(to_array(h, "spec_angmom", "h"), "spec_angmom")

        def f(r):
            r = to_quantity(np.asarray(r, dtype=float), "length")
            return to_array(effective_potential(r, h_q, potential), "spec_energy", "V_eff") - E
    else:
        if any(isinstance(x, u.Quantity) for x in (h, r_min, r_max)):
            raise UnitsError(
                "energy is a plain number, so h, r_min and r_max must be plain numbers in the same "
                "consistent units (a Quantity r_min was read in km, whatever the potential's "
                "units); or give the energy as a Quantity (km2 / s2) too."
            )
        E = _real(energy, "energy")
        lo, hi = float(to_array(r_min, "length", "r_min", allow_plain=True, finite=False)), float(
            to_array(r_max, "length", "r_max", allow_plain=True, finite=False)
        )

        def f(r):
            return np.asarray(effective_potential(np.asarray(r, dtype=float), h, potential)) - E

    if not (0 < lo < hi and math.isfinite(hi)):
        raise InvalidInputError("need 0 < r_min < r_max < inf for the search interval.")
    grid = np.geomspace(lo, hi, int(n_grid))
    values = f(grid)
    roots = [float(r) for r, v in zip(grid, values, strict=True) if v == 0.0]
    brackets = [
        (grid[i], grid[i + 1])
        for i in np.flatnonzero(np.signbit(values[:-1]) != np.signbit(values[1:]))
        if values[i] != 0.0 and values[i + 1] != 0.0
    ]
    # two roots closer than the grid spacing hide in a local minimum of V_eff - E that stays
    # positive on the grid (a nearly circular orbit), or in a local maximum that stays negative
    # (an energy just below the top of a barrier): find the extremum and split the bracket there
    mid, left, right = values[1:-1], values[:-2], values[2:]
    hidden = [(i, 1.0) for i in np.flatnonzero((mid > 0) & (mid <= left) & (mid <= right)) + 1]
    hidden += [(i, -1.0) for i in np.flatnonzero((mid < 0) & (mid >= left) & (mid >= right)) + 1]
    for i, sign in hidden:
        best = minimize_scalar(lambda x, s=sign: s * float(f(np.array([x]))[0]),
                               bounds=(grid[i - 1], grid[i + 1]),
                               method="bounded", options={"xatol": 1e-14 * grid[i]})
        if best.fun < 0:
            brackets += [(grid[i - 1], best.x), (best.x, grid[i + 1])]
        elif best.fun == 0:
            roots.append(float(best.x))  # a double root: the circular orbit or the barrier top
    for lo_b, hi_b in brackets:
        roots.append(brentq(lambda x: float(f(np.array([x]))[0]), lo_b, hi_b,
                            xtol=1e-15 * lo_b, rtol=4 * np.finfo(float).eps, maxiter=200))
    roots = np.array(sorted(roots))
    return to_quantity(roots, "length") if quantity else roots


def bertrand_apsidal_angle(n):
    """Apsidal angle of a nearly circular orbit under the power-law force :math:`F \\propto -r^n`.

    :math:`\\Delta\\theta = \\pi / \\sqrt{n + 3}` (rad), for ``n > -3``. It is a rational multiple
    of :math:`\\pi` that stays so for all amplitudes only for ``n = -2`` (gravity: ``pi``) and
    ``n = 1`` (Hooke: ``pi/2``): Bertrand's theorem (Goldstein sec. 3.6 and appendix A).

    Parameters
    ----------
    n : float
        Exponent of the force law.
    """
    n = to_array(n, "dimensionless", "n")
    if np.any(n <= -3):
        raise DomainError("circular orbits are unstable for n <= -3: there is no apsidal angle.")
    return np.pi / np.sqrt(n + 3.0)


@dataclass(frozen=True)
class BinetOrbit:
    """A planar orbit under a central force, from the Binet equation.

    Attributes
    ----------
    theta : ndarray
        Polar angle samples (rad), from 0 to ``theta_max``.
    r : ndarray
        Radius at each sample (the units of the inputs: km when Quantities were given).
    apsis_theta : ndarray
        Polar angles of the apsides found (where dr/dtheta = 0), ascending (rad).
    apsis_r : ndarray
        Radii at those apsides.
    h : float
        Specific angular momentum used.
    """

    theta: np.ndarray
    r: np.ndarray
    apsis_theta: np.ndarray
    apsis_r: np.ndarray
    h: float

    @cached_property
    def apsidal_angle(self) -> float:
        """Mean polar angle between successive apsides (periapsis to apoapsis), rad."""
        if self.apsis_theta.size < 2:
            raise DomainError(
                "fewer than two apsides were found: integrate further (larger theta_max), or the "
                "orbit is circular to the integration tolerance (r constant: apsides undefined; "
                "for the apsidal angle of nearly circular orbits use bertrand_apsidal_angle) or "
                "unbound."
            )
        return float(np.mean(np.diff(self.apsis_theta)))

    @cached_property
    def precession_per_orbit(self) -> float:
        """Advance of the periapsis per radial period, :math:`2\\Delta\\theta - 2\\pi` (rad)."""
        return 2.0 * self.apsidal_angle - 2.0 * np.pi

    def is_closed(self, max_turns: int = 12, tol: float = 1e-6) -> bool:
        """Whether the apsidal angle is (to ``tol`` rad) a rational multiple p/q of 2 pi, q <= max_turns."""
        ratio = self.apsidal_angle / (2.0 * np.pi)
        return any(
            abs(ratio * q - round(ratio * q)) * 2.0 * np.pi < tol for q in range(1, 2 * max_turns + 1)
        )

    @cached_property
    def xy(self) -> np.ndarray:
        """Cartesian positions in the orbital plane, shape (n, 2)."""
        return np.stack([self.r * np.cos(self.theta), self.r * np.sin(self.theta)], axis=-1)


def _raise_plunge(sol, u0, r0):
    """DomainError if a failed Binet integration stopped because u = 1/r blew up (r -> 0)."""
    if sol.sol is None:
        return
    theta_end = float(sol.sol.t_max)
    u_end = float(sol.sol(theta_end)[0])
    if not (math.isfinite(u_end) and u_end > 1e3 * u0):
        return
    raise DomainError(
        f"orbit_equation: the orbit falls into the centre: u = 1/r grows without bound as theta "
        f"approaches {theta_end:.9g} rad (r = {1.0 / u_end:.3g} there, r0 = {r0:.6g}). The "
        "attraction grows faster than h^2 / r^3 at small r (a force steeper than 1/r^3) and "
        "this angular momentum cannot stop the plunge, so r reaches 0 at a finite angle (no "
        "further apsis). Integrate to a smaller theta_max, or give more angular momentum h."
    )


def orbit_equation(force, r0, h, dr_dtheta0=0.0, theta_max=4.0 * np.pi, n_points=2000, rtol=1e-12):
    """Integrate the orbit equation (Binet) :math:`u'' + u = -F(1/u) / (h^2 u^2)`, u = 1/r.

    Parameters
    ----------
    force : callable
        Radial force per unit mass ``F(r)`` (negative = attractive), called with a float ``r``
        (in km when the other inputs are Quantities), returning a float (km / s2) or, with
        Quantity inputs, a Quantity of acceleration (converted to km / s2).
    r0 : Quantity (length) or float
        Radius at theta = 0 (> 0).
    h : Quantity (km2 / s) or float
        Specific angular momentum (> 0).
    dr_dtheta0 : Quantity (length) or float
        :math:`dr/d\\theta` at theta = 0; zero starts at an apsis.
    theta_max : float
        Polar angle to integrate to (rad).
    n_points : int
        Number of output samples of ``r(theta)``.
    rtol : float
        Relative tolerance of scipy's DOP853 (the absolute tolerance is scaled to ``1/r0``).

    Returns
    -------
    BinetOrbit
        Samples, the apsides found (by root finding on :math:`du/d\\theta = 0` in the dense output)
        and the apsidal angle and precession derived from them.

    Notes
    -----
    With :math:`r^2\\dot\\theta = h` and u = 1/r the radial equation of motion becomes
    :math:`d^2u/d\\theta^2 + u = -F(1/u)/(h^2u^2)` (Goldstein eq. 3.34). For gravity,
    :math:`F = -\\mu u^2` and the solution is the conic :math:`u = (\\mu/h^2)(1 + e\\cos\\theta)`.

    Examples
    --------
    >>> from visviva.central_force import orbit_equation, power_law_force
    >>> orbit = orbit_equation(power_law_force(1.0, -2), r0=1.0, h=0.9)
    >>> print(f"{orbit.apsidal_angle / 3.141592653589793:.9f}")  # Kepler: closed, pi
    1.000000000
    """
    from scipy.integrate import solve_ivp

    _callable(force, "force")
    quantity = _split_units(r0, h)

    def scalar(value, kind, name, allow_plain):
        arr = to_array(value, kind, name, allow_plain=allow_plain)
        if arr.ndim != 0:
            raise ShapeError(
                f"orbit_equation integrates one orbit: {name} must be a scalar; got shape "
                f"{arr.shape}. Call it once per orbit."
            )
        return float(arr)

    if quantity:
        r0 = scalar(r0, "length", "r0", False)
        h = scalar(h, "spec_angmom", "h", False)
        plain_zero = not isinstance(dr_dtheta0, u.Quantity) and np.all(np.asarray(dr_dtheta0) == 0)
        dr_dtheta0 = scalar(dr_dtheta0, "length", "dr_dtheta0", plain_zero)
    else:
        r0 = scalar(r0, "length", "r0", True)
        h = scalar(h, "length", "h", True)
        dr_dtheta0 = scalar(dr_dtheta0, "length", "dr_dtheta0", True)
    for name, val in (("r0", r0), ("h", h)):
        if not val > 0:
            hint = (" With h = 0 the motion is radial (theta stays constant, so there is no orbit "
                    "equation in theta): integrate r(t) instead, e.g. with "
                    "visviva.mechanics.solve_particles; infall from rest at r0 reaches r = 0 at "
                    "t = pi/2 sqrt(r0^3 / 2 mu).") if name == "h" and val == 0 else ""
            raise InvalidInputError(f"{name} must be finite and > 0; got {fmt_number(val)}.{hint}")
    theta_max = float(to_array(theta_max, "angle", "theta_max", finite=False))
    if not (math.isfinite(theta_max) and theta_max > 0):
        raise InvalidInputError("theta_max must be finite and > 0 (rad).")
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer) or n_points < 2:
        raise InvalidInputError(f"n_points must be an integer >= 2; got {fmt_number(n_points)}.")
    if not (isinstance(rtol, float | int) and math.isfinite(rtol) and 0 < rtol < 1):
        raise InvalidInputError(f"rtol must be a float in (0, 1); got {fmt_number(rtol)}.")
    h2 = h * h

    def rhs(_theta, y):
        uu, du = y
        if uu <= 0:
            return [du, 0.0]
        F = force(1.0 / uu)
        if isinstance(F, u.Quantity):  # e.g. -vv.EARTH.gm / r**2 with r in km: km3 / s2 / 1
            if not quantity:
                raise UnitsError(
                    f"force(r) returned a Quantity ('{F.unit}') but r0 and h are plain numbers: "
                    "return plain numbers in their units, or give r0 and h as Quantities."
                )
            try:
                F = F.to_value(u.km / u.s**2) if F.unit.physical_type != "dimensionless" else F.value
            except u.UnitConversionError as exc:
                raise UnitsError(
                    f"force(r) returned '{F.unit}', not a force per unit mass (km / s2); r is "
                    "passed as a plain number in km."
                ) from exc
        try:
            F = float(F)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                "force(r) must return one float (the radial force per unit mass, in km/s2 when "
                f"the inputs are Quantities); got {F!r}."
            ) from exc
        if not math.isfinite(F):
            raise InvalidInputError(
                f"force(r) returned {fmt_number(F)} at r = {fmt_number(1.0 / uu)}: the force must be "
                "finite along "
                "the orbit. Check the force law (and its units)."
            )
        return [du, -uu - F / (h2 * uu * uu)]

    def apsis(_theta, y):
        return y[1]

    def escaped(_theta, y):
        return y[0]

    escaped.terminal = True
    u0 = 1.0 / r0
    du0 = -dr_dtheta0 / r0**2
    theta = np.linspace(0.0, theta_max, int(n_points))
    atol = rtol * u0 * 1e-3
    sol = solve_ivp(rhs, (0.0, theta_max), [u0, du0], method="DOP853", t_eval=theta,
                    events=(apsis, escaped), rtol=rtol, atol=atol, dense_output=True)
    if not sol.success:
        _raise_plunge(sol, u0, r0)
        raise InvalidInputError(f"the orbit equation could not be integrated: {sol.message}")
    u_s = sol.y[0]
    if sol.t_events[1].size or np.any(u_s <= 0) or not np.all(np.isfinite(u_s)):
        raise DomainError(
            "the orbit reaches r = infinity (u = 0) within theta_max: it is unbound; use a smaller "
            "theta_max or more angular momentum/less energy for a bound orbit."
        )
    apsis_theta = sol.t_events[0]
    # u = 1/r is smallest at an apsis (du/dtheta = 0) or at the ends. An orbit that just escapes
    # dips below u = 0 over an arc narrower than one step (missed by the escape event and by the
    # samples) and a parabola touches u = 0: its apsis "r" was negative or ~1e14 r0, reported as
    # a bound orbit (a parabola came out "closed" with apsidal angle pi). Below 1e4 atol, u is
    # not resolved from 0: bound, parabolic and hyperbolic cannot be told apart.
    u_floor = 1e4 * atol
    u_apsis = sol.sol(apsis_theta)[0] if apsis_theta.size else np.empty(0)
    u_far = float(np.min(np.concatenate([u_s, u_apsis])))
    if u_far <= u_floor:
        raise DomainError(
            f"orbit_equation: u = 1/r falls to {u_far:.3g} (r0 = {r0:.6g}), within the integration "
            f"tolerance ({u_floor:.3g}) of u = 0 or below it: the orbit escapes to r = infinity "
            "(parabolic or unbound), or is a bound orbit with r_max / r0 beyond "
            f"{1.0 / (u_floor * r0):.3g}, which rtol = {rtol:.3g} does not resolve. Give less "
            "energy (smaller h at an apsis) for a bound orbit, or a smaller rtol."
        )
    # an apsis exactly at theta = 0 (dr/dtheta0 = 0) is not reported as an event: add it
    if du0 == 0.0:
        apsis_theta = np.concatenate([[0.0], apsis_theta[apsis_theta > 0]])
    # a circular orbit (r constant to the integration tolerance) has no apsides: the events
    # found are zero crossings of rounding noise in du/dtheta, at meaningless angles
    if np.ptp(u_s) <= 1e3 * rtol * np.max(u_s):
        apsis_theta = np.empty(0)
    apsis_r = 1.0 / sol.sol(apsis_theta)[0] if apsis_theta.size else np.empty(0)
    return BinetOrbit(theta=sol.t, r=1.0 / u_s, apsis_theta=apsis_theta, apsis_r=apsis_r, h=h)
