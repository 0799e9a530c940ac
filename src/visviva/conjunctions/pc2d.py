"""The 2-D collision probability of one encounter plane (Foster's integral, Chan's series).

The one owner of the plane's ``ln Pc`` for :mod:`visviva.conjunctions.probability` (which
exports it) and :mod:`visviva.conjunctions.accuracy` (which checks Chan's value against
Foster's); the kernels are :mod:`visviva.core.collision`.
"""

from __future__ import annotations

__all__ = ["log_pc_2d", "check_plane", "FOSTER_RTOL"]

#: relative accuracy of the Foster integral (Gauss-Legendre panels, :mod:`visviva.core.collision`)
FOSTER_RTOL = 1e-13


def log_pc_2d(xm, zm, sx, sz, hbr, method):
    """``ln Pc`` of one encounter plane in its principal axes.

    Parameters
    ----------
    xm, zm : float
        Miss components along the plane's principal axes, m.
    sx, sz : float
        Standard deviations along those axes, m.
    hbr : float
        Combined hard-body radius, m.
    method : {"foster", "chan"}
        Foster's integral of the Gaussian over the hard-body circle (to :data:`FOSTER_RTOL`
        relative) or Chan's equivalent-area series.

    Returns
    -------
    float
        The natural logarithm of the probability (at most 0).

    Raises
    ------
    visviva.errors.InvalidInputError
        A non-finite miss or sigma, a sigma <= 0 (clip it first, as NASA CARA does, at
        ``(1e-4 hbr)^2`` in variance), a NaN or negative ``hbr``, an unknown method: Chan's series
        returned NaN for a zero sigma and looped for ever on a negative one (audit48).
    visviva.errors.ConvergenceError
        Where Foster's integral does not reach :data:`FOSTER_RTOL`.

    References
    ----------
    Foster & Estes (1992), NASA JSC-25898; Chan (2008), *Spacecraft Collision Probability*.
    """
    from ..core import collision as kern

    check_plane(xm, zm, sx, sz, hbr, method)
    if method == "chan":
        return min(float(kern.log_pc_chan(xm, zm, sx, sz, hbr)), 0.0)
    lp, status = kern.log_pc_circle(xm, zm, sx, sz, hbr, kern.GAUSS_LO, kern.GAUSS_HI, FOSTER_RTOL)
    if status:
        from ..errors import ConvergenceError

        raise ConvergenceError(
            f"the Foster integral did not reach {FOSTER_RTOL:g} relative accuracy "
            f"(miss {xm:g}, {zm:g} m, sigma {sx:g}, {sz:g} m, HBR {hbr:g} m); report this case."
        )
    # a probability: near 1 the integral's 1e-13 rounding could put it above
    return min(float(lp), 0.0)


def check_plane(xm, zm, sx, sz, hbr, method):
    """Refuse what the kernels cannot integrate (see :func:`log_pc_2d`, Raises)."""
    import math

    from ..errors import InvalidInputError

    if method not in ("foster", "chan"):
        raise InvalidInputError(f"method must be 'foster' or 'chan', got {method!r}.")
    if not (math.isfinite(xm) and math.isfinite(zm)):
        raise InvalidInputError(f"the miss components must be finite, got {xm!r}, {zm!r} m.")
    if not (sx > 0 and sz > 0 and math.isfinite(sx) and math.isfinite(sz)):
        raise InvalidInputError(
            f"the sigmas must be finite and > 0, got {sx!r}, {sz!r} m; clip a zero or "
            "negative eigenvalue first (NASA CARA raises it to (1e-4 HBR)^2, as "
            "visviva.conjunctions.encounter_plane does).")
    if not hbr >= 0:
        raise InvalidInputError(f"hbr must be >= 0, got {hbr!r} m.")
