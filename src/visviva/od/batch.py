"""Batch weighted least squares: the orbit that best explains a table of observations.

The estimate is the epoch state x0 = (r0, v0). Each iteration integrates the trajectory and
its state-transition matrix Phi(t_i, t0) once over the whole arc
(:class:`visviva.od.dynamics.Dynamics`), forms the residuals z_i = y_i - h(x(t_i)) and the
rows H_i Phi(t_i, t0), and solves the weighted normal equations for the correction
(Tapley, Schutz & Born 2004, sec. 4.3; Montenbruck & Gill 2000, sec. 8.1). The system is
solved by SVD of the whitened, column-scaled design matrix rather than by forming the normal
matrix, which keeps the full precision of km-sized positions next to mm/s velocities.
"""

from __future__ import annotations

import numpy as np

from .._covariance import in_frame, km_covariance
from ..errors import ConvergenceError, InvalidInputError, VisvivaError
from .burn_estimation import check_observable as check_burn_observable
from .burn_estimation import check_separable, columns, considered_burns, estimated
from .damping import WINDOW_FIT, WINDOW_SETTLE, Marquardt, Window, solve
from .fit_checks import failed, stall_message, stalled, undetermined, warn_misfit
from .initial_state import check_initial
from .light_time import model
from .measurements import residuals
from .observations import KINDS, Observations

#: a fit that converged with rows edited out fits again with every row, and edits again once a
#: correction was under this many of its own sigmas: rows edited while the estimate still moved
#: by tens of sigmas were a whole good pass, never re-admitted (audit24: the docs' IOD fit
#: dropped 25 of 87 rows, 44 m off for a 17.6 m sigma)
EDIT_AFTER_STEP = 3.0

__all__ = ["fit_orbit", "OrbitFit"]


class OrbitFit:
    """The outcome of :func:`fit_orbit`.

    Attributes
    ----------
    state : StateVectors
        Estimated GCRS state at ``epoch`` (km, km/s).
    covariance : ndarray (6, 6)
        Formal covariance of the estimate, km^2, km^2/s, km^2/s^2 (order x, y, z, vx, vy, vz);
        with ``consider=``, the consider covariance (data and considered coefficients), and
        with the execution errors of known burns (``considered_maneuvers``).
    residuals : ndarray (N, 3)
        Observed minus computed for each observation at the estimate (km, km/s, rad; the
        components beyond a row's own are zero).
    normalized_residuals : ndarray (N, 3)
        Residuals divided by the row's sigma.
    rejected : ndarray of bool (N,)
        Rows left out as outliers.
    rms : float
        Root mean square of the normalised residuals of the accepted rows (about 1 when the
        sigmas are right and the model fits).
    rms_by_kind : dict
        The same, per observation kind.
    converged : bool
        Always True for a returned fit (a failed one raises :class:`~visviva.ConvergenceError`).
    iterations : int
        Iterations used.
    history : list of dict
        Per iteration: ``iteration``, ``rms``, ``n_rejected``, ``correction`` (the step's size
        relative to the covariance, sqrt(dx^T P^-1 dx / 6)), ``damping`` (lambda),
        ``accepted``, ``window`` (s: the rows within it of the epoch were fitted; None: all).
    chi2 : float
        Sum of squared normalised residuals of the accepted rows.
    dof : int
        Accepted measurement components minus 6.
    maneuvers : list of ImpulsiveBurn / FiniteBurn
        The burns of the fit's dynamics, the estimated ones with their estimated Δv (what
        :meth:`propagate` flies); empty without burns.
    estimated_maneuvers : list of int
        Indices (into ``maneuvers``) of the burns whose Δv was estimated.
    considered_maneuvers : list of int
        Indices (into ``maneuvers``) of the known impulses with an execution covariance that
        the data see: their execution errors are consider parameters, held in ``covariance``
        and ``full_covariance`` (not in ``noise_covariance``) and correlated with the
        estimate past the burn by :meth:`propagate`.
    maneuver_consider_sensitivity : ndarray (6 + 3 m + k, 3 q)
        S_b = d x_hat / d Δv of the estimate on the Δvs of those burns (on their axes).
    delta_v : Quantity (m, 3)
        The estimated Δv of those burns, km/s, on each burn's own axes (its ``frame``).
    delta_v_covariance : ndarray (m, 3, 3)
        Their formal covariances, km^2/s^2, on the same axes.
    full_covariance : ndarray (6 + 3 m + k, 6 + 3 m + k)
        The covariance of the whole estimate (state, then each Δv, then the k estimated
        coefficients in ``parameters`` order), km and km/s based, m^2/kg for drag's B,
        dimensionless for Cr; with ``consider=`` the consider covariance.
    noise_covariance : ndarray (6, 6)
        The data-only covariance of the state (the same as ``covariance`` without ``consider=``
        and without known burns' execution errors).
    parameters : dict
        The estimated coefficients (``estimate=``): ``"drag"``, the ballistic coefficient
        B = Cd A / m (Quantity, m^2/kg), ``"srp"``, the reflectivity Cr (float); empty without.
    parameter_sigma : dict
        Their formal 1-sigma, same keys and units.
    parameter_covariance : ndarray (k, k)
        Their covariance (m^2/kg for B, dimensionless for Cr).
    considered : dict
        The consider parameters (``consider=``) and their sigmas.
    consider_sensitivity : ndarray (6 + 3 m + k, q)
        S_xc = d x_hat / d c of the estimate on the q consider parameters (their units).
    perturbations : list of Perturbation
        The dynamics of the fit (what :meth:`propagate` uses by default), the estimated
        coefficients in their forces.
    apriori_covariance : ndarray (6, 6) or None
        The a priori covariance of the initial state the fit combined with the data
        (``apriori_covariance=``), km-based; None for a fit of the data alone.
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @property
    def sigma_position_km(self) -> np.ndarray:
        """Formal 1-sigma of x, y, z (km)."""
        return np.sqrt(np.diag(self.covariance)[:3])

    @property
    def sigma_velocity_km_s(self) -> np.ndarray:
        """Formal 1-sigma of vx, vy, vz (km/s)."""
        return np.sqrt(np.diag(self.covariance)[3:])

    @property
    def delta_v_sigma(self):
        """Formal 1-sigma of each estimated Δv component (Quantity (m, 3), km/s, each burn's
        axes)."""
        from astropy import units as u

        return np.sqrt(np.diagonal(self.delta_v_covariance, axis1=-2, axis2=-1)) * u.km / u.s

    def propagate(self, t, perturbations=None, **kwargs):
        """The estimate and its covariance at other times, with the fit's dynamics.

        Parameters
        ----------
        t : Quantity or astropy Time
            Output times: offsets from the estimate's epoch (any sign, increasing) or Times.
        perturbations : list of Perturbation, optional
            Dynamics (default: the fit's own perturbations).
        **kwargs
            Passed to :func:`visviva.propagate_covariance` (``output_frame="RTN"``,
            ``process_noise=...``, ``rtol``, ``atol``).

        Returns
        -------
        CovarianceResult
            ``.r``, ``.v``, ``.covariance`` (km-based), ``.stm`` at ``t``.

        Notes
        -----
        The fit's burns are flown (``maneuvers``); past an estimated burn the covariance holds
        its Δv's uncertainty and its correlation with the state,
        P(t) = [Phi S] P_full [Phi S]^T (S = d y(t) / d Δv), plus any process noise and the
        execution errors of the burns that were not estimated.
        """
        from ..satellites.covariance import propagate_covariance

        if "maneuvers" in kwargs:
            raise InvalidInputError("fit.propagate flies the fit's own burns (fit.maneuvers); "
                                    "call vv.propagate_covariance for other ones.")
        dyn = self.perturbations if perturbations is None else perturbations
        if self.parameters or self.considered:
            return self._propagate_parameters(t, dyn, kwargs)
        if not (self.estimated_maneuvers or self.considered_maneuvers):
            return propagate_covariance(self.state, self.covariance, t, dyn,
                                        maneuvers=self.maneuvers, **kwargs)
        out_name = kwargs.pop("output_frame", None) or kwargs.get("frame", "GCRS")
        out = propagate_covariance(self.state, self.covariance, t, dyn, maneuvers=self.maneuvers,
                                   output_frame="GCRS", **kwargs)
        s = out.delta_v_partials[..., self._burn_columns(out, self.estimated_maneuvers)]
        pxv = self.full_covariance[:6, 6:]
        cross = out.stm @ pxv @ np.swapaxes(s, -1, -2)
        p = out.covariance + s @ self.full_covariance[6:, 6:] @ np.swapaxes(s, -1, -2)
        p = p + cross + np.swapaxes(cross, -1, -2)
        p = p + self._burn_consider_cross(out, np.concatenate([out.stm, s], axis=-1))
        return in_frame(out, p, out_name)

    def _propagate_parameters(self, t, dyn, kwargs):
        """:meth:`propagate` with estimated or considered coefficients: the state's error and
        the coefficients' (estimated: their covariance and correlation with the state;
        considered: C and S_xc C) mapped by [Phi, S_p], S_p = d y(t) / d p."""
        from astropy import units as u

        from ..satellites.covariance import propagate_covariance
        from ..satellites.force_parameters import NAMES

        if "consider" in kwargs:
            raise InvalidInputError("fit.propagate carries the fit's own considered "
                                    "coefficients (fit.considered); call "
                                    "vv.propagate_covariance for other ones.")
        names = list(self.parameters) + list(self.considered)
        unit = {n: (1.0 * u.m**2 / u.kg if n == "drag" else 1.0) for n in names}
        out_name = kwargs.pop("output_frame", None) or kwargs.get("frame", "GCRS")
        n = self.full_covariance.shape[0]
        q = len(self.considered)
        joint = np.zeros((n + q, n + q))
        joint[:n, :n] = self.full_covariance
        if q:
            c = np.diag([float(np.square(getattr(v, "value", v)))
                         for v in self.considered.values()])
            joint[:n, n:] = self.consider_sensitivity @ c
            joint[n:, :n] = joint[:n, n:].T
            joint[n:, n:] = c
        out = propagate_covariance(self.state, joint[:6, :6], t, dyn, maneuvers=self.maneuvers,
                                   consider=unit, output_frame="GCRS", **kwargs)
        s = out.parameter_partials
        p = out.covariance - s @ np.swapaxes(s, -1, -2)  # less the unit coefficients' part
        canonical = [k for k in NAMES if k in names]  # propagate_covariance's column order
        s = s[..., [canonical.index(k) for k in names]]
        if self.estimated_maneuvers:  # the estimated Δvs' columns come first
            cols = self._burn_columns(out, self.estimated_maneuvers)
            s = np.concatenate([out.delta_v_partials[..., cols], s], axis=-1)
        cross = out.stm @ joint[:6, 6:] @ np.swapaxes(s, -1, -2)
        p = p + cross + np.swapaxes(cross, -1, -2) + s @ joint[6:, 6:] @ np.swapaxes(s, -1, -2)
        p = p + self._burn_consider_cross(out, np.concatenate([out.stm, s[..., :n - 6]],
                                                              axis=-1))
        return in_frame(out, p, out_name)

    def _burn_columns(self, out, indices):
        """The columns of ``out.delta_v_partials`` of the fit's burns ``indices``."""
        burns = [id(b) for b in out.impulses]
        return np.concatenate([np.arange(3) + 3 * burns.index(id(self.maneuvers[i]))
                               for i in indices] or [np.zeros(0, dtype=int)])

    def _burn_consider_cross(self, out, g):
        """G K C S_b^T + its transpose: the correlation of the estimate (mapped by ``g`` =
        [Phi, S...] in ``full_covariance``'s order) with the considered execution errors of
        the known burns (K = ``maneuver_consider_sensitivity``, C their execution covariances,
        S_b = d y(t) / d Δv_b; their own S_b C S_b^T is propagate_covariance's burn noise)."""
        if not self.considered_maneuvers:
            return 0.0
        sb = out.delta_v_partials[..., self._burn_columns(out, self.considered_maneuvers)]
        q = len(self.considered_maneuvers)
        c = np.zeros((3 * q, 3 * q))
        for j, i in enumerate(self.considered_maneuvers):
            c[3 * j:3 * j + 3, 3 * j:3 * j + 3] = self.maneuvers[i].execution_covariance
        cross = g @ self.maneuver_consider_sensitivity @ c @ np.swapaxes(sb, -1, -2)
        return cross + np.swapaxes(cross, -1, -2)

    def __repr__(self):
        return (
            f"OrbitFit(rms={self.rms:.3f}, {self.iterations} iterations, "
            f"{int(self.rejected.sum())} rejected of {len(self.rejected)}, "
            f"sigma_r={np.linalg.norm(self.sigma_position_km) * 1e3:.3g} m"
            f"{', with a priori' if getattr(self, 'apriori_covariance', None) is not None else ''})"
        )


def fit_orbit(observations, initial, perturbations=None, *, maneuvers=None,
              estimate_maneuvers=None, estimate=None, parameter_sigma=None, consider=None,
              apriori_covariance=None, max_iterations=25, tol=1e-5, outlier_sigma=4.0,
              rtol=None, atol=None, damping="auto"):  # fmt: skip
    """Estimate an orbit from observations by batch weighted least squares.

    Parameters
    ----------
    observations : Observations
        The measurements (positions, ranges, range rates, az/el, RA/Dec); the table's
        ``light_time`` (default True: two-way range and range rate, one-way angles, as real
        tracking measures them) and ``radec_reference`` choose the measurement model
        (:mod:`visviva.od.light_time`).
    initial : StateVectors or None
        First guess of the GCRS state, with an ``epoch`` (the estimate's epoch); e.g. from
        :func:`~visviva.gauss_angles`, :func:`~visviva.gibbs` or :func:`~visviva.herrick_gibbs`.
        None: an Earth orbit from the observations themselves
        (:func:`visviva.od.initial_orbit`: Gibbs or Herrick-Gibbs on three position fixes of
        the first pass, or Gauss on three RA/Dec). A state read from an OPM with manoeuvres
        (or indexed or converted from one) needs ``maneuvers=`` (``opm.burns()``).
    perturbations : list of Perturbation or None
        Dynamics: None or [] for two-body motion, or Cowell perturbations
        (``[vv.J2(vv.EARTH)]``, ``vv.Zonal``, ``vv.AtmosphericDrag``, ``vv.ThirdBody``,
        ``vv.SolarRadiationPressure``).
    maneuvers : list of ImpulsiveBurn / FiniteBurn, optional
        Burns in the arc, part of the dynamics (as :func:`~visviva.propagate_cowell`'s
        ``maneuvers=``; times from the estimate's epoch, either side of it).
    estimate_maneuvers : bool or list of int, optional
        Which impulsive burns of ``maneuvers`` have their Δv estimated: True for all of them,
        or their indices in ``maneuvers``. The three Δv components on each burn's own axes
        join the state as solve-for parameters, starting from the burn's ``delta_v`` (the
        planned value, or zero); ``fit.delta_v``, ``fit.delta_v_sigma``,
        ``fit.delta_v_covariance`` report them. A burn with an ``execution_covariance``
        (``delta_v_covariance=`` or ``magnitude_sigma``/``pointing_sigma``) has its
        ``delta_v`` as an a priori estimate of that covariance; without one the Δv is
        determined by the observations alone. None or False: every burn is known.
    estimate : str or list of str, optional
        Force-model coefficients solved for with the state: ``"drag"`` (the ballistic
        coefficient B = Cd A / m of the one :class:`~visviva.AtmosphericDrag` of
        ``perturbations``, m^2/kg; Cd and A / m are not separable, Cd = B / (A / m)) and
        ``"srp"`` (the reflectivity Cr of the one :class:`~visviva.SolarRadiationPressure`).
        Their values in ``perturbations`` are the starting values; ``fit.parameters``,
        ``fit.parameter_sigma`` report them and ``fit.perturbations`` flies them.
    parameter_sigma : dict, optional
        A priori sigmas of estimated coefficients (``{"drag": 0.005 * u.m**2 / u.kg}``, a
        Quantity for drag; ``{"srp": 0.2}``): pseudo-observations of the starting value, so
        that a coefficient the data barely determine stays near it. Without one the data
        alone determine the coefficient.
    consider : dict, optional
        Consider parameters and their sigmas (``{"drag": 0.004 * u.m**2 / u.kg}``): held at
        their value in ``perturbations``, their uncertainty added to the estimate's covariance
        (``fit.covariance``; ``fit.noise_covariance`` is the data-only one).
    apriori_covariance : array_like (6, 6) or Quantity, optional
        Covariance of ``initial`` (read as :func:`~visviva.filter_orbit`'s ``covariance``:
        plain km^2, km^2/s, km^2/s^2 or an area Quantity; e.g. a previous fit's
        ``fit.covariance``): ``initial`` becomes an a priori estimate that the fit combines
        with the observations (Tapley et al., sec. 4.6), the deviation measured from
        ``initial`` over all iterations. Symmetric positive semi-definite; a zero variance is
        refused, a singular correlation is held (``fit.apriori_covariance``). None: the data
        alone determine the state (``initial`` is only the starting point).
    max_iterations : int
        Iterations allowed before :class:`~visviva.ConvergenceError` is raised.
    tol : float
        Converged when the relative change of the RMS between iterations is below ``tol``
        (and the set of rejected rows stays the same).
    outlier_sigma : float or None
        From the second iteration on, rows with a normalised residual above
        ``outlier_sigma`` times max(1, s) are left out (re-admitted when they fit again),
        s = 1.4826 x the median absolute normalised residual (a robust RMS); None keeps every
        row. A fit that converges with rows left out (and 5 iterations to spare) fits once
        more with every row, editing again once a correction is under 3 of its own sigmas:
        rows left out while the estimate was far off can be a good pass it never came back
        to.
    rtol, atol : float, optional
        Integration tolerances of the variational equations (default 1e-11).
    damping : {"auto", None}
        "auto": damped steps, and the arc fitted outward from the epoch, after a step that
        fits worse (:mod:`visviva.od.damping`); None: plain Gauss-Newton steps.

    Returns
    -------
    OrbitFit
        ``.state``, ``.covariance``, ``.residuals``, ``.rms``, ``.converged``,
        ``.iterations``, ``.history``, ``.rejected``.

    Raises
    ------
    ConvergenceError
        The iteration diverged, stalled, did not settle within ``max_iterations``, or found the
        data not determining the unknowns (:func:`visviva.od.fit_checks.undetermined`); the
        exception's ``history`` attribute holds the per-iteration report.
    InvalidInputError
        Fewer measurement components than the 6 unknowns, observations that do not determine
        the orbit, or bad arguments.

    Notes
    -----
    Minimises chi^2 = sum_i (y_i - h_i(x0))^2 / sigma_i^2 over the epoch state x0 by
    Gauss-Newton steps dx = (A^T A)^-1 A^T b with A_i = H_i Phi(t_i, t0) / sigma_i and
    b_i = (y_i - h_i) / sigma_i; the covariance is P = (A^T A)^-1 at the solution (Tapley,
    Schutz & Born 2004, eqs. 4.3.25-4.3.31). Phi comes from the variational equations
    (:mod:`visviva.core.variational`), never from finite differences. Outlier editing is the
    usual k-sigma rule (Tapley et al., sec. 4.16) on a robust scale (the median absolute
    deviation), so that a few gross errors cannot hide behind the RMS they inflate.
    With correct sigmas the normalised estimation error (x0 - x_true)^T P^-1 (x0 - x_true)
    follows a chi-square law with 6 degrees of freedom and ``rms`` is close to 1 (tested over
    many noise seeds).

    Manoeuvre estimation: an estimated impulse's Δv (3 components on its own axes) extends the
    unknowns to p = (x0, Δv_1, ..., Δv_m), and the design matrix to
    A_i = H_i [Phi(t_i, t0), S_i1, ..., S_im] / sigma_i with S_ik = d y(t_i) / d Δv_k
    = Phi(t_i, t_k+) [[0], [M_k^T]] (zero before the burn; M_k the burn's local axes at the
    state before it; :mod:`visviva.satellites.burn_partials`); P = (A^T A)^-1 is then
    (6 + 3m) x (6 + 3m), and the NEES of the whole estimate follows chi-square(6 + 3m). A burn
    with an execution covariance C adds the a priori rows W (Δv_plan - Δv) with W^T W = C^-1
    (directions of C with a variance below 1e-12 of its largest are held at the plan by a
    variance of that size), as pseudo-observations of the plan (Tapley et al., sec. 4.6).

    Coefficients (``estimate=``): the unknowns gain B and/or Cr, and the design matrix their
    columns H_i d y(t_i) / d p, integrated with the STM (S' = F S + [0; da/dp],
    :mod:`visviva.core.variational`); an a priori sigma adds the row (p_0 - p) / sigma.
    Consider parameters c of covariance C (``consider=``; Tapley et al., sec. 6.3; Bierman
    1977, ch. VI): with the whitened partials A_c of the data on c, the estimate's sensitivity
    S_xc = -P A^T A_c and its covariance P_c = P + S_xc C S_xc^T (:mod:`visviva.od.parameters`).
    With burns the coefficients' partials are carried through them like the Δv's.

    A priori state (``apriori_covariance=`` P_bar): J = chi^2 + (x_bar - x0)^T P_bar^-1
    (x_bar - x0) with x_bar = ``initial``, fixed over the iterations; the rows W (x_bar - x0)
    with W^T W = P_bar^-1 join the system (:mod:`visviva.od.priors`), and
    P = (A^T A + P_bar^-1)^-1. On a linear problem this is the Bayes (Kalman) combination of
    the prior with the data, so fitting new data from a previous fit's state and covariance
    gives the fit of all the data at once, and the smoother of :func:`~visviva.filter_orbit`
    with the same prior agrees with it (both tested).
    """
    from ..satellites.cowell import perturbation_list
    from ..states import StateVectors
    from .dynamics import DEFAULT_ATOL, DEFAULT_RTOL, Dynamics
    from .parameters import check_observable, parameter_results, partials, prior_rows
    from .priors import maneuver_priors, state_prior, with_priors

    if not isinstance(observations, Observations):
        raise InvalidInputError(
            "observations must be a vv.Observations table; build one with "
            "vv.Observations(time=..., kind=..., value=..., sigma=..., station=...)."
        )
    if initial is None and apriori_covariance is not None:
        raise InvalidInputError(
            "apriori_covariance is the covariance of the initial state: give that state as "
            "initial= (e.g. a previous fit's fit.state with its fit.covariance).")
    if initial is None:
        from ..bodies import EARTH
        from .first_orbit import initial_orbit

        initial = initial_orbit(observations, EARTH)
    x, gm, epoch = check_initial(initial, maneuvers)
    from ..satellites.burn_segments import Schedule, burn_schedule, distinct_burns

    burns = [] if maneuvers is None else distinct_burns(
        [maneuvers] if not isinstance(maneuvers, list | tuple) else maneuvers)
    schedule = burn_schedule(burns, initial, epoch)  # the same objects: swapped by identity
    chosen = estimated(burns, estimate_maneuvers)
    from .parameters import coefficients

    est, con = coefficients(perturbation_list(perturbations, allow_none=True), estimate,
                            parameter_sigma, consider)
    n_dv = 6 + 3 * len(chosen)
    n_par = n_dv + len(est)
    with_params = bool(est or con)
    if not (isinstance(max_iterations, int | np.integer) and max_iterations >= 1):
        raise InvalidInputError(f"max_iterations must be an integer >= 1; got {max_iterations!r}.")
    if outlier_sigma is not None and not outlier_sigma > 0:
        raise InvalidInputError(f"outlier_sigma must be > 0 or None; got {outlier_sigma!r}.")
    for name, value in (("tol", tol), ("rtol", rtol), ("atol", atol)):
        if value is not None and not (np.isfinite(value) and value > 0):
            raise InvalidInputError(f"{name} must be a finite number > 0; got {value!r}.")
    priors = maneuver_priors([burns[i] for i in chosen], chosen)
    apriori = None
    if apriori_covariance is not None:  # the initial state as a pseudo-observation
        apriori, w0 = state_prior(apriori_covariance)
        priors.insert(0, (0, w0, x.copy()))
    n_prior = sum(w.shape[0] for _, w, _ in priors) + sum(c.sigma is not None for c in est)
    n_comp = int(observations.dims.sum())
    if n_comp + n_prior < n_par:
        raise InvalidInputError(
            f"{len(observations)} observation(s) give {n_comp} measurement components, fewer than "
            f"the {n_par} unknowns (the state, 3 per estimated Δv, the estimated "
            "coefficients); add observations, or give the initial state's covariance "
            "(apriori_covariance=)."
        )
    offsets = observations.offsets_s(epoch)
    dyn = Dynamics(gm, perturbations, epoch, (offsets.min(), offsets.max()),
                   DEFAULT_RTOL if rtol is None else rtol, DEFAULT_ATOL if atol is None else atol,
                   schedule=schedule)
    dv = np.array([burns[i].delta_v_km_s for i in chosen]).reshape(-1)
    pv = np.array([c.value for c in est])
    check_separable(schedule, burns, chosen, priors, offsets)
    flown = list(burns)
    kinds = observations.kinds
    dims = observations.dims
    comp_mask = np.arange(3)[None, :] < dims[:, None]  # (N, 3) components in use
    sig = observations.sigmas[:, None]
    rejected = np.zeros(len(observations), dtype=bool)
    history = []
    rms_prev = None
    last_step, P = np.inf, None  # the previous correction in its own sigmas, its covariance
    editing = False
    readmitted = None  # the iteration that put the rejected rows back, once
    converged = False
    lm = Marquardt(damping, tol)
    win = Window(offsets, dims, n_par)  # arc continuation after a long rejected step
    since = 0  # the history entry from which the rows are the current ones

    def restart(wider=False):  # the rows changed (a window opened or widened): start over
        nonlocal rms_prev, rejected, since
        if wider:
            win.widen()
        lm.reset()
        rms_prev, rejected, since = None, np.zeros_like(rejected), len(history)

    def retreat(it, rms, why):  # a rejected iterate: a damped step from the accepted one
        history.append({"iteration": it, "rms": rms, "n_rejected": int(rejected.sum()),
                        "correction": None, "damping": lm.used, "accepted": False,
                        "window": win.seconds})
        if why_not := undetermined(lm, rms, last_step, win.active, P, observations, chosen,
                                   [c.name for c in est]):
            raise failed(history, why_not)
        if lm.lam > 0 and win.open(last_step):  # far off: fit the rows near the epoch first
            p = lm.base[2]
            restart()
            return p[:6], p[6:n_dv], p[n_dv:]
        p = lm.retreat()
        if p is None:
            raise failed(history,
                f"the orbit fit diverged at iteration {it}: no damped step (up to lambda "
                f"{lm.lam / 10:.3g}) from the last accepted iterate lowers the RMS ({why}). "
                "Start from a better initial state (IOD) or fit a shorter arc first.")
        return p[:6], p[6:n_dv], p[n_dv:]

    def pseudo(p):  # the a priori rows' residuals at the unknowns p
        out = [w @ (value - p[col:col + w.shape[1]]) for col, w, value in priors]
        return np.concatenate(out + ([prior_rows(est, p[n_dv:], n_dv, n_par)[1]] if est else [])
                              + [np.zeros(0)])

    for it in range(1, max_iterations + 1):
        for j, i in enumerate(chosen):  # the estimated burns fly the current Δv
            flown[i] = burns[i].with_delta_v(dv[3 * j:3 * j + 3])
        if chosen:
            swap = {id(burns[i]): flown[i] for i in chosen}
            dyn.schedule = Schedule([(a, b, swap.get(id(m), m)) for a, b, m in schedule.items])
        for j, c in enumerate(est):  # the estimated coefficients fly their current value
            c.write(dyn, pv[j])
        y = None
        try:
            y, phi = dyn.propagate(x, offsets, parameters=with_params)
            with np.errstate(over="ignore", invalid="ignore"):  # a wild estimate: checked below
                h, H = model(observations, y, gm)
        except VisvivaError as exc:
            if it == 1 and y is not None and isinstance(exc, InvalidInputError):
                raise  # the measurement model refuses the first guess itself
            if lm.armed:
                x, dv, pv = retreat(it, float("inf"), f"iteration {it}: {exc}")
                continue
            raise failed(history,
                f"the orbit fit diverged at iteration {it}: the estimate's trajectory cannot be "
                f"integrated or measured ({exc}). Start from a better initial state (IOD) or "
                "fit a shorter arc."
            ) from exc
        z = residuals(kinds, observations.values, h)
        zn = np.where(comp_mask, z / sig, 0.0)
        if readmitted is None:  # editing from the second iteration (far guesses need it)
            editing = outlier_sigma is not None and rms_prev is not None and not win.active
        else:  # every row back in: editing resumes once settled, and stays on
            editing = editing or last_step < EDIT_AFTER_STEP
        if editing:
            # a robust scale (1.4826 x the median absolute normalised residual) that a minority
            # of outliers cannot inflate; large while the estimate is still far off
            scale = 1.4826 * float(np.median(np.abs(zn[comp_mask])))
            limit = outlier_sigma * max(1.0, scale)
            new_rejected = np.max(np.abs(zn), axis=1) > limit
        else:
            new_rejected = np.zeros_like(rejected)
        inside = comp_mask & win.rows()[:, None]  # every row unless a window is open
        use = inside & ~new_rejected[:, None]
        if use.sum() + n_prior < n_par and win.active:
            restart(wider=True)
            continue
        if use.sum() + n_prior < n_par:
            raise failed(history,
                f"the orbit fit diverged at iteration {it}: outlier editing left "
                f"{int(use.sum())} measurement components for {n_par} unknowns. Check the data "
                "and sigmas, or pass outlier_sigma=None."
            )
        rms = float(np.sqrt(np.mean(zn[use] ** 2)))
        if lm.armed and lm.rejects(zn, inside, pseudo(np.r_[x, dv, pv])):  # a worse fit
            x, dv, pv = retreat(it, rms, "the RMS grew")
            continue
        if not np.isfinite(rms):
            raise failed(history,
                f"the orbit fit diverged at iteration {it} (RMS by iteration: "
                + "".join(f"{hh['iteration']}: {hh['rms']:.4g}; " for hh in history)
                + "now not finite): the estimate's trajectory left the measurement model's "
                "domain (predicted values not finite). Start from a better initial state (IOD) "
                "or fit a shorter arc first.")
        if chosen:
            cols = columns(dyn.schedule, [flown[i] for i in chosen])
            phi = np.concatenate([phi, dyn.sensitivity[..., cols]], axis=-1)
            check_burn_observable(H @ phi[:, :, 6:], [burns[i] for i in chosen], chosen, priors)
        if est:
            sens = partials(dyn, est)
            check_observable(H @ sens, est)
            phi = np.concatenate([phi, sens], axis=-1)
        A = (H @ phi)[use] / np.broadcast_to(sig, use.shape)[use][:, None]
        b = zn[use]
        n_meas = A.shape[0]
        if priors:  # the a priori state and planned Δvs as pseudo-observations
            A, b = with_priors(A, b, priors, np.r_[x, dv, pv], n_par)
        if est:  # the a priori coefficients as pseudo-observations
            pa, pb = prior_rows(est, pv, n_dv, n_par)
            A, b = np.vstack([A, pa]), np.concatenate([b, pb])
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
            if lm.armed:
                x, dv, pv = retreat(it, rms, "the partials are not finite")
                continue
            raise failed(history,
                f"the orbit fit diverged at iteration {it}: the measurement partials are not "
                "finite (the trajectory left the model's domain). Start from a better initial "
                "state (IOD); check that its gm is the observed body's."
            )
        try:
            dx, P = solve(A, b)
        except InvalidInputError as exc:
            if it == 1:  # the data themselves
                raise
            if win.active:  # the window's rows do not determine the unknowns: more rows
                restart(wider=True)
                continue
            raise failed(history,  # the estimate has wandered where the data say nothing
                f"the orbit fit diverged at iteration {it} (RMS by iteration: "
                + "; ".join(f"{hh['iteration']}: {hh['rms']:.4g}" for hh in history)
                + f"; now {rms:.4g}): the estimate went where the data no longer determine "
                "it (singular normal equations). Start from a better initial state (IOD) or "
                "fit a shorter arc first.") from exc
        # the step in its own sigmas, sqrt(dx^T P^-1 dx / n) with P^-1 = A^T A: |A dx| needs
        # no inverse (solving P raised numpy's LinAlgError on an ill-conditioned step; audit20)
        step = float(np.linalg.norm(A @ dx) / np.sqrt(n_par))
        history.append({"iteration": it, "rms": rms, "n_rejected": int(new_rejected.sum()),
                        "correction": step, "damping": lm.used, "accepted": True,
                        "window": win.seconds})  # fmt: skip
        settled = (rms_prev is not None and lm.used == 0.0  # a damped step is short: not settled
                   and abs(rms - rms_prev) <= tol * max(rms_prev, 1e-300))
        if win.active and (settled or step < WINDOW_SETTLE):  # the window's fit settled
            win.widen(np.max(np.abs(zn), axis=1) <= WINDOW_FIT * max(1.0, rms))
            restart()
            continue
        if ((settled or step < 1e-4) and np.array_equal(new_rejected, rejected) and it > 1
                and (editing or outlier_sigma is None)):
            if new_rejected.any() and readmitted is None and max_iterations - it >= 5:
                # rows edited while the estimate was far off may be a good pass that the fit
                # without them never comes back to: fit once more with every row, editing
                # again once the corrections have settled (real outliers go out again)
                readmitted, editing, last_step = it, False, np.inf
                rejected = np.zeros_like(rejected)
                rms_prev = None
                continue
            converged = True
            break
        if rms_prev is not None and rms > 1e3 * min(hh["rms"] for hh in history[since:]) and it > 3:
            break
        rejected = new_rejected
        rms_prev = rms
        last_step = step
        lm.accept(A, b, np.r_[x, dv, pv], zn, use, n_meas)
        if why := stalled(history[since:], lm.gains):  # creeping to max_iterations: say why now
            raise failed(history, stall_message(it, rms, step, [c.name for c in est], why))
        dx = lm.step(A, b, dx)  # Gauss-Newton's dx unless a step was rejected lately
        x = x + dx[:6]
        dv = dv + dx[6:n_dv]
        pv = pv + dx[n_dv:]
    if not converged:
        lines = "; ".join(f"{hh['iteration']}: rms {hh['rms']:.4g}" for hh in history)
        raise failed(history,
            f"the orbit fit did not converge in {len(history)} iterations (RMS by iteration: "
            f"{lines}). Start from a better initial state (IOD), check the sigmas and the "
            "station of each row, raise max_iterations, or choose dynamics closer to the data."
        )
    observations.warn_below_horizon(y[:, :3], ~new_rejected, "the fitted orbit")
    warn_misfit(rms, int(new_rejected.sum()), len(new_rejected))
    rms_by_kind = {}
    for k in KINDS:
        m = (kinds == k)[:, None] & use
        if m.any():
            rms_by_kind[k] = float(np.sqrt(np.mean(zn[m] ** 2)))
    state = StateVectors._from_canonical(x[:3].copy(), x[3:].copy(), np.float64(gm), epoch)
    from astropy import units as u

    for i in chosen:  # the estimate's own uncertainty replaces a planned execution error
        flown[i].execution_covariance = None
    m = len(chosen)
    try:
        extra = parameter_results(dyn, est, con, pv, P, A, H, use, sig, n_meas, n_dv)
    except ConvergenceError as exc:  # a coefficient out of its domain: the report goes with it
        exc.history = history
        raise
    P_data = P
    if con:
        P = extra["_considered"]
    known, k_burn = considered_burns(dyn, flown, chosen, H, use, sig, A, P_data)
    if known:  # the known burns' execution errors, considered
        c_burn = np.zeros((3 * len(known), 3 * len(known)))
        for j, i in enumerate(known):
            c_burn[3 * j:3 * j + 3, 3 * j:3 * j + 3] = flown[i].execution_covariance
        P = P + k_burn @ c_burn @ k_burn.T
    return OrbitFit(
        state=state,
        covariance=km_covariance(P[:6, :6].copy()),
        full_covariance=km_covariance(P),
        noise_covariance=km_covariance(P_data[:6, :6].copy()),
        **{k: v for k, v in extra.items() if not k.startswith("_")},
        maneuvers=flown,
        estimated_maneuvers=list(chosen),
        considered_maneuvers=known,
        maneuver_consider_sensitivity=k_burn,
        delta_v=dv.reshape(m, 3) * u.km / u.s,
        delta_v_covariance=np.array([P[6 + 3 * j:9 + 3 * j, 6 + 3 * j:9 + 3 * j]
                                     for j in range(m)]).reshape(m, 3, 3),
        residuals=np.where(comp_mask, z, 0.0),
        normalized_residuals=zn,
        rejected=new_rejected,
        rms=rms,
        rms_by_kind=rms_by_kind,
        converged=True,
        iterations=len(history),
        history=history,
        chi2=float(np.sum(zn[use] ** 2)),
        dof=int(use.sum()) + n_prior - n_par,
        apriori_covariance=None if apriori is None else km_covariance(apriori),
    )

