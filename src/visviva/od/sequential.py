"""Sequential orbit determination: an extended Kalman filter and its Rauch-Tung-Striebel smoother.

The filter walks the observation epochs in time order. Between epochs it integrates the
estimate and its state-transition matrix with the fit's own dynamics
(:class:`visviva.od.dynamics.Dynamics`, the variational equations) and maps the covariance,
adding state-noise compensation for accelerations the model lacks; at each epoch it forms the
pre-fit residuals and partials of the rows there with the fit's measurement models (light time
included, :func:`visviva.od.light_time.model`), edits rows whose residual is far outside the
predicted spread, and updates the state and covariance (square-root form:
:mod:`visviva.od.extended`, :mod:`visviva.od.square_root`). The optional smoother
then runs backwards over the stored predictions (Tapley, Schutz & Born 2004, secs. 4.7, 4.9,
4.15; Vallado 2013, sec. 10.6). ``method="ukf"`` runs the unscented filter and smoother of
:mod:`visviva.od.unscented` instead, with the same bookkeeping (editing, NIS, divergence).
"""

from __future__ import annotations

import numpy as np

from .._covariance import km_covariance
from .._units import advance_epoch
from ..errors import ConvergenceError, InvalidInputError
from .extended import ekf_pass, initial_impulses
from .initial_state import check_initial
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
    method : str
        "ekf" or "ukf", the filter that ran.
    parameters, parameter_sigma : dict
        With ``estimate=``: each estimated coefficient's filtered value and 1-sigma at every
        time (T,) (B as a Quantity in m^2/kg, Cr as numbers); empty without.
    smoothed_parameters, smoothed_parameter_sigma : dict or None
        The same, smoothed (``smoother=True``), else None.
    full_covariances : ndarray (T, 6 + k, 6 + k)
        The filtered covariances of state and coefficients (``covariances`` without them).
    perturbations : list of Perturbation
        The dynamics, the coefficients at their last estimate.
    process_noise : ndarray (3,) or None
        The white-noise acceleration density q used, km^2/s^3 per axis of
        ``process_noise_frame`` (None: none).
    process_noise_frame : str or None
        Its axes ("RTN", "GCRS", "TNW", "VNB"; None without process noise).
    parameter_noise : dict
        The Gauss-Markov noise used on each estimated coefficient that had one,
        {name: (sigma, tau)}: the steady-state 1-sigma (B as a Quantity in m^2/kg, Cr as a
        number) and the correlation time (Quantity, s); empty when every coefficient was a
        constant (no ``parameter_noise=``).
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def __repr__(self):
        sig = np.sqrt(np.trace(self.covariance[:3, :3])) * 1e3
        return (
            f"FilteredOrbit({len(self.times)} epochs, {len(self.rejected)} observations, "
            f"{int(self.rejected.sum())} rejected, final sigma_r={sig:.3g} m"
            f"{', smoothed' if self.smoothed_states is not None else ''}"
            f"{', unscented' if self.__dict__.get('method') == 'ukf' else ''}"
            f"{self.noise_summary()})"
        )

    def noise_summary(self) -> str:
        """The process noise (km^2/s^3, with its frame) and the coefficients' Gauss-Markov noise
        (sigma, tau in s) the filter used, as ``", process noise ..."`` text ("" for none): the
        tail of the repr and of ``visviva od``'s method line."""
        from astropy import units as u

        out = ""
        q = self.__dict__.get("process_noise")
        if q is not None:
            out += (f", process noise {':'.join(f'{v:g}' for v in dict.fromkeys(np.ravel(q)))} "
                    f"km^2/s^3 {self.__dict__.get('process_noise_frame')}")
        for name, (sd, tau) in (self.__dict__.get("parameter_noise") or {}).items():
            sd = f"{u.Quantity(sd).value:g}{' m^2/kg' if name == 'drag' else ''}"
            out += f", {name} Gauss-Markov sigma {sd} tau {tau.to_value(u.s):g} s"
        return out


def _method(method, sigma_points):
    """The filter's name, "ekf" or "ukf", with ``sigma_points`` checked against it."""
    name = method.lower() if isinstance(method, str) else None
    if name not in ("ekf", "ukf"):
        raise InvalidInputError(
            f'method must be "ekf" (extended Kalman filter) or "ukf" (unscented Kalman '
            f"filter); got {method!r}."
        )
    if name == "ekf" and sigma_points is not None:
        raise InvalidInputError(
            'sigma_points is the unscented filter\'s (alpha, beta, kappa); pass method="ukf" '
            "with it, or leave it out for the extended filter."
        )
    if name == "ukf":
        from .unscented import unscented_weights

        unscented_weights(sigma_points)  # checks the parameters before any integration
    return name


def _check_covariance(covariance):
    from .priors import state_covariance

    P = state_covariance(covariance)
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


def filter_orbit(observations, initial, covariance, perturbations=None, *, maneuvers=None,
                 process_noise=None,
                 process_noise_frame="RTN", noise_step=None, smoother=False, editing_sigma=4.0,
                 divergence_count=10, rtol=None, atol=None, method="ekf",
                 sigma_points=None, estimate=None, parameter_sigma=None,
                 parameter_noise=None):  # fmt: skip
    """Estimate an orbit sequentially with an extended or unscented Kalman filter (and optional
    smoother).

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
    method : {"ekf", "ukf"}
        "ekf" (default): the extended Kalman filter (STM and measurement partials). "ukf": the
        unscented Kalman filter (13 sigma points through the same dynamics and measurement
        models; :mod:`visviva.od.unscented`), for an a priori covariance large enough for the
        problem to be nonlinear across it (km and m/s in LEO), where the extended filter is
        overconfident, or diverges; about 1.4 times the cost per epoch (about 2 with drag or
        SRP). It flies ``maneuvers=`` (each sigma point through each burn in its own local
        frame) and ``estimate=`` (each sigma point with its own coefficients), also together.
    sigma_points : tuple of float, optional
        (alpha, beta, kappa) of the unscented filter's scaled unscented transform (default
        (1, 2, 0): points sqrt(6) sigma out, no negative weight); only with ``method="ukf"``.
    estimate : str or list of str, optional
        Coefficients estimated with the state, as :func:`~visviva.fit_orbit`'s (``"drag"``:
        the ballistic coefficient B = Cd A / m, m^2/kg; ``"srp"``: Cr): appended to the
        filter's state as constants (unless ``parameter_noise=``), starting from their values
        in ``perturbations``, each with its a priori sigma from ``parameter_sigma`` (required:
        the filter's initial covariance), uncorrelated with the state; through ``maneuvers=``
        too (:mod:`visviva.od.coefficient_prediction`). ``.parameters``, ``.parameter_sigma`` (each (T,) per name),
        ``.full_covariances`` (T, 6 + k, 6 + k) report them; ``.perturbations`` flies the
        last estimate.
    parameter_sigma : dict, optional
        The a priori sigmas of ``estimate`` (``{"drag": 0.005 * u.m**2 / u.kg}``).
    parameter_noise : dict, optional
        First-order Gauss-Markov noise on estimated coefficients, {name: (sigma, tau)}: the
        steady-state 1-sigma (as ``parameter_sigma``'s, >= 0) and the correlation time (a time
        Quantity or s, finite, >= 60 s). Between epochs the coefficient decays towards its value
        in ``perturbations`` by exp(-dt/tau) and its variance relaxes towards sigma^2, so the
        filter follows a coefficient that changes over the arc
        (:mod:`visviva.od.gauss_markov`); the names left out stay constants.

    Returns
    -------
    FilteredOrbit
        ``.times``, ``.states`` (T, 6), ``.covariances`` (T, 6, 6), ``.prefit_residuals``,
        ``.postfit_residuals``, ``.rejected``, ``.nis``, ``.state``/``.covariance`` at the last
        epoch, and with ``smoother=True`` ``.smoothed_states``, ``.smoothed_covariances`` and
        ``.first_state``/``.first_covariance`` at the initial epoch; ``.method``.

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
    + R, K = P^- H^T S^-1, x_k^+ = x_k^- + K z and P_k^+ = P^- - K S K^T. Rows at one epoch
    are processed together. The smoother (Rauch, Tung & Striebel 1965; Tapley et al., sec.
    4.15) runs back with C_k = P_k^+ Phi^T (P_k+1^-)^-1, x_k^s = x_k^+ + C_k (x_k+1^s -
    x_k+1^-), P_k^s = P_k^+ + C_k (P_k+1^s - P_k+1^-) C_k^T. The filter carries a square root
    L of P (P = L L^T) and computes each of these covariances as the Gram matrix of a QR
    factor (Carlson's array update, Bierman 1977; Tapley et al., sec. 5.4; the smoother in
    its Joseph form, :mod:`visviva.od.square_root`): symmetric positive semi-definite by
    construction, also when nanometre data meet a kilometre prior, where the Joseph form
    (I - K H) P^- (I - K H)^T + K R K^T lost definiteness to round-off. When two epochs are
    more than 6 h apart, the extended filter predicts over every gap longer than 5 min by the
    unscented transform (below; with ``estimate=`` the coefficients ride the sigma points),
    Phi replaced by its statistical linearisation: across days the flow is nonlinear across
    the covariance (:data:`visviva.od.extended.UNSCENTED_GAP_S`); and where the measurements
    then bend across the predicted covariance (the curvature check, more than 3 sigmas) the
    update is the unscented filter's too.

    With two-body dynamics, position observations and no process noise the problem is nearly
    linear, and the filter's final estimate equals the batch estimate
    (:func:`~visviva.fit_orbit`) mapped to the last epoch, the smoother's first estimate the
    batch estimate at the epoch (tested to 1e-3 sigma). Use the batch fit for a fixed arc with
    good dynamics; use the filter when the data arrive in sequence, when a state is needed at
    every observation, or when unmodelled accelerations call for process noise.

    ``method="ukf"`` replaces Phi and H by the scaled unscented transform (Julier & Uhlmann
    2004; Wan & van der Merwe 2000): sigma points X_0 = x, X_i = x +- sqrt(n + lambda) L_i
    (L L^T = P, lambda = alpha^2 (n + kappa) - n), carried through the dynamics (one compiled
    call for all 13 per step) and the measurement model; P^- is their weighted covariance plus
    the same SNC Q on the same sub-steps, S = P_zz + R, K = P_xz S^-1,
    P^+ = P^- - K S K^T, all in square-root form (van der Merwe & Wan 2001: the points drawn
    from a carried factor L, prediction and update by QR, positive semi-definite by
    construction at any conditioning), azimuth and right ascension averaged as angles. Its
    smoother is Saerkkae's (2008) unscented RTS smoother (on factors too), C_k = D_k+1 (P_k+1^-)^-1 with the sigma points'
    cross-covariance D_k+1 = cov(x_k, x_k+1^-) in place of P_k Phi^T. On a nearly linear
    problem both filters agree to 1e-4 sigma; from a 1 km, 1 m/s prior the extended filter's
    NEES averaged 14 (chi-square mean 6), the unscented one's 6.2. Through burns the sigma points
    are redrawn at every burn start and end, each impulse is applied to each point on its own
    local axes and its execution error added as sum_i W_i^m G_i C G_i^T; with ``estimate=``
    the points carry (x, p), each flying its own p (:mod:`visviva.od.unscented`).
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
    method = _method(method, sigma_points)
    est = _estimated_coefficients(perturbations, estimate, parameter_sigma)
    from .gauss_markov import gauss_markov

    gm_noise = gauss_markov(parameter_noise, est)
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
    if schedule:  # burns within a microsecond of an epoch are at it (as propagate_cowell's)
        schedule.snap(np.sort(epochs))
    if method == "ekf" and schedule and schedule.impulses_at(0.0):  # after the state given
        x, P = initial_impulses(dyn, schedule, x, P, q, code)
    if est:  # the coefficients join the state, uncorrelated with it
        x = np.r_[x, [c.value for c in est]]
        P = _augmented(P, np.diag([c.sigma ** 2 for c in est]))
    screen = _Screen(observations, epoch, epochs, epoch_index, editing_sigma, divergence_count)
    if method == "ukf":
        from .unscented import unscented_pass

        xs, Ps, xp, Pp, joints = unscented_pass(dyn, observations, x, P, epochs, screen, q,
                                                code, step_s, sigma_points, schedule, est,
                                                apply_at_start=True, gm=gm_noise)  # fmt: skip
    else:
        xs, Ps, xp, Pp, phis, roots = ekf_pass(dyn, schedule, observations, x, P, epochs,
                                               screen, q, code, step_s, est, gm_noise)  # fmt: skip
    # post-fit residuals: every row against the updated state at its epoch, in one call of the
    # (row by row) model after the pass instead of one per epoch (the same numbers)
    h, _ = model(observations, xs[epoch_index, :6], gm)
    z = residuals(observations.kinds, observations.values, h)
    postfit = np.where(np.arange(3)[None, :] < observations.dims[:, None], z, 0.0)
    observations.warn_below_horizon(xs[epoch_index, :3], ~screen.rejected, "the filtered orbit")
    sm_x = sm_P = first_state = first_cov = None
    if smoother:
        if method == "ukf":
            sm_x, sm_P = _rts(xs, Ps, xp, Pp, joints=joints)
        else:
            sm_x, sm_P = _rts(xs, Ps, xp, Pp, phis, roots=roots)
        first_state = StateVectors._from_canonical(sm_x[0, :3].copy(), sm_x[0, 3:6].copy(),
                                                   np.float64(gm), epoch)  # fmt: skip
        first_cov = sm_P[0, :6, :6]

    times = advance_epoch(epoch, epochs)  # the offsets are TT seconds (Observations.offsets_s)
    last = StateVectors._from_canonical(xs[-1, :3].copy(), xs[-1, 3:6].copy(), np.float64(gm),
                                        times[-1])  # fmt: skip
    extra = _coefficient_fields(est, xs, Ps, dyn.perturbations, sm_x, sm_P, gm_noise)
    full = Ps
    xs, Ps, xp, Pp = xs[:, :6], Ps[:, :6, :6], xp[:, :6], Pp[:, :6, :6]
    if sm_x is not None:
        sm_x, sm_P = sm_x[:, :6], sm_P[:, :6, :6]
    return FilteredOrbit(
        times=times, offsets_s=epochs, states=xs, covariances=km_covariance(Ps),
        predicted_states=xp, predicted_covariances=km_covariance(Pp), smoothed_states=sm_x,
        smoothed_covariances=None if sm_P is None else km_covariance(sm_P),
        full_covariances=km_covariance(full), **extra,
        prefit_residuals=screen.prefit_residuals, postfit_residuals=postfit,
        prefit_ratios=screen.ratios, nis=screen.nis, rejected=screen.rejected, epoch_index=epoch_index, state=last, covariance=km_covariance(Ps[-1].copy()),
        first_state=first_state, first_covariance=None if first_cov is None else km_covariance(first_cov),
        process_noise=q, process_noise_frame=frame, method=method,
    )  # fmt: skip


class _Screen:
    """The rows of each epoch, their pre-fit residuals, editing, NIS and the divergence watch:
    the bookkeeping both filters (extended and unscented) share."""

    def __init__(self, observations, epoch, epochs, epoch_index, editing_sigma, divergence_count):
        n = len(observations)
        self.epoch, self.epochs = epoch, epochs
        self.prefit_residuals = np.zeros((n, 3))
        self.ratios = np.zeros(n)
        self.nis = np.zeros(n)
        self.rejected = np.zeros(n, dtype=bool)
        self.editing_sigma = editing_sigma
        self.limit = editing_sigma if editing_sigma is not None else 5.0
        self.divergence_count = divergence_count
        self.run = 0
        self.sig = observations.sigmas
        self.dims = observations.dims
        self.kinds = observations.kinds
        self.order = np.argsort(epoch_index, kind="stable")
        self.bounds = np.searchsorted(epoch_index[self.order], np.arange(len(epochs) + 1))

    def rows(self, k):
        """The observation rows at epoch ``k``."""
        return self.order[self.bounds[k]:self.bounds[k + 1]]

    def diverged(self, k, why):
        n_t = len(self.epochs)
        return ConvergenceError(
            f"the filter diverged at {_isot(self.epoch, self.epochs[k])} (epoch {k} of {n_t}): "
            f"{why}. Give a better initial state or a larger initial covariance, add process "
            "noise, or use dynamics closer to the data."
        )

    def prefit(self, rows, z):
        """Store the pre-fit residuals z (m, 3) of ``rows``; the mask of the components in use,
        those components (row-major) and their variances R."""
        dims = self.dims[rows]
        comp = np.arange(3)[None, :] < dims[:, None]
        self.prefit_residuals[rows] = np.where(comp, z, 0.0)
        return comp, z[comp], np.repeat(self.sig[rows], dims) ** 2

    def check(self, k, rows, zc, S):
        """Ratios, NIS, editing and the divergence watch of the rows at epoch ``k`` with
        innovations ``zc`` and their covariance ``S``; the mask of the components to use."""
        dims = self.dims[rows]
        owner = np.repeat(np.arange(rows.size), dims)
        std = np.sqrt(np.diag(S))
        if not (np.all(np.isfinite(zc)) and np.all(np.isfinite(S))):
            raise self.diverged(k, "the predicted measurements are not finite")
        ratio = np.zeros(rows.size)
        np.maximum.at(ratio, owner, np.abs(zc) / std)
        self.ratios[rows] = ratio
        start = 0
        for i, d in enumerate(dims.tolist()):  # a row's components are contiguous
            sel = slice(start, start + d)
            start += d
            self.nis[rows[i]] = float(zc[sel] @ np.linalg.solve(S[sel, sel], zc[sel]))
        bad = ratio > self.limit
        self.run = self.run + 1 if bad.any() else 0
        if self.run >= self.divergence_count:
            worst = int(np.argmax(ratio))
            raise self.diverged(
                k, f"at {self.run} consecutive observation epochs some observation is more "
                f"than {self.limit:g} sigma from the prediction (here row {int(rows[worst])} "
                f"({self.kinds[rows[worst]]}), {ratio[worst]:.3g} sigma)")
        rej = bad if self.editing_sigma is not None else np.zeros(rows.size, dtype=bool)
        self.rejected[rows] = rej
        return ~rej[owner]

    def finite(self, k, x, P):
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
            raise self.diverged(k, "the updated estimate is not finite")


def _estimated_coefficients(perturbations, estimate, parameter_sigma):
    """The coefficients :func:`filter_orbit` estimates (each with its a priori sigma)."""
    if not estimate:
        if parameter_sigma:
            raise InvalidInputError("parameter_sigma= without estimate=: name the coefficients "
                                    "to estimate (estimate='drag').")
        return []
    from ..satellites.cowell import perturbation_list
    from ..satellites.force_parameters import coefficients

    est, _ = coefficients(list(perturbation_list(perturbations, allow_none=True)), estimate,
                          parameter_sigma, None)
    missing = [c.name for c in est if c.sigma is None]
    if missing:
        raise InvalidInputError(
            f"filter_orbit needs an a priori sigma for each estimated coefficient (its initial "
            f"covariance): parameter_sigma={{{missing[0]!r}: ...}}.")
    return est


def _augmented(P, C):
    """The block-diagonal covariance diag(P, C)."""
    n, k = P.shape[0], C.shape[0]
    out = np.zeros((n + k, n + k))
    out[:n, :n] = P
    out[n:, n:] = C
    return out


def _coefficient_fields(est, xs, Ps, perturbations, sm_x=None, sm_P=None, gauss=None):
    """The FilteredOrbit fields of the estimated coefficients (empty without), smoothed too
    with the smoother's (``sm_x``, ``sm_P``), and the Gauss-Markov noise ``gauss``
    (:class:`visviva.od.gauss_markov.GaussMarkov`) of those that had one."""
    from astropy import units as u

    from ..satellites.force_parameters import estimated_perturbations

    def quantity(name, value):
        return value * u.m**2 / u.kg if name == "drag" else value

    out = {"parameters": {}, "parameter_sigma": {}}
    for j, c in enumerate(est):
        out["parameters"][c.name] = quantity(c.name, xs[:, 6 + j].copy())
        out["parameter_sigma"][c.name] = quantity(c.name, np.sqrt(Ps[:, 6 + j, 6 + j]))
    out["parameter_noise"] = {} if gauss is None else {
        c.name: (quantity(c.name, float(gauss.sigma[j])), float(gauss.tau_s[j]) * u.s)
        for j, c in enumerate(est) if np.isfinite(gauss.tau_s[j])}
    out["perturbations"] = estimated_perturbations(perturbations, est, xs[-1, 6:])
    out["smoothed_parameters"] = out["smoothed_parameter_sigma"] = None
    if sm_x is not None:
        out["smoothed_parameters"] = {c.name: quantity(c.name, sm_x[:, 6 + j].copy())
                                      for j, c in enumerate(est)}
        out["smoothed_parameter_sigma"] = {
            c.name: quantity(c.name, np.sqrt(sm_P[:, 6 + j, 6 + j])) for j, c in enumerate(est)}
    return out


#: how far (relative) a smoothed variance may exceed the filtered one (round-off) before the
#: smoother is refused
SMOOTHED_VARIANCE_RTOL = 1e-3


def _rts(xs, Ps, xp, Pp, phis=None, roots=None, joints=None):
    """Rauch-Tung-Striebel pass backwards over filtered (xs, Ps) and predicted (xp, Pp), in
    square-root form: with the STMs ``phis`` and ``roots``, the extended filter's filtered and
    predicted square roots and its noises' (:func:`visviva.od.extended.ekf_pass`;
    :func:`visviva.od.square_root.smooth_factor`), or with ``joints``, the unscented filter's
    filtered and predicted square roots and the joint square roots of (x_k, x_k+1^-) from its
    sigma points (Saerkkae's unscented RTS smoother, the same recursion;
    :func:`visviva.od.square_root.smooth_factor_from_joint`)."""
    from . import square_root as sr

    sx = xs.copy()
    sP = Ps.copy()
    Lf, Lp, extra = roots if roots is not None else joints
    Ls = Lf.copy()
    n = xs.shape[1]
    for k in range(len(xs) - 2, -1, -1):
        try:
            if roots is not None:
                C = sr.smoother_gain(Lf[k], phis[k + 1], Lp[k + 1])
                Ls[k] = sr.smooth_factor(Lf[k], phis[k + 1], extra[k + 1], C, Ls[k + 1])
            else:  # C = cross^T (P_k+1^-)^-1, cross = L21 L11^T
                T = extra[k + 1]
                C = sr.smoother_gain(T[:n, :n], None, Lp[k + 1], image=T[n:, :n])
                Ls[k] = sr.smooth_factor_from_joint(T, C, Ls[k + 1])
        except np.linalg.LinAlgError:
            raise _singular() from None
        sP[k] = sr.covariance(Ls[k])
        sx[k] = xs[k] + C @ (sx[k + 1] - xp[k + 1])
    # the smoothed variances cannot exceed the filtered ones (P^s = P^+ + C (P^s - P^-) C^T
    # with P^s - P^- <= 0): far above them, the gain came from a near-singular P^-
    var_s = np.diagonal(sP, axis1=1, axis2=2)
    var_f = np.diagonal(Ps, axis1=1, axis2=2)
    if not (np.all(np.isfinite(sx)) and np.all(np.isfinite(sP))
            and np.all(var_s >= 0)
            and np.all(var_s <= var_f * (1.0 + SMOOTHED_VARIANCE_RTOL))):
        raise _singular()
    return sx, sP


def _singular():
    return ConvergenceError(
        "the smoother's estimate is not finite, has negative variances or variances above "
        "the filter's: a predicted covariance is singular or nearly so (a parameter_noise "
        "sigma of 0 decays a coefficient's variance to 0); give sigma > 0, or smoother=False.")


def _isot(epoch, offset_s):
    from astropy import units as u

    return (epoch + offset_s * u.s).utc.isot
