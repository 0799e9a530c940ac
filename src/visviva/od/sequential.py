"""Sequential orbit determination: an extended Kalman filter and its Rauch-Tung-Striebel smoother.

The filter walks the observation epochs in time order. Between epochs it integrates the
estimate and its state-transition matrix with the fit's own dynamics
(:class:`visviva.od.dynamics.Dynamics`, the variational equations) and maps the covariance,
adding state-noise compensation for accelerations the model lacks; at each epoch it forms the
pre-fit residuals and partials of the rows there with the fit's measurement models (light time
included, :func:`visviva.od.light_time.model`), edits rows whose residual is far outside the
predicted spread, and updates the state and covariance (Joseph form). The optional smoother
then runs backwards over the stored predictions (Tapley, Schutz & Born 2004, secs. 4.7, 4.9,
4.15; Vallado 2013, sec. 10.6).
"""

from __future__ import annotations

import copy

import numpy as np

from .._covariance import km_covariance
from ..errors import ConvergenceError, InvalidInputError, VisvivaError
from .batch import check_initial
from .light_time import model
from .measurements import residuals
from .observations import Observations

__all__ = ["filter_orbit", "FilteredOrbit"]


class FilteredOrbit:
    """The outcome of :func:`filter_orbit`.

    Attributes
    ----------
    times : astropy Time (T,)
        The initial state's epoch, then every distinct observation time.
    offsets_s : ndarray (T,)
        The same as seconds from the initial epoch.
    states : ndarray (T, 6)
        Filtered GCRS state after the update at each time, km and km/s (the first row is the
        a priori state unless observations fall on the epoch).
    covariances : ndarray (T, 6, 6)
        Their covariances, km^2, km^2/s, km^2/s^2.
    predicted_states, predicted_covariances : ndarray (T, 6), (T, 6, 6)
        The same before the update (propagated from the previous time).
    smoothed_states, smoothed_covariances : ndarray or None
        The Rauch-Tung-Striebel estimates at every time (``smoother=True``), else None.
    prefit_residuals, postfit_residuals : ndarray (N, 3)
        Observed minus computed for each observation, with the predicted state and with the
        updated one (km, km/s, rad; the components beyond a row's own are zero).
    prefit_ratios : ndarray (N,)
        The largest pre-fit residual of each row over its predicted standard deviation
        sqrt(H P H^T + R) (the quantity the editing compares with ``editing_sigma``).
    nis : ndarray (N,)
        Normalised innovation squared of each row, z^T S^-1 z (chi-square with the row's
        number of components when the filter is consistent).
    rejected : ndarray of bool (N,)
        Rows left out by the editing.
    epoch_index : ndarray of int (N,)
        Row -> index into ``times``.
    state : StateVectors
        Filtered state at the last time.
    covariance : ndarray (6, 6)
        Its covariance.
    first_state : StateVectors or None
        The smoothed state at the first time (the initial epoch), with ``smoother=True``.
    first_covariance : ndarray (6, 6) or None
        Its covariance.
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def __repr__(self):
        sig = np.sqrt(np.trace(self.covariance[:3, :3])) * 1e3
        return (
            f"FilteredOrbit({len(self.times)} epochs, {len(self.rejected)} observations, "
            f"{int(self.rejected.sum())} rejected, final sigma_r={sig:.3g} m"
            f"{', smoothed' if self.smoothed_states is not None else ''})"
        )


class _FromOrigin:
    """A force model whose t = 0 lies ``t0_s`` after the model's own epoch."""

    def __init__(self, model, t0_s):
        from ..core.force_block import with_time_origin

        self._arrays = (with_time_origin(model.force, t0_s),) + tuple(model.arrays()[1:])

    def arrays(self):
        return self._arrays


def _propagate(dyn, x, t_from, t_to):
    """States and STMs Phi(t, t_from) at the points of a grid ``t_to`` (s from the epoch)."""
    if t_from == 0.0:
        return dyn.propagate(x, t_to)
    shifted = copy.copy(dyn)
    shifted.model = _FromOrigin(dyn.model, t_from)
    return shifted.propagate(x, np.asarray(t_to) - t_from)


def _check_covariance(covariance):
    from .._covariance import as_covariance, check_shape, require_psd

    P = as_covariance(covariance, "covariance", length_unit="km")
    check_shape(P, "covariance")
    require_psd(P, "covariance")
    if not np.any(P):
        raise InvalidInputError(
            "covariance is zero: the filter would trust the initial state completely and ignore "
            "every observation. Give the initial state's uncertainty."
        )
    return P


def _positive(name, value):
    if isinstance(value, bool | np.bool_):
        raise InvalidInputError(f"{name} must be a finite number > 0; got {value!r}.")
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not (np.isfinite(v) and v > 0):
        raise InvalidInputError(f"{name} must be a finite number > 0; got {value!r}.")
    return v


def _predict_covariance(x0, grid, y, phi, P, q, code, jumps=None):
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


def _predict(dyn, schedule, x, P, t_from, grid, q, code, apply_at_start=False):
    """The state, covariance and Phi(t_from + grid[-1], t_from) predicted from (x, P) at
    ``t_from`` (s from the epoch) over the sub-steps ``grid`` (s from t_from), through the
    burns of ``schedule`` (:func:`visviva.satellites.burn_partials.propagate_through`)."""
    if not schedule:
        y, phi = _propagate(dyn, x, t_from, t_from + grid)
        return y[-1].copy(), _predict_covariance(x, grid, y, phi, P, q, code), phi[-1]
    t_end = t_from + float(grid[-1])
    if not any(t_from < edge <= t_end or (apply_at_start and edge == t_from)
               for a, b, _ in schedule.items for edge in (a, b)):
        # no burn starts or ends here: one segment (a finite burn's thrust on over it, drag
        # and SRP scaled to the mass), as the walk would integrate it
        shifted = copy.copy(dyn)
        shifted.model = schedule.segment_model(dyn.model, t_from, t_end)
        y, phi = shifted.propagate(x, grid)
        return y[-1].copy(), _predict_covariance(x, grid, y, phi, P, q, code), phi[-1]
    from ..satellites.burn_partials import propagate_through
    from ..satellites.covariance import burn_noise

    y, phi, sens = propagate_through(dyn, schedule, x, t_from + grid, start=t_from,
                                     apply_at_start=apply_at_start)
    if grid.size == 1 and grid[0] == 0.0:  # impulses at the epoch itself
        jumps = burn_noise(schedule, grid + t_from, sens, t_from, apply_at_start)
        return y[-1].copy(), phi[-1] @ P @ phi[-1].T + sum(jumps.values(), 0.0 * P), phi[-1]
    sens = np.concatenate([np.zeros((1,) + sens.shape[1:]), sens])
    jumps = burn_noise(schedule, t_from + np.r_[0.0, grid], sens, t_from, apply_at_start)
    return y[-1].copy(), _predict_covariance(x, grid, y, phi, P, q, code, jumps), phi[-1]


def filter_orbit(observations, initial, covariance, perturbations=None, *, maneuvers=None,
                 process_noise=None,
                 process_noise_frame="RTN", noise_step=None, smoother=False, editing_sigma=4.0,
                 divergence_count=10, rtol=None, atol=None):  # fmt: skip
    """Estimate an orbit sequentially with an extended Kalman filter (and optional smoother).

    Parameters
    ----------
    observations : Observations
        The measurements, in time order (a table's times never go backwards); every one at or
        after the initial state's epoch.
    initial : StateVectors
        The a priori GCRS state, with an ``epoch`` at or before the first observation (e.g. a
        :func:`~visviva.fit_orbit` estimate, an IOD or a propagated earlier estimate). A state
        from an OPM with manoeuvres needs ``maneuvers=``.
    covariance : array_like (6, 6) or Quantity
        Its covariance in GCRS axes; plain numbers are km^2, km^2/s, km^2/s^2 (order x, y, z,
        vx, vy, vz); a Quantity with an area unit is read in that length unit and seconds.
        Symmetric and positive semi-definite.
    perturbations : list of Perturbation or None
        Dynamics, as for :func:`~visviva.fit_orbit` (None or [] for two-body motion).
    maneuvers : list of ImpulsiveBurn / FiniteBurn, optional
        Known burns in the arc (as :func:`~visviva.propagate_cowell`'s ``maneuvers=``): the
        prediction flies them, the covariance crosses each impulse with its Jacobian and
        adds its ``execution_covariance`` (:func:`~visviva.propagate_covariance`, Notes). An
        impulse at the initial epoch is applied first (the initial state is before it); an
        observation at an impulse's epoch sees the state after it.
    process_noise : float, array_like (3,) or Quantity, optional
        Spectral density q of a white-noise acceleration on each axis of
        ``process_noise_frame``, km^2/s^3 (= (km/s^2)^2 / Hz); None: none. It stands for the
        accelerations the dynamics leave out (drag errors, manoeuvre residuals, SRP).
    process_noise_frame : {"RTN", "GCRS", "TNW", "VNB"}
        The axes of ``process_noise`` (the local frames rotate with the orbit; their density
        is averaged over each sub-step's ends).
    noise_step : Quantity or float, optional
        Longest interval over which the noise is added in straight-line motion, s (default
        60 s); longer gaps between observations are cut into such steps.
    smoother : bool
        Also run the Rauch-Tung-Striebel smoother backwards over the filtered arc.
    editing_sigma : float or None
        A row whose largest pre-fit residual exceeds ``editing_sigma`` times its predicted
        standard deviation sqrt(H P H^T + R) is rejected (not used, reported in
        ``rejected``); None keeps every row.
    divergence_count : int
        That many consecutive observation epochs each with a row beyond ``editing_sigma`` (5
        when editing is off) mean the filter has lost the orbit:
        :class:`~visviva.ConvergenceError` naming the epoch.
    rtol, atol : float, optional
        Integration tolerances of the variational equations (default 1e-11).

    Returns
    -------
    FilteredOrbit
        ``.times``, ``.states`` (T, 6), ``.covariances`` (T, 6, 6), ``.prefit_residuals``,
        ``.postfit_residuals``, ``.rejected``, ``.nis``, ``.state``/``.covariance`` at the last
        epoch, and with ``smoother=True`` ``.smoothed_states``, ``.smoothed_covariances`` and
        ``.first_state``/``.first_covariance`` at the initial epoch.

    Raises
    ------
    InvalidInputError
        A covariance that is not symmetric positive semi-definite, or NaN; observations before
        the initial epoch; bad arguments; a state from an OPM with manoeuvres without
        ``maneuvers=``.
    ShapeError
        A covariance that is not 6 x 6, or a process noise of the wrong size.
    ConvergenceError
        The filter diverged: ``divergence_count`` consecutive epochs with rows far outside the
        predicted spread, or an estimate that cannot be integrated or is not finite.

    Notes
    -----
    Between epochs t_k-1 and t_k the state is integrated with its STM Phi (the variational
    equations of the fit's force model) and the covariance mapped,
    P_k^- = Phi P_k-1^+ Phi^T + Q, with the state noise compensation of a white acceleration of
    density Qc = diag(q) (rotated from RTN at the start of each sub-step of at most
    ``noise_step``; Tapley, Schutz & Born 2004, sec. 4.9)::

        Q(dt) = [[dt^3/3 Qc, dt^2/2 Qc], [dt^2/2 Qc, dt Qc]].

    At t_k the rows there give z = y - h(x_k^-), H = dh/dx (light time included), S = H P^- H^T
    + R, K = P^- H^T S^-1, x_k^+ = x_k^- + K z and the Joseph form
    P_k^+ = (I - K H) P^- (I - K H)^T + K R K^T, which stays symmetric positive definite under
    round-off (Tapley et al., eq. 4.7.19; Bucy & Joseph 1968). Rows at one epoch are processed
    together. The smoother (Rauch, Tung & Striebel 1965; Tapley et al., sec. 4.15) runs back
    with C_k = P_k^+ Phi^T (P_k+1^-)^-1, x_k^s = x_k^+ + C_k (x_k+1^s - x_k+1^-),
    P_k^s = P_k^+ + C_k (P_k+1^s - P_k+1^-) C_k^T.

    With two-body dynamics, position observations and no process noise the problem is nearly
    linear, and the filter's final estimate equals the batch estimate
    (:func:`~visviva.fit_orbit`) mapped to the last epoch, the smoother's first estimate the
    batch estimate at the epoch (tested to 1e-3 sigma). Use the batch fit for a fixed arc with
    good dynamics; use the filter when the data arrive in sequence, when a state is needed at
    every observation, or when unmodelled accelerations call for process noise.
    """
    from ..states import StateVectors
    from .dynamics import DEFAULT_ATOL, DEFAULT_RTOL, Dynamics

    if not isinstance(observations, Observations):
        raise InvalidInputError(
            "observations must be a vv.Observations table; build one with "
            "vv.Observations(time=..., kind=..., value=..., sigma=..., station=...)."
        )
    x, gm, epoch = check_initial(initial, maneuvers)
    from ..satellites.burn_segments import burn_schedule

    schedule = burn_schedule([] if maneuvers is None else maneuvers, initial, epoch)
    P = _check_covariance(covariance)
    from .._covariance import frame_code
    from ..satellites.covariance import noise_density, noise_step_s

    q = noise_density(process_noise)
    code = frame_code(process_noise_frame, "process_noise_frame")
    frame = None if q is None else str(process_noise_frame).upper()
    step_s = noise_step_s(noise_step)
    if editing_sigma is not None:
        editing_sigma = _positive("editing_sigma", editing_sigma)
    if isinstance(divergence_count, bool) or not (
            isinstance(divergence_count, int | np.integer) and divergence_count >= 1):
        raise InvalidInputError(
            f"divergence_count must be an integer >= 1; got {divergence_count!r}."
        )
    if not isinstance(smoother, bool | np.bool_):
        raise InvalidInputError(f"smoother must be True or False; got {smoother!r}.")
    rtol = DEFAULT_RTOL if rtol is None else _positive("rtol", rtol)
    atol = DEFAULT_ATOL if atol is None else _positive("atol", atol)
    offsets = observations.offsets_s(epoch)
    if offsets[0] < 0:
        raise InvalidInputError(
            f"observation 0 ({observations.times[0].isot}) is {-offsets[0]:.3f} s before the "
            f"initial state's epoch ({epoch.isot}): the filter runs forward from the epoch. "
            "Start from a state at or before the first observation (propagate it back with "
            "vv.propagate_cowell), or drop the earlier rows."
        )
    dyn = Dynamics(gm, perturbations, epoch, (0.0, offsets.max()), rtol, atol)
    epochs, epoch_index = np.unique(offsets, return_inverse=True)
    if epochs[0] != 0.0:
        epochs = np.concatenate([[0.0], epochs])
        epoch_index = epoch_index + 1
    n_t, n = len(epochs), len(observations)
    xs = np.empty((n_t, 6))
    Ps = np.empty((n_t, 6, 6))
    xp = np.empty((n_t, 6))
    Pp = np.empty((n_t, 6, 6))
    phis = np.empty((n_t, 6, 6))
    if schedule:  # burns within a microsecond of an epoch are at it (as propagate_cowell's)
        schedule.snap(np.sort(epochs))
    if schedule and schedule.impulses_at(0.0):  # burns at the epoch, after the state given
        x, P, _ = _predict(dyn, schedule, x, P, 0.0, np.zeros(1), q, code, apply_at_start=True)
    xs[0] = xp[0] = x
    Ps[0] = Pp[0] = P
    phis[0] = np.eye(6)
    prefit = np.zeros((n, 3))
    ratios = np.zeros(n)
    nis = np.zeros(n)
    rejected = np.zeros(n, dtype=bool)
    limit = editing_sigma if editing_sigma is not None else 5.0
    run = 0
    sig = observations.sigmas
    dims = observations.dims
    kinds = observations.kinds
    order = np.argsort(epoch_index, kind="stable")
    bounds = np.searchsorted(epoch_index[order], np.arange(n_t + 1))

    def diverged(k, why):
        return ConvergenceError(
            f"the filter diverged at {_isot(epoch, epochs[k])} (epoch {k} of {n_t}): {why}. "
            "Give a better initial state or a larger initial covariance, add process noise, or "
            "use dynamics closer to the data."
        )

    for k in range(n_t):
        if k:
            dt = epochs[k] - epochs[k - 1]
            if q is None:
                grid = np.array([dt])
            else:
                grid = np.linspace(0.0, dt, int(np.ceil(dt / step_s)) + 1)[1:]
            try:
                x, P, phis[k] = _predict(dyn, schedule, x, P, epochs[k - 1], grid, q, code)
            except VisvivaError as exc:
                raise diverged(k, f"the estimate cannot be integrated ({exc})") from exc
            xp[k], Pp[k] = x, P
        rows = order[bounds[k]:bounds[k + 1]]
        if rows.size:
            h, H = model(observations, np.repeat(x[None], rows.size, axis=0), gm, rows)
            z = residuals(kinds[rows], observations.values[rows], h)
            comp = np.arange(3)[None, :] < dims[rows][:, None]
            prefit[rows] = np.where(comp, z, 0.0)
            Hc = H[comp]  # (m, 6) components in use, row-major
            zc = z[comp]
            owner = np.repeat(np.arange(rows.size), dims[rows])
            Rd = np.repeat(sig[rows], dims[rows]) ** 2
            S = Hc @ P @ Hc.T + np.diag(Rd)
            std = np.sqrt(np.diag(S))
            if not (np.all(np.isfinite(zc)) and np.all(np.isfinite(S))):
                raise diverged(k, "the predicted measurements are not finite")
            ratio = np.zeros(rows.size)
            np.maximum.at(ratio, owner, np.abs(zc) / std)
            ratios[rows] = ratio
            start = 0
            for i, d in enumerate(dims[rows].tolist()):  # a row's components are contiguous
                sel = slice(start, start + d)
                start += d
                nis[rows[i]] = float(zc[sel] @ np.linalg.solve(S[sel, sel], zc[sel]))
            bad = ratio > limit
            run = run + 1 if bad.any() else 0
            if run >= divergence_count:
                worst = int(np.argmax(ratio))
                raise diverged(
                    k, f"at {run} consecutive observation epochs some observation is more than "
                    f"{limit:g} sigma from the prediction (here row {int(rows[worst])} "
                    f"({kinds[rows[worst]]}), {ratio[worst]:.3g} sigma)")
            rej = bad if editing_sigma is not None else np.zeros(rows.size, dtype=bool)
            rejected[rows] = rej
            use = ~rej[owner]
            if use.any():
                Hu, zu = Hc[use], zc[use]
                Su = S[np.ix_(use, use)]
                K = np.linalg.solve(Su, Hu @ P).T  # P H^T S^-1 (S symmetric)
                x = x + K @ zu
                ikh = np.eye(6) - K @ Hu
                P = ikh @ P @ ikh.T + (K * Rd[use]) @ K.T
                P = 0.5 * (P + P.T)
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
                raise diverged(k, "the updated estimate is not finite")
        xs[k], Ps[k] = x, P
    # post-fit residuals: every row against the updated state at its epoch, in one call of the
    # (row by row) model after the pass instead of one per epoch (the same numbers)
    h, _ = model(observations, xs[epoch_index], gm)
    z = residuals(kinds, observations.values, h)
    postfit = np.where(np.arange(3)[None, :] < dims[:, None], z, 0.0)
    sm_x = sm_P = first_state = first_cov = None
    if smoother:
        sm_x, sm_P = _rts(xs, Ps, xp, Pp, phis)
        first_state = StateVectors._from_canonical(sm_x[0, :3].copy(), sm_x[0, 3:].copy(),
                                                   np.float64(gm), epoch)  # fmt: skip
        first_cov = sm_P[0]
    from astropy import units as u

    times = epoch + epochs * u.s
    last = StateVectors._from_canonical(xs[-1, :3].copy(), xs[-1, 3:].copy(), np.float64(gm),
                                        times[-1])  # fmt: skip
    return FilteredOrbit(
        times=times, offsets_s=epochs, states=xs, covariances=km_covariance(Ps),
        predicted_states=xp, predicted_covariances=km_covariance(Pp), smoothed_states=sm_x,
        smoothed_covariances=None if sm_P is None else km_covariance(sm_P),
        prefit_residuals=prefit, postfit_residuals=postfit, prefit_ratios=ratios, nis=nis,
        rejected=rejected, epoch_index=epoch_index, state=last, covariance=km_covariance(Ps[-1].copy()),
        first_state=first_state, first_covariance=None if first_cov is None else km_covariance(first_cov), perturbations=dyn.perturbations,
        process_noise=q, process_noise_frame=frame,
    )  # fmt: skip


def _rts(xs, Ps, xp, Pp, phis):
    """Rauch-Tung-Striebel pass backwards over filtered (xs, Ps) and predicted (xp, Pp)."""
    sx = xs.copy()
    sP = Ps.copy()
    for k in range(len(xs) - 2, -1, -1):
        # C = P_k Phi^T (P_k+1^-)^-1, from the symmetric system P_k+1^- C^T = Phi P_k
        # (scaled to unit diagonal first: position and velocity variances differ by 1e6+)
        d = 1.0 / np.sqrt(np.diag(Pp[k + 1]))
        M = Pp[k + 1] * np.outer(d, d)
        C = (d[:, None] * np.linalg.solve(M, d[:, None] * (phis[k + 1] @ Ps[k]))).T
        sx[k] = xs[k] + C @ (sx[k + 1] - xp[k + 1])
        Pk = Ps[k] + C @ (sP[k + 1] - Pp[k + 1]) @ C.T
        sP[k] = 0.5 * (Pk + Pk.T)
    return sx, sP


def _isot(epoch, offset_s):
    from astropy import units as u

    return (epoch + offset_s * u.s).utc.isot
