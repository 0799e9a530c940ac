"""What a converged batch fit says about itself: a misfit that its covariance cannot describe.

A fit whose normalised residuals are many times their sigmas has converged to the data's best
estimate under a model that does not explain them (or to another minimum): its covariance,
scaled to the sigmas, is then too small by about the RMS. It is returned (a fit without a burn
or a troposphere model shows the misfit on purpose) with a warning.
"""

from __future__ import annotations

import warnings

__all__ = ["MISFIT_RMS", "warn_misfit"]

#: a converged fit whose RMS of normalised residuals exceeds this warns (for residuals that
#: are the noise the sigmas describe, the RMS is 1 +- 1/sqrt(2 dof))
MISFIT_RMS = 10.0


def warn_misfit(rms, stacklevel=3):
    """RuntimeWarning when a converged fit's RMS of normalised residuals exceeds MISFIT_RMS."""
    if rms > MISFIT_RMS:  # audit20: a local minimum at RMS 68000 came back with a 13 m sigma
        warnings.warn(
            f"the fit converged with an RMS of {rms:.4g}: its residuals are that many times "
            "their sigmas, so the model does not explain the data (a burn, force or "
            "troposphere missing, wrong sigmas or stations, an a priori the data contradict, "
            "or a first guess that led to another minimum) and fit.covariance, scaled to the "
            "sigmas, understates the error about as many times.", RuntimeWarning,
            stacklevel=stacklevel)
