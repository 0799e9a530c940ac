"""The forward leg of a Cowell run with burns, integrated segment by segment.

The run is split at 0, every burn's start and end, and the last output time. Each segment is
one call of the compiled integrator (``cowell._run`` for one state, ``cowell._run_many`` for N)
from a fresh start: its own t = 0 (the force block's time origin moved there,
:func:`visviva.core.force_block.with_time_origin`), a fresh first derivative and step size,
the thrust slots of the finite burn that is on over it. Impulses are added between segments.
Outputs in [a, b) come from the segment [a, b); an output at an impulse's epoch is the state
after the impulse. States are ``(..., 6)`` and outputs ``(..., T, 6)`` for one state or N.
"""

from __future__ import annotations

import numpy as np

__all__ = ["run_segments", "run_segments_many"]

#: A segment shorter than this (burn epochs less than a nanosecond apart) is not integrated (the
#: integrator cannot step below ~1e-322 s from t = 0): the state drifts along its velocity over
#: it, off the true motion by |a| dt^2 / 2 < 1e-20 km.
DRIFT_S = 1e-9


def _drive(schedule, model, t_out, t_end, y0, segment):
    """Walk the segments of ``schedule`` up to ``t_end``; ``segment(y, t_seg, a, b, seg_model)``
    integrates one and returns ``(y_out, stopped_at)`` (``stopped_at``: None when it reached b,
    else the time, s from the epoch, where it stopped). Returns the outputs ``(..., T, 6)``."""
    schedule.snap(t_out)
    points = schedule.breakpoints(float(t_end))
    y = np.array(y0, dtype=np.float64)
    pieces = []
    t_reached = 0.0
    for i, a in enumerate(points):
        for burn in schedule.impulses_at(a):
            dv = burn.delta_v_inertial(y[..., :3], y[..., 3:])
            y[..., 3:] += dv
            schedule.log_impulse(burn, a, dv)
        if i == len(points) - 1:  # t_end: the outputs there, after its impulses
            t_reached = a
            pieces.append(np.repeat(y[..., None, :], int(np.count_nonzero(t_out == a)), axis=-2))
            break
        b = points[i + 1]
        schedule.check_state(a, y)
        mask = (t_out >= a) & (t_out < b)
        n_seg = int(np.count_nonzero(mask))
        # the segment's outputs, then its end (the state the next segment starts from)
        t_seg = np.ascontiguousarray(np.append(t_out[mask] - a, b - a))
        if b - a < DRIFT_S:
            y_seg = np.repeat(y[..., None, :], t_seg.size, axis=-2)
            y_seg[..., :3] += y[..., None, 3:] * t_seg[:, None]
            pieces.append(y_seg[..., :n_seg, :])
            y = y_seg[..., n_seg, :].copy()
            continue
        y_seg, stopped_at = segment(np.ascontiguousarray(y), t_seg, a, b,
                                    schedule.segment_model(model, a, b))
        pieces.append(y_seg[..., :n_seg, :])
        if stopped_at is not None:  # failed, or a terminal event
            t_reached = stopped_at
            break
        y = y_seg[..., n_seg, :].copy()
    schedule.log_finite(t_reached)
    return np.concatenate(pieces, axis=-2), t_reached


def run_segments(schedule, run_one, y0, t_out, t_end, model, rtol, atol, h_max, max_steps, ev,
                 ev_tol):
    """Integrate one state from t = 0 to ``t_end`` > 0 through the burns of ``schedule``.

    Parameters
    ----------
    schedule : visviva.satellites.burns._Schedule
        The burns (s from the epoch) and their log (written here).
    run_one : callable
        ``cowell._run``: one segment.
    y0, t_out, t_end, model, rtol, atol, h_max, max_steps, ev, ev_tol
        As for ``cowell._run`` (``t_out`` >= 0, increasing; ``t_end`` its last entry).

    Returns
    -------
    tuple
        ``(status, y_out, ev_t, ev_y, ev_which, info)`` as ``cowell._run`` returns them for the
        whole leg: event times from the epoch, ``info`` summed over the segments (final time
        and terminal event of the last segment run).
    """
    info = np.zeros(6)
    info[5] = -1.0
    status = [0]
    events = []

    def segment(y, t_seg, a, b, seg):
        st, y_seg, ev_t, ev_y, ev_which, seg_info = run_one(
            y, t_seg, b - a, seg, rtol, atol, h_max, max(1, max_steps - int(info[2])), ev,
            ev_tol)
        status[0] = st
        events.append((ev_t + a, ev_y, ev_which))
        info[1:4] += seg_info[1:4]
        if st != 0 or seg_info[5] >= 0:
            info[5] = seg_info[5]
            return y_seg, a + seg_info[4]
        return y_seg, None

    y_out, info[4] = _drive(schedule, model, t_out, t_end, y0, segment)
    info[0] = len(y_out)
    ev_t, ev_y, ev_which = (np.concatenate([e[k] for e in events]) if events else
                            np.zeros((0, 6) if k == 1 else 0) for k in range(3))
    return status[0], y_out, ev_t, ev_y, ev_which, info


def run_segments_many(schedule, run_many, y0, t_out, t_end, model, rtol, atol, h_max,
                      max_steps):
    """Integrate N states (rows of ``y0``) from t = 0 to ``t_end`` > 0 through the burns.

    Parameters
    ----------
    schedule : visviva.satellites.burns._Schedule
        The burns; each applies to every state (a local frame at each state's own r, v).
    run_many : callable
        ``cowell._run_many``: one segment for all states.
    y0, t_out, t_end, model, rtol, atol, h_max, max_steps
        As for ``cowell._run_many``.

    Returns
    -------
    tuple
        ``(y_out (N, T, 6), status (N,), info (N, 6))`` for the whole leg.
    """
    n = y0.shape[0]
    info = np.zeros((n, 6))
    status = np.zeros(n, dtype=np.int64)

    def segment(y, t_seg, a, b, seg):
        y_seg, st, seg_info = run_many(y, t_seg, b - a, seg, rtol, atol, h_max,
                                       max(1, max_steps - int(info[:, 2].max())))
        info[:, 2:4] += seg_info[:, 2:4]
        info[:, 4] = a + seg_info[:, 4]
        if np.any(st != 0):
            status[:] = st
            return y_seg, a + float(seg_info[:, 4].min())
        return y_seg, None

    y_out, _ = _drive(schedule, model, t_out, t_end, y0, segment)
    return y_out, status, info
