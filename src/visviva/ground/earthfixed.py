"""TEME to Earth-fixed (ITRS) states at many arbitrary times from a few astropy anchors.

astropy's TEME -> ITRS transformation is ``r_itrs = W R3(theta) r_teme`` with ``theta`` the
Greenwich mean sidereal time (IAU 1982) and ``W`` polar motion (Vallado et al. 2006,
AIAA 2006-6753). Over an hour ``W`` changes by well under a micro-arcsecond and ``theta`` grows
at a constant rate ``omega`` = 1.00273790935 revolutions per UT1 day to 1e-12 rad, so

    R(t) = R(t_k) R3(omega (t - t_k)),

and the 6 x 6 state map at ``t`` is the anchor's map ``M_k`` (from
:func:`visviva.satellites.frames.transform_matrices`, astropy's own rotation) applied to the
TEME state rotated by ``R3(omega (t - t_k))``. One astropy call per hour of window then serves
any number of satellites and times (equal to astropy to ~1 mm: see the tests).
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

__all__ = ["EarthFixedMap", "GMST_RATE_RAD_S"]

#: rate of Greenwich mean sidereal time, rad per (UT1) second: 1.00273790935 * 2 pi / 86400
GMST_RATE_RAD_S = 1.00273790935 * 2.0 * np.pi / 86400.0


class EarthFixedMap:
    """TEME -> ITRS for any times in ``[t_ref, t_ref + span_s]`` (s after ``t_ref``).

    Parameters
    ----------
    t_ref : astropy Time
        Scalar reference time (seconds are counted from it, SI seconds).
    span_s : float
        Length of the interval to cover, s.
    anchor_s : float
        Spacing of the astropy anchors, s (default 3600).
    """

    def __init__(self, t_ref, span_s: float, anchor_s: float = 3600.0):
        from ..satellites.frames import transform_matrices

        self.t_ref = t_ref
        self.anchor_s = float(anchor_s)
        k = int(np.ceil(max(span_s, 0.0) / anchor_s)) + 1
        self.anchor_times_s = np.arange(k) * self.anchor_s
        self.matrices = transform_matrices(t_ref + self.anchor_times_s * u.s, "teme", "itrs")

    def apply(self, r, v, t_s):
        """ITRS states from TEME states at seconds ``t_s`` after ``t_ref``.

        Parameters
        ----------
        r, v : ndarray (..., 3)
            TEME position (km) and velocity (km/s).
        t_s : ndarray, broadcastable to ``r.shape[:-1]``
            Times, s after ``t_ref``.

        Returns
        -------
        r, v : ndarray (..., 3)
            ITRS position and velocity (relative to the rotating Earth).
        """
        t_s = np.asarray(t_s, dtype=np.float64)
        k = np.clip(np.rint(t_s / self.anchor_s).astype(np.int64), 0, len(self.anchor_times_s) - 1)
        theta = GMST_RATE_RAD_S * (t_s - self.anchor_times_s[k])
        c, s = np.cos(theta), np.sin(theta)
        shape = np.broadcast_shapes(r.shape[:-1], t_s.shape)
        r = np.broadcast_to(r, shape + (3,))
        v = np.broadcast_to(v, shape + (3,))
        # R3(theta) x = (c x + s y, -s x + c y, z)
        y = np.empty(shape + (6,))
        y[..., 0] = c * r[..., 0] + s * r[..., 1]
        y[..., 1] = -s * r[..., 0] + c * r[..., 1]
        y[..., 2] = r[..., 2]
        y[..., 3] = c * v[..., 0] + s * v[..., 1]
        y[..., 4] = -s * v[..., 0] + c * v[..., 1]
        y[..., 5] = v[..., 2]
        m = np.broadcast_to(self.matrices[k], shape + (6, 6))
        out = np.einsum("...ij,...j->...i", m, y)
        return np.ascontiguousarray(out[..., :3]), np.ascontiguousarray(out[..., 3:])
