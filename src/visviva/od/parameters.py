"""Drag and SRP coefficients in a batch fit: a priori rows and the consider covariance.

The coefficients themselves (names, units, partials) are those of
:mod:`visviva.satellites.force_parameters`.

Consider covariance (Tapley, Schutz & Born 2004, sec. 6.3; Bierman 1977, ch. VI): with the
whitened design matrices A (solve-for) and A_c (consider parameters c of covariance C), the
estimate's data-only covariance P = (A^T A)^-1 and its sensitivity to c,
S_xc = d x_hat / d c = -P A^T A_c, the covariance that holds the uncertainty of c is

    P_c = P + S_xc C S_xc^T,

and the estimate's covariance with c is P_xc = S_xc C.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ..satellites.force_parameters import coefficients, estimated_perturbations, partials

__all__ = ["coefficients", "partials", "estimated_perturbations", "prior_rows",
           "check_observable", "consider_covariance", "parameter_results"]


def prior_rows(coefs, values, first, n_par):
    """The whitened a priori rows (A, b) of the estimated coefficients that have a sigma:
    (p_prior - p) / sigma, the coefficient's column at ``first`` + its position."""
    rows_a, rows_b = [], []
    for j, c in enumerate(coefs):
        if c.sigma is None:
            continue
        row = np.zeros(n_par)
        row[first + j] = 1.0 / c.sigma
        rows_a.append(row)
        rows_b.append((c.prior - values[j]) / c.sigma)
    return np.array(rows_a).reshape(-1, n_par), np.array(rows_b)


def check_observable(sens, coefs):
    """Refuse an estimated coefficient whose force leaves no trace in the data (zero partials)
    and no a priori constrains."""
    for j, c in enumerate(coefs):
        if c.sigma is None and not np.any(sens[..., j]):
            raise InvalidInputError(
                f"the {c.name} coefficient has no effect on these observations (zero partials): "
                "it cannot be estimated. Leave it out of estimate=, or give it an a priori "
                "sigma (parameter_sigma=).")


def consider_covariance(P, A, Ac, C):
    """(P_c, S_xc): the consider covariance P + S_xc C S_xc^T of the estimate and its
    sensitivity S_xc = -P A^T A_c to the consider parameters (module docstring)."""
    S = -P @ (A.T @ Ac)
    return P + S @ C @ S.T, S


def parameter_results(dyn, est, con, pv, P, A, H, use, sig, n_meas, n_dv):
    """The OrbitFit fields of the estimated and considered coefficients
    (:mod:`visviva.od.parameters`); ``_considered``: the consider covariance of the estimate."""
    from astropy import units as u

    def quantity(name, value):
        return value * u.m**2 / u.kg if name == "drag" else float(value)

    k = len(est)
    cov = P[n_dv:, n_dv:].copy()
    out = {
        "perturbations": estimated_perturbations(dyn.perturbations, est, pv),
        "parameters": {c.name: quantity(c.name, pv[j]) for j, c in enumerate(est)},
        "parameter_sigma": {c.name: quantity(c.name, np.sqrt(cov[j, j]))
                            for j, c in enumerate(est)},
        "parameter_covariance": cov.reshape(k, k),
        "considered": {c.name: quantity(c.name, c.sigma) for c in con},
        "consider_sensitivity": np.zeros((P.shape[0], len(con))),
    }
    if con:
        Ac = (H @ partials(dyn, con))[use] / np.broadcast_to(sig, use.shape)[use][:, None]
        Ac = np.vstack([Ac, np.zeros((A.shape[0] - Ac.shape[0], len(con)))])  # a priori rows
        C = np.diag([c.sigma ** 2 for c in con])
        out["_considered"], out["consider_sensitivity"] = consider_covariance(P, A, Ac, C)
    return out
