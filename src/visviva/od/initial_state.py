"""The first guess of an orbit fit or filter: one geocentric GCRS state with an epoch."""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["check_initial"]


def check_initial(initial, maneuvers=None):
    from .._units import to_array, to_vector

    if not (hasattr(initial, "r") and hasattr(initial, "v") and hasattr(initial, "gm")):
        raise InvalidInputError(
            "initial must be a vv.StateVectors first guess (e.g. from vv.gauss_angles or "
            "vv.gibbs); got " + type(initial).__name__ + "."
        )
    if hasattr(initial, "to_states") and hasattr(initial, "times"):
        # a CowellResult: its r, v are at .times (its .epoch is where the propagation began)
        initial = initial.to_states()
    from .._containers import refuse_pending
    from ..satellites.satellite_states import require_gcrs

    require_gcrs(initial, "orbit determination")
    if maneuvers is None:
        refuse_pending(initial, "orbit determination (fit_orbit, filter_orbit, "
                       "simulate_observations)", "Pass maneuvers=opm.burns() to fly them (or "
                       "maneuvers=[] to leave them out).")
    r0 = to_vector(initial.r, "length", "initial.r")
    v0 = to_vector(initial.v, "speed", "initial.v")
    if r0.shape != (3,) or v0.shape != (3,):
        raise InvalidInputError(f"initial must be one state (r shape (3,)); got {r0.shape}.")
    gm = float(np.ravel(to_array(initial.gm, "gm", "initial.gm"))[0])
    from ..satellites.cowell import central_body

    body = central_body(gm, [])
    if body.name != "earth":  # audit20: a Moon-centred guess "converged" on Earth tracking
        raise InvalidInputError(
            f"the state's gm = {gm:.10g} km3/s2 is the {body.name.capitalize()}'s: orbit "
            "determination works in the GCRS, about the Earth (ground stations are on the "
            "Earth, position rows are geocentric). Give a geocentric state (gm=vv.EARTH), "
            f"converted from the {body.name.capitalize()}-centred one."
        )
    epoch = getattr(initial, "epoch", None)
    if epoch is None:
        raise InvalidInputError(
            "initial has no epoch: build it with epoch=Time(...) (the estimate is the state at "
            "that epoch)."
        )
    if not epoch.isscalar:
        epoch = epoch.ravel()[0]
    return np.concatenate([r0, v0]), gm, epoch
