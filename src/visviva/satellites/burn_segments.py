"""A leg of a Cowell run with burns (forward or backward from the epoch), segment by segment.

The leg is split at 0, every burn's start and end, and its last output time. Each segment is
one call of the compiled integrator (``cowell._run`` for one state,
``cowell_batch.run_many`` for N) from a fresh start: its own t = 0 (the force block's time origin moved there,
:func:`visviva.core.force_block.with_time_origin`), a fresh first derivative and step size,
the thrust slots of the finite burn that is on over it. Impulses are added between segments.
Backwards, impulses are taken off and finite burns' thrust is integrated with the mass growing
back (the same m(t) as forwards). An output at an impulse's epoch is the state after the
impulse. States are ``(..., 6)`` and outputs ``(..., T, 6)`` for one state or N.
"""

from __future__ import annotations

import math

import numpy as np
from astropy import units as u

from .._units import to_quantity
from ..core import force_block as fb
from ..core.local_frames import INERTIAL, local_axes
from ..errors import InvalidInputError, InvalidStateError
from .burns import BurnRecord, FiniteBurn, ImpulsiveBurn, refuse_pending

__all__ = ["Schedule", "SNAP_S", "burn_schedule", "distinct_burns", "run_segments",
           "run_segments_many"]

#: A segment shorter than this (burn epochs less than a nanosecond apart) is not integrated (the
#: integrator cannot step below ~1e-322 s from t = 0): the state drifts along its velocity over
#: it, off the true motion by |a| dt^2 / 2 < 1e-20 km.
DRIFT_S = 1e-9


def _drive(schedule, model, t_out, t_end, y0, segment, jump=None):
    """Walk the segments of ``schedule`` from 0 to ``t_end`` (either sign; ``t_out`` in the
    run's direction); ``segment(y, t_seg, a, b, seg_model)`` integrates one and returns
    ``(y_out, stopped_at)`` (``stopped_at``: None when it reached b, else the time, s from the
    epoch, where it stopped). Returns the outputs ``(..., T, 6)`` and the time reached.

    Forwards, the impulses at a breakpoint are added on arrival (an impulse at 0 too: the
    state given is the one before it). Backwards, they are taken off on arrival
    (:meth:`~visviva.satellites.burns.ImpulsiveBurn.pre_burn_velocity`), except at 0 (the state
    given is before those) and at ``t_end``. Either way an output at an impulse's epoch is the
    state after the impulse. (The schedule is snapped to the outputs and 0 before.)
    ``jump(a, y_before, y_after)`` (optional) sees the states just before and after the
    impulses at ``a`` in physical time and returns True to stop there (a terminal event)."""
    points = schedule.breakpoints(float(t_end))
    backward = t_end < 0
    y = np.array(y0, dtype=np.float64)
    pieces = []
    t_reached = 0.0
    for i, a in enumerate(points):
        if i > 0 or not backward:
            impulses = schedule.impulses_at(a)
            stop = False
            if impulses and not backward:
                y_before = y.copy()
                for burn in impulses:
                    dv = burn.delta_v_inertial(y[..., :3], y[..., 3:])
                    y[..., 3:] += dv
                    schedule.log_impulse(burn, a, dv)
                stop = jump is not None and jump(a, y_before, y)
            # the outputs at a: the state there, after its impulses
            pieces.append(np.repeat(y[..., None, :], int(np.count_nonzero(t_out == a)), axis=-2))
            if i == len(points) - 1 or stop:
                t_reached = a
                break
            if impulses and backward:
                y_after = y.copy()
                for burn in impulses[::-1]:
                    v_before = burn.pre_burn_velocity(y[..., :3], y[..., 3:])
                    dv = y[..., 3:] - v_before
                    y[..., 3:] = v_before
                    schedule.log_impulse(burn, a, dv, backward=True)
                if jump is not None and jump(a, y, y_after):
                    t_reached = a
                    break
        b = points[i + 1]
        schedule.check_state(a, b, y)
        mask = (t_out < a) & (t_out > b) if backward else (t_out > a) & (t_out < b)
        n_seg = int(np.count_nonzero(mask))
        # the segment's outputs, then its end (the state the next segment starts from)
        t_seg = np.ascontiguousarray(np.append(t_out[mask] - a, b - a))
        if abs(b - a) < DRIFT_S:
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
    """Integrate one state from t = 0 to ``t_end`` (either sign) through the burns of
    ``schedule``.

    Parameters
    ----------
    schedule : Schedule
        The burns (s from the epoch) and their log (written here).
    run_one : callable
        ``cowell._run``: one segment.
    y0, t_out, t_end, model, rtol, atol, h_max, max_steps, ev, ev_tol
        As for ``cowell._run`` (``t_out`` from 0 towards ``t_end``, its last entry).

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

    epochs = []

    def jump(a, y_before, y_after):
        """The events whose sign the impulses at ``a`` flip (an apsis made by a burn)."""
        from ..core.cowell_events import event_function

        epochs.append(a)
        force, _, _, eph_r, eph_v = (fb.with_time_origin(model.force, a),) + model.arrays()[1:5]
        kinds, params, dirs, terms = ev
        stop = False
        def side(e, y, dt):
            """The sign of event ``e`` at ``y``, or where it is zero, ``dt`` s later (on a
            two-body drift): the integrator skips a zero at a segment's start, and reports
            one at its end as a crossing to the other side."""
            g = event_function(kinds[e], params[e], 0.0, y, force, eph_r, eph_v)
            if g == 0.0:
                r = y[:3]
                acc = -force[fb.GM] * r / np.linalg.norm(r) ** 3
                near = np.concatenate([r + y[3:] * dt + 0.5 * acc * dt * dt, y[3:] + acc * dt])
                g = event_function(kinds[e], params[e], dt, near, force, eph_r, eph_v)
                g = g if dt > 0 else -g
            return -1.0 if g < 0.0 else 1.0

        for e in range(kinds.size):
            s0, s1 = side(e, y_before, -1e-3), side(e, y_after, 1e-3)
            rising = s1 > s0
            if s0 == s1 or dirs[e] * s1 < 0:
                continue
            events.append((np.array([a]), y_after[None, :].copy(),
                           np.array([(e + 1.0) * (1.0 if rising else -1.0)])))
            if terms[e] != 0 and not stop:
                info[5], stop = e, True
        return stop

    y_out, info[4] = _drive(schedule, model, t_out, t_end, y0, segment, jump)
    info[0] = len(y_out)
    ev_t, ev_y, ev_which = (np.concatenate([e[k] for e in events]) if events else
                            np.zeros((0, 6) if k == 1 else 0) for k in range(3))
    order = np.argsort(ev_t * np.sign(t_end or 1.0), kind="stable")  # in the run's direction
    keep = _cancel_touches(ev_t[order], ev_which[order], epochs, 2.0 * ev_tol)
    order = order[keep]
    return status[0], y_out, ev_t[order], ev_y[order], ev_which[order], info


def _cancel_touches(ev_t, ev_which, epochs, window):
    """Which events to keep: at an impulse's epoch a crossing of the event function across the
    jump and one found by the integrator on either side within ``window`` (s) of it, in
    opposite directions, are one touch of zero, not two crossings (a burn at an apsis that
    leaves the orbit's radius rising, or falling, on both sides): both are dropped, so that an
    apsis made or unmade by a burn is reported once or not at all.

    Parameters
    ----------
    ev_t, ev_which : ndarray
        The events in the run's order: times (s from the epoch) and (index + 1) x direction.
    epochs : list of float
        The impulses' epochs.
    window : float
        s.

    Returns
    -------
    ndarray of bool
    """
    keep = np.ones(ev_t.size, dtype=bool)
    for a in epochs:
        near = np.flatnonzero(np.abs(ev_t - a) <= window)
        for e in np.unique(np.abs(ev_which[near])):
            stack = []
            for k in near[np.abs(ev_which[near]) == e]:
                if stack and np.sign(ev_which[stack[-1]]) != np.sign(ev_which[k]):
                    keep[stack.pop()] = keep[k] = False
                else:
                    stack.append(k)
    return keep


def run_segments_many(schedule, run_many, y0, t_out, t_end, model, rtol, atol, h_max,
                      max_steps):
    """Integrate N states (rows of ``y0``) from t = 0 to ``t_end`` (either sign) through the
    burns.

    Parameters
    ----------
    schedule : Schedule
        The burns; each applies to every state (a local frame at each state's own r, v).
    run_many : callable
        ``cowell_batch.run_many``: one segment for all states.
    y0, t_out, t_end, model, rtol, atol, h_max, max_steps
        As for ``cowell_batch.run_many``.

    Returns
    -------
    tuple
        ``(y_out (N, T, 6), status (N,), info (N, 6))`` for the whole leg.
    """
    n = y0.shape[0]
    info = np.zeros((n, 6))
    info[:, 5] = -1.0
    status = np.zeros(n, dtype=np.int64)

    def segment(y, t_seg, a, b, seg):
        y_seg, st, seg_info = run_many(y, t_seg, b - a, seg, rtol, atol, h_max,
                                       max(1, max_steps - int(info[:, 2].max())))
        info[:, 2:4] += seg_info[:, 2:4]
        info[:, 4] = a + seg_info[:, 4]
        if np.any(st != 0):
            status[:] = st
            return y_seg, a + float(seg_info[:, 4].min())
        hit = seg_info[:, 5] >= 0  # a terminal event (the surface): the batch stops there
        if hit.any():
            info[hit, 5] = seg_info[hit, 5]
            return y_seg, a + float(seg_info[hit, 4][0])
        return y_seg, None

    y_out, _ = _drive(schedule, model, t_out, t_end, y0, segment)
    return y_out, status, info


#: A burn's start or end this close to an output time (s) is taken at that time: offsets from
#: astropy Times round at 1e-12 s, which must not move an output to the other side of a burn.
SNAP_S = 1e-6


class Schedule:
    """The burns of one run, ordered, with the log of what they did."""

    def __init__(self, items):
        self.items = items  # (start_s, end_s, burn), by start
        self.records = []

    def __bool__(self) -> bool:
        """Whether there is any burn (an empty schedule runs as no schedule)."""
        return bool(self.items)

    def snap(self, t_out) -> None:
        """Move burn starts and ends within :data:`SNAP_S` of an output time onto it (a finite
        burn whose start and end would meet keeps its duration)."""
        t_out = np.asarray(t_out, dtype=np.float64)
        if t_out.size == 0:
            return

        def near(x):
            k = int(np.searchsorted(t_out, x))
            close = [t_out[j] for j in (k - 1, k) if 0 <= j < t_out.size]
            best = min(close, key=lambda c: abs(c - x))
            return float(best) if abs(best - x) <= SNAP_S else x

        def both(a, b):  # a finite burn never shrinks to nothing: then it moves as a whole
            a1, b1 = near(a), near(b)
            return (a1, b1) if b1 > a1 or a == b else (a1, a1 + (b - a))

        self.items = [(*both(a, b), m) for a, b, m in self.items]

    def check_state(self, a: float, b: float, y) -> None:
        """Refuse a finite burn in a local frame that is on over the segment from ``a`` to
        ``b`` where the frame is undefined at its first state ``y`` (one state (6,) or N
        states (N, 6))."""
        for start, end, burn in self.items:
            if (isinstance(burn, FiniteBurn) and start <= min(a, b) < end
                    and burn.code != INERTIAL):
                if not np.all(np.isfinite(local_axes(y[..., :3], y[..., 3:], burn.code))):
                    where = "its start" if a == start else f"t = {a:g} s"
                    raise InvalidStateError(
                        f"the {burn.frame} frame of {burn!r} is undefined at {where} (r x v = 0 "
                        "or v = 0): give its direction in GCRS."
                    )

    def breakpoints(self, t_last: float) -> list:
        """0, the burns' starts and ends between 0 and ``t_last`` (either sign), and
        ``t_last``, unique, in the run's direction (decreasing for a backward leg)."""
        pts = {0.0, t_last}
        lo, hi = min(0.0, t_last), max(0.0, t_last)
        for a, b, _ in self.items:
            pts.update(x for x in (a, b) if lo <= x <= hi)
        return sorted(pts, reverse=t_last < 0)

    def crosses(self, t_last: float) -> bool:
        """Whether the leg from 0 to ``t_last`` meets a burn: one inside it, a finite burn on
        over it, or an impulse at 0 (forward legs apply those; a backward leg starts after)."""
        for a, b, burn in self.items:
            finite = isinstance(burn, FiniteBurn)
            if t_last >= 0 and ((finite and a < t_last and b > 0.0) or 0.0 <= a <= t_last):
                return True
            if t_last < 0 and ((finite and a < 0.0 and b > t_last) or t_last < a < 0.0):
                return True
        return False

    def segment_model(self, model, a: float, b: float):
        """The force model of the segment from a to b (s from the epoch, either direction): its
        time origin at a, the thrust of the finite burn that is on over it, drag and SRP scaled
        to the spacecraft's mass there (:func:`visviva.satellites.burn_mass.scale_area`)."""
        from .burn_mass import scale_area

        force = fb.with_time_origin(model.force, a)
        lo = min(a, b)
        for start, end, burn in self.items:
            if isinstance(burn, FiniteBurn) and start <= lo < end:
                burn.pack(force, a - start)
        scale_area(self, force, a, b)
        return _SegmentModel(force, model)

    def impulses_at(self, t: float) -> list:
        return [b for a, _, b in self.items if a == t and isinstance(b, ImpulsiveBurn)]

    def log_impulse(self, burn, t, dv, backward: bool = False):
        n = np.linalg.norm(dv, axis=-1)
        after = (None if burn.mass is None else
                 burn.mass + (0.0 * u.kg if burn.delta_mass is None else burn.delta_mass))
        self.records.append(BurnRecord(burn, t * u.s, t * u.s, n * u.km / u.s,
                                       to_quantity(dv, "speed"), burn.mass, after, True,
                                       backward))

    def log_finite(self, t_reached: float):
        """Record the finite burns the leg from 0 to ``t_reached`` (s, either sign) crossed,
        each the part of it inside the leg (cut where the leg stopped)."""
        lo, hi = min(0.0, t_reached), max(0.0, t_reached)
        for start, end, burn in self.items:
            if isinstance(burn, FiniteBurn) and start < hi and end > lo:
                t0, t1 = max(start, lo), min(end, hi)
                m0, m1 = burn.mass_at(t0 - start), burn.mass_at(t1 - start)
                dv = burn.delta_v_after(t1 - start) - burn.delta_v_after(t0 - start)
                self.records.append(BurnRecord(
                    burn, t0 * u.s, t1 * u.s, dv * u.km / u.s, None,
                    None if m0 is None else m0 * u.kg, None if m1 is None else m1 * u.kg,
                    t0 == start and t1 == end, t_reached < 0))

    def _leg(self, plain, segmented):
        """``plain`` (``cowell._run`` or ``cowell_batch.run_many``) for a leg that meets no burn
        (the same bits as a run without burns), else ``segmented`` with this schedule."""
        def run(*args):
            self.snap(np.sort(np.append(args[1], 0.0)))
            if not self.crosses(float(args[2])):
                return plain(*args)
            return segmented(self, plain, *args)

        return run

    def run(self, run_one):
        """A function with the signature and outputs of ``cowell._run`` that integrates a leg
        (forward or backward from the epoch) segment by segment."""
        return self._leg(run_one, run_segments)

    def run_many(self, run_many):
        """The same for N states and ``cowell_batch.run_many``."""
        return self._leg(run_many, run_segments_many)

    def annotate(self, result) -> None:
        """Set ``result.burns`` (records by start) and ``result.final_mass`` (the mass after
        the latest burn the run crossed that knows its mass, either direction)."""
        records = sorted(self.records, key=lambda r: r.t_start.value)
        result.burns = records
        masses = [r.mass_after for r in records if r.mass_after is not None]
        result.final_mass = masses[-1] if masses else None


class _SegmentModel:
    """A force model whose block is replaced (``.force``, ``.arrays()``) for one segment."""

    def __init__(self, force, model):
        self.force = force
        self._model = model

    def arrays(self):
        return (self.force,) + self._model.arrays()[1:]


def distinct_burns(maneuvers) -> list:
    """``maneuvers`` as a list in which a burn object given more than once is a copy from its
    second occurrence on: each entry is flown (twice for a burn listed twice, as
    :func:`visviva.propagate_cowell` does) and has columns of its own in the partials on Δv
    (:mod:`visviva.satellites.burn_partials` tells the impulses apart by identity)."""
    import copy

    seen, out = set(), []
    for m in maneuvers:
        out.append(copy.copy(m) if id(m) in seen else m)
        seen.add(id(m))
    return out


def burn_schedule(maneuvers, state, epoch):
    """Check ``maneuvers`` of :func:`visviva.propagate_cowell` and order them.

    Parameters
    ----------
    maneuvers : None or iterable of ImpulsiveBurn / FiniteBurn
        As given (None: the default).
    state : StateVectors
        The initial state (an OPM's state says how many manoeuvres its message has).
    epoch : astropy.time.Time or None
        The state's epoch.

    Returns
    -------
    visviva.satellites.burn_segments.Schedule or None
        None without ``maneuvers``; an empty (false) schedule for an empty list.
    """
    if maneuvers is None:
        refuse_pending(state, "propagate_cowell", "Pass maneuvers=opm.burns() to apply them (or "
                       "call opm.propagate(t, perturbations)), or maneuvers=[] to propagate "
                       "without.")
        return None
    if isinstance(maneuvers, ImpulsiveBurn | FiniteBurn):
        maneuvers = [maneuvers]
    maneuvers = distinct_burns(maneuvers)
    if not maneuvers:
        return Schedule([])  # nothing to split at; the result reports no burns
    for m in maneuvers:
        if not isinstance(m, ImpulsiveBurn | FiniteBurn):
            raise InvalidInputError(
                f"{m!r} is not a burn; give vv.ImpulsiveBurn(...) or vv.FiniteBurn(...) (an "
                "OPM's manoeuvres: opm.burns())."
            )
    items = []
    for m in maneuvers:
        a = m.start_offset_s(epoch)
        if not math.isfinite(a):
            raise InvalidInputError(f"{m!r} starts at {a} s from the state's epoch.")
        items.append((a, a + getattr(m, "duration_s", 0.0), m))
    items.sort(key=lambda x: x[0])
    for i, (a, b, m) in enumerate(items):
        if not isinstance(m, FiniteBurn):
            continue
        for j, (c, d, other) in enumerate(items):
            if j == i:
                continue
            inside = a < c < b if isinstance(other, ImpulsiveBurn) else (c < b and a < d)
            if inside:
                raise InvalidInputError(
                    f"{other!r} overlaps {m!r}; burns must not overlap (an impulse may sit at a "
                    "finite burn's start or end)."
                )
    from .burn_mass import check_chain

    check_chain(items)
    return Schedule(items)
