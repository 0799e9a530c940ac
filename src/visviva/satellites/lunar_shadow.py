"""The Earth's shadow over a Moon-centred run: a warning where the force model leaves it out.

SRP's shadow and the eclipse events are those of the central body only. About the Moon, the
Earth's shadow is missed: during a lunar eclipse a lunar orbiter flies in the Earth's umbra for
up to ~3.5 hours with SRP on at full strength, and ``Eclipse`` reports nothing. Measured
(audit56) for a 50 km polar lunar orbit, A/m = 0.02 m^2/kg, Cr = 1.3, over the eclipse of
2025-03-14: 4.0 m after 8 hours against a run with SRP off over the umbral phase. This module
finds such times before the run and warns; it does not model the Earth's shadow.
"""

from __future__ import annotations

import warnings

import numpy as np

from .._callsite import outside_stacklevel
from ..bodies import EARTH, SUN

__all__ = ["earth_shadow_windows", "warn_earth_shadow"]

#: Sampling step of the check, s (the Moon moves ~600 km across the shadow in it).
SAMPLE_STEP_S = 600.0
#: Relative speed of the Moon across the Earth's shadow, km/s (1.02 km/s orbital speed plus the
#: shadow's own turning, rounded up): the margin of one sampling step.
SHADOW_SPEED_KM_S = 1.1
#: The Earth's atmosphere widens the shadow by ~2 % (Danjon's enlargement); 5 % is kept.
ENLARGEMENT = 1.05


def earth_shadow_windows(epoch, span_s, reach_km):
    """Times at which the Earth's penumbra comes within ``reach_km`` of the Moon's centre.

    Parameters
    ----------
    epoch : astropy Time
        The run's epoch.
    span_s : (float, float)
        The run's first and last times, s (TT) after the epoch.
    reach_km : float
        The largest distance of the orbiter from the Moon's centre, km.

    Returns
    -------
    list of (float, float)
        Windows (start, end), s after the epoch, widened by one sampling step each side; empty
        when the orbit stays clear of the Earth's penumbra.

    Notes
    -----
    The penumbra is the cone tangent to the Sun and the Earth, crossing between them; at a
    distance x behind the Earth along the Sun-Earth line its radius is
    x tan f + R_E / cos f, sin f = (R_S + R_E) / D (Montenbruck & Gill 2000, sec. 3.4.2),
    enlarged by 5 % for the atmosphere.
    """
    from .ephemeris import tabulate

    lo, hi = float(min(span_s)), float(max(span_s))
    t0, step, r, _ = tabulate(["sun", "earth"], epoch, lo, hi, SAMPLE_STEP_S, "moon")
    times = t0 + step * np.arange(r.shape[1])
    sun, earth = r[0], r[1]
    axis = earth - sun
    dist = np.linalg.norm(axis, axis=1)
    axis /= dist[:, None]
    behind = -np.einsum("ij,ij->i", earth, axis)  # the Moon's centre past the Earth, km
    perp = np.linalg.norm(-earth - behind[:, None] * axis, axis=1)
    sin_f = (SUN.radius_km + EARTH.radius_km) / dist
    cos_f = np.sqrt(1.0 - sin_f * sin_f)
    radius = ENLARGEMENT * (behind * sin_f / cos_f + EARTH.radius_km / cos_f)
    near = (behind > 0.0) & (perp < radius + reach_km + SHADOW_SPEED_KM_S * step)
    windows = []
    idx = np.flatnonzero(near)
    if idx.size:
        breaks = np.flatnonzero(np.diff(idx) > 1)
        for a, b in zip(np.r_[idx[0], idx[breaks + 1]], np.r_[idx[breaks], idx[-1]],
                        strict=True):
            windows.append((max(times[a] - step, lo), min(times[b] + step, hi)))
    return [w for w in windows if w[1] > w[0]]


def orbit_reach_km(r0, v0, gm, span_s) -> float:
    """An upper bound of the distance from the central body over the run, km: the apoapsis
    of each state's osculating orbit, or for an unbound one |r| + |v| times the span."""
    r0 = np.atleast_2d(r0)
    v0 = np.atleast_2d(v0)
    rn = np.linalg.norm(r0, axis=1)
    vn = np.linalg.norm(v0, axis=1)
    energy = 0.5 * vn * vn - gm / rn
    h = np.linalg.norm(np.cross(r0, v0), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = -gm / (2.0 * energy)
        e = np.sqrt(np.maximum(0.0, 1.0 + 2.0 * energy * h * h / (gm * gm)))
        apo = np.where(energy < 0.0, a * (1.0 + e), np.inf)
    span = abs(float(span_s[1]) - float(span_s[0]))
    reach = np.where(np.isfinite(apo), apo, rn + vn * span)
    return float(np.max(np.maximum(reach, rn)))


def warn_earth_shadow(model, events, r0, v0) -> None:
    """Warn when a Moon-centred run with SRP's shadow or eclipse events meets the Earth's shadow.

    Parameters
    ----------
    model : ForceModel
        The run's force model (central body, epoch, span, whether SRP and its shadow are on).
    events : list of Event
        The run's events.
    r0, v0 : ndarray (3,) or (N, 3)
        Initial positions (km) and velocities (km/s) about the central body.
    """
    from ..core import force_block as fb

    if model.central_body.name != "moon" or model.epoch is None:
        return
    srp = model.force[fb.SRP_ON] != 0.0 and model.force[fb.SHADOW_MODEL] != 0.0  # None: no shadow
    eclipses = any(getattr(e, "name", "") == "eclipse" for e in events)
    if not (srp or eclipses):
        return
    gm = float(model.force[fb.GM])
    windows = earth_shadow_windows(model.epoch, model.span_s,
                                   orbit_reach_km(r0, v0, gm, model.span_s))
    if not windows:
        return
    from .._units import advance_epoch

    spans = ", ".join(
        f"{advance_epoch(model.epoch, a).utc.isot[:16]} to "
        f"{advance_epoch(model.epoch, b).utc.isot[:16]} UTC" for a, b in windows[:4]
    ) + (f" and {len(windows) - 4} more" if len(windows) > 4 else "")
    what = " and ".join(x for x in (
        "solar radiation pressure stays on at full strength" if srp else "",
        "Eclipse events do not report it" if eclipses else "") if x)
    warnings.warn(
        f"this Moon-centred run meets the Earth's shadow (a lunar eclipse: {spans}), which "
        f"is not modelled: only the Moon's shadow is, so {what} there (for a 50 km lunar orbit "
        "with A/m = 0.02 m2/kg, 4 m after 8 hours). Split the run at the eclipse and leave "
        "SRP out over it, or accept the error.",
        UserWarning, stacklevel=outside_stacklevel(),
    )
