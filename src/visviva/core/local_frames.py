"""Local orbital frames (RTN, TNW, VNB): the one place their axes are defined.

Each frame is three orthonormal axes built from a state (r, v) with h = r x v:

=====  ==========================  ==========================  ==========================
frame  first axis                  second axis                 third axis
=====  ==========================  ==========================  ==========================
RTN    R = r / |r|                 T = N x R                   N = h / |h|
TNW    T = v / |v|                 N = W x T                   W = h / |h|
VNB    V = v / |v|                 N = h / |h|                 B = V x N
=====  ==========================  ==========================  ==========================

RTN is the radial / transverse / normal frame of CCSDS 508.0-B-1 (CDM) and 502.0-B-3 (OPM,
annex: also called RSW or RIC; Vallado 2013 sec. 3.3). TNW is CCSDS's TNW (Vallado's NTW with
its axes reordered): T along the velocity, W along the orbit normal, N = W x T in the orbit
plane, pointing inward for a circular orbit (Orekit's ``LOFType.TNW``). VNB is GMAT's
velocity / normal / binormal frame (B = V x N, outward for a circular orbit).

RTN and TNW share one construction (first axis e1, third e3 = h/|h|, second e3 x e1) with e1
along r or along v; VNB takes e2 = h/|h| and e3 = e1 x e2. The same construction runs in the
compiled thrust force (:func:`to_inertial`) and on arrays (:func:`local_axes`).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel

__all__ = ["INERTIAL", "RTN", "TNW", "VNB", "FRAME_CODES", "EME2000_NOTE", "local_axes",
           "to_inertial", "to_inertial_jacobian"]

#: Frame codes (the ``THRUST_FRAME`` slot of :mod:`visviva.core.force_block`).
INERTIAL = 0
RTN = 1
TNW = 2
VNB = 3
#: Frame name -> code, for the local frames (RSW, RIC and QSW are other names of RTN's axes:
#: Vallado, NASA CARA, Orekit).
FRAME_CODES = {"RTN": RTN, "TNW": TNW, "VNB": VNB, "RSW": RTN, "RIC": RTN, "QSW": RTN}
#: why EME2000 (J2000) is refused as a frame argument (states, burns, covariances): the one text
#: of the satellites layer's refusals (the bias itself: visviva.ccsds.timeframes.FRAME_BIAS)
EME2000_NOTE = ("EME2000 (J2000) differs from the GCRS by the 23 mas frame bias (0.8 m in LEO, "
                "4.7 m at GEO), which frame arguments do not apply: pass 'gcrs' if that is "
                "acceptable, or turn EME2000 numbers to the GCRS axes first with "
                "visviva.ccsds.timeframes.to_gcrs_axes('EME2000', ...)")


def local_axes(r, v, frame: int) -> np.ndarray:
    """The axes of a local frame as the rows of a rotation matrix.

    Parameters
    ----------
    r : ndarray (..., 3)
        Position, km (any length unit: only directions are used).
    v : ndarray (..., 3)
        Velocity, km/s (any speed unit).
    frame : int
        :data:`RTN`, :data:`TNW` or :data:`VNB`.

    Returns
    -------
    ndarray (..., 3, 3)
        ``M`` with the frame's axes as rows: ``M @ x_inertial`` gives the local components,
        ``M.T @ x_local`` the inertial ones. Rows of zeros or NaN where r x v = 0 (the caller
        checks).
    """
    r = np.asarray(r, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    h = np.cross(r, v)
    e1 = (r if frame == RTN else v)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = h / np.linalg.norm(h, axis=-1, keepdims=True)
        e1 = e1 / np.linalg.norm(e1, axis=-1, keepdims=True)
    if frame == VNB:
        return np.stack([e1, w, np.cross(e1, w)], axis=-2)
    if frame not in (RTN, TNW):
        raise ValueError(f"unknown local frame code {frame}")
    return np.stack([e1, np.cross(w, e1), w], axis=-2)


@kernel
def to_inertial(frame, y, d0, d1, d2, out):
    """Rotate local components (d0, d1, d2) to inertial ones at the state ``y`` (r, v).

    Parameters
    ----------
    frame : int
        :data:`INERTIAL` (the components are returned as given), :data:`RTN`, :data:`TNW` or
        :data:`VNB`.
    y : ndarray (6,)
        Position (km) and velocity (km/s).
    d0, d1, d2 : float
        Components along the frame's first, second and third axes.
    out : ndarray (3,)
        Output: the inertial vector.
    """
    if frame == INERTIAL:
        out[0] = d0
        out[1] = d1
        out[2] = d2
        return
    hx = y[1] * y[5] - y[2] * y[4]
    hy = y[2] * y[3] - y[0] * y[5]
    hz = y[0] * y[4] - y[1] * y[3]
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    wx = hx / hn
    wy = hy / hn
    wz = hz / hn
    k = 0 if frame == RTN else 3
    en = math.sqrt(y[k] * y[k] + y[k + 1] * y[k + 1] + y[k + 2] * y[k + 2])
    ax = y[k] / en
    ay = y[k + 1] / en
    az = y[k + 2] / en
    cx = wy * az - wz * ay  # c = w x e1
    cy = wz * ax - wx * az
    cz = wx * ay - wy * ax
    if frame == VNB:  # e2 = w, e3 = e1 x w = -c
        out[0] = d0 * ax + d1 * wx - d2 * cx
        out[1] = d0 * ay + d1 * wy - d2 * cy
        out[2] = d0 * az + d1 * wz - d2 * cz
    else:  # e2 = c, e3 = w
        out[0] = d0 * ax + d1 * cx + d2 * wx
        out[1] = d0 * ay + d1 * cy + d2 * wy
        out[2] = d0 * az + d1 * cz + d2 * wz


@kernel
def _cross_matrix(a0, a1, a2, out):
    """out = [a]x, the matrix of a x (.)."""
    out[0, 0] = 0.0
    out[0, 1] = -a2
    out[0, 2] = a1
    out[1, 0] = a2
    out[1, 1] = 0.0
    out[1, 2] = -a0
    out[2, 0] = -a1
    out[2, 1] = a0
    out[2, 2] = 0.0


@kernel
def to_inertial_jacobian(frame, y, d0, d1, d2, jac):
    """The partials of :func:`to_inertial` with respect to the state: d (M^T d) / d (r, v).

    Parameters
    ----------
    frame : int
        :data:`INERTIAL` (all zeros), :data:`RTN`, :data:`TNW` or :data:`VNB`.
    y : ndarray (6,)
        Position (km) and velocity (km/s).
    d0, d1, d2 : float
        Components along the frame's axes (any unit u).
    jac : ndarray (3, 6)
        Output: d (inertial vector) / d (r, v), u/km and u/(km/s).

    Notes
    -----
    With e1 = a / |a| (a = r for RTN, v for TNW and VNB), w = h / |h|, h = r x v and
    c = w x e1, the vector is d0 e1 + alpha c + beta w (RTN, TNW: alpha = d1, beta = d2;
    VNB: e2 = w, e3 = e1 x w = -c, so alpha = -d2, beta = d1). Its differential is

        (d0 I + alpha [w]x) de1 + (beta I - alpha [e1]x) dw,
        de1 = (I - e1 e1^T) da / |a|,    dw = (I - w w^T) (-[v]x dr + [r]x dv) / |h|,

    with [a]x the cross-product matrix (d(w x e1) = -[e1]x dw + [w]x de1). Checked against
    central differences in tests/test_burn_partials.py.
    """
    for i in range(3):
        for j in range(6):
            jac[i, j] = 0.0
    if frame == INERTIAL:
        return
    hx = y[1] * y[5] - y[2] * y[4]
    hy = y[2] * y[3] - y[0] * y[5]
    hz = y[0] * y[4] - y[1] * y[3]
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    w = np.empty(3)
    w[0] = hx / hn
    w[1] = hy / hn
    w[2] = hz / hn
    k = 0 if frame == RTN else 3
    en = math.sqrt(y[k] * y[k] + y[k + 1] * y[k + 1] + y[k + 2] * y[k + 2])
    e = np.empty(3)
    for i in range(3):
        e[i] = y[k + i] / en
    if frame == VNB:
        alpha = -d2
        beta = d1
    else:
        alpha = d1
        beta = d2
    cw = np.empty((3, 3))
    ce = np.empty((3, 3))
    _cross_matrix(w[0], w[1], w[2], cw)
    _cross_matrix(e[0], e[1], e[2], ce)
    # A = (d0 I + alpha [w]x) (I - e e^T) / |a|, B = (beta I - alpha [e]x) (I - w w^T) / |h|
    pa = np.empty((3, 3))
    pb = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            pa[i, j] = alpha * cw[i, j]
            pb[i, j] = -alpha * ce[i, j]
        pa[i, i] += d0
        pb[i, i] += beta
    a_mat = np.zeros((3, 3))
    b_mat = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            sa = 0.0
            sb = 0.0
            for m in range(3):
                pe = (1.0 if m == j else 0.0) - e[m] * e[j]
                pw = (1.0 if m == j else 0.0) - w[m] * w[j]
                sa += pa[i, m] * pe
                sb += pb[i, m] * pw
            a_mat[i, j] = sa / en
            b_mat[i, j] = sb / hn
    cr = np.empty((3, 3))
    cv = np.empty((3, 3))
    _cross_matrix(y[0], y[1], y[2], cr)
    _cross_matrix(y[3], y[4], y[5], cv)
    for i in range(3):
        for j in range(3):
            sr = 0.0
            sv = 0.0
            for m in range(3):
                sr -= b_mat[i, m] * cv[m, j]
                sv += b_mat[i, m] * cr[m, j]
            jac[i, j] += sr
            jac[i, 3 + j] += sv
            jac[i, 3 * (k // 3) + j] += a_mat[i, j]
