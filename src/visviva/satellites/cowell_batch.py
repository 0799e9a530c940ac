"""N states of one force model through the parallel Cowell kernel (``propagate_cowell`` with a
``StateVectors`` of shape (N,)).

Every state stops at the central body's surface when the run is watched
(:mod:`visviva.satellites.surface`): the parallel kernel carries the terminal altitude-0 event
of each state, located on the dense output like a single state's, and ``propagate_cowell``
raises :class:`~visviva.errors.SurfaceImpact` naming the first state that met it. (Checked at
the output times only, a state that decayed between two outputs was integrated on below the
surface through an extrapolated atmosphere until its step budget ran out.)
"""

from __future__ import annotations

import numpy as np

from ..core.cowell import integrate_cowell_many, rhs_kind
from ..errors import StepSizeError, raise_for_status
from .dop853 import dop853_tableau

__all__ = ["propagate_batch", "run_many", "raise_budget", "terminal_events"]

#: the terminal events of the parallel kernel: none, or the surface (kind 0, altitude 0, both
#: directions; :class:`visviva.satellites.surface.SurfaceCrossing`)
_NONE = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0, dtype=np.int64))
_SURFACE = (np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros(1, dtype=np.int64))


def terminal_events(surface: bool) -> tuple:
    """The parallel kernel's terminal-event arrays ``(kinds, params, directions)``: the surface
    (geodetic altitude 0) when ``surface``, else none (shared, read-only)."""
    return _SURFACE if surface else _NONE


def run_many(y0, t_out, t_end, model, rtol, atol, h_max, max_steps, surface=False):
    """N states (rows of ``y0``) through the parallel kernel: ``(y_out, status, info)``.

    With ``surface`` a state that reaches geodetic altitude 0 stops there: ``info[k, 5]`` is 0
    (else -1), ``info[k, 4]`` the time, and its outputs after it are NaN.
    """
    n = y0.shape[0]
    y_out = np.zeros((n, t_out.size, 6))
    status = np.zeros(n, dtype=np.int64)
    info = np.zeros((n, 6))
    arrays = model.arrays()  # one force block (1, F) for all N
    kinds, params, dirs = terminal_events(surface)
    integrate_cowell_many(
        y0, t_out, t_end, rtol, atol, h_max, max_steps, arrays[0][None], *arrays[1:],
        *dop853_tableau(), y_out, status, info, rhs_kind(model.force, kinds), kinds, params, dirs,
    )  # fmt: skip
    for k in np.flatnonzero(info[:, 5] >= 0):
        y_out[k, int(info[k, 0]):] = np.nan  # never reached: below the surface
    return y_out, status, info


def raise_budget(max_steps, t_reached_s, where):
    """Raise the :class:`~visviva.errors.StepSizeError` of a run that used its step budget."""
    raise StepSizeError(
        f"Cowell propagation used its whole step budget (max_steps={max_steps}){where} and "
        f"stopped at t = {t_reached_s:.6f} s before the last output time. To fix: raise "
        "max_steps, loosen rtol/atol, or propagate a shorter span."
    )


def propagate_batch(y0, offsets, span, model, rtol, atol, h_max, max_steps, schedule,
                    surface):  # fmt: skip
    """N states (rows of ``y0``, (N, 6)) through the parallel kernel, both legs from the epoch.

    ``surface``: whether the run is watched (:func:`visviva.satellites.surface.watched_body`).
    Returns ``(y (N, T, 6), n_steps, nfev, impact)``: ``impact`` None, or (state, time s) of
    the first state, by index, that reached the surface (its outputs after it NaN; with burns
    those of every state after the segment of the impact).
    """

    def run(*args):
        return run_many(*args, surface=surface)

    pieces = []
    n_steps = nfev = 0
    impact = None
    back = offsets[offsets < 0][::-1]
    fwd = offsets[offsets >= 0]
    for part, t_end in ((back, span[0]), (fwd, span[1])):
        if part.size == 0:
            continue
        leg = schedule.run_many(run) if schedule else run
        y_out, status, info = leg(y0, np.ascontiguousarray(part), t_end, model, rtol, atol, h_max,
                                  max_steps)
        if np.any(status != 0) and np.any(info[:, 2] >= max_steps):
            k = int(np.flatnonzero(info[:, 2] >= max_steps)[0])
            raise_budget(max_steps, info[k, 4], f" for state {k}")
        raise_for_status(status, "Cowell propagation (batch)", t_reached_s=info[:, 4])
        n_steps += int(info[:, 2].sum())
        nfev += int(info[:, 3].sum())
        if y_out.shape[1] < part.size:  # burns: the run stopped at a state's impact
            missing = np.full((y_out.shape[0], part.size - y_out.shape[1], 6), np.nan)
            y_out = np.concatenate([y_out, missing], axis=1)
        hit = np.flatnonzero(info[:, 5] >= 0)
        if hit.size and (impact is None or hit[0] < impact[0]):
            impact = (int(hit[0]), float(info[hit[0], 4]))
        pieces.append(y_out[:, ::-1] if t_end < 0 else y_out)
    return np.concatenate(pieces, axis=1), n_steps, nfev, impact
