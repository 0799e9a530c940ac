"""Initial orbit determination from angles only: Gauss's method and Escobal's double-r.

>>> import visviva as vv
>>> from astropy import units as u
>>> from astropy.time import Time
>>> t = Time(["2012-08-20T11:40:28", "2012-08-20T11:48:28", "2012-08-20T11:52:28"])
>>> s = vv.gauss_angles([0.939913, 45.025748, 67.886655] * u.deg,
...                     [18.667717, 35.664741, 36.996583] * u.deg, t,
...                     [[4054.881, 2748.195, 4074.237], [3956.224, 2888.232, 4074.364],
...                      [3905.073, 2956.935, 4074.430]] * u.km, 398600.4418 * u.km**3 / u.s**2)
>>> print(s.r.round(1))    # Vallado (2013), Example 7-2
[6356.4 5290.6 6511.4] km
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._units import to_array, to_vector
from ..errors import ConvergenceError, DomainError, InvalidInputError, ShapeError
from .iod import gibbs_velocity, gm_value

__all__ = ["gauss_angles", "double_r", "state_at"]

#: largest angle (rad) between an observed line of sight and the orbit's for an IOD solution
SIGHT_TOL_RAD = 1e-8


# -- angles only --------------------------------------------------------------------------------


def _angles_inputs(ra, dec, t, site_positions):
    from astropy.time import Time

    alpha = to_array(ra, "angle", "ra")
    delta = to_array(dec, "angle", "dec")
    if alpha.shape != (3,) or delta.shape != (3,):
        raise ShapeError(
            f"angles-only IOD takes exactly three observations: ra and dec of shape (3,); got "
            f"{alpha.shape} and {delta.shape}. Pick three from a longer pass."
        )
    if np.any(np.abs(delta) > np.pi / 2):
        k = int(np.flatnonzero(np.abs(delta) > np.pi / 2)[0])
        raise DomainError(
            f"dec[{k}] = {float(delta[k]):g} rad is outside [-pi/2, pi/2]. Plain numbers are "
            "radians: pass degrees as a Quantity, e.g. dec=[10, 12, 14] * u.deg."
        )
    if isinstance(t, Time):
        if t.shape != (3,):
            raise ShapeError(f"t must hold three times; got shape {t.shape}.")
        from ..satellites.frames import offline_iers

        with offline_iers():  # times in UT1 need the installed IERS table, never a download
            secs = (t.tt - t[1].tt).sec
        epoch = t[1]
    else:
        secs = to_array(t, "time", "t", allow_plain=True)
        if secs.shape != (3,):
            raise ShapeError(f"t must hold three times; got shape {secs.shape}.")
        secs = secs - secs[1]
        epoch = None
    if not (secs[0] < 0 < secs[2]):
        raise InvalidInputError(
            "the three observation times must increase strictly; sort the observations."
        )
    sites = to_vector(site_positions, "length", "site_positions", allow_plain=True)
    if sites.shape != (3, 3):
        raise ShapeError(f"site_positions must have shape (3, 3); got {sites.shape}.")
    los = np.stack(
        [np.cos(delta) * np.cos(alpha), np.cos(delta) * np.sin(alpha), np.sin(delta)], axis=-1
    )
    return los, np.asarray(secs, dtype=np.float64), sites, epoch


def _propagate(r, v, gm, dt):
    from ..core.universal import propagate_scalar

    out = propagate_scalar(r[0], r[1], r[2], v[0], v[1], v[2], gm, dt)
    if out[0] != 0:
        return None
    return np.array(out[1:4]), np.array(out[4:7])


def _lagrange_fg(r2, v2, gm, tau):
    """Exact Lagrange coefficients f, g with r(t2 + tau) = f r2 + g v2 (two-body)."""
    res = _propagate(r2, v2, gm, tau)
    if res is None:
        return None
    r = res[0]
    m = np.stack([r2, v2], axis=1)
    fg, *_ = np.linalg.lstsq(m, r, rcond=None)
    return float(fg[0]), float(fg[1])


def _gauss_determinants(los, sites):
    """D0 = L1 . (L2 x L3) and D_ij = R_i . p_j with p1 = L2 x L3, p2 = L1 x L3, p3 = L1 x L2."""
    L1, L2, L3 = los
    p1, p2, p3 = np.cross(L2, L3), np.cross(L1, L3), np.cross(L1, L2)
    D0 = float(L1 @ p1)
    if abs(D0) < 1e-12:
        raise DomainError(
            "the three lines of sight are coplanar (D0 = 0): Gauss's method cannot separate the "
            "ranges; use observations spread further apart or double_r."
        )
    return D0, np.array([[R @ p for p in (p1, p2, p3)] for R in sites])


def _series_fg(gm, r2m, tau):
    """Lagrange f and g to third order in ``tau`` about a radius ``r2m``."""
    return 1.0 - gm * tau**2 / (2 * r2m**3), tau - gm * tau**3 / (6 * r2m**3)


def _gauss_ranges(los, sites, D0, D, f1, g1, f3, g3):
    """Ranges, r2 and v2 of Gauss's method for given Lagrange coefficients."""
    L1, L2, L3 = los
    R1, R2, R3 = sites
    den = f1 * g3 - f3 * g1
    c1, c3 = g3 / den, -g1 / den
    rho1 = (-D[0, 0] + D[1, 0] / c1 - D[2, 0] * c3 / c1) / D0
    rho2 = (-c1 * D[0, 1] + D[1, 1] - c3 * D[2, 1]) / D0
    rho3 = (-D[0, 2] * c1 / c3 + D[1, 2] / c3 - D[2, 2]) / D0
    r1v, r2v, r3v = R1 + rho1 * L1, R2 + rho2 * L2, R3 + rho3 * L3
    v2v = (-f3 * r1v + f1 * r3v) / den
    return r2v, v2v, np.array([rho1, rho2, rho3])


def _gauss_solution(los, taus, sites, gm, r2_guess, max_iter, tol):
    """Gauss's method from a guess of |r2|, refined with exact f and g until the ranges settle."""
    tau1, tau3 = taus[0], taus[2]
    D0, D = _gauss_determinants(los, sites)
    f1, g1 = _series_fg(gm, r2_guess, tau1)
    f3, g3 = _series_fg(gm, r2_guess, tau3)
    rho_old = None
    for _ in range(max_iter):
        r2v, v2v, rho = _gauss_ranges(los, sites, D0, D, f1, g1, f3, g3)
        if rho_old is not None and np.max(np.abs(rho - rho_old)) < tol * max(1.0, np.max(np.abs(rho))):
            return r2v, v2v, rho
        rho_old = rho
        fg1 = _lagrange_fg(r2v, v2v, gm, tau1)
        fg3 = _lagrange_fg(r2v, v2v, gm, tau3)
        if fg1 is None or fg3 is None or not np.all(np.isfinite(v2v)):
            return None
        # average with the previous coefficients (Curtis 2020, Algorithm 5.6) for stability
        f1, g1 = 0.5 * (f1 + fg1[0]), 0.5 * (g1 + fg1[1])
        f3, g3 = 0.5 * (f3 + fg3[0]), 0.5 * (g3 + fg3[1])
    return None


#: emission-time iterations of gauss_angles(light_time=True) (each gains a factor v/c ~ 1e-5)
LIGHT_TIME_ITERATIONS = 3


def _retarded(r2, v2, gm, los, taus, sites):
    """(r2, v2) at the middle reception time of the orbit whose positions at the emission
    times t_i - rho_i / c lie on the lines of sight received at t_i (the emission-time correction of e.g. Escobal 1965)."""
    from ..constants import C_KM_S

    shifted = taus
    for _ in range(LIGHT_TIME_ITERATIONS):
        rho = np.empty(3)
        for k in range(3):
            res = _propagate(r2, v2, gm, shifted[k]) if shifted[k] != 0.0 else (r2, v2)
            if res is None:
                return r2, v2
            rho[k] = np.linalg.norm(res[0] - sites[k])
        shifted = taus - rho / C_KM_S
        better = _newton_angles(r2, v2, gm, los, shifted, sites)
        if better is None:
            raise ConvergenceError(
                "gauss_angles(light_time=True): no orbit passes through the lines of sight at "
                "the emission times of the light (t - rho / c) near the orbit found without "
                "light time. Check the data, or pass light_time=False.")
        r2, v2 = better
    return r2, v2


def _perpendiculars(los):
    """Two unit vectors perpendicular to each line of sight, (3, 2, 3)."""
    out = np.empty((3, 2, 3))
    for k, L in enumerate(los):
        a = np.cross(L, [1.0, 0.0, 0.0] if abs(L[0]) < 0.9 else [0.0, 1.0, 0.0])
        a /= np.linalg.norm(a)
        out[k] = a, np.cross(L, a)
    return out


def _sight_offsets(x, gm, taus, sites, perp):
    """Offsets (km) of the orbit (r2, v2) = x from the three lines of sight, (6,) or None."""
    out = np.empty(6)
    for k in range(3):
        res = _propagate(x[:3], x[3:], gm, taus[k]) if taus[k] != 0.0 else (x[:3], x[3:])
        if res is None:
            return None
        out[2 * k: 2 * k + 2] = perp[k] @ (res[0] - sites[k])
    return out


def _newton_angles(r2, v2, gm, los, taus, sites, max_iter=40):
    """Orbit through the three lines of sight by Newton's method on (r2, v2), or None.

    Six equations (the two offsets of the orbit from each line of sight) in six unknowns,
    the Jacobian by central differences, steps halved until the offsets shrink. Converges
    from Gauss's first estimate where the fixed-point refinement of the ranges diverges.
    """
    perp = _perpendiculars(los)
    x = np.concatenate([r2, v2])
    F = _sight_offsets(x, gm, taus, sites, perp)
    if F is None or not np.all(np.isfinite(x)):
        return None
    for _ in range(max_iter):
        size = float(np.linalg.norm(x[:3]))
        h = 1e-6 * np.concatenate([np.full(3, size), np.full(3, np.linalg.norm(x[3:]))])
        J = np.empty((6, 6))
        for j in range(6):
            e = np.zeros(6)
            e[j] = h[j]
            Fp = _sight_offsets(x + e, gm, taus, sites, perp)
            Fm = _sight_offsets(x - e, gm, taus, sites, perp)
            if Fp is None or Fm is None:
                return None
            J[:, j] = (Fp - Fm) / 2.0
        try:
            dx = h * np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            break
        lam = 1.0
        while lam > 1e-4:
            Fn = _sight_offsets(x + lam * dx, gm, taus, sites, perp)
            if Fn is not None and np.linalg.norm(Fn) < np.linalg.norm(F):
                break
            lam *= 0.5
        else:
            break  # no step lowers the offsets: at the round-off floor (or stuck)
        x, F = x + lam * dx, Fn
        if np.linalg.norm(lam * dx[:3]) <= 1e-14 * size:
            break
    return (x[:3], x[3:]) if np.linalg.norm(F) <= 1e-8 * np.linalg.norm(x[:3]) else None


def _los_residual(r2, v2, gm, los, taus, sites):
    """Largest angle (rad) between the observed lines of sight and those of the orbit."""
    worst = 0.0
    for k in range(3):
        res = _propagate(r2, v2, gm, taus[k]) if taus[k] != 0.0 else (r2, v2)
        if res is None:
            return math.inf
        d = res[0] - sites[k]
        worst = max(worst, math.atan2(float(np.linalg.norm(np.cross(d, los[k]))), float(d @ los[k])))
    return worst


def state_at(r2, v2, gm, epoch):
    """A StateVectors from canonical r (km), v (km/s) and gm at ``epoch`` (None or a Time)."""
    from ..states import StateVectors

    return StateVectors._from_canonical(np.asarray(r2), np.asarray(v2), np.float64(gm), epoch)


def gauss_angles(ra, dec, t, site_positions, gm, *, max_iter=100, tol=1e-12,
                 return_all=False, light_time=False):  # fmt: skip
    """Orbit from three angles-only observations (Gauss's method with iterative refinement).

    Parameters
    ----------
    ra, dec : Quantity (angle) or array_like (rad), shape (3,)
        Topocentric right ascension and declination of the three observations (GCRS axes).
    t : astropy Time or Quantity (time), shape (3,)
        Observation times, strictly increasing.
    site_positions : Quantity (length) or array_like (km), shape (3, 3)
        GCRS position of the observer at each time.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter.
    max_iter : int
        Largest number of refinement iterations.
    tol : float
        Relative change of the slant ranges that ends the refinement.
    return_all : bool
        False (default): one orbit. True: every distinct orbit found through the three lines
        of sight, a list, the returned one first.
    light_time : bool
        False (default; the textbooks' examples): each direction is the satellite's at its
        time. True: the directions are those of light received at ``t`` (real data; what
        :class:`~visviva.Observations` models with ``light_time=True``), which left the
        satellite rho / c earlier: the orbit is solved again through the lines of sight at
        those emission times (without it a MEO seen at 22,000 km came back 0.3 km off on
        noise-free data, a LEO 20-30 m: the satellite's motion during the flight).

    Returns
    -------
    StateVectors or list of StateVectors
        Position (km) and velocity (km/s) at the middle time (``epoch`` = ``t[1]`` when ``t``
        is a Time).

    Warns
    -----
    RuntimeWarning
        When more than one bound orbit passes through the three lines of sight, or none (the
        orbit returned is then unbound).

    Raises
    ------
    ConvergenceError
        No root of Gauss's eighth-degree polynomial leads to an orbit through the three lines
        of sight.
    DomainError
        The lines of sight are coplanar.

    Notes
    -----
    Gauss's method (Curtis 2020, Algorithms 5.5 and 5.6; Vallado 2013, Algorithm 52):
    with L_i the unit lines of sight and R_i the site vectors, the ranges follow from the
    determinants D_ij = R_i . p_j (p1 = L2 x L3, p2 = L1 x L3, p3 = L1 x L2) once the Lagrange
    coefficients are known. Every positive real root r2 of

        r2^8 + a r2^6 + b r2^3 + c = 0

    (series f and g to third order in tau) starts an iteration in which f and g are
    recomputed exactly by two-body propagation (universal variables) and averaged with their
    previous values until the ranges change by less than ``tol``. That fixed-point iteration
    can diverge or run off to another orbit, so each root's first estimate also starts Newton's
    method on the six offsets of the orbit (r2, v2) from the three lines of sight. Three
    directions can be matched by more than one orbit (Charlier's ambiguity; on noise-free
    passes seen from the ground, about one case in ten for GEO-like arcs): candidates through
    the lines of sight (within 1e-8 rad) are ranked bound before unbound, then by how far they
    moved from their root, and a warning lists the bound ones when there are several. The
    result is exact for noise-free two-body data (with ``light_time=True`` where the data
    carry the light's flight time: without it the orbit is off by about v rho / c).
    """
    g = gm_value(gm)
    los, taus, sites, epoch = _angles_inputs(ra, dec, t, site_positions)
    tau1, tau3 = taus[0], taus[2]
    tau = tau3 - tau1
    D0, D = _gauss_determinants(los, sites)
    A = (-D[0, 1] * tau3 / tau + D[1, 1] + D[2, 1] * tau1 / tau) / D0
    B = (D[0, 1] * (tau3**2 - tau**2) * tau3 / tau + D[2, 1] * (tau**2 - tau1**2) * tau1 / tau) / (
        6 * D0
    )
    E = float(los[1] @ sites[1])
    R2sq = float(sites[1] @ sites[1])
    a = -(A * A + 2 * A * E + R2sq)
    b = -2 * g * B * (A + E)
    c = -(g * B) ** 2
    roots = np.roots([1.0, 0.0, a, 0.0, 0.0, b, 0.0, 0.0, c])
    real = sorted(
        float(z.real) for z in roots if abs(z.imag) <= 1e-8 * abs(z) and z.real > 0
    )
    candidates = []  # (unbound, shift from the root, r2, v2)
    for r2_guess in real:
        found = []
        sol = _gauss_solution(los, taus, sites, g, r2_guess, max_iter, tol)
        if sol is not None:
            found.append(sol[:2])
        # Newton from Gauss's first estimate: the refinement above can diverge or run off to
        # another orbit through the same lines of sight
        first = _gauss_ranges(los, sites, D0, D, *_series_fg(g, r2_guess, tau1),
                              *_series_fg(g, r2_guess, tau3))  # fmt: skip
        newton = _newton_angles(first[0], first[1], g, los, taus, sites)
        if newton is not None:
            found.append(newton)
        for r2v, v2v in found:
            if _los_residual(r2v, v2v, g, los, taus, sites) > SIGHT_TOL_RAD:
                continue
            bound = float(v2v @ v2v) / 2.0 - g / float(np.linalg.norm(r2v)) < 0.0
            shift = abs(float(np.linalg.norm(r2v)) - r2_guess) / r2_guess
            candidates.append((not bound, shift, r2v, v2v))
    if not candidates:
        raise ConvergenceError(
            f"Gauss's method found no orbit: the positive roots {real} of the eighth-degree "
            "polynomial give no converged ranges. Check the observations (angles in the GCRS, "
            "site positions in km), space them further apart, or use vv.od.double_r with a "
            "range guess."
        )
    # several orbits can pass through three lines of sight: a bound one first, then the one
    # that stayed closest to the root of Gauss's polynomial it came from
    candidates.sort(key=lambda c: (c[0], c[1]))
    distinct = []
    for c in candidates:
        if all(np.linalg.norm(c[2] - d[2]) > 1e-4 * np.linalg.norm(d[2]) for d in distinct):
            distinct.append(c)
    if light_time:
        distinct = [(c[0], c[1], *_retarded(c[2], c[3], g, los, taus, sites)) for c in distinct]
    states = [state_at(c[2], c[3], g, epoch) for c in distinct]
    if return_all:
        return states
    bound = [c for c in distinct if not c[0]]
    if not bound:  # audit20: an escape orbit 27 million km out, returned without a word
        r2v, v2v = distinct[0][2], distinct[0][3]
        warnings.warn(
            f"no bound orbit passes through the three lines of sight: returning an unbound one "
            f"(|r2| = {np.linalg.norm(r2v):.6g} km, speed {np.linalg.norm(v2v):.4g} km/s, "
            f"above escape speed {math.sqrt(2.0 * g / np.linalg.norm(r2v)):.4g} km/s). For a "
            "satellite this says the directions do not determine its orbit (lines of sight "
            "nearly in one plane, as for a geostationary object seen from the equator; too "
            "short an arc; noise): take observations further apart or from another site.",
            RuntimeWarning, stacklevel=2)  # fmt: skip
    if len(bound) > 1:
        radii = ", ".join(f"{np.linalg.norm(c[2]):.1f}" for c in bound)
        warnings.warn(
            f"{len(bound)} bound orbits pass through the three lines of sight (|r2| = {radii} "
            "km): three directions cannot tell them apart. Returning the first; see them all "
            "with return_all=True, and settle it with more observations (vv.fit_orbit).",
            RuntimeWarning, stacklevel=2)  # fmt: skip
    return states[0]


def double_r(ra, dec, t, site_positions, gm, r1_guess=None, r2_guess=None, *, max_iter=50,
             tol=1e-9, light_time=False):  # fmt: skip
    """Orbit from three angles-only observations by the double-r iteration (Escobal 1965).

    Parameters
    ----------
    ra, dec : Quantity (angle) or array_like (rad), shape (3,)
        Topocentric right ascension and declination (GCRS axes).
    t : astropy Time or Quantity (time), shape (3,)
        Observation times, strictly increasing.
    site_positions : Quantity (length) or array_like (km), shape (3, 3)
        GCRS observer positions.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter.
    r1_guess, r2_guess : Quantity (length) or float (km), optional
        Guesses of the geocentric distances at the first and second observation (default:
        twice the largest site radius, a low orbit).
    max_iter : int
        Largest number of Newton iterations.
    tol : float
        Relative change of (r1, r2) that ends the iteration.
    light_time : bool
        True: the directions are of light received at ``t``, which left the satellite rho / c
        earlier (as for :func:`gauss_angles`); the orbit is solved again at those emission
        times. False (default): the satellite's directions at ``t``.

    Returns
    -------
    StateVectors
        Position and velocity at the middle time.

    Raises
    ------
    ConvergenceError
        The Newton iteration did not converge (try other distance guesses).

    Notes
    -----
    Unknowns are the geocentric distances r1, r2. Each gives a range along the line of sight,
    rho_i = -c_i/2 + sqrt(c_i^2/4 - (R_i^2 - r_i^2)) with c_i = 2 L_i . R_i, hence r1 and r2
    vectors; the orbit plane (r1 x r2) and the third line of sight give r3. The transfer
    angles and the conic through the three points (semi-latus rectum p from the three radii,
    eccentricity and semi-major axis) give the times of flight by Kepler's equation; Newton's
    method on the residuals F1 = tau1 - (t1 - t2), F2 = tau3 - (t3 - t2), with partials by
    small changes of r1, r2, drives them to zero (Escobal 1965; Vallado 2013, Algorithm 53).
    The result is then polished by Newton's method on its offsets from the three lines of
    sight, as in :func:`gauss_angles`. Unlike Gauss's method it does not need the observations to span a
    short arc, but it needs distance guesses.
    """
    g = gm_value(gm)
    los, taus, sites, epoch = _angles_inputs(ra, dec, t, site_positions)
    site_r = float(np.max(np.linalg.norm(sites, axis=-1)))
    x = np.array([
        2.0 * site_r if r1_guess is None else float(to_array(r1_guess, "length", "r1_guess",
                                                              allow_plain=True)),
        2.0 * site_r if r2_guess is None else float(to_array(r2_guess, "length", "r2_guess",
                                                              allow_plain=True)),
    ])  # fmt: skip

    def residual(xx):
        out = _double_r_orbit(xx, los, taus, sites, g)
        return None if out is None else out[0]

    for _ in range(max_iter):
        F = residual(x)
        if F is None:
            break
        J = np.empty((2, 2))
        ok = True
        for j in range(2):
            dx = 1e-6 * x[j]
            xp = x.copy()
            xp[j] += dx
            Fp = residual(xp)
            if Fp is None:
                ok = False
                break
            J[:, j] = (Fp - F) / dx
        if not ok:
            break
        try:
            step = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            break
        # keep the distances above the sites' radius
        lam = 1.0
        while np.any(x + lam * step <= site_r) and lam > 1e-6:
            lam *= 0.5
        x = x + lam * step
        if np.max(np.abs(lam * step) / x) < tol:
            out = _double_r_orbit(x, los, taus, sites, g)
            if out is None:
                break
            r2v, v2v = out[1], out[2]
            # polish by Newton's method from this orbit (it stays on it; Gauss's fixed-point
            # refinement can run off to another orbit through the same lines of sight)
            polished = _newton_angles(r2v, v2v, g, los, taus, sites)
            if polished is not None:
                resid_p = _los_residual(polished[0], polished[1], g, los, taus, sites)
                resid_d = _los_residual(r2v, v2v, g, los, taus, sites)
                if resid_p <= resid_d:
                    r2v, v2v = polished[0], polished[1]
            if light_time:
                r2v, v2v = _retarded(r2v, v2v, g, los, taus, sites)
            _warn_other_orbits(r2v, (ra, dec, t, site_positions, gm, light_time))
            return state_at(r2v, v2v, g, epoch)
    raise ConvergenceError(
        f"double-r iteration did not converge from r1, r2 = {x} km; give better distance guesses "
        "(r1_guess, r2_guess) or use gauss_angles."
    )


def _warn_other_orbits(r2v, args):
    """Warn when other bound orbits than double-r's (position ``r2v`` at the middle time) pass
    through the three lines of sight: those :func:`gauss_angles` finds with the same ``args``.
    double-r returned whichever its distance guesses led to, without a word, where Gauss's
    method warned on the same data (a HEO 7500 km off the truth; audit31)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            every = gauss_angles(*args[:5], return_all=True, light_time=args[5])
    except (ConvergenceError, DomainError):
        return
    g = gm_value(args[4])
    others = []
    for s in every:
        r, v = s.r.to_value("km"), s.v.to_value("km/s")
        bound = float(v @ v) / 2.0 - g / float(np.linalg.norm(r)) < 0.0
        if bound and np.linalg.norm(r - r2v) > 1e-4 * np.linalg.norm(r2v):
            others.append(float(np.linalg.norm(r)))
    if others:
        radii = ", ".join(f"{x:.1f}" for x in [float(np.linalg.norm(r2v)), *others])
        warnings.warn(
            f"{len(others) + 1} bound orbits pass through the three lines of sight (|r2| = "
            f"{radii} km): three directions cannot tell them apart. double-r returns the one its "
            "distance guesses led to (the first); see them all with "
            "vv.gauss_angles(..., return_all=True), and settle it with more observations "
            "(vv.fit_orbit).", RuntimeWarning, stacklevel=3)


def _double_r_orbit(x, los, taus, sites, gm):
    """Time-of-flight residuals of the double-r iteration and the (r2, v2) of the conic."""
    rs = []
    for k in range(2):
        c = 2.0 * float(los[k] @ sites[k])
        disc = c * c / 4.0 - (float(sites[k] @ sites[k]) - x[k] ** 2)
        if disc < 0:
            return None
        rho = -c / 2.0 + math.sqrt(disc)
        rs.append(sites[k] + rho * los[k])
    r1v, r2v = rs
    w = np.cross(r1v, r2v)
    nw = np.linalg.norm(w)
    if nw == 0:
        return None
    w /= nw
    # third position: the line of sight meets the orbit plane
    den = float(los[2] @ w)
    if abs(den) < 1e-12:
        return None
    rho3 = -float(sites[2] @ w) / den
    r3v = sites[2] + rho3 * los[2]
    r1, r2, r3 = (float(np.linalg.norm(v)) for v in (r1v, r2v, r3v))
    try:
        v2v = gibbs_velocity(r1v, r2v, r3v, gm, math.pi)
    except DomainError:
        return None
    # times of flight along the Gibbs orbit from r2 to r1 and r3
    F = np.empty(2)
    for idx, (rv, tau) in enumerate(((r1v, taus[0]), (r3v, taus[2]))):
        dt = _time_between(r2v, v2v, rv, gm)
        if dt is None:
            return None
        F[idx] = (dt - tau) / max(abs(tau), 1.0)
    return F, r2v, v2v


def _time_between(r0, v0, r, gm):
    """Signed two-body time from (r0, v0) to position r on the same ellipse, |dt| <= P/2."""
    h = np.cross(r0, v0)
    e_vec = np.cross(v0, h) / gm - r0 / np.linalg.norm(r0)
    e = float(np.linalg.norm(e_vec))
    energy = float(v0 @ v0) / 2.0 - gm / float(np.linalg.norm(r0))
    if e >= 1.0 or energy >= 0:
        return None
    a = -gm / (2.0 * energy)
    n = math.sqrt(gm / a**3)
    hn = h / np.linalg.norm(h)
    p_hat = e_vec / e if e > 1e-12 else r0 / np.linalg.norm(r0)
    q_hat = np.cross(hn, p_hat)

    def mean_anomaly(rv):
        nu = math.atan2(float(rv @ q_hat), float(rv @ p_hat))
        E = 2.0 * math.atan2(math.sqrt(1 - e) * math.sin(nu / 2), math.sqrt(1 + e) * math.cos(nu / 2))
        return E - e * math.sin(E)

    dM = mean_anomaly(r) - mean_anomaly(r0)
    dM = (dM + math.pi) % (2.0 * math.pi) - math.pi
    return dM / n
