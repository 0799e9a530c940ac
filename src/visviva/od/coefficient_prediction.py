"""The extended Kalman filter's prediction of a state augmented with force-model coefficients.

:func:`visviva.filter_orbit` (``method="ekf"``, ``estimate=``) carries z = (x, p): the orbit
state x and the estimated drag and SRP coefficients p. One prediction from t_k-1 to t_k flies
the orbit with the coefficients' current values and maps the covariance with the augmented
transition

    Phi_z = [[Phi, S], [0, I]],   S = d x(t_k) / d p,

S integrated with Phi (the variational equations' parameter columns, S' = F S + d a / d p;
Tapley, Schutz & Born 2004, sec. 4.2). Through known burns
(:func:`visviva.satellites.burn_partials.propagate_through`, ``parameters=True``) Phi and S
cross each impulse with its Jacobian, a finite burn's segment scales the drag and SRP slots
with the mass, and each impulse's execution error adds S_dv C S_dv^T where it is crossed, as
in the filter's prediction of the plain state. The process noise acts on x alone and is added
as its accumulation from zero (linear in the covariance). With Gauss-Markov coefficients
(:mod:`visviva.od.gauss_markov`) the prediction goes sub-step by sub-step, each flying the
coefficients of its start, which then decay and take their noise.
"""

from __future__ import annotations

import numpy as np

__all__ = ["predict_covariance", "predict_coefficients"]


def predict_covariance(x0, grid, y, phi, P, q, code, jumps=None):
    """P at grid[-1] from P at the origin (state x0): Phi P Phi^T, plus the SNC noise on each
    sub-step (:func:`visviva.satellites.covariance.with_process_noise`) and the execution
    errors of the burns crossed (``jumps``: {index into (0, *grid): (6, 6)})."""
    if q is None:
        out = phi[-1] @ P @ phi[-1].T
        for extra in (jumps or {}).values():  # one sub-step: each is mapped to grid[-1]
            out = out + extra
        return out
    from ..satellites.covariance import with_process_noise

    return with_process_noise(np.r_[0.0, grid], np.vstack([x0, y]),
                              np.concatenate([np.eye(6)[None], phi]), P, q, code, jumps)[-1]


def predict_coefficients(dyn, schedule, z, P, t_from, grid, q, code, est, gauss=None):
    """State z = (x, p) (6 + k,), covariance P and transition Phi_z predicted from ``t_from``
    (s from the epoch) over the sub-steps ``grid`` (s from t_from), through the burns of
    ``schedule`` (empty: none), the coefficients ``est`` constants or, with ``gauss``
    (:class:`visviva.od.gauss_markov.GaussMarkov`), Gauss-Markov processes."""
    if gauss is None:
        return _constant(dyn, schedule, z, P, t_from, grid, q, code, est)
    phi = np.eye(z.size)
    for a, b in zip(np.r_[0.0, grid[:-1]], grid, strict=True):
        z, P, f = _constant(dyn, schedule, z, P, t_from + a, np.array([b - a]), q, code, est)
        z, P, f = gauss.apply(z, P, f, b - a)
        phi = f @ phi
    return z, 0.5 * (P + P.T), phi


def _constant(dyn, schedule, z, P, t_from, grid, q, code, est):
    """:func:`predict_coefficients` with the coefficients held over ``grid``."""
    for j, c in enumerate(est):
        c.write(dyn, z[6 + j])
    if schedule:
        y, phi, S, jumps = _through_burns(dyn, schedule, z[:6], t_from, grid, est)
    else:
        from ..satellites.force_parameters import partials

        d = dyn if t_from == 0.0 else dyn.at_origin(t_from)
        y, phi = d.propagate(z[:6], grid, parameters=True)
        S, jumps = partials(d, est)[-1], None
    phi_z = np.eye(z.size)
    phi_z[:6, :6] = phi[-1]
    phi_z[:6, 6:] = S
    out = phi_z @ P @ phi_z.T
    if q is not None or jumps:
        out[:6, :6] += predict_covariance(z[:6], grid, y, phi, np.zeros((6, 6)), q, code, jumps)
    return np.r_[y[-1], z[6:]], 0.5 * (out + out.T), phi_z


def _through_burns(dyn, schedule, x, t_from, grid, est):
    """States (T, 6), STMs (T, 6, 6), S = d x(t_end) / d p (6, k) and the execution errors'
    jumps of a prediction through the burns (an impulse at ``t_from`` already applied)."""
    from ..core.force_partials import N_PARAMETERS
    from ..satellites.burn_partials import propagate_through
    from ..satellites.covariance import burn_noise

    y, phi, sens = propagate_through(dyn, schedule, x, t_from + grid, start=t_from,
                                     apply_at_start=False, parameters=True)
    n_dv = sens.shape[-1] - N_PARAMETERS
    slots = sens[-1, :, n_dv:]  # d x / d (the epoch's drag and SRP slots)
    S = np.stack([slots[:, c.column] * c.factor for c in est], axis=-1)
    dv = np.concatenate([np.zeros((1, 6, n_dv)), sens[..., :n_dv]])
    jumps = burn_noise(schedule, t_from + np.r_[0.0, grid], dv, t_from, False)
    return y, phi, S, jumps
