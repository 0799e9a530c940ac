"""State-transition matrices through manoeuvres, and the partials of the state on a burn's Δv.

A Cowell run with burns (:mod:`visviva.satellites.burn_segments`) is split at every burn's
start and end. Here the variational equations (:class:`visviva.satellites.variational.Dynamics`)
follow the same segments, and across each impulse the STM is multiplied by the impulse's own
Jacobian: a Δv held on a local frame's axes (RTN, TNW, VNB) turns with the state it is applied
to, so

    v+ = v- + M(r, v-)^T Δv_local,    Phi_burn = d y+ / d y- = I + [[0, 0], [J_r, J_v]],

with J = d(M^T Δv)/d(r, v) (:func:`visviva.core.local_frames.to_inertial_jacobian`; J = 0 for
an inertial Δv). The partials of the state on the burn's Δv itself are d y+ / d Δv_local =
[[0], [M^T]] at the burn, carried to later times by the STM: d y(t) / d Δv = Phi(t, t_b+)
[[0], [M^T]]. Backwards in time (a state after the burn, outputs before it) the same maps are
inverted: d y- / d y+ = Phi_burn^-1 and d y- / d Δv = -Phi_burn^-1 [[0], [M^T]] (the pre-burn
state solves v- + M(r, v-)^T Δv = v+). A finite burn's thrust is part of the force model of its
segments, with its partials (:func:`visviva.core.force_partials.acceleration_partials`).

These give the covariance through a burn with its execution error
(:func:`visviva.propagate_covariance`), the estimation of a burn's Δv
(:func:`visviva.fit_orbit` with ``estimate_maneuvers=``) and the filter's prediction across a
burn (:func:`visviva.filter_orbit`).
"""

from __future__ import annotations

import copy

import numpy as np

from ..core.force_partials import N_PARAMETERS
from ..core.local_frames import INERTIAL, local_axes, to_inertial_jacobian
from .burn_mass import area_scale
from .burn_segments import DRIFT_S
from .burns import ImpulsiveBurn

__all__ = ["impulse_jacobians", "propagate_through", "impulses_of"]


def impulses_of(schedule) -> list:
    """The impulsive burns of ``schedule`` in its order (the columns of the sensitivities)."""
    return [] if not schedule else [m for _, _, m in schedule.items
                                    if isinstance(m, ImpulsiveBurn)]


def impulse_jacobians(burn, y_minus):
    """The Jacobians of an impulse at the state just before it.

    Parameters
    ----------
    burn : ImpulsiveBurn
        The burn (its Δv on its own axes).
    y_minus : ndarray (6,)
        State before the burn, km and km/s.

    Returns
    -------
    phi_burn : ndarray (6, 6)
        d y+ / d y- = I + [[0, 0], [J_r, J_v]] (J = 0 for an inertial Δv).
    g : ndarray (6, 3)
        d y+ / d Δv = [[0], [M^T]] (km/s per km/s on the burn's axes; [[0], [I]] inertial).
    """
    y = np.ascontiguousarray(y_minus, dtype=np.float64)
    phi = np.eye(6)
    g = np.zeros((6, 3))
    if burn.code == INERTIAL:
        g[3:] = np.eye(3)
        return phi, g
    jac = np.zeros((3, 6))
    to_inertial_jacobian(burn.code, y, *burn.delta_v_km_s, jac)
    phi[3:] += jac
    g[3:] = local_axes(y[:3], y[3:], burn.code).T
    return phi, g


def _segment(dyn, schedule, y, a, b, t_rel, max_steps, parameters=False):
    """States and STMs Phi(a + t_rel, a) over one segment from a to b (s from the epoch), and
    with ``parameters`` the partials (T, 6, 2) on the epoch's drag and SRP slots over it (from
    zero at a; the segment's slots are the epoch's times the mass ratio)."""
    n_p = N_PARAMETERS if parameters else 0
    if abs(b - a) < DRIFT_S:  # a drift along the velocity (see burn_segments.DRIFT_S)
        ys = np.repeat(y[None], t_rel.size, axis=0)
        ys[:, :3] += y[None, 3:] * t_rel[:, None]
        phis = np.repeat(np.eye(6)[None], t_rel.size, axis=0)
        phis[:, :3, 3:] += t_rel[:, None, None] * np.eye(3)
        return ys, phis, np.zeros((t_rel.size, 6, n_p))
    seg = copy.copy(dyn)
    seg.schedule = None
    seg.model = schedule.segment_model(dyn.model, a, b)
    ys, phis = seg.propagate(y, t_rel, max_steps, parameters=parameters)
    dyn.n_steps += seg.n_steps
    dyn.n_evaluations += seg.n_evaluations
    if not parameters:
        return ys, phis, np.zeros((t_rel.size, 6, 0))
    scale = area_scale(schedule, a, b)
    return ys, phis, seg.parameter_partials * (1.0 if scale is None else scale)


def _leg(dyn, schedule, y0, t_out, start, apply_at_start, cols, max_steps, n_p=0):
    """One direction from ``start``: ``t_out`` (s from the epoch) monotonic away from it.
    Returns states (T, 6) and Psi = [Phi(t, start) | d y(t) / d Δv_k ... | d y(t) / d p]
    (T, 6, 6 + 3n + n_p), p the drag and SRP slots when ``n_p``."""
    t_end = float(t_out[-1])
    start = float(start)
    backward = bool(t_end < start)
    lo, hi = min(start, t_end), max(start, t_end)
    pts = {start, t_end}
    for a, b, _ in schedule.items:
        pts.update(x for x in (a, b) if lo <= x <= hi)
    pts = sorted(pts, reverse=backward)
    y = np.array(y0, dtype=np.float64)
    psi = np.zeros((6, 6 + 3 * len(cols) + n_p))
    psi[:, :6] = np.eye(6)
    ys, psis = [], []
    for i, a in enumerate(pts):
        imps = schedule.impulses_at(a) if (i > 0 or (apply_at_start and not backward)) else []
        if imps and not backward:
            for burn in imps:
                phi_b, g = impulse_jacobians(burn, y)
                y[3:] += burn.delta_v_inertial(y[:3], y[3:])
                psi = phi_b @ psi
                k = 6 + 3 * cols[id(burn)]
                psi[:, k:k + 3] += g
        n_at = int(np.count_nonzero(t_out == a))
        ys += [y.copy()] * n_at
        psis += [psi.copy()] * n_at
        if i == len(pts) - 1:
            break
        if imps and backward:
            for burn in imps[::-1]:
                y_minus = y.copy()
                y_minus[3:] = burn.pre_burn_velocity(y[:3], y[3:])
                phi_b, g = impulse_jacobians(burn, y_minus)
                inv = np.linalg.inv(phi_b)
                psi = inv @ psi
                k = 6 + 3 * cols[id(burn)]
                psi[:, k:k + 3] -= inv @ g
                y = y_minus
        b = pts[i + 1]
        schedule.check_state(a, b, y)
        mask = (t_out < a) & (t_out > b) if backward else (t_out > a) & (t_out < b)
        t_rel = np.append(t_out[mask], b) - a
        y_seg, phi_seg, p_seg = _segment(dyn, schedule, y, a, b, t_rel, max_steps, n_p > 0)
        walked = phi_seg @ psi
        if n_p:  # the coefficients act over the segment too
            walked[:, :, -n_p:] += p_seg
        ys += list(y_seg[:-1])
        psis += list(walked[:-1])
        y = y_seg[-1].copy()
        psi = walked[-1]
    return np.array(ys), np.array(psis)


def propagate_through(dyn, schedule, y0, offsets_s, *, start=0.0, apply_at_start=True,
                      max_steps=2_000_000, parameters=False):
    """States, STMs and Δv partials at ``offsets_s`` through the burns of ``schedule``.

    Parameters
    ----------
    dyn : Dynamics
        The force model (:class:`visviva.satellites.variational.Dynamics`; its ``n_steps``,
        ``n_evaluations`` count the segments' work).
    schedule : Schedule
        The burns, s from the epoch (:func:`visviva.satellites.burn_segments.burn_schedule`).
    y0 : ndarray (6,)
        The state at ``start``, km and km/s (before the impulses at ``start`` when
        ``apply_at_start``, after them otherwise).
    offsets_s : ndarray (T,)
        Output times, s from the epoch, any order, on either side of ``start``. An output at an
        impulse's epoch is the state after the impulse (as :func:`visviva.propagate_cowell`).
    start : float
        Time of ``y0``, s from the epoch.
    apply_at_start : bool
        Whether the impulses at ``start`` are still to be applied (forwards).
    max_steps : int
        Step budget of each segment.
    parameters : bool
        Also the partials on the epoch's drag and SRP slots, carried through the segments
        and the impulses like the Δv partials (the last N_PARAMETERS columns of ``sens``).

    Returns
    -------
    y : ndarray (T, 6)
    phi : ndarray (T, 6, 6)
        Phi(t, start).
    sens : ndarray (T, 6, 3 n)
        d y(t) / d Δv_k of the n impulses (:func:`impulses_of`), on each burn's own axes;
        zero for a burn not crossed between ``start`` and t.
    """
    offsets = np.asarray(offsets_s, dtype=np.float64)
    schedule.snap(np.sort(np.append(offsets, start)))
    cols = {id(m): k for k, m in enumerate(impulses_of(schedule))}
    dyn.n_steps = dyn.n_evaluations = 0
    y_all = np.empty((offsets.size, 6))
    n_p = N_PARAMETERS if parameters else 0
    psi_all = np.empty((offsets.size, 6, 6 + 3 * len(cols) + n_p))
    for side in (-1.0, 1.0):
        idx = np.flatnonzero(offsets < start) if side < 0 else np.flatnonzero(offsets >= start)
        if idx.size == 0:
            continue
        order = idx[np.argsort(side * offsets[idx], kind="stable")]
        ys, psis = _leg(dyn, schedule, y0, offsets[order], start, apply_at_start, cols,
                        max_steps, n_p)
        y_all[order] = ys
        psi_all[order] = psis
    return y_all, psi_all[:, :, :6].copy(), psi_all[:, :, 6:].copy()
