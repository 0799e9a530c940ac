"""Accuracy checks of the collision-probability methods against a method without their assumption.

Each check recomputes a conjunction with a method that does not make the assumption in question
and warns, with both values, where the two are more than 10 % apart:

* :func:`check_chan`: Chan's equivalent-area series against Foster's exact 2-D integral;
* :func:`check_3d`: the 3-D flux integral against Hall's 3D-Nc over the same time span;
* :func:`check_2d`: the 2-D (encounter-plane) methods against Hall's 3D-Nc over this
  conjunction, where NASA CARA's usage-violation indicators say that the short-encounter
  assumption may fail (an encounter long beside the orbital period, or far from TCA);
* :func:`check_tca`: the 2-D methods' miss ``|r1 - r2|`` (states taken at TCA) against the miss
  at the straight-line TCA, where the states given are not at TCA.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import (
    ChanAccuracyWarning,
    Pc2dAccuracyWarning,
    Pc3dAccuracyWarning,
    VisvivaError,
)
from .covariance import CLIP_FACTOR

__all__ = ["check_chan", "check_3d", "check_2d", "check_tca", "linear_encounter_bounds",
           "velocity_spread", "CHAN_LOG_TOL", "NEGLIGIBLE_LN_PC"]

#: ``|ln Pc_chan - ln Pc_foster|`` above which ``method="chan"`` warns (a factor 1.1)
CHAN_LOG_TOL = math.log(1.1)
#: Below this Pc (both values compared) the accuracy checks stay silent: 1e-30 is twenty
#: orders under any manoeuvre threshold (1e-4 .. 1e-7), and there one method's log-space
#: integral may underflow to 0 where the other still gives 1e-52 (a spurious warning on every
#: fast, well-separated encounter).
NEGLIGIBLE_LN_PC = math.log(1e-30)


def as_6x6(c, half):
    """A covariance as the regular 6x6 that 3D-Nc needs.

    Parameters
    ----------
    c : ndarray, shape (6, 6) or (3, 3)
        Covariance, m^2 (and m^2/s, m^2/s^2).
    half : float
        Half the encounter's time span, s.

    Returns
    -------
    ndarray, shape (6, 6)
        ``c`` itself when 6x6; for a position-only covariance (exact velocities, as the 2-D
        methods and the flux integral take them) a velocity sigma that moves the position by
        1e-3 of its smallest sigma over ``half``: that changes 3D-Nc's Pc by ~1e-9 on Alfano's
        (2009) cases.
    """
    if c.shape == (6, 6):
        return c
    out = np.zeros((6, 6))
    out[:3, :3] = c
    w0 = float(np.linalg.eigvalsh(c)[0])
    out[3:, 3:] = np.eye(3) * max(w0, 0.0) * (1e-3 / half) ** 2
    return out


def check_chan(lp_chan, xm, zm, sx, sz, hbr):
    """Warn when Chan's value is more than 10 % from Foster's exact integral of the same plane.

    Chan's equivalent-area circle is exact only for a circular covariance; its error grows with
    the aspect ratio ``sx / sz`` and with ``hbr / sz`` (on Alfano's (2009) case 4 it gives 8e-17
    where the integral is 4.9e-2, on case 9 0.98 for 0.29). The Foster kernel costs well under
    a millisecond, so every Chan value is checked against it.
    """
    from .pc2d import log_pc_2d

    try:
        lp_foster = log_pc_2d(xm, zm, sx, sz, hbr, "foster")
    except ArithmeticError:  # ConvergenceError: no reference to compare with
        return
    if (lp_chan == lp_foster or abs(lp_chan - lp_foster) <= CHAN_LOG_TOL
            or max(lp_chan, lp_foster) < NEGLIGIBLE_LN_PC):
        return
    warnings.warn(
        f"Chan's approximation gives Pc = {math.exp(lp_chan):.4g} (ln Pc = {lp_chan:.6g}) where "
        f"Foster's exact 2-D integral of the same encounter plane gives {math.exp(lp_foster):.4g} "
        f"(ln Pc = {lp_foster:.6g}): the equivalent-area circle does not hold for this covariance "
        f"(sigmas {sx:.4g} m and {sz:.4g} m, aspect ratio {sx / sz:.3g}, HBR {hbr:.4g} m). "
        "Use method='foster' (or 'pc3d_hall').",
        ChanAccuracyWarning, stacklevel=3)


#: ``|ln Pc_3d - ln Pc_3d_hall|`` above which ``method="3d"`` warns (a factor 1.1)
_3D_LOG_TOL = math.log(1.1)


def check_3d(lp_3d, r1, v1, c1, r2, v2, c2, hbr, gm_km, half):
    """Warn when the flux integral is more than 10 % from Hall's 3D-Nc over the same time span.

    The flux integral counts the crossings of the plane normal to the relative velocity with
    Cartesian, linearly propagated covariances; on slow, curved encounters (relative speeds of
    metres per second over a quarter orbit) neither holds and it is silently off by up to 57x
    (Alfano's (2009) case 11: 0.14 where CARA's ``Pc3D_Hall`` gives 2.4e-3). Hall's 3D-Nc
    (``"pc3d_hall"``) has no such assumption and costs less than the flux integral (on
    Alfano's cases 1-11, 0.07-0.32 s, median 0.15 s, beside 0.31-1.23 s, median 0.47 s), so every "3d" value is checked
    against it over ``[-half, half]``, the flux integral's own window. Where 3D-Nc cannot run (an
    unbound orbit, a retrograde equatorial one) there is nothing to compare with.
    """
    if not 0 < half < math.inf or not 0 < hbr < math.inf:
        return
    from .nc3d import log_pc3d_hall

    try:
        with warnings.catch_warnings():  # the flux integral has given its own repair warning
            warnings.simplefilter("ignore")
            lp_hall = log_pc3d_hall(r1, v1, as_6x6(c1, half), r2, v2, as_6x6(c2, half), hbr,
                                    gm_km * 1e9, (-half, half))
    except (VisvivaError, ArithmeticError, np.linalg.LinAlgError):
        return
    if (lp_3d == lp_hall or abs(lp_3d - lp_hall) <= _3D_LOG_TOL
            or max(lp_3d, lp_hall) < NEGLIGIBLE_LN_PC):
        return
    speed = float(np.linalg.norm(np.asarray(v1) - np.asarray(v2)))
    warnings.warn(
        f"The 3-D flux integral (method='3d') gives Pc = {math.exp(lp_3d):.4g} "
        f"(ln Pc = {lp_3d:.6g}) where Hall's 3D-Nc (method='pc3d_hall') over the same time span "
        f"gives {math.exp(lp_hall):.4g} (ln Pc = {lp_hall:.6g}): the flux integral's "
        "assumptions (crossings of the plane normal to the relative velocity, Cartesian "
        "covariances propagated linearly) do not hold for this encounter (relative speed "
        f"{speed:.4g} m/s at TCA, integrated over +-{half:.4g} s). Use method='pc3d_hall' "
        f"(window=({-half:.6g}, {half:.6g}) for this same span).",
        Pc3dAccuracyWarning, stacklevel=3)


#: ``|ln Pc_2d - ln Pc_3d_hall|`` above which the 2-D methods warn (a factor 1.1)
_2D_LOG_TOL = math.log(1.1)
#: NASA CARA's cutoffs of its 2-D usage-violation indicators (``UsageViolationPc2D``:
#: "Extended" above 0.01-0.05 and "Offset" above 0.01 are unacceptable): above either the
#: 2-D value is checked against 3D-Nc
EXTENDED_LIMIT = 0.01
OFFSET_LIMIT = 0.01
#: Coppola's (2012) precision factor of the encounter's time bounds, CARA's ``ConjDurationGamma``
_GAMMA = 1e-16


def linear_encounter_bounds(r1, v1, c1, r2, v2, c2, hbr, gm_m):
    """Coppola's (2012) time bounds of a rectilinear encounter and CARA's usage indicators.

    Parameters
    ----------
    r1, v1, r2, v2 : ndarray, shape (3,)
        States at TCA, m and m/s.
    c1, c2 : ndarray, shape (6, 6) or (3, 3)
        Covariances, m^2 ...
    hbr : float
        Combined hard-body radius, m (sets the eigenvalue clip ``(1e-4 hbr)^2``).
    gm_m : float
        Gravitational parameter, m^3/s^2 (for the orbital periods).

    Returns
    -------
    tuple of float or None
        ``(extended, offset, t_a, t_b)``: ``extended = 2 dtau / P`` and ``offset =
        max(|t_a|, |t_b|) / P``, with ``P`` the shorter orbital period, and the bounds ``t_a,
        t_b = T -+ dtau`` (s from TCA), ``T`` the time of the smallest Mahalanobis distance
        along the straight relative motion and ``dtau = sqrt(2) erfcinv(1e-16) / sqrt(u^T
        A^-1 u)``; None where the relative velocity is zero or no object is bound (or given
        at the origin: relative states, whose orbit is unknown).

    Notes
    -----
    V. Coppola, "Including velocity uncertainty in the probability of collision between space
    objects", AAS 12-247 (2012); the indicators are those of NASA CARA's ``UsageViolationPc2D``
    (D. Hall et al., 2023), whose cutoffs are :data:`EXTENDED_LIMIT` and :data:`OFFSET_LIMIT`.
    The 2-D methods assume the encounter is short beside the orbit and centred on TCA.
    """
    from scipy.special import erfcinv

    a = c1[:3, :3] + c2[:3, :3]
    w, vec = np.linalg.eigh(0.5 * (a + a.T))
    w = np.maximum(w, max((CLIP_FACTOR * hbr) ** 2, 1e-300))
    ainv = (vec / w) @ vec.T
    r, u = r2 - r1, v2 - v1
    uau = float(u @ ainv @ u)
    if not uau > 0:
        return None
    t_m = -float(r @ ainv @ u) / uau
    dtau = math.sqrt(2.0) * float(erfcinv(_GAMMA)) / math.sqrt(uau)
    periods = []
    if not (np.any(r1) and np.any(r2)):
        return None  # relative states (an object at the origin): no orbits to speak of
    for rr, vv in ((r1, v1), (r2, v2)):
        inv_a = 2.0 / float(np.linalg.norm(rr)) - float(vv @ vv) / gm_m
        if inv_a > 0:
            periods.append(2.0 * math.pi * math.sqrt(inv_a ** -3 / gm_m))
    if not periods:
        return None
    p = min(periods)
    t_a, t_b = t_m - dtau, t_m + dtau
    return min(1.0, 2.0 * dtau / p), min(1.0, max(abs(t_a), abs(t_b)) / p), t_a, t_b


#: drop of the smallest squared Mahalanobis distance (see :func:`velocity_spread`) above which
#: the 2-D value is checked against 3D-Nc: Pc could move by a factor e^0.5
SPREAD_LIMIT = 1.0


def velocity_spread(r1, v1, c1, r2, v2, c2, hbr, t_a, t_b, points=25):
    """How much the velocity uncertainty lowers the smallest Mahalanobis distance of the
    straight-line encounter over Coppola's bounds ``[t_a, t_b]`` (s from TCA).

    The 2-D methods hold the relative position covariance ``A`` fixed at its TCA value; along
    the straight line it is ``A(t) = A + t (C_rv + C_vr) + t^2 C_vv``. Returns ``min_t MD2(t;
    A) - min_t [MD2(t; A(t)) + ln(det A(t) / det A)]`` (the second term is CARA's modified
    Mahalanobis distance, the "Q function" of ``UsageViolationPc2D``), 0 for position-only
    covariances. A large drop (CARA's Omitron case: 82 to 9.8, where the 2-D Pc 2.3e-20 is 15
    orders below 3D-Nc's 1.9e-5) says the encounter-plane value cannot be trusted however
    short the encounter is.
    """
    if c1.shape != (6, 6) or c2.shape != (6, 6):
        return 0.0
    c = c1 + c2
    a = c[:3, :3]
    b = c[:3, 3:] + c[3:, :3]
    d = c[3:, 3:]
    if not (b.any() or d.any()):
        return 0.0
    floor = max((CLIP_FACTOR * hbr) ** 2, 1e-300)
    t = np.linspace(t_a, t_b, points)
    x = (r2 - r1)[None, :] + t[:, None] * (v2 - v1)[None, :]
    # A, then A(t) at every point; eigenvalues clipped at (1e-4 HBR)^2 as CARA does
    a_t = np.concatenate([a[None], a[None] + t[:, None, None] * b[None]
                          + (t * t)[:, None, None] * d[None]])
    w, vec = np.linalg.eigh(a_t)
    w = np.maximum(w, floor)
    y0 = x @ vec[0]  # x in A's eigenvectors
    y = np.einsum("tji,tj->ti", vec[1:], x)
    fixed = np.sum(y0 * y0 / w[0], axis=1)
    spread = np.sum(y * y / w[1:], axis=1) + np.sum(np.log(w[1:] / w[0]), axis=1)
    return float(np.min(fixed) - np.min(spread))


def check_2d(lp_2d, method, r1, v1, c1, r2, v2, c2, hbr, gm_m):
    """Warn when a 2-D (encounter-plane) Pc is more than 10 % from Hall's 3D-Nc of this
    conjunction, checked where CARA's usage-violation indicators flag the encounter or the
    velocity uncertainty spreads it (:func:`velocity_spread` above :data:`SPREAD_LIMIT`).

    The 2-D methods assume a short, rectilinear encounter centred on TCA. Slow encounters (GEO
    pairs drifting past each other at centimetres per second, Alfano's (2009) cases 1, 2, 4,
    10) last hours, and there the 2-D value was silently 0.40x to 0.80x CARA's two-body Monte
    Carlo; on CARA's Omitron case (67 m/s) the velocity covariance brings the two objects'
    densities together within seconds of TCA and the 2-D 2.3e-20 is 15 orders below 3D-Nc's
    1.9e-5. Where :func:`linear_encounter_bounds` gives ``extended`` or ``offset`` above CARA's
    cutoffs, or the spread is above its limit, 3D-Nc (``"pc3d_hall"``, default window; 0.1-0.8 s) is computed and a
    :class:`~visviva.errors.Pc2dAccuracyWarning` gives both values when they differ by more
    than 10 %. Fast encounters (LEO, km/s: ``extended`` ~ 1e-4) cost nothing more.
    """
    if not 0 < hbr < math.inf:
        return
    bounds = linear_encounter_bounds(r1, v1, c1, r2, v2, c2, hbr, gm_m)
    if bounds is None:
        return
    extended, offset, t_a, t_b = bounds
    drop = velocity_spread(r1, v1, c1, r2, v2, c2, hbr, t_a, t_b)
    if extended <= EXTENDED_LIMIT and offset <= OFFSET_LIMIT and drop <= SPREAD_LIMIT:
        return
    from .nc3d import log_pc3d_hall

    half = max(abs(t_a), abs(t_b))

    try:
        with warnings.catch_warnings():  # repairs and windows: the 2-D value's own business
            warnings.simplefilter("ignore")
            lp_hall = log_pc3d_hall(r1, v1, as_6x6(c1, half), r2, v2, as_6x6(c2, half), hbr,
                                    gm_m, None)
    except (VisvivaError, ArithmeticError, np.linalg.LinAlgError):
        return
    if (lp_2d == lp_hall or abs(lp_2d - lp_hall) <= _2D_LOG_TOL
            or max(lp_2d, lp_hall) < NEGLIGIBLE_LN_PC):
        return
    speed = float(np.linalg.norm(np.asarray(v1) - np.asarray(v2)))
    what = (f"The 2-D encounter-plane Pc (method={method!r}) is" if method != "monte_carlo"
            else "The encounter-plane Pc that method='monte_carlo' samples is")
    warnings.warn(
        f"{what} {math.exp(lp_2d):.4g} "
        f"(ln Pc = {lp_2d:.6g}) where Hall's 3D-Nc (method='pc3d_hall') of this conjunction "
        f"gives {math.exp(lp_hall):.4g} (ln Pc = {lp_hall:.6g}): the encounter-plane "
        "assumptions (a straight-line encounter, short beside the orbit, with the position "
        "covariance of TCA throughout) do not hold (relative speed "
        f"{speed:.4g} m/s; the straight-line encounter lasts "
        f"{t_b - t_a:.4g} s, {t_a:.4g} to {t_b:.4g} s about TCA: NASA CARA's usage-violation "
        f"indicators Extended = {extended:.3g}, Offset = {offset:.3g}, cutoffs 0.01; the "
        "velocity uncertainty lowers the smallest squared Mahalanobis distance by "
        f"{drop:.3g}, cutoff {SPREAD_LIMIT:g}). Use method='pc3d_hall'.",
        Pc2dAccuracyWarning, stacklevel=3)


#: ``|ln Pc(|r|) - ln Pc(|r_perp|)|`` above which the 2-D methods warn that the states are not
#: at TCA (a factor 1.1)
_TCA_LOG_TOL = math.log(1.1)


def check_tca(method, r1, v1, r2, v2, plane, hbr, stacklevel=3):
    """Warn when the states are not at TCA and that moves the 2-D Pc by more than 10 %.

    Parameters
    ----------
    method : {"foster", "chan", "monte_carlo"}
        The 2-D method (``"monte_carlo"`` samples the plane that ``"foster"`` integrates).
    r1, v1, r2, v2 : ndarray, shape (3,)
        The states given, m and m/s.
    plane : EncounterPlane
        Their (repaired) encounter plane.
    hbr : float
        Combined hard-body radius, m.
    stacklevel : int
        Of the warning (3: the caller of the function that calls this one).

    Notes
    -----
    The 2-D methods take the miss distance as ``|r1 - r2|`` (NASA CARA's ``PcCircle``
    convention), which is the miss only at TCA, where ``r1 - r2`` is normal to the relative
    velocity ``u``. States ``dt`` from TCA add ``u dt`` along the velocity: 0.1 s at 10.6 km/s
    put 1.06 km into a 100 m miss, and Pc came out 7.7e-16 for 1.09e-3 without a word
    (audit48). The miss at the straight-line TCA is the component of ``r1 - r2`` normal to
    ``u`` (Foster's projection on the encounter plane); where the two misses give Pc more than
    10 % apart, a :class:`~visviva.errors.Pc2dAccuracyWarning` gives both, the offset of the
    straight-line TCA and what to do. States at TCA (a CDM's, a screening's refined TCA) have no
    component along ``u`` beyond rounding: where the miss changes too little to move ``ln Pc``
    by 0.01 (``|d ln Pc / d miss| <= (miss + hbr) / sigma_min^2``) nothing is recomputed.
    """
    from .pc2d import log_pc_2d

    r = np.asarray(r1, dtype=np.float64) - np.asarray(r2, dtype=np.float64)
    u = np.asarray(v1, dtype=np.float64) - np.asarray(v2, dtype=np.float64)
    rn = float(np.linalg.norm(r))
    along = float(r @ plane.basis[1])
    if not (0 < hbr < math.inf) or rn == 0 or along == 0:
        return
    perp = float(np.linalg.norm(r - along * plane.basis[1]))
    # |d ln Pc / d miss| <= (miss + hbr) / sigma_min^2: rounding of states at TCA moves nothing
    if (rn - perp) * (rn + hbr) < 1e-2 * float(plane.sigma[1]) ** 2:
        return
    kind = "chan" if method == "chan" else "foster"
    xm, zm = plane.principal_miss
    sx, sz = plane.sigma
    try:
        lp_given = log_pc_2d(xm, zm, sx, sz, hbr, kind)
        lp_tca = log_pc_2d(xm * perp / rn, zm * perp / rn, sx, sz, hbr, kind)
    except ArithmeticError:  # ConvergenceError: nothing to compare with
        return
    if (lp_given == lp_tca or abs(lp_given - lp_tca) <= _TCA_LOG_TOL
            or max(lp_given, lp_tca) < NEGLIGIBLE_LN_PC):
        return
    speed = float(np.linalg.norm(u))
    dt = -float(r @ u) / (speed * speed)
    what = (f"method={method!r} gives" if method != "monte_carlo"
            else "the encounter plane that method='monte_carlo' samples has")
    warnings.warn(
        f"The states are not at the time of closest approach: r1 - r2 has {along:.4g} m along "
        f"the relative velocity ({speed:.4g} m/s), so the straight-line TCA is {dt:.4g} s "
        f"from the states' time, with a miss of {perp:.4g} m there, not |r1 - r2| = {rn:.4g} m. "
        f"The 2-D methods take |r1 - r2| as the miss (NASA CARA's PcCircle convention): "
        f"{what} Pc = {math.exp(lp_given):.4g} (ln Pc = {lp_given:.6g}); with the miss at the "
        f"straight-line TCA it is {math.exp(lp_tca):.4g} (ln Pc = {lp_tca:.6g}). Give both "
        "states and covariances at TCA (propagate them there), or use method='pc3d_hall', "
        "which follows the encounter in time.",
        Pc2dAccuracyWarning, stacklevel=stacklevel)
