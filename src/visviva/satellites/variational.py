"""Trajectory and state-transition matrix of Cowell's force model: one compiled call per arc.

The one driver of the variational equations (:mod:`visviva.core.variational`): orbit
determination (:func:`visviva.fit_orbit`, :func:`visviva.od.simulate_observations`) and
covariance propagation (:func:`visviva.propagate_covariance`) both integrate through it.

``perturbations=None`` or ``[]`` is two-body motion; a list of Cowell perturbation objects
(``vv.J2(vv.EARTH)``, ``vv.Zonal``, ``vv.AtmosphericDrag``, ``vv.ThirdBody``,
``vv.SolarRadiationPressure``, ``SphericalHarmonics``) is assembled into the force model of
:func:`visviva.propagate_cowell` (:class:`visviva.satellites.cowell.ForceModel`), and the state
with its STM comes from the variational equations (:mod:`visviva.core.variational`).
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import InvalidInputError, StepSizeError, raise_for_status
from .cowell import ForceModel, perturbation_list
from .dop853 import dop853_tableau, integration_tolerances

__all__ = ["Dynamics", "DEFAULT_RTOL", "DEFAULT_ATOL"]

#: no events for the parallel kernel (kinds / directions, parameters)
_NO_EVENTS = (np.zeros(0, dtype=np.int64), np.zeros(0))
#: Tolerances of the variational integration: the trajectory is good to ~1 mm over a day of LEO.
DEFAULT_RTOL = 1e-11
DEFAULT_ATOL = 1e-11


class Dynamics:
    """A force model ready to integrate state + STM from an epoch (a fit's, a covariance's).

    Parameters
    ----------
    gm_km3_s2 : float
        GM of the central body, km^3/s^2.
    perturbations : list of Perturbation or None
        Cowell perturbations (None or [] for two-body motion).
    epoch : astropy Time or None
        Epoch of the state (needed by third bodies, SRP, NRLMSIS, harmonics).
    span_s : tuple of float
        (earliest, latest) offsets from the epoch the arc needs, s.
    rtol, atol : float
        Integration tolerances (atol in km and km/s).
    schedule : Schedule, optional
        Burns (:func:`visviva.satellites.burn_segments.burn_schedule`): the arc is integrated
        segment by segment through them (:func:`visviva.satellites.burn_partials.
        propagate_through`), and after :meth:`propagate` ``sensitivity`` (T, 6, 3 n) holds the
        partials of the states on the Δv of its n impulses (``impulses``).
    """

    def __init__(self, gm_km3_s2, perturbations, epoch, span_s, rtol=DEFAULT_RTOL,
                 atol=DEFAULT_ATOL, schedule=None):  # fmt: skip
        self.schedule = schedule
        self.sensitivity = None
        self.perturbations = list(perturbation_list(perturbations, allow_none=True))
        span = (min(0.0, float(span_s[0])) - 60.0, max(0.0, float(span_s[1])) + 60.0)
        self.model = ForceModel(gm_km3_s2, self.perturbations, (), epoch, span)
        self.gm = float(gm_km3_s2)
        self.rtol, self.atol = integration_tolerances(rtol, atol)

    def propagate(self, y0, offsets_s, max_steps=2_000_000, parameters=False):
        """States (T, 6) and STMs Phi(t, epoch) (T, 6, 6) at ``offsets_s`` (s from the epoch).

        ``offsets_s`` may hold both signs and need not be sorted; each side is one compiled
        integration outward from the epoch. Afterwards ``n_steps`` and ``n_evaluations`` hold the
        steps and right-hand-side evaluations of the call. ``parameters=True`` also integrates
        the sensitivities on the force model's drag and SRP coefficients, in the same compiled
        call (two more columns of the variational equations, S' = F S + [0; da/dp]):
        afterwards ``parameter_partials`` (T, 6, 2) holds d y / d ``force[BALLISTIC]``
        (Cd A / m, km^2/kg) and d y / d ``force[SRP_COEFFICIENT]`` (P Cr A / m, km/s^2), zero
        for a force that is off (:func:`visviva.core.force_partials.parameter_accelerations`).
        """
        if self.schedule:
            from .burn_partials import propagate_through

            y, phi, sens = propagate_through(self, self.schedule, y0, offsets_s,
                                             max_steps=max_steps, parameters=parameters)
            if parameters:  # the coefficients' columns, carried through the burns
                self.parameter_partials = sens[..., sens.shape[-1] - 2:]
                sens = sens[..., :sens.shape[-1] - 2]
            self.sensitivity = sens
            return y, phi
        from ..core.variational import integrate_variational

        nc = 8 if parameters else 6

        A, B, C, E3, E5, D = dop853_tableau()
        offsets_s = np.asarray(offsets_s, dtype=np.float64)
        y0 = np.ascontiguousarray(y0, dtype=np.float64)
        self.n_steps = self.n_evaluations = 0
        self.sensitivity = np.zeros((offsets_s.size, 6, 0))
        y_all = np.empty((offsets_s.size, 6))
        phi_all = np.empty((offsets_s.size, 6, nc))
        for side in (-1.0, 1.0):
            idx = np.flatnonzero(offsets_s < 0) if side < 0 else np.flatnonzero(offsets_s >= 0)
            if idx.size == 0:
                continue
            order = idx[np.argsort(side * offsets_s[idx], kind="stable")]
            t = np.ascontiguousarray(offsets_s[order])
            y_out = np.empty((t.size, 6))
            phi_out = np.empty((t.size, 6, nc))
            info = np.zeros(3)
            status = integrate_variational(
                y0, t, self.rtol, self.atol, np.inf, max_steps, *self.model.arrays(),
                A, B, C, E3, E5, D, y_out, phi_out, info,
            )  # fmt: skip
            if status != 0 and int(info[1]) >= max_steps:
                raise StepSizeError(
                    f"the variational integration used its whole step budget ({max_steps} "
                    "steps); use a shorter arc or check the state (a decaying orbit?)."
                )
            raise_for_status(np.int64(status), "state-transition-matrix integration")
            self.n_steps += int(info[1])
            self.n_evaluations += int(info[2])
            if not np.all(np.isfinite(y_out)):
                raise InvalidInputError(
                    "the integrated trajectory is not finite (it crosses the central body?); "
                    "check the state (units km, km/s; its frame) or start from a better one."
                )
            y_all[order] = y_out
            phi_all[order] = phi_out
        if parameters:
            self.parameter_partials = phi_all[..., 6:]
            return y_all, np.ascontiguousarray(phi_all[..., :6])
        return y_all, phi_all

    def at_origin(self, t0_s):
        """These dynamics with t = 0 moved ``t0_s`` s after the epoch (a filter's interval
        started at its own time; the force block's origin-dependent slots shifted by
        :func:`visviva.core.force_block.with_time_origin`)."""
        if t0_s == 0.0:
            return self
        shifted = copy.copy(self)
        shifted.model = _FromOrigin(self.model, t0_s)
        return shifted

    def propagate_many(self, y0, offsets_s, max_steps=2_000_000, threads=True, per_state=None):
        """States (N, T, 6) of N initial states (rows of ``y0``) at ``offsets_s`` (s from the
        epoch, > 0 and increasing): the same force model and DOP853 integrator without the STM,
        in one compiled call for all N (:func:`visviva.core.cowell.integrate_cowell_many`; an
        unscented filter's sigma points). ``threads=False`` runs it on the calling thread:
        waking numba's workers costs ~0.1-5 ms (a scheduler time slice on a busy machine), more
        than 13 short arcs take (the same bits either way). ``per_state`` ({force-block slot:
        (N,) factors}, e.g. ``{force_block.BALLISTIC: B_i}`` on a block holding a unit
        coefficient) flies state i with those slots multiplied by its factors (each sigma point
        its own coefficients); None: one block for all (the same bits as before)."""
        import numba

        from ..core.cowell import integrate_cowell_many, rhs_kind
        from .cowell_batch import terminal_events
        from .surface import watched_body

        y0 = np.ascontiguousarray(y0, dtype=np.float64)
        t = np.ascontiguousarray(offsets_s, dtype=np.float64)
        n = y0.shape[0]
        y_out = np.zeros((n, t.size, 6))
        status = np.zeros(n, dtype=np.int64)
        info = np.zeros((n, 6))
        arrays = self.model.arrays()
        force = arrays[0][None]
        if per_state:
            force = np.repeat(force, n, axis=0)
            for slot, factors in per_state.items():
                force[:, slot] *= factors
        # each state stops at the surface, as propagate_cowell's batches do (audit21)
        watched = watched_body(self.gm, self.perturbations, y0[:, :3]) is not None
        kinds, params, dirs = terminal_events(watched)
        before = numba.get_num_threads()
        if not threads:
            numba.set_num_threads(1)
        try:
            integrate_cowell_many(
                y0, t, float(t[-1]), self.rtol, self.atol, np.inf, max_steps, force,
                *arrays[1:], *dop853_tableau(), y_out, status, info,
                rhs_kind(arrays[0], kinds), kinds, params, dirs,
            )  # fmt: skip
        finally:
            numba.set_num_threads(before)
        hit = np.flatnonzero(info[:, 5] >= 0)
        if hit.size:
            from astropy import units as u

            from ..errors import SurfaceImpact

            k = int(hit[0])
            raise SurfaceImpact(
                f"state {k} of {n} (a sigma point) reached the central body's surface "
                f"{info[k, 4]:.3f} s after the start of the step: the orbit (or the spread of "
                "the covariance about it) decays or passes below the surface; the force model "
                "means nothing there. Check the state and covariance (a perigee this low?), or "
                "shorten the arc.", t=info[k, 4] * u.s, state=k)
        if np.any(status != 0) and np.any(info[:, 2] >= max_steps):
            raise StepSizeError(
                f"the integration used its whole step budget ({max_steps} steps); use a "
                "shorter arc or check the state (a decaying orbit?)."
            )
        raise_for_status(status, "sigma-point integration", t_reached_s=info[:, 4])
        if not np.all(np.isfinite(y_out)):
            raise InvalidInputError(
                "the integrated trajectory is not finite (it crosses the central body?); "
                "check the state (units km, km/s; its frame) or start from a better one."
            )
        return y_out


class _FromOrigin:
    """A force model whose t = 0 lies ``t0_s`` after the model's own epoch."""

    def __init__(self, model, t0_s):
        from ..core.force_block import with_time_origin

        self._arrays = (with_time_origin(model.force, t0_s),) + tuple(model.arrays()[1:])

    def arrays(self):
        return self._arrays
