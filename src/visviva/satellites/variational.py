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

import numpy as np

from ..errors import InvalidInputError, StepSizeError, raise_for_status
from .cowell import ForceModel, perturbation_list
from .dop853 import dop853_tableau

__all__ = ["Dynamics", "DEFAULT_RTOL", "DEFAULT_ATOL"]

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
        self.rtol = rtol
        self.atol = atol

    def propagate(self, y0, offsets_s, max_steps=2_000_000):
        """States (T, 6) and STMs Phi(t, epoch) (T, 6, 6) at ``offsets_s`` (s from the epoch).

        ``offsets_s`` may hold both signs and need not be sorted; each side is one compiled
        integration outward from the epoch. Afterwards ``n_steps`` and ``n_evaluations`` hold the
        steps and right-hand-side evaluations of the call.
        """
        if self.schedule:
            from .burn_partials import propagate_through

            y, phi, self.sensitivity = propagate_through(self, self.schedule, y0, offsets_s,
                                                         max_steps=max_steps)
            return y, phi
        from ..core.variational import integrate_variational

        A, B, C, E3, E5, D = dop853_tableau()
        offsets_s = np.asarray(offsets_s, dtype=np.float64)
        y0 = np.ascontiguousarray(y0, dtype=np.float64)
        self.n_steps = self.n_evaluations = 0
        self.sensitivity = np.zeros((offsets_s.size, 6, 0))
        y_all = np.empty((offsets_s.size, 6))
        phi_all = np.empty((offsets_s.size, 6, 6))
        for side in (-1.0, 1.0):
            idx = np.flatnonzero(offsets_s < 0) if side < 0 else np.flatnonzero(offsets_s >= 0)
            if idx.size == 0:
                continue
            order = idx[np.argsort(side * offsets_s[idx], kind="stable")]
            t = np.ascontiguousarray(offsets_s[order])
            y_out = np.empty((t.size, 6))
            phi_out = np.empty((t.size, 6, 6))
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
        return y_all, phi_all
