"""The band edges of the exponential atmosphere, where the integrators end their steps.

Vallado's exponential table (2013, Table 8-4; :data:`visviva.core.perturbations.VALLADO_EXPONENTIAL_TABLE`)
is used piecewise, as published (GMAT's ``Exponential`` atmosphere does the same): in the band
h_k <= h < h_(k+1), rho = rho_k exp(-(h - h_k)/H_k). At a band edge the density jumps (the
table's rho_(k+1) is the band below's density at its top rounded to four digits: up to 0.14 %,
at 25 km, mostly 1e-5 relative) and its slope -rho/H jumps (H changes: by 18 % at 300 km, 0.6 %
at 350 km). DOP853's error estimate sees neither, so a step across an edge makes an error that
depends on where the step falls: an orbit of 290 x 380 km (crossing 300 and 350 km twice an
orbit) split at an arbitrary time moved by 0.11 m after a day at rtol 1e-13 and 0.4 m at the
default tolerances, against 0.006 mm for the same orbit in one band.

So the integrators treat the edges as they treat the cylindrical shadow's boundary
(:mod:`visviva.core.cowell_events`, "Shadow boundaries"): the band at the start of a step is
held for the whole step (the force block's ``DENSITY_BAND`` slot in the integrator's copy,
:func:`hold_band`); a step whose dense output leaves the band (:func:`band_crossing`, the
geodetic altitude sampled as the shadow functions are, dips included) is dropped and redone up
to the edge, located to ``BOUNDARY_RTOL`` of the step on the altitude event function (event kind
0, the same altitude the density uses); the next band is then held and the integration restarts
with a fresh derivative. The state-transition matrix takes the saltation matrix of the density's
jump there (:func:`altitude_gradient`). Runs with another density model, or without drag,
do none of this (their bits are unchanged).
"""

from __future__ import annotations

import math

from . import force_block as fb
from ._jit import kernel, step_kernel
from .cowell_events import (
    BOUNDARY_RTOL,
    SHADOW_SAMPLES,
    first_crossing,
    step_sample,
)
from .geodetic import body_pole, geodetic, pole_altitude
from .perturbations import exponential_band

__all__ = ["bands_on", "hold_band", "start_band", "band_crossing", "altitude_gradient"]


@kernel
def bands_on(force):
    """True when drag with the exponential table is on (its band edges end the steps)."""
    return force[fb.DRAG_ON] != 0.0 and force[fb.DENSITY_MODEL] == 0.0


@kernel
def hold_band(rforce, band):
    """Hold band ``band`` (a row of the table) in ``rforce``, the integrator's copy of the
    force block, for the steps to come."""
    rforce[fb.DENSITY_BAND] = band + 1.0


@kernel
def start_band(t, rforce, y, atm):
    """The band of the altitude of state ``y`` at ``t`` s, held in ``rforce``; returns it."""
    h = pole_altitude(t, y[0], y[1], y[2], rforce)
    band = exponential_band(h, atm)
    hold_band(rforce, band)
    return band


@step_kernel
def band_crossing(band, atm, t, h, y, y_new, F, y_tmp, gs0, gs1, force, eph_r, eph_v):
    """The first point of the step (t, t + h) where the altitude leaves band ``band`` of the
    exponential table ``atm``, located to ``BOUNDARY_RTOL`` |h| on the dense output ``F``.

    Returns (ta, tb, which): the edge lies in [ta, tb], tb beyond it; which = 0 for the band's
    lower edge, 1 for its upper one, -1 when the step stays in the band. The distances to the
    edges, positive inside, are sampled at :data:`SHADOW_SAMPLES` + 1 points into ``gs0``
    (lower) and ``gs1`` (upper); each edge is found by
    :func:`visviva.core.cowell_events.first_crossing` (as the shadow boundaries are, grazes
    included), on the altitude event function (kind 0) that the density uses."""
    n = atm.shape[0]
    lo = atm[band, 0] if band > 0 else -math.inf
    hi = atm[band + 1, 0] if band + 1 < n else math.inf
    for k in range(SHADOW_SAMPLES + 1):
        tk = step_sample(k, t, h, y, y_new, F, y_tmp)
        alt = pole_altitude(tk, y_tmp[0], y_tmp[1], y_tmp[2], force)
        gs0[k] = alt - lo
        gs1[k] = hi - alt
    # event kind 0, h - edge: >= 0 in the band above its lower edge, < 0 below its upper one
    tol = BOUNDARY_RTOL * abs(h)
    low = (False, t, t)
    high = (False, t, t)
    if not math.isinf(lo):
        low = first_crossing(0, lo, 1.0, gs0, t, h, y, F, y_tmp, tol, force, eph_r, eph_v)
    if not math.isinf(hi):
        high = first_crossing(0, hi, -1.0, gs1, t, h, y, F, y_tmp, tol, force, eph_r, eph_v)
    if high[0] and (not low[0] or (high[2] - low[2]) * h < 0.0):
        return high[1], high[2], 1
    if low[0]:
        return low[1], low[2], 0
    return t + h, t + h, -1


@kernel
def altitude_gradient(t, y, force, grad):
    """The gradient of the geodetic altitude with respect to the position at ``t`` s, the
    ellipsoid's normal about the body's pole (:func:`visviva.core.geodetic.geodetic`; into
    ``grad``, 3 values), and its rate along the trajectory dh/dt, km/s (returned): the
    boundary function of a band edge, for the saltation matrix of the density's jump there
    (:func:`visviva.core.variational._boundary_jump`)."""
    px, py = body_pole(t, force)
    _, s, c, zp, rho, pz = geodetic(y[0], y[1], y[2], force[fb.ELLIPSOID_RADIUS], force[fb.FLATTENING],
                                    px, py)  # fmt: skip
    pole = (px, py, pz)
    for i in range(3):
        rh = (y[i] - zp * pole[i]) / rho if rho > 0.0 else 0.0
        grad[i] = c * rh + s * pole[i]
    return grad[0] * y[3] + grad[1] * y[4] + grad[2] * y[5]
