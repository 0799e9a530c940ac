"""Lambert's problem: velocities that carry a body from r1 to r2 in a given time.

>>> import visviva as vv
>>> from astropy import units as u
>>> # Curtis (2014), Example 5.2: r1, r2 in km, 1 hour, Earth mu = 398600 km^3/s^2
>>> v1, v2 = vv.lambert([5000.0, 10000.0, 2100.0] * u.km, [-14600.0, 2500.0, 7000.0] * u.km,
...                    3600 * u.s, 398600 * u.km**3 / u.s**2)
>>> print(", ".join(f"{x:.4f}" for x in v1.to_value(u.km / u.s)))
-5.9925, 1.9254, 3.2456
"""

from __future__ import annotations

import numpy as np

from .._units import require_flag, to_array, to_quantity, to_vector
from ..constants import C_KM_S
from ..core import status as st
from ..core import tier
from ..core.lambert import izzo_many, universal_many
from ..errors import STATUS_TABLE, DomainError, InvalidInputError, ShapeError, VisvivaError

__all__ = ["lambert", "LAMBERT_METHODS"]

#: Non-dimensional time of flight (tof / sqrt(L^3/GM), L = max|r|) below which a solver that
#: fails to converge is reporting a too-short tof (a straight-line, gravity-free transfer).
TOF_TOO_SHORT = 1e-2
#: Non-dimensional time of flight above which a failure to converge means a too-long tof.
TOF_TOO_LONG = 1e3

#: The solvers and what they handle (every conic; M >= 0 revolutions; both branches).
LAMBERT_METHODS = {
    "izzo": {"kernel": izzo_many, "conics": ("ellipse", "parabola", "hyperbola"), "multirev": True},
    "universal": {
        "kernel": universal_many,
        "conics": ("ellipse", "parabola", "hyperbola"),
        "multirev": True,
    },
}


def lambert(
    r1, r2, tof, gm, revolutions: int = 0, prograde: bool = True, *, branch="left", method="izzo",
    on_failure: str = "raise",
):
    """Solve Lambert's problem: the velocities at r1 and r2 of the conic from r1 to r2 in ``tof``.

    Parameters
    ----------
    r1, r2 : Quantity (..., 3), length
        Initial and final positions relative to the attractor.
    tof : Quantity (...), time
        Time of flight, > 0. Broadcasts against r1 and r2.
    gm : Quantity or Body
        Gravitational parameter of the attractor.
    revolutions : int
        Number of complete revolutions M >= 0 before arriving.
    prograde : bool
        True (default): the transfer orbit turns counter-clockwise about +z (angular momentum
        h_z > 0), which picks the short way when r1 x r2 points to +z and the long way
        otherwise; False gives the other way. When (r1 x r2)_z = 0 exactly (a transfer plane
        containing the z axis) True gives the short way.
    branch : {"left", "right"}
        For ``revolutions >= 1`` there are two solutions (or none if ``tof`` is below the
        minimum time for M revolutions): Izzo's left branch (x < x_Tmin) and right branch
        (x > x_Tmin). The left branch has the smaller semi-major axis (shorter period), the
        right branch the larger one (checked over random geometries in the tests). Ignored for
        M = 0.
    method : {"izzo", "universal"}
        Izzo (2015), Householder iterations (default); or the universal-variable method of
        Bate, Mueller & White / Vallado Algorithm 58 with bisection (an independent check).
        Both stay accurate up to the collinear limit: near a 180 deg transfer (g -> 0) the
        kernels form 1 + cos(dnu) and g without cancellation, so both arrive at r2 to
        ~1e-10 km in LEO from 1e-8 to 1e-4 rad off 180 deg (tests/test_lambert.py) and to
        ~1e-6 km (3e-15 relative) on a 2.2e8 km heliocentric arc 1e-9 deg off 180 deg.
        On short, fast hyperbolic transfers the universal method keeps full precision (t(psi)
        summed from terms of one sign, a final bisection in y), to a few ulp of v1.
        On long, nearly parabolic arcs (psi -> 4 pi^2 (M + 1)^2, or 4 pi^2 M^2 on the right
        branch of M >= 1) the universal method finishes by bisection in |sqrt(psi) - 2 pi k|
        itself, which psi could not carry: from 7000 km to 8000 km (90 deg, Earth) a 1e9 s
        arc arrives 0.5 m off with it (0.42 km before), 28 m with Izzo (one ulp of v1 moves
        the arrival 28 m); 1e8 s with 3 revolutions, right branch, 0.1 m (115 m before)
        against 0.08 m; v1 within a few ulp of the 60-digit solution.
    on_failure : {"raise", "mask"}
        What a batch does with transfers that have no solution (tof <= 0, r1 and r2 collinear,
        no M-revolution solution in that time, a tof too short or too long to resolve, a
        transfer faster than light).
        ``"raise"`` (default): one error naming every failing index and why each failed.
        ``"mask"``: ``v1`` and ``v2`` come back as masked Quantities
        (``astropy.utils.masked.Masked``; ``v1.mask`` is True on all three components of each
        failed transfer, whose values underneath are NaN) and the others are solved as usual.

    Returns
    -------
    v1, v2 : Quantity (..., 3), km/s
        Velocities at departure and arrival (masked Quantities with ``on_failure="mask"``).

    Raises
    ------
    DomainError
        r1 and r2 collinear (transfer plane undefined), tof <= 0, no M-revolution solution
        in that time, a tof too short or too long to resolve, or a transfer faster than light
        (a speed at r1 or r2 above c = 299792.458 km/s, where Newtonian mechanics is meaningless:
        a tof of 0.01 s between LEO points 90 deg apart asks for 9.9e5 km/s) (with
        ``on_failure="raise"``; ``"mask"`` masks them). The message lists every failing index, by
        cause, and the exception's ``failures`` attribute maps each failing index (a tuple
        into the broadcast shape) to its reason, ``causes`` to its cause ("tof <= 0",
        "r1 and r2 collinear", "no M-revolution solution in that time", "tof too short to
        resolve", "faster than light", "tof too long to resolve", "solver status").

    Notes
    -----
    Izzo, D. (2015), Revisiting Lambert's problem, Celest. Mech. Dyn. Astron. 121, 1-15:
    with c = |r2 - r1|, s = (|r1| + |r2| + c)/2, lambda^2 = 1 - c/s and T = sqrt(2 mu/s^3) tof,
    solve T(x) = T for x (eqs. 18-22), then
    v = gamma [(lambda y - x) - rho (lambda y + x)]/r1 r1_hat + gamma sigma (y + lambda x)/r1 t1_hat
    (eq. 23). Verified against Curtis (2014), Example 5.2 and the second method.
    """
    if on_failure not in ("raise", "mask"):
        raise InvalidInputError(f"on_failure must be 'raise' or 'mask'; got {on_failure!r}.")
    v1, v2, shape, status, bad, problem = _solve(r1, r2, tof, gm, revolutions, prograde, branch,
                                                 method)
    if on_failure == "raise" and bad.any():
        _raise_failures(_failures(status, bad, problem), shape)
    v1 = to_quantity(v1.reshape(shape + (3,)), "speed")
    v2 = to_quantity(v2.reshape(shape + (3,)), "speed")
    if on_failure == "raise":
        return v1, v2
    from astropy.utils.masked import Masked

    mask = np.broadcast_to(bad.reshape(shape)[..., None], shape + (3,))
    v1[mask] = np.nan  # under the mask: never a plausible number
    v2[mask] = np.nan
    return Masked(v1, mask=mask.copy()), Masked(v2, mask=mask.copy())


def _solve(r1, r2, tof, gm, revolutions, prograde, branch, method):
    """Checked inputs, one kernel call: flat ``(v1, v2)`` (n, 3) km/s, the broadcast shape, the
    kernel status, the failed transfers ``bad`` (n,) and what :func:`_failures` needs."""
    R1 = to_vector(r1, "length", "r1")
    R2 = to_vector(r2, "length", "r2")
    T = to_array(tof, "time", "tof")
    mu = to_array(gm, "gm", "gm")
    prograde = require_flag(prograde, "prograde")
    if (
        isinstance(revolutions, bool)
        or not isinstance(revolutions, int | np.integer)
        or revolutions < 0
    ):
        raise InvalidInputError(f"revolutions must be an integer >= 0; got {revolutions!r}.")
    if branch not in ("left", "right"):
        raise InvalidInputError(f"branch must be 'left' or 'right'; got {branch!r}.")
    if method not in LAMBERT_METHODS:
        raise InvalidInputError(f"method must be one of {sorted(LAMBERT_METHODS)}; got {method!r}.")
    if np.any(mu <= 0):
        raise InvalidInputError("gm must be > 0 (e.g. vv.SUN.gm).")
    try:
        shape = np.broadcast_shapes(R1.shape[:-1], R2.shape[:-1], T.shape, mu.shape)
    except ValueError:
        raise ShapeError(
            f"r1 {R1.shape}, r2 {R2.shape}, tof {T.shape} and gm {mu.shape} do not broadcast "
            "together: give positions of shape (..., 3) with matching leading shapes (or one "
            "side a single (3,) vector) and tof, gm broadcasting against those leading shapes."
        ) from None
    n = int(np.prod(shape))
    r1f = np.ascontiguousarray(np.broadcast_to(R1, shape + (3,)).reshape(n, 3))
    r2f = np.ascontiguousarray(np.broadcast_to(R2, shape + (3,)).reshape(n, 3))
    tf = np.ascontiguousarray(np.broadcast_to(T, shape).reshape(n))
    mf = np.ascontiguousarray(np.broadcast_to(mu, shape).reshape(n))
    # Lambert's problem is scale-free: solve it in units where max|r| = 1 and GM = 1 so that
    # positions of 1e-200 or 1e200 km neither underflow nor overflow (r**2 in the kernels).
    with np.errstate(all="ignore"):
        length = np.maximum(np.abs(r1f).max(axis=1), np.abs(r2f).max(axis=1))
        length = np.where((length > 0) & np.isfinite(length), length, 1.0)
        speed = np.sqrt(mf / length)  # km/s per unit non-dimensional speed
        time_unit = length / speed
        r1n = np.ascontiguousarray(r1f / length[:, None])
        r2n = np.ascontiguousarray(r2f / length[:, None])
        tn = np.ascontiguousarray(tf / time_unit)
    scaled = np.isfinite(speed) & (speed > 0) & np.isfinite(tn)
    # rescale only where squares could overflow or underflow: ordinary inputs go through the
    # kernels unchanged (bit for bit)
    extreme = (length < 1e-60) | (length > 1e60) | (mf < 1e-60) | (mf > 1e60)
    rescale = scaled & extreme
    k1 = np.where(rescale[:, None], r1n, r1f)
    k2 = np.where(rescale[:, None], r2n, r2f)
    kt = np.where(rescale, tn, tf)
    km = np.where(rescale, 1.0, mf)
    v1 = np.empty((n, 3))
    v2 = np.empty((n, 3))
    status = np.zeros(n, dtype=np.int64)
    tier.call(  # a small call on a fresh install runs interpreted (core/tier.py)
        LAMBERT_METHODS[method]["kernel"],
        np.ascontiguousarray(k1), np.ascontiguousarray(k2), np.ascontiguousarray(kt),
        np.ascontiguousarray(km), int(revolutions), bool(prograde), branch == "right", v1, v2,
        status, small=n <= tier.SMALL_ITEMS,
    )  # fmt: skip
    v1 = np.where(rescale[:, None], v1 * speed[:, None], v1)
    v2 = np.where(rescale[:, None], v2 * speed[:, None], v2)
    # a solved transfer whose speeds overflowed (finite inputs): a failure like the others
    status = np.where((status == st.OK) & ~np.isfinite(v1 + v2).all(axis=1), st.OVERFLOW, status)
    # a Newtonian transfer faster than light is no transfer at all (audit: 1.7e9 km/s silently)
    with np.errstate(invalid="ignore", over="ignore"):
        fastest = np.maximum(np.linalg.norm(v1, axis=1), np.linalg.norm(v2, axis=1))
    light = (status == st.OK) & (fastest > C_KM_S)
    bad = (status != st.OK) | ~(tf > 0) | light
    problem = {"tof": tf, "tn": tn, "time_unit": time_unit, "length": length, "r1n": r1n,
               "r2n": r2n, "scaled": scaled, "revolutions": revolutions, "light": light,
               "fastest": fastest}
    return v1, v2, shape, status, bad, problem


#: failure causes in the order the message lists them: (key, heading)
_CAUSES = (
    ("tof", "tof <= 0"),
    ("collinear", "r1 and r2 collinear"),
    ("revolutions", "no M-revolution solution in that time"),
    ("short", "tof too short to resolve"),
    ("light", "faster than light"),
    ("long", "tof too long to resolve"),
    ("other", "solver status"),
)


def _failures(status, bad, pb) -> list:
    """Every failed transfer (``bad``) as ``(flat index, cause, reason, exception class)``."""
    tf, tn, time_unit, length = pb["tof"], pb["tn"], pb["time_unit"], pb["length"]
    r1n, r2n, revolutions = pb["r1n"], pb["r2n"], pb["revolutions"]
    out = []
    for k in np.flatnonzero(bad):
        k = int(k)
        code = int(status[k])
        if not tf[k] > 0 and np.isfinite(tf[k]):
            out.append((k, "tof", f"tof = {tf[k]:.6g} s: tof must be > 0; for a backward arc "
                        "swap r1 and r2", DomainError))
        elif pb["light"][k]:
            chord = np.linalg.norm(r2n[k] - r1n[k]) * length[k]
            out.append((k, "light", (
                f"tof = {tf[k]:.6g} s needs {pb['fastest'][k]:.6g} km/s, faster than light "
                f"(c = {C_KM_S} km/s): Newtonian mechanics is meaningless there (light itself "
                f"takes |r2 - r1| / c = {chord / C_KM_S:.6g} s); give a longer tof"), DomainError))
        elif code == st.NO_CONVERGENCE and pb["scaled"][k] and tn[k] < TOF_TOO_SHORT:
            out.append((k, "short", (
                f"tof = {tf[k]} s is too short for this geometry: it is {tn[k]:.3g} times the "
                f"time unit sqrt(L^3/GM) = {time_unit[k]:.6g} s of the problem (L = "
                f"{length[k]:.6g} km), so the transfer is a straight line at "
                f"~{np.linalg.norm(r2n[k] - r1n[k]) * length[k] / tf[k]:.3g} km/s and the solver "
                "cannot resolve the conic; give a longer tof (a tof above "
                f"~{TOF_TOO_SHORT * time_unit[k]:.3g} s always works)"), DomainError))
        elif code == st.NO_CONVERGENCE and pb["scaled"][k] and tn[k] > TOF_TOO_LONG:
            out.append((k, "long", (
                f"tof = {tf[k]} s is too long for a {revolutions}-revolution transfer in this "
                f"geometry: it is {tn[k]:.3g} times the time unit sqrt(L^3/GM) = "
                f"{time_unit[k]:.6g} s of the problem (L = {length[k]:.6g} km), so the transfer "
                "orbit is a nearly parabolic ellipse that double precision cannot resolve; allow "
                "more revolutions or give a shorter tof"), DomainError))
        elif code == st.DOMAIN and np.linalg.norm(np.cross(r1n[k], r2n[k])) <= (
                1e-12 * np.linalg.norm(r1n[k]) * np.linalg.norm(r2n[k])):
            out.append((k, "collinear", "r1 and r2 are collinear (transfer angle 0 or 180 deg): "
                        "the transfer plane is undefined; offset one position slightly out of "
                        "the line", DomainError))
        elif code == st.DOMAIN:
            out.append((k, "revolutions", (
                f"no {revolutions}-revolution transfer exists in tof = {tf[k]} s: the time of "
                "flight is below the minimum for that many revolutions; use fewer revolutions "
                "or a longer tof"), DomainError))
        else:
            exc, what, todo = STATUS_TABLE.get(
                code, (VisvivaError, f"unknown status code {code}", "report this as a bug"))
            out.append((k, "other", f"{what} (tof = {tf[k]} s); {todo}", exc))
    return out


def _raise_failures(failures, shape) -> None:
    """One error for all failed transfers: every index, grouped by cause, each with its reason
    (the first of a cause in full, the others by their tof); ``exc.failures`` maps them all."""

    def where(k):
        return tuple(int(i) for i in np.unravel_index(k, shape)) if shape else ()

    n = int(np.prod(shape))
    exc_type = failures[0][3]
    if len(failures) == 1:
        k, _, reason, _ = failures[0]
        at = f" at index {where(k)}" if shape else ""
        exc = exc_type(f"Lambert{at}: {reason}.")
    else:
        parts = []
        for cause, heading in _CAUSES:
            group = [f for f in failures if f[1] == cause]
            if not group:
                continue
            k0, _, reason, _ = group[0]
            others = ", ".join(str(where(k)) for k, *_ in group[1:])
            parts.append(f"{heading} at {len(group)} index(es): {where(k0)}: {reason}"
                         + (f"; likewise {others}" if others else ""))
        exc = exc_type(
            f"Lambert: {len(failures)} of {n} transfers have no solution (every failing index "
            "follows, by cause; on_failure='mask' returns the others with these masked): "
            + " | ".join(parts) + ".")
    exc.failures = {where(k): reason for k, _, reason, _ in failures}
    headings = dict(_CAUSES)
    exc.causes = {where(k): headings[cause] for k, cause, _, _ in failures}
    raise exc
