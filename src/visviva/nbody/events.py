"""What a :class:`visviva.Simulation` raises when a run stops: events, singular states, small steps.

The kernels signal with a status code (:mod:`visviva.core.status`) and the event's particles in
``istate``; these functions turn that into the typed exception with what to do.
"""

from __future__ import annotations

import numpy as np

from ..core import nbody_common as _nc
from ..core import status as _st
from ..errors import (
    STATUS_TABLE,
    Collision,
    Encounter,
    Escape,
    InvalidStateError,
    StepSizeError,
    fmt_number,
    raise_for_status,
)
from .trajectory import coincident_pairs

__all__ = ["raise_non_finite", "check_not_coincident", "raise_event"]


def raise_non_finite(state, integrator: str):
    """Raise InvalidStateError for a run that produced NaN or infinite values."""
    t = float(state.fstate[_nc.F_T])
    check_not_coincident(state, f"{integrator} integration")
    raise InvalidStateError(
        f"the {integrator} integration produced NaN or infinite accelerations, "
        f"positions or velocities (by t = {fmt_number(t)}): a force overflowed or was singular. "
        "To fix: check the additional forces, use a smaller dt, softening > 0, or collision "
        "detection (radius=..., collision='merge')."
    )


def check_not_coincident(state, what: str):
    """Raise InvalidStateError when massive particles share a position without softening."""
    t = float(state.fstate[_nc.F_T])
    pairs = coincident_pairs(state.x, state.m, state.fstate[_nc.F_SOFT2])
    if pairs:
        raise InvalidStateError(
            f"{what}: particles {pairs[0]} are at exactly the same position "
            f"{state.x[pairs[0][0]].tolist()} at t = {fmt_number(t)}, where the point-mass "
            "gravity (and the potential energy) is infinite. To fix: separate them, set "
            "softening > 0, or give them radii with collision='merge'."
        )


def raise_event(state, status: int, integrator: str):
    """Raise the exception for a kernel's status (event, tiny step, non-finite values)."""
    t = float(state.fstate[_nc.F_T])
    a, b = int(state.istate[_nc.I_EVENT_A]), int(state.istate[_nc.I_EVENT_B])
    if status in (_st.COLLISION, _st.ENCOUNTER, _st.ESCAPE):
        cls = {_st.COLLISION: Collision, _st.ENCOUNTER: Encounter, _st.ESCAPE: Escape}[status]
        what = STATUS_TABLE[status][1]
        parts = (a,) if b < 0 else (a, b)
        raise cls(f"{what} at t = {fmt_number(t)}: particles {parts}. The simulation stopped "
                  "there and can be continued.", t=t, particles=parts)
    if status == _st.STEP_TOO_SMALL:
        check_not_coincident(state, f"{integrator} integration")
        floor = float(state.fstate[_nc.F_DT_FLOOR])
        failed = float(state.fstate[_nc.F_DT_FAILED])
        detail = (f" (proposed step {failed:.3g} < floor {floor:.3g})" if floor > 0 else "")
        min_dt = float(state.fstate[_nc.F_MIN_DT])
        if min_dt > 0 and floor == min_dt:  # the user's floor (REBOUND's min_dt goes on)
            raise StepSizeError(
                f"{integrator} integration stopped at t = {fmt_number(t)}: the adaptive step "
                f"needed {failed:.3g}, below min_dt = {min_dt:.6g}. visviva refuses a step the "
                "accuracy control rejects (REBOUND's min_dt takes such steps anyway, at an "
                "accuracy nobody checks). To fix: lower min_dt (0: only the relative floor of "
                "1e-15 of the time span), or, for a (nearly) colliding pair, give the particles "
                "radii and collision='merge', 'bounce' or 'halt', or set softening > 0.")
        raise StepSizeError(
            f"{integrator} integration stopped at t = {fmt_number(t)}: the adaptive step fell "
            f"below its floor{detail}, the larger of min_dt and 1e-15 times max(|t|, time "
            "span): the run could not finish. Particles are probably (nearly) colliding or a "
            "force is singular. To fix: give the particles radii and collision='merge' or "
            "'bounce' (or 'halt'), set softening > 0, separate the particles, or integrate a "
            "shorter span."
        )
    if status == _st.NON_FINITE:
        raise_non_finite(state, integrator)
    raise_for_status(np.array([status]), f"{integrator} integration to t")

