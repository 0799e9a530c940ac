"""The forward leg of a Cowell run with burns, integrated segment by segment.

The run is split at 0, every burn's start and end, and the last output time. Each segment is
one call of the compiled integrator (:func:`visviva.satellites.cowell._run`) from a fresh
start: its own t = 0 (the force block's time origin moved there,
:func:`visviva.core.force_block.with_time_origin`), a fresh first derivative and step size,
the thrust slots of the finite burn that is on over it. Impulses are added between segments.
Outputs in [a, b) come from the segment [a, b); an output at an impulse's epoch is the state
after the impulse.
"""

from __future__ import annotations

import numpy as np

__all__ = ["run_segments"]


def run_segments(schedule, run_one, y0, t_out, t_end, model, rtol, atol, h_max, max_steps, ev,
                 ev_tol):
    """Integrate from t = 0 to ``t_end`` > 0 through the burns of ``schedule``.

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
    schedule.snap(t_out)
    points = schedule.breakpoints(float(t_end))
    y = np.array(y0, dtype=np.float64)
    ys, ets, eys, ews = [], [], [], []
    info = np.zeros(6)
    info[5] = -1.0
    status = 0
    t_reached = 0.0
    for i, a in enumerate(points):
        for burn in schedule.impulses_at(a):
            dv = burn.delta_v_inertial(y[:3], y[3:])
            y[3:] += dv
            schedule.log_impulse(burn, a, dv)
        if i == len(points) - 1:  # t_end: the outputs there, after its impulses
            ys.append(np.tile(y, (int(np.count_nonzero(t_out == a)), 1)))
            break
        b = points[i + 1]
        schedule.check_state(a, y)
        mask = (t_out >= a) & (t_out < b)
        n_seg = int(np.count_nonzero(mask))
        seg = schedule.segment_model(model, a, b)
        # the segment's outputs, then its end (the state the next segment starts from)
        t_seg = np.ascontiguousarray(np.append(t_out[mask] - a, b - a))
        status, y_seg, ev_t, ev_y, ev_which, seg_info = run_one(
            y, t_seg, b - a, seg, rtol, atol, h_max, max(1, max_steps - int(info[2])), ev,
            ev_tol)
        ys.append(y_seg[:n_seg])
        ets.append(ev_t + a)
        eys.append(ev_y)
        ews.append(ev_which)
        info[1] += seg_info[1]
        info[2] += seg_info[2]
        info[3] += seg_info[3]
        t_reached = a + seg_info[4]
        if status != 0 or seg_info[5] >= 0:  # failed, or a terminal event
            info[5] = seg_info[5]
            break
        y = y_seg[n_seg].copy()
    schedule.log_finite(t_reached)
    y_out = np.concatenate(ys) if ys else np.zeros((0, 6))
    info[0] = len(y_out)
    info[4] = t_reached
    ev_t = np.concatenate(ets) if ets else np.zeros(0)
    ev_y = np.concatenate(eys) if eys else np.zeros((0, 6))
    ev_which = np.concatenate(ews) if ews else np.zeros(0)
    return status, y_out, ev_t, ev_y, ev_which, info
