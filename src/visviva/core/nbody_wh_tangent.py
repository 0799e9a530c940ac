"""The tangent map of a WHFast step: MEGNO with the Wisdom-Holman integrator (Jacobi coordinates).

A tangent vector ``delta = (dx, dv)`` follows the linearisation of the map WHFast applies to the
particles (Rein & Tamayo 2016, first-order part; written here from the definitions): each piece
of the drift-kick-drift step ``Kepler(h/2) Kick(h) Kepler(h/2)`` has its own exact tangent,

* the coordinate transforms (:func:`visviva.core.nbody_wh_maps.to_jacobi` and back) are linear,
  so the same functions carry the tangent vector;
* the Kepler drift of each Jacobi body (GM = ``G eta_i``): the derivative of the
  universal-variable solution with respect to the initial state (:func:`kepler_tangent`);
* the interaction kick ``dv'_i += h (a'_i + G eta_i x'_i / |x'_i|**3)``: its Jacobian in Jacobi
  coordinates, ``to_jacobi(J(x) from_jacobi(dx'))_i + G eta_i (dx'_i / r**3 - 3 x'_i (x'_i . dx'_i)
  / r**5)`` with ``J`` the gravity gradient of
  :func:`visviva.core.nbody_variational.tangent_acceleration`.

Universal variables (the notation of :mod:`visviva.core.universal`): with ``beta = 2 gm / r0 -
v0**2``, ``eta = r0 . v0`` and the Stumpff-Danby functions ``G_k(beta, s)``, the drift is
``x = f x0 + g v0``, ``v = fdot x0 + gdot v0`` where ``s`` solves
``h = r0 G1 + eta G2 + gm G3``. Its variation at fixed ``h`` follows from ``dG_k/ds = G_{k-1}``
(``dG_0/ds = -beta G_1``), ``dG_k/dbeta = (k G_{k+2} - s G_{k+1}) / 2`` and, from the Kepler
equation, ``ds = -(G1 dr0 + G2 deta + (r0 dG1/dbeta + eta dG2/dbeta + gm dG3/dbeta) dbeta) / r``;
``df, dg, dfdot, dgdot`` follow by the product rule.

The tangent vector is stored in inertial coordinates at WHFast's grid points (what
``Simulation.tangent_vector`` returns, comparable with REBOUND's variational particles), with the
synchronised physical state of the grid point in Jacobi coordinates (``_MX``, ``_MV``: where the
next step's first half drift is linearised). The physical trajectory is never touched: each step
the tangent advances from the state the physical step left behind (WHFast's internal state just
after its kick, and the inertial positions the kick used), and MEGNO is updated by the one owner
of its sums, :func:`visviva.core.nbody_variational.megno_update`. The symplectic correctors and
democratic heliocentric coordinates have no tangent map here: ``init_megno`` refuses them.

References
----------
Rein, H. & Tamayo, D. (2016), "Second-order variational equations for N-body simulations",
MNRAS 459, 2275.
Danby, J. M. A., *Fundamentals of Celestial Mechanics*, 2nd ed., Willmann-Bell 1992, sec. 6.9.
Mikkola, S. & Innanen, K. (1999), "Symplectic tangent map for planetary motions", CeMDA 74, 59.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel
from .nbody_common import F_G, F_SOFT2
from .nbody_variational import DV, DX, ln_norm_rescaled, megno_update, tangent_acceleration
from .nbody_wh_maps import from_jacobi, to_jacobi
from .status import NO_CONVERGENCE, NON_FINITE, OK, ZERO_POSITION
from .stumpff import SERIES_LIMIT, stumpff_all
from .universal import solve_universal

__all__ = ["kepler_tangent", "whfast_tangent", "whfast_tangent_start"]

# slots after the integrator's own (offsets from base; DX, DV = 0, 1 are the tangent vector)
_TJX = 2  # the tangent vector in Jacobi coordinates
_TJV = 3
_DA = 4  # the tangent acceleration (inertial)
_DAJ = 5  # ... in Jacobi coordinates
_MX = 6  # the synchronised physical state at the last grid point, Jacobi coordinates
_MV = 7

_TWO_PI = 2.0 * math.pi
#: 1/(2k+3)!, 1/(2k+4)!, 1/(2k+5)! (rows), k = 0..13: Taylor coefficients of c3, c4, c5 in
#: (-psi) (a global array: numba compiles it in as a constant).
_C345 = np.array([[1.0 / math.factorial(2 * k + j) for k in range(14)] for j in (3, 4, 5)])


@kernel
def _c345(psi):
    """Stumpff ``c3, c4, c5`` of ``psi`` (series for ``|psi| <= 4``, stopped where the next
    term is below 1e-19 of the sum: 6, 9 or 14 terms for ``|psi|`` up to 1/64, 1/2, 4; beyond,
    the closed forms and ``c_{k+2} = (1/k! - c_k) / psi``). Plain Horner sums: the tangent map
    needs accuracy, not the unbiased rounding of :mod:`visviva.core.stumpff`."""
    a = abs(psi)
    if a <= SERIES_LIMIT:
        top = 5 if a <= 0.015625 else (8 if a <= 0.5 else 13)
        z = -psi
        c3 = _C345[0, top]
        c4 = _C345[1, top]
        c5 = _C345[2, top]
        for k in range(top - 1, -1, -1):
            c3 = c3 * z + _C345[0, k]
            c4 = c4 * z + _C345[1, k]
            c5 = c5 * z + _C345[2, k]
        return c3, c4, c5
    c0, c1, c2, c3 = stumpff_all(psi)
    return c3, (0.5 - c2) / psi, (1.0 / 6.0 - c3) / psi


@kernel
def kepler_tangent(x0, v0, dx, dv, i, gm, h, xo, vo):
    """The Kepler drift of one body (row ``i``) over ``h`` and its tangent (state transition
    applied to one vector).

    Parameters
    ----------
    x0, v0 : ndarray, shape (N, 3)
        The state before the drift, row ``i`` (length, length / time).
    dx, dv : ndarray, shape (N, 3)
        A tangent vector at ``(x0[i], v0[i])``, row ``i``; replaced by its image after the drift
        (in place).
    i : int
        The row (rows, not row views, are passed: a view costs two reference-count updates,
        which made the tangent step 2x slower).
    gm : float
        Gravitational parameter (length**3 / time**2), > 0.
    h : float
        The drift time (time), any sign.
    xo, vo : ndarray, shape (N, 3)
        Row ``i`` receives the state after the drift (may be ``x0, v0`` themselves): only the
        linearisation point of a next tangent step (the physical drift is
        :func:`visviva.core.universal.propagate_scalar`'s).

    Returns
    -------
    status : int
        ``OK``, or ``ZERO_POSITION``/``NON_FINITE``/``NO_CONVERGENCE`` (nothing written).
    s : float
        The universal anomaly solved for (reduced by whole periods).

    Notes
    -----
    The module docstring gives the equations (Danby 1992, sec. 6.9). The solver starts from the
    reversed series of Kepler's equation, ``t = r0 s + eta s**2 / 2 + (gm - beta r0) s**3 / 6
    + ...``: ``s ~ t / r0 - (eta / 2) t**2 / r0**3 + (eta**2 / 2 - r0 (gm - beta r0) / 6) t**3 /
    r0**5``, good to ``O((n t)**4)``, so that a WHFast half step (``n t`` of 0.3 or less) takes
    one or two Laguerre iterations. An elliptic drift longer than a period is reduced by whole
    periods for the solver; ``G3..G5`` then carry the secular part,
    ``G_{k+2} = (s**k / k! - G_k) / beta``.
    """
    r0 = math.sqrt(x0[i, 0] * x0[i, 0] + x0[i, 1] * x0[i, 1] + x0[i, 2] * x0[i, 2])
    speeds = v0[i, 0] + v0[i, 1] + v0[i, 2]
    if not (math.isfinite(r0) and math.isfinite(speeds) and math.isfinite(h)):
        return NON_FINITE, math.nan
    if r0 == 0.0:
        return ZERO_POSITION, math.nan
    eta = x0[i, 0] * v0[i, 0] + x0[i, 1] * v0[i, 1] + x0[i, 2] * v0[i, 2]
    beta = 2.0 * gm / r0 - (v0[i, 0] * v0[i, 0] + v0[i, 1] * v0[i, 1] + v0[i, 2] * v0[i, 2])
    tau = h
    turns = 0.0
    if beta > 0.0:
        period = _TWO_PI * gm / (beta * math.sqrt(beta))
        if abs(h) > period:
            turns = float(math.trunc(h / period))
            tau = h - turns * period
    sr = 0.0
    G0 = 1.0
    G1 = 0.0
    G2 = 0.0
    if tau != 0.0:
        u = tau / r0
        s_guess = u * (1.0 - 0.5 * eta * u / r0
                       + (0.5 * eta * eta / r0 - (gm - beta * r0) / 6.0) * u * u / r0)
        ok, sr, G0, G1, G2 = solve_universal(r0, eta, gm, beta, tau, s_guess)
        if not ok:
            return NO_CONVERGENCE, math.nan
    c3, c4, c5 = _c345(beta * sr * sr)
    s = sr
    if turns == 0.0:
        G3 = sr * sr * sr * c3
        G4 = sr * sr * sr * sr * c4
        G5 = sr * sr * sr * sr * sr * c5
    else:
        s = sr + turns * _TWO_PI / math.sqrt(beta)
        G3 = (s - G1) / beta
        G4 = (0.5 * s * s - G2) / beta
        G5 = (s * s * s / 6.0 - G3) / beta
    r = r0 * G0 + eta * G1 + gm * G2
    f = 1.0 - gm * G2 / r0
    g = r0 * G1 + eta * G2
    fd = -gm * G1 / (r0 * r)
    gd = 1.0 - gm * G2 / r
    # the variations of r0, eta, beta, then of s (Kepler's equation at fixed h) and the G_k
    dr0 = (x0[i, 0] * dx[i, 0] + x0[i, 1] * dx[i, 1] + x0[i, 2] * dx[i, 2]) / r0
    deta = (dx[i, 0] * v0[i, 0] + dx[i, 1] * v0[i, 1] + dx[i, 2] * v0[i, 2]
            + x0[i, 0] * dv[i, 0] + x0[i, 1] * dv[i, 1] + x0[i, 2] * dv[i, 2])
    vdv = v0[i, 0] * dv[i, 0] + v0[i, 1] * dv[i, 1] + v0[i, 2] * dv[i, 2]
    dbeta = -2.0 * gm * dr0 / (r0 * r0) - 2.0 * vdv
    b0 = -0.5 * s * G1
    b1 = 0.5 * (G3 - s * G2)
    b2 = 0.5 * (2.0 * G4 - s * G3)
    b3 = 0.5 * (3.0 * G5 - s * G4)
    ds = -(G1 * dr0 + G2 * deta + (r0 * b1 + eta * b2 + gm * b3) * dbeta) / r
    dG0 = -beta * G1 * ds + b0 * dbeta
    dG1 = G0 * ds + b1 * dbeta
    dG2 = G1 * ds + b2 * dbeta
    dr = dr0 * G0 + r0 * dG0 + deta * G1 + eta * dG1 + gm * dG2
    df = -gm * (dG2 / r0 - G2 * dr0 / (r0 * r0))
    dg = dr0 * G1 + r0 * dG1 + deta * G2 + eta * dG2
    dfd = -gm * (dG1 - G1 * (dr0 / r0 + dr / r)) / (r0 * r)
    dgd = -gm * (dG2 - G2 * dr / r) / r
    for c in range(3):
        a = x0[i, c]
        b = v0[i, c]
        ex = dx[i, c]
        ev = dv[i, c]
        dx[i, c] = df * a + f * ex + dg * b + g * ev
        dv[i, c] = dfd * a + fd * ex + dgd * b + gd * ev
        xo[i, c] = f * a + g * b
        vo[i, c] = fd * a + gd * b
    return OK, sr


@kernel
def _tangent_drift(xs, vs, tx, tv, eta, G, h, xo, vo):
    """Every Jacobi body's Kepler drift tangent over ``h`` from ``xs, vs`` (``tx, tv`` in place;
    the drifted state into ``xo, vo``); the centre of mass (row 0) moves on a straight line."""
    n = xs.shape[0]
    for c in range(3):
        tx[0, c] += tv[0, c] * h
        xo[0, c] = xs[0, c] + vs[0, c] * h
        vo[0, c] = vs[0, c]
    for i in range(1, n):
        st, _s = kepler_tangent(xs, vs, tx, tv, i, G * eta[i], h, xo, vo)
        if st != OK:
            return st
    return OK


@kernel
def whfast_tangent_start(x, v, m, eta, buf, base):
    """Remember the synchronised state ``x, v`` (inertial) where WHFast builds its internal state
    afresh: the linearisation point of the next step's first half drift."""
    to_jacobi(x, m, eta, buf[base + _MX])
    to_jacobi(v, m, eta, buf[base + _MV])


@kernel
def whfast_tangent(xj, vj, x, m, massive, eta, fstate, buf, base, h):
    """Advance the tangent vector over the Jacobi WHFast step ``h`` just taken, and update MEGNO.

    ``xj, vj``: WHFast's internal state after the step's kick (Jacobi); ``x``: the inertial
    positions the kick was evaluated at. The tangent vector goes from the last grid point to
    this one by the linearised ``Kepler(h/2) Kick(h) Kepler(h/2)``: the first drift from the
    remembered synchronised state, the second from ``xj, vj`` (which also gives the
    synchronised state remembered for the next step). Returns a status code.
    """
    G = fstate[F_G]
    n = xj.shape[0]
    tx = buf[base + _TJX]
    tv = buf[base + _TJV]
    mx = buf[base + _MX]
    mv = buf[base + _MV]
    da = buf[base + _DA]
    daj = buf[base + _DAJ]
    dx = buf[base + DX]
    to_jacobi(dx, m, eta, tx)
    to_jacobi(buf[base + DV], m, eta, tv)
    half = 0.5 * h
    st = _tangent_drift(mx, mv, tx, tv, eta, G, half, mx, mv)
    if st != OK:
        return st
    # the kick: the inertial gravity gradient through the (linear) transforms, minus the
    # Jacobian of each body's Kepler term
    from_jacobi(tx, m, eta, dx)
    tangent_acceleration(x, dx, m, massive, G, fstate[F_SOFT2], da)
    to_jacobi(da, m, eta, daj)
    for c in range(3):
        tv[0, c] += daj[0, c] * h
    for i in range(1, n):
        r2 = xj[i, 0] * xj[i, 0] + xj[i, 1] * xj[i, 1] + xj[i, 2] * xj[i, 2]
        k = G * eta[i] / (r2 * math.sqrt(r2))
        p = 3.0 * (xj[i, 0] * tx[i, 0] + xj[i, 1] * tx[i, 1] + xj[i, 2] * tx[i, 2]) / r2
        for c in range(3):
            tv[i, c] += (daj[i, c] + k * (tx[i, c] - p * xj[i, c])) * h
    st = _tangent_drift(xj, vj, tx, tv, eta, G, half, mx, mv)
    if st != OK:
        return st
    from_jacobi(tx, m, eta, dx)
    from_jacobi(tv, m, eta, buf[base + DV])
    megno_update(fstate, h, ln_norm_rescaled(fstate, buf, base, False))
    return OK
