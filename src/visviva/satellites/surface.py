"""The central body's surface bounds a perturbed Cowell propagation.

A trajectory that reaches the surface of its central body under a force model of that body
(zonal harmonics, drag, solar radiation pressure with its shadow, third bodies about it) has
left the model's domain: below the surface the field expansion and the atmosphere mean nothing,
and a drag run would go on through an extrapolated atmosphere. :func:`visviva.propagate_cowell`
therefore watches the geodetic altitude (the exact height above the body's ellipsoid, as
:class:`~visviva.satellites.AltitudeCrossing` does; WGS-84 for the Earth) and raises
:class:`visviva.errors.SurfaceImpact` when it reaches 0, with the propagation up to that point
attached (``exc.result``). A terminal event of the user's that comes first (``ReEntry()`` at
100 km) ends the run as before, without an error.

A terminal altitude-0 event (:class:`SurfaceCrossing`) is found on the integrator's dense
output, to the event tolerance (1e-6 s), for one state and for each state of a batch (the
parallel kernel carries it: :mod:`visviva.satellites.cowell_batch`).

Pure two-body motion (no perturbations) and a GM of no known body are not watched: a conic
through the attractor is the exact solution of the two-body problem, as
:meth:`visviva.StateVectors.propagate` gives it.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from ..errors import InvalidStateError, SurfaceImpact
from .events import AltitudeCrossing
from .perturbations import ellipsoid_radius_of, flattening_of

__all__ = ["SurfaceCrossing", "watched_body", "altitude_km", "with_surface", "check_single",
           "batch_impact"]


class SurfaceCrossing(AltitudeCrossing):
    """The geodetic altitude reaches 0 (either direction of time): the run stops there."""

    name = "surface"
    #: a guard, not a measurement: it does not make the force model tabulate the Earth's pole
    #: (about the pole when a force did, else about the frame's z axis: < 60 m apart)
    uses_pole = False

    def __init__(self):
        super().__init__(0.0 * u.km, direction=0, terminal=True)


def watched_body(gm_km3_s2: float, perturbations, r0_km):
    """The central body whose surface bounds the run, or None; refuses initial positions
    ``r0_km`` (3,) or (N, 3) below that surface.

    A run with perturbations about a known body (its GM within 0.1 % of one in
    :data:`visviva.bodies.BODIES`, or a body a perturbation names) is watched; pure two-body
    motion and a GM of no known body are not.
    """
    from ..bodies import BODIES

    if not perturbations:
        return None
    body = next((p.central_body for p in perturbations if p.central_body is not None), None)
    if body is None:
        same = [b for b in BODIES.values()
                if abs(float(gm_km3_s2) / b.gm_km3_s2 - 1.0) <= 1e-3]
        if not same:
            return None
        body = same[0]
    h = np.atleast_1d(altitude_km(r0_km, body))
    if np.any(h < 0.0):
        k = int(np.argmin(h))
        where = f"state {k} starts" if np.ndim(r0_km) == 2 else "the initial state is"
        raise InvalidStateError(
            f"{where} {-float(h[k]):.6g} km below the surface of {body.name} (geodetic "
            f"altitude above its ellipsoid, equatorial radius {ellipsoid_radius_of(body)} km): the "
            "perturbations "
            "of that body mean nothing there. Check the position's units and frame (km, "
            "centred on the body), or propagate without perturbations for a conic."
        )
    return body


def altitude_km(r_km, body, pole=(0.0, 0.0)) -> np.ndarray:
    """Geodetic altitude (km) of positions ``r_km`` (..., 3): the exact height above ``body``'s
    ellipsoid about the pole whose unit vector has x, y ``pole`` (default the frame's z axis),
    the compiled altitude event's (:func:`visviva.core.geodetic.geodetic`)."""
    from ..core import tier
    from ..core.geodetic import geodetic_altitudes

    r = np.asarray(r_km, dtype=np.float64)
    flat = np.ascontiguousarray(r.reshape(-1, 3))
    out = np.empty(flat.shape[0])
    tier.call(  # a small call on a fresh install runs interpreted (core/tier.py)
        geodetic_altitudes, flat, float(ellipsoid_radius_of(body)), float(flattening_of(body)),
        float(pole[0]), float(pole[1]), out, small=flat.shape[0] <= tier.SMALL_ITEMS)
    return out.reshape(r.shape[:-1])


def with_surface(events, body) -> list:
    """``events`` and, for a watched run, the terminal :class:`SurfaceCrossing`."""
    return list(events) + ([SurfaceCrossing()] if body is not None else [])


def _impact(body, t_s: float, result, what: str) -> SurfaceImpact:
    return SurfaceImpact(
        f"the trajectory reached the surface of {body.name} at t = {t_s:.6f} s from the epoch "
        f"(geodetic altitude 0), where the force model means nothing: {what} To stop earlier "
        "without an error, pass events=[vv.satellites.ReEntry()] (100 km) or another terminal "
        "AltitudeCrossing.",
        t=t_s * u.s, result=result)


def check_single(result, body):
    """``result`` of one state, or :class:`~visviva.errors.SurfaceImpact` when its run stopped
    at the surface (the run up to the impact attached)."""
    hit = next((e for e in result.events if e.name == SurfaceCrossing.name), None)
    if body is None or hit is None:
        return result
    raise _impact(body, float(hit.t.to_value(u.s)), result,
                  "the propagation stopped there; the run up to the impact is in exc.result "
                  "(exc.result.t, .r, .v, .events).")


def batch_impact(body, k: int, t_s: float, result) -> SurfaceImpact:
    """The :class:`~visviva.errors.SurfaceImpact` of state ``k`` of a batch, which reached the
    surface at ``t_s`` (s from the epoch); ``result`` the batch's run (NaN where a state did not
    get to), ``exc.state`` = ``k``."""
    exc = _impact(body, t_s, result,
                  f"state {k} of the batch stopped there (the first state, by index, that did). "
                  "exc.result holds every state at every output time it reached (NaN after an "
                  "impact).")
    exc.state = k
    return exc
