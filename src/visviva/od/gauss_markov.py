"""First-order Gauss-Markov process noise on the coefficients a filter estimates.

:func:`visviva.filter_orbit`'s ``parameter_noise={"drag": (sigma, tau)}`` turns an estimated
coefficient p (the drag ballistic coefficient B, the SRP Cr) from a constant into a first-order
Gauss-Markov process about its a priori value p0 (the value in ``perturbations``):

    d(p - p0)/dt = -(p - p0) / tau + w,   w white, E[w(t) w(s)] = (2 sigma^2 / tau) delta(t - s),

whose variance relaxes to the steady state sigma^2 with the correlation time tau. Over a step
of dt seconds the discrete model is exact (Tapley, Schutz & Born 2004, sec. 4.9.1; Vallado 2013,
sec. 10.6):

    p_k - p0 = m (p_k-1 - p0) + w_k,   m = exp(-dt / tau),   var(w_k) = sigma^2 (1 - m^2),

so the estimate decays towards p0 by m, its variance P_pp -> m^2 P_pp + sigma^2 (1 - m^2)
(which keeps sigma^2 when it starts there), and its covariance with the orbit state is scaled
by m (the transition's p row). The filter cuts each prediction into steps of at most tau / 50
(of the shortest tau; with ``process_noise`` also at most ``noise_step``) and flies each step
with the coefficient it had at the step's start (1 % of the deviation p - p0 off its mean over
the step); the decay and the noise are applied at the step's end.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["GaussMarkov", "gauss_markov"]

#: sub-steps per correlation time: the orbit flies the coefficient of each step's start
STEPS_PER_TAU = 50
#: the shortest correlation time, s: a coefficient that decorrelates within a minute is white
#: noise on the acceleration at the time scales of orbit determination (``process_noise``)
MIN_TAU_S = 60.0


class GaussMarkov:
    """The Gauss-Markov models of a filter's k estimated coefficients (columns 6.. of its state).

    Attributes
    ----------
    prior : ndarray (k,)
        The values the coefficients decay towards (their a priori values).
    sigma : ndarray (k,)
        Steady-state standard deviations (0 for a coefficient without noise).
    tau_s : ndarray (k,)
        Correlation times, s (inf for a coefficient without noise: a constant).
    """

    def __init__(self, prior, sigma, tau_s):
        self.prior = np.asarray(prior, dtype=float)
        self.sigma = np.asarray(sigma, dtype=float)
        self.tau_s = np.asarray(tau_s, dtype=float)

    def longest_step_s(self, q, step_s):
        """The longest sub-step of a prediction, s: tau / :data:`STEPS_PER_TAU` of the shortest
        tau (inf when no coefficient has noise), and at most ``step_s`` with process noise
        ``q``."""
        longest = float(np.min(self.tau_s)) / STEPS_PER_TAU
        return longest if q is None else min(longest, step_s)

    def step(self, dt):
        """(m, d, v): the decay factors m = exp(-dt / tau) (k,), 1 - m, and the noise variances
        sigma^2 (1 - m^2) (k,) of a step of ``dt`` s."""
        # m and 1 - m each to full relative precision (1 - d would lose m's digits once
        # dt >> tau: 1.1e-7 for dt = 16 tau carried a relative error of 1e-9)
        x = -dt / self.tau_s
        return np.exp(x), -np.expm1(x), self.sigma**2 * -np.expm1(2.0 * x)

    def _decayed(self, p, d):
        """p - (1 - m) (p - p0): exactly p where the decay is 1 (no Gauss-Markov model)."""
        return p - d * (p - self.prior)

    def apply(self, z, P, phi, dt):
        """The state z (6 + k,), covariance P and transition ``phi`` of a prediction ending
        with a step of ``dt`` s, with the coefficients' decay and noise over that step:
        p -> p0 + m (p - p0), P -> G P G^T + diag(0, v), phi -> G phi, G = diag(1, m)."""
        m, d, v = self.step(dt)
        g = np.r_[np.ones(z.size - m.size), m]
        z = np.r_[z[:-m.size], self._decayed(z[-m.size:], d)]
        P = g[:, None] * P * g[None, :]
        P[np.arange(-m.size, 0), np.arange(-m.size, 0)] += v
        return z, P, g[:, None] * phi

    def apply_points(self, Y, dt):
        """Sigma points Y (N, 6 + k) at a step's end with their coefficients decayed; and the
        noise covariance diag(0, v) (6 + k, 6 + k) the step adds."""
        _, d, v = self.step(dt)
        k = d.size
        Y = Y.copy()
        Y[:, -k:] = self._decayed(Y[:, -k:], d)
        return Y, np.diag(np.r_[np.zeros(Y.shape[1] - k), v])


def _pair(name, value):
    """(sigma, tau_s) of one ``parameter_noise`` entry, checked."""
    from .._units import to_array

    try:
        sigma, tau = value
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"parameter_noise[{name!r}] must be a pair (sigma, tau): the steady-state 1-sigma "
            f"(as parameter_sigma's) and the correlation time, e.g. "
            f"{{'drag': (0.002 * u.m**2 / u.kg, 3 * u.hour)}}; got {value!r}.") from None
    kind = "area_per_mass" if name == "drag" else "dimensionless"
    what = f"parameter_noise[{name!r}]"
    s = np.ravel(to_array(sigma, kind, f"{what} sigma", finite=False))
    t = np.ravel(to_array(tau, "time", f"{what} tau", allow_plain=True, finite=False))
    if s.size != 1 or t.size != 1:
        raise InvalidInputError(f"{what} must be one sigma and one tau; got {value!r}.")
    s, t = float(s[0]), float(t[0])
    if not (np.isfinite(s) and s >= 0):
        raise InvalidInputError(f"{what}: sigma must be a finite number >= 0; got {sigma!r}.")
    if not (np.isfinite(t) and t > 0):
        raise InvalidInputError(
            f"{what}: tau must be a finite time > 0; got {tau!r}. (With tau infinite the "
            "coefficient is a constant and gets no noise: leave it out of parameter_noise. A "
            "random walk of rate r (variance per second) is the limit of a large tau with "
            "sigma = sqrt(r tau / 2).)")
    if t < MIN_TAU_S:
        raise InvalidInputError(
            f"{what}: tau = {t:g} s is shorter than {MIN_TAU_S:g} s; a coefficient that "
            "decorrelates that fast is white noise on the acceleration: give it as "
            "process_noise= instead (or a tau of minutes to days, as drag and SRP vary).")
    return s, t


def gauss_markov(parameter_noise, est):
    """The :class:`GaussMarkov` of the estimated coefficients ``est`` (a list of
    :class:`~visviva.satellites.force_parameters.Coefficient`) from ``parameter_noise``
    ({name: (sigma, tau)}); None when it is None or empty."""
    if not parameter_noise:
        if parameter_noise is not None and not isinstance(parameter_noise, dict):
            raise InvalidInputError(
                f"parameter_noise must be a mapping name -> (sigma, tau); got {parameter_noise!r}.")
        return None
    if not isinstance(parameter_noise, dict):
        raise InvalidInputError(
            "parameter_noise must be a mapping of estimated coefficient to (sigma, tau), e.g. "
            f"{{'drag': (0.002 * u.m**2 / u.kg, 3 * u.hour)}}; got {parameter_noise!r}.")
    names = [c.name for c in est]
    extra = [n for n in parameter_noise if n not in names]
    if extra:
        raise InvalidInputError(
            f"parameter_noise gives {extra[0]!r}, which estimate= does not name (estimated: "
            f"{names or 'none'}): the noise is on an estimated coefficient; add it to "
            "estimate= (with its parameter_sigma) or leave it out.")
    pairs = [_pair(c.name, parameter_noise[c.name]) if c.name in parameter_noise
             else (0.0, np.inf) for c in est]
    return GaussMarkov([c.prior for c in est], [s for s, _ in pairs], [t for _, t in pairs])
