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
    """TEME -> ITRS for any times in ``[t_ref + start_s, t_ref + end_s]``.

    Parameters
    ----------
    t_ref : astropy Time
        Scalar reference time (times are counted from it in SI seconds).
    start_s, end_s : float
        The interval to cover, s after ``t_ref``.
    anchor_s : float
        Spacing of the astropy anchors, s (default 3600).
    """

    def __init__(self, t_ref, start_s: float, end_s: float, anchor_s: float = 3600.0):
        from ..satellites.frames import transform_matrices

        self.t_ref = t_ref
        self.anchor_s = float(anchor_s)
        k = int(np.ceil(max(end_s - start_s, 0.0) / anchor_s)) + 1
        self.anchor_times_s = start_s + np.arange(k) * self.anchor_s
        anchors = t_ref + self.anchor_times_s * u.s
        self.matrices = np.ascontiguousarray(transform_matrices(anchors, "teme", "itrs"))
        self._anchors = anchors

    @property
    def gcrs_to_teme(self):
        """GCRS -> TEME rotations at the anchors, (A, 3, 3): ``R3(eqeq) N P B``.

        IAU 2006/2000A bias-precession-nutation and equation of the equinoxes from ERFA
        (astropy's library), equal to astropy's GCRS -> TEME to ~3e-7 rad; used for slowly
        moving directions (the Sun), where it saves an astropy transformation.
        """
        import erfa

        if "_gcrs_to_teme" not in self.__dict__:
            tt = self._anchors.tt
            npb = erfa.pnm06a(tt.jd1, tt.jd2)
            ee = erfa.ee06a(tt.jd1, tt.jd2)
            c, s = np.cos(ee), np.sin(ee)
            r3 = np.zeros((len(ee), 3, 3))
            r3[:, 0, 0] = c
            r3[:, 0, 1] = s
            r3[:, 1, 0] = -s
            r3[:, 1, 1] = c
            r3[:, 2, 2] = 1.0
            self.__dict__["_gcrs_to_teme"] = r3 @ npb
        return self.__dict__["_gcrs_to_teme"]

    def _anchor(self, t_s):
        t_s = np.asarray(t_s, dtype=np.float64)
        k = np.rint((t_s - self.anchor_times_s[0]) / self.anchor_s).astype(np.int64)
        return t_s, np.clip(k, 0, len(self.anchor_times_s) - 1)

    def gcrs_positions_to_itrs(self, p, t_s):
        """Geocentric GCRS positions (km, (..., 3)) at ``t_s`` -> ITRS (e.g. the Sun)."""
        t_s, k = self._anchor(t_s)
        p_teme = np.einsum("...ij,...j->...i", self.gcrs_to_teme[k], p)
        r, _ = self.apply(p_teme, np.zeros_like(p_teme), t_s)
        return r

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
        from ..core.topocentric import teme_to_itrs_anchored

        shape = np.broadcast_shapes(np.shape(r)[:-1], np.shape(t_s))
        rf = np.ascontiguousarray(np.broadcast_to(r, shape + (3,)), dtype=np.float64)
        vf = np.ascontiguousarray(np.broadcast_to(v, shape + (3,)), dtype=np.float64)
        tf = np.ascontiguousarray(np.broadcast_to(t_s, shape), dtype=np.float64).reshape(-1)
        r_out = np.empty(shape + (3,))
        v_out = np.empty(shape + (3,))
        teme_to_itrs_anchored(rf.reshape(-1, 3), vf.reshape(-1, 3), tf,
                              float(self.anchor_times_s[0]), self.anchor_s, self.matrices,
                              GMST_RATE_RAD_S, r_out.reshape(-1, 3), v_out.reshape(-1, 3))
        return r_out, v_out
