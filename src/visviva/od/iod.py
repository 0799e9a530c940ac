"""Initial orbit determination: Gibbs, Herrick-Gibbs, Gauss (angles only) and double-r.

>>> import visviva as vv
>>> from astropy import units as u
>>> r1 = [-294.32, 4265.1, 5986.7] * u.km    # Curtis (2020), Example 5.1
>>> r2 = [-1365.5, 3637.6, 6346.8] * u.km
>>> r3 = [-2940.3, 2473.7, 6555.8] * u.km
>>> v2 = vv.gibbs(r1, r2, r3, 398600 * u.km**3 / u.s**2)
>>> print(v2.round(4))
[-6.2174 -4.0122  1.599 ] km / s
"""

from __future__ import annotations

import math

import numpy as np

from .._units import is_quantity, to_array, to_quantity, to_vector
from ..errors import ConvergenceError, DomainError, InvalidInputError, ShapeError

__all__ = ["gibbs", "herrick_gibbs", "gauss_angles", "double_r", "initial_orbit"]

#: largest angle between r1 and the plane of r2, r3 that Gibbs accepts by default, rad
COPLANAR_TOL_RAD = math.radians(1.0)
#: largest angle between successive positions that Herrick-Gibbs accepts by default, rad
#: (its series is ~2e-5 of the speed off at 10 deg, 3e-3 at 36 deg)
HERRICK_GIBBS_MAX_ARC_RAD = math.radians(10.0)


def _gm(gm):
    g = to_array(gm, "gm", "gm", allow_plain=True)
    if g.ndim != 0 or not g > 0:
        raise InvalidInputError(f"gm must be one number > 0 (e.g. vv.EARTH.gm); got {gm!r}.")
    return float(g)


def _positions(r1, r2, r3):
    arrs = [to_vector(r, "length", f"r{k}", allow_plain=True) for k, r in enumerate((r1, r2, r3), 1)]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrs))
    except ValueError as exc:
        raise ShapeError(f"r1, r2, r3 do not broadcast: {[a.shape for a in arrs]}.") from exc
    arrs = [np.broadcast_to(a, shape) for a in arrs]
    for k, a in enumerate(arrs, 1):
        if np.any(np.linalg.norm(a, axis=-1) == 0):
            raise InvalidInputError(f"r{k} has zero length; give positions from the attractor.")
    return arrs, any(is_quantity(r) for r in (r1, r2, r3))


def _out(v_km_s, quantity):
    return to_quantity(v_km_s, "speed") if quantity else v_km_s


def _unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def gibbs(r1, r2, r3, gm, *, coplanar_tol=COPLANAR_TOL_RAD):
    """Velocity at the middle of three position vectors on one two-body orbit (Gibbs).

    Parameters
    ----------
    r1, r2, r3 : Quantity (length) or array_like (km), shape (..., 3)
        Successive positions on one orbit, relative to the attractor, in time order.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter of the attractor.
    coplanar_tol : float
        Largest angle (rad) between r1 and the plane of r2 and r3 (default 1 deg).

    Returns
    -------
    v2 : Quantity (km/s) or ndarray (km/s), shape (..., 3)
        Velocity at ``r2`` (a Quantity when the positions are Quantities).

    Raises
    ------
    DomainError
        The vectors are not coplanar within ``coplanar_tol``, or two are parallel.

    Notes
    -----
    With N = r1 (r2 x r3) + r2 (r3 x r1) + r3 (r1 x r2), D = r1 x r2 + r2 x r3 + r3 x r1 and
    S = r1 (r2 - r3) + r2 (r3 - r1) + r3 (r1 - r2) (magnitudes in the scalar factors),

        v2 = sqrt(GM / (N D)) (D x r2 / r2 + S)

    (Vallado 2013, Algorithm 54 and Example 7-3; Curtis 2020, Algorithm 5.1, Example 5.1).
    Exact for noise-free positions; best when the vectors are more than a few degrees apart
    (use :func:`herrick_gibbs` for short arcs).
    """
    g = _gm(gm)
    (a, b, c), quantity = _positions(r1, r2, r3)
    ra, rb, rc = (np.linalg.norm(x, axis=-1, keepdims=True) for x in (a, b, c))
    c12, c23, c31 = np.cross(a, b), np.cross(b, c), np.cross(c, a)
    _check_coplanar(a, c23, ra, coplanar_tol)
    for (i, j), x, y, cr in (((1, 2), a, b, c12), ((2, 3), b, c, c23), ((1, 3), a, c, c31)):
        same = (np.linalg.norm(cr, axis=-1) <= 1e-12 * np.linalg.norm(x, axis=-1)
                * np.linalg.norm(y, axis=-1)) & (np.sum(x * y, axis=-1) > 0)  # fmt: skip
        if np.any(same):
            raise DomainError(
                f"r{i} and r{j} point the same way from the attractor: no conic passes twice "
                "along one direction (and equal positions leave the orbit undetermined). Use "
                "positions some degrees apart."
            )
    N = ra * c23 + rb * c31 + rc * c12
    D = c12 + c23 + c31
    S = a * (rb - rc) + b * (rc - ra) + c * (ra - rb)
    nN = np.linalg.norm(N, axis=-1, keepdims=True)
    nD = np.linalg.norm(D, axis=-1, keepdims=True)
    if np.any(nN * nD == 0):
        raise DomainError("Gibbs: N or D vanishes (collinear positions); use other points.")
    if np.any(np.sum(N * D, axis=-1) <= 0):
        raise DomainError(
            "there is no two-body orbit through these three positions: the only conic with its "
            "focus at the attractor through them is the branch of a hyperbola that bends away "
            "from the attractor (N . D < 0). Check the data (order, frame, units)."
        )
    v2 = np.sqrt(g / (nN * nD)) * (np.cross(D, b) / rb + S)
    _check_hyperbolic_order(a, b, c, v2, g)
    return _out(v2, quantity)


def _check_coplanar(r1, n23, r1_norm, tol):
    """Refuse r1 more than ``tol`` rad off the plane whose normal is ``n23`` = r2 x r3."""
    nn = np.linalg.norm(n23, axis=-1)
    if np.any(nn == 0):
        raise DomainError("r2 and r3 are parallel: their plane is undefined. Use other points.")
    tilt = np.arcsin(np.clip(np.abs(np.sum(r1 * n23, axis=-1)) / (r1_norm[..., 0] * nn), 0, 1))
    if np.any(tilt > tol):
        raise DomainError(
            f"the three positions are not coplanar: r1 lies {np.degrees(np.max(tilt)):.3f} deg "
            f"off the plane of r2 and r3 (tolerance {np.degrees(tol):.3f} deg). They "
            "cannot be on one two-body orbit; check the data or raise coplanar_tol."
        )


def _check_hyperbolic_order(r1, r2, r3, v2, gm):
    """On an open conic the true anomalies must increase r1 -> r2 -> r3 (no second pass)."""
    h = np.cross(r2, v2)
    e = np.cross(v2, h) / gm - r2 / np.linalg.norm(r2, axis=-1, keepdims=True)
    ecc = np.linalg.norm(e, axis=-1, keepdims=True)
    open_ = ecc[..., 0] >= 1.0
    if not np.any(open_):
        return
    p_hat = e / ecc
    q_hat = np.cross(h / np.linalg.norm(h, axis=-1, keepdims=True), p_hat)
    nu = [np.arctan2(np.sum(r * q_hat, axis=-1), np.sum(r * p_hat, axis=-1)) for r in (r1, r2, r3)]
    if np.any(open_ & ~((nu[0] < nu[1]) & (nu[1] < nu[2]))):
        raise DomainError(
            "there is no two-body orbit through these positions in this order: the conic "
            "through them is a hyperbola (escape orbit), which passes each point once, and not "
            "in the order r1, r2, r3. Check the order of the positions."
        )


def _offsets(t1, t2, t3):
    """Times as seconds: astropy Times (differences in TT) or time Quantities / plain seconds."""
    from astropy.time import Time

    ts = (t1, t2, t3)
    if all(isinstance(t, Time) for t in ts):
        if any(t.shape != () for t in ts):
            raise ShapeError(
                f"t1, t2, t3 must be scalars (one time per position); got Time shapes "
                f"{[t.shape for t in ts]}."
            )
        return [float((t.tt - t1.tt).sec) for t in ts]
    if any(isinstance(t, Time) for t in ts):
        raise InvalidInputError("give t1, t2, t3 all as astropy Times or all as time offsets.")
    out = [to_array(t, "time", f"t{k}", allow_plain=True) for k, t in enumerate(ts, 1)]
    if any(o.ndim for o in out):
        raise ShapeError("t1, t2, t3 must be scalars (one time per position).")
    return [float(o) for o in out]


def herrick_gibbs(r1, r2, r3, t1, t2, t3, gm, *, coplanar_tol=COPLANAR_TOL_RAD,
                  max_arc=HERRICK_GIBBS_MAX_ARC_RAD):  # fmt: skip
    """Velocity at the middle of three closely spaced positions (Herrick-Gibbs).

    Parameters
    ----------
    r1, r2, r3 : Quantity (length) or array_like (km), shape (3,) or (..., 3)
        Positions relative to the attractor at the three times.
    t1, t2, t3 : astropy Time, Quantity (time) or float (s)
        Times of the positions, strictly increasing.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter.
    coplanar_tol : float
        Largest angle (rad) between r1 and the plane of r2 and r3 (default 1 deg).
    max_arc : float
        Largest angle (rad) between r1 and r2 or between r2 and r3 (default 10 deg, where the
        series is about 2e-5 of the speed off; use :func:`gibbs` for longer arcs).

    Returns
    -------
    v2 : Quantity (km/s) or ndarray (km/s)
        Velocity at ``r2``.

    Raises
    ------
    InvalidInputError
        Times not strictly increasing.
    DomainError
        The positions are not coplanar within ``coplanar_tol``, or an arc is longer than
        ``max_arc``.

    Notes
    -----
    A Taylor series of r(t) about t2 to fifth order with r'' = -GM r / r^3 (Herrick 1971;
    Vallado 2013, Algorithm 55, eq. 7-31, Example 7-4):

        v2 = -dt32 (1/(dt21 dt31) + GM/(12 r1^3)) r1
             + (dt32 - dt21) (1/(dt21 dt32) + GM/(12 r2^3)) r2
             + dt21 (1/(dt32 dt31) + GM/(12 r3^3)) r3.

    Accurate for arcs of a few degrees (where Gibbs loses precision); error grows like dt^4.
    """
    g = _gm(gm)
    (a, b, c), quantity = _positions(r1, r2, r3)
    s1, s2, s3 = _offsets(t1, t2, t3)
    d21, d31, d32 = s2 - s1, s3 - s1, s3 - s2
    if not (d21 > 0 and d32 > 0):
        raise InvalidInputError(
            f"the times must increase strictly (t1 < t2 < t3); got offsets {s1}, {s2}, {s3} s."
        )
    ra, rb, rc = (np.linalg.norm(x, axis=-1, keepdims=True) for x in (a, b, c))
    _check_coplanar(a, np.cross(b, c), ra, coplanar_tol)
    arc = np.maximum(_angle_between(a, b), _angle_between(b, c))
    if np.any(arc > max_arc):
        raise DomainError(
            f"the positions are {np.degrees(np.max(arc)):.2f} deg apart, beyond the "
            f"{np.degrees(max_arc):.2f} deg where Herrick-Gibbs's series holds (its error grows "
            "like the fourth power of the arc): use vv.gibbs for arcs this long, or raise "
            "max_arc."
        )
    v2 = (
        -d32 * (1.0 / (d21 * d31) + g / (12.0 * ra**3)) * a
        + (d32 - d21) * (1.0 / (d21 * d32) + g / (12.0 * rb**3)) * b
        + d21 * (1.0 / (d32 * d31) + g / (12.0 * rc**3)) * c
    )
    return _out(v2, quantity)


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


def _gauss_solution(los, taus, sites, gm, r2_guess, max_iter, tol):
    """Gauss's method from a guess of |r2|, refined with exact f and g until the ranges settle."""
    L1, L2, L3 = los
    R1, R2, R3 = sites
    tau1, tau3 = taus[0], taus[2]
    D0, D = _gauss_determinants(los, sites)
    r2m = r2_guess
    f1 = 1.0 - gm * tau1**2 / (2 * r2m**3)
    g1 = tau1 - gm * tau1**3 / (6 * r2m**3)
    f3 = 1.0 - gm * tau3**2 / (2 * r2m**3)
    g3 = tau3 - gm * tau3**3 / (6 * r2m**3)
    rho_old = None
    for _ in range(max_iter):
        den = f1 * g3 - f3 * g1
        c1, c3 = g3 / den, -g1 / den
        rho1 = (-D[0, 0] + D[1, 0] / c1 - D[2, 0] * c3 / c1) / D0
        rho2 = (-c1 * D[0, 1] + D[1, 1] - c3 * D[2, 1]) / D0
        rho3 = (-D[0, 2] * c1 / c3 + D[1, 2] / c3 - D[2, 2]) / D0
        r1v, r2v, r3v = R1 + rho1 * L1, R2 + rho2 * L2, R3 + rho3 * L3
        v2v = (-f3 * r1v + f1 * r3v) / den
        rho = np.array([rho1, rho2, rho3])
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


def _los_residual(r2, v2, gm, los, taus, sites):
    """Largest angle (rad) between the observed lines of sight and those of the orbit."""
    worst = 0.0
    for k in range(3):
        res = _propagate(r2, v2, gm, taus[k]) if k != 1 else (r2, v2)
        if res is None:
            return math.inf
        d = res[0] - sites[k]
        cosang = float(np.clip(d @ los[k] / np.linalg.norm(d), -1.0, 1.0))
        worst = max(worst, math.acos(cosang))
    return worst


def _wrap_state(r2, v2, gm, epoch):
    from ..states import StateVectors

    return StateVectors._from_canonical(np.asarray(r2), np.asarray(v2), np.float64(gm), epoch)


def gauss_angles(ra, dec, t, site_positions, gm, *, max_iter=100, tol=1e-12):
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

    Returns
    -------
    StateVectors
        Position (km) and velocity (km/s) at the middle time (``epoch`` = ``t[1]`` when ``t``
        is a Time).

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
    previous values until the ranges change by less than ``tol``. When several roots lead to
    orbits, the one whose lines of sight match the observations best is returned. The result
    is exact for noise-free two-body data.
    """
    g = _gm(gm)
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
    best = None
    for r2_guess in real:
        sol = _gauss_solution(los, taus, sites, g, r2_guess, max_iter, tol)
        if sol is None or sol[2][1] <= 0:
            continue
        resid = _los_residual(sol[0], sol[1], g, los, taus, sites)
        if best is None or resid < best[0]:
            best = (resid, sol)
    if best is None:
        raise ConvergenceError(
            f"Gauss's method found no orbit: the positive roots {real} of the eighth-degree "
            "polynomial give no converged ranges. Check the observations (angles in the GCRS, "
            "site positions in km), space them further apart, or use vv.od.double_r with a "
            "range guess."
        )
    r2v, v2v, _ = best[1]
    return _wrap_state(r2v, v2v, g, epoch)


def double_r(ra, dec, t, site_positions, gm, r1_guess=None, r2_guess=None, *, max_iter=50,
             tol=1e-9):  # fmt: skip
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
    The result is then polished with the exact Lagrange coefficients, like
    :func:`gauss_angles`. Unlike Gauss's method it does not need the observations to span a
    short arc, but it needs distance guesses.
    """
    g = _gm(gm)
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
            # polish with the exact Lagrange coefficients (Gauss refinement) from this orbit
            polished = _gauss_solution(los, taus, sites, g, float(np.linalg.norm(r2v)),
                                       100, 1e-12)  # fmt: skip
            if polished is not None:
                resid_p = _los_residual(polished[0], polished[1], g, los, taus, sites)
                resid_d = _los_residual(r2v, v2v, g, los, taus, sites)
                if resid_p <= resid_d:
                    r2v, v2v = polished[0], polished[1]
            return _wrap_state(r2v, v2v, g, epoch)
    raise ConvergenceError(
        f"double-r iteration did not converge from r1, r2 = {x} km; give better distance guesses "
        "(r1_guess, r2_guess) or use gauss_angles."
    )


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
        v2v = gibbs(r1v, r2v, r3v, gm, coplanar_tol=math.pi)
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


def _first_group(idx, secs, gap_s=300.0):
    """The leading run of ``idx`` whose successive times are at most ``gap_s`` apart."""
    end = 1
    while end < len(idx) and secs[idx[end]] - secs[idx[end - 1]] <= gap_s:
        end += 1
    return idx[:end]


def initial_orbit(observations, gm):
    """A first state from a table of observations, for :func:`~visviva.fit_orbit`.

    Parameters
    ----------
    observations : Observations
        Positions, or az/el or RA/Dec rows with a range row of the same station at the same
        time (together a position), or at least three RA/Dec rows of one station.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter.

    Returns
    -------
    StateVectors
        The GCRS state at the middle of the three observations used, with that epoch.

    Raises
    ------
    InvalidInputError
        The table has neither three positions (or angle + range pairs) nor three RA/Dec rows
        within one pass.

    Notes
    -----
    Three position fixes from the first pass (fixes at most 5 min apart): first, middle and
    last. Gibbs when they span more than 5 deg of arc, Herrick-Gibbs otherwise; with only
    angles, Gauss's method on the first, middle and last RA/Dec of the first pass.
    """
    g = _gm(gm)
    kinds = observations.kinds
    vals = observations.values
    secs = (observations.times.tt - observations.times[0].tt).sec
    site_r, _, enu = observations.sites()
    fixes = {}
    for i in np.flatnonzero(kinds == "position"):
        fixes.setdefault(i, vals[i, :3])
    ranges = {(round(secs[i], 6), id(observations.stations[i])): vals[i, 0]
              for i in np.flatnonzero(kinds == "range")}  # fmt: skip
    for i in np.flatnonzero((kinds == "azel") | (kinds == "radec")):
        rho = ranges.get((round(secs[i], 6), id(observations.stations[i])))
        if rho is None:
            continue
        a, b = vals[i, 0], vals[i, 1]
        if kinds[i] == "azel":
            los = enu[i].T @ np.array([np.cos(b) * np.sin(a), np.cos(b) * np.cos(a), np.sin(b)])
        else:
            los = np.array([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)])
        fixes.setdefault(i, site_r[i] + rho * los)
    order = np.array(sorted(fixes, key=lambda i: secs[i]), dtype=np.int64)
    if order.size >= 3:
        group = _first_group(order, secs)
        if group.size < 3:
            group = order
        i1, i2, i3 = group[0], group[len(group) // 2], group[-1]
        if secs[i1] < secs[i2] < secs[i3]:
            r1, r2, r3 = fixes[i1], fixes[i2], fixes[i3]
            arc = max(_angle(r1, r2), _angle(r2, r3))
            if arc > math.radians(5.0):
                v2 = gibbs(r1, r2, r3, g, coplanar_tol=math.radians(5.0))
            else:
                v2 = herrick_gibbs(r1, r2, r3, secs[i1], secs[i2], secs[i3], g)
            return _wrap_state(r2, np.asarray(v2), g, observations.times[i2])
    radec = np.flatnonzero(kinds == "radec")
    if radec.size >= 3:
        group = _first_group(radec, secs)
        if group.size >= 3:
            pick = [group[0], group[len(group) // 2], group[-1]]
            return gauss_angles(vals[pick, 0], vals[pick, 1], observations.times[pick],
                                site_r[pick], g)  # fmt: skip
    raise InvalidInputError(
        "cannot find a first orbit in these observations: give three positions, az/el or RA/Dec "
        "rows each with a range from the same station at the same time, or three RA/Dec rows "
        "within one pass; or pass initial=vv.StateVectors(...) yourself."
    )


def _angle_between(a, b):
    """Angles (rad) between the vectors of two (..., 3) arrays."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def _angle(a, b):
    c = float(a @ b) / (float(np.linalg.norm(a)) * float(np.linalg.norm(b)))
    return math.acos(max(-1.0, min(1.0, c)))
