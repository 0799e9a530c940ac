"""What a converged batch fit says about itself: a misfit that its covariance cannot describe.

A fit whose normalised residuals are many times their sigmas has converged to the data's best
estimate under a model that does not explain them (or to another minimum): its covariance,
scaled to the sigmas, is then too small by about the RMS. It is returned (a fit without a burn
or a troposphere model shows the misfit on purpose) with a warning.
"""

from __future__ import annotations

import warnings

from ..errors import ConvergenceError

__all__ = ["MISFIT_REJECTED", "MISFIT_RMS", "STALL_CHANGE", "STALL_GAIN", "STALL_ITERATIONS", "STALL_STEP",
           "UNDETERMINED_CHI2", "UNDETERMINED_RADIUS", "UNDETERMINED_STEP", "failed", "stall_message", "stalled",
           "undetermined", "warn_misfit"]

#: a converged fit whose RMS of normalised residuals exceeds this warns (for residuals that
#: are the noise the sigmas describe, the RMS is 1 +- 1/sqrt(2 dof))
MISFIT_RMS = 10.0


#: a converged fit that rejects more than this fraction of its rows as outliers warns (noise
#: as the sigmas describe it puts well under 1 % of the rows past the editing limit; audit24:
#: station heights given in km to `visviva od`, which reads metres, rejected 36 % of the rows
#: at an RMS of 8.9, without a word)
MISFIT_REJECTED = 0.2

#: a fit has stalled when its RMS changed by less than STALL_CHANGE (relative) from each accepted
#: iterate to the next over STALL_ITERATIONS of them in a row, while each correction was over
#: STALL_STEP of its own sigmas: a linear model that predicts a chi^2 drop of n x STALL_STEP^2
#: that never comes (a flat, curved valley: an unknown the data barely see, or a guess far off)
STALL_CHANGE = 1e-3
STALL_ITERATIONS = 4
STALL_STEP = 3.0
#: ... or when each of STALL_ITERATIONS accepted iterates in a row lowered chi^2 by under
#: STALL_GAIN of what its step's linear model promised (Madsen, Nielsen & Tingleff 2004's gain
#: ratio; about 1 near a minimum): damped steps creeping down a curved valley, the RMS falling
#: a few % per iterate, never settling (a drag coefficient two stations barely see: 273
#: iterations to leave its domain)
STALL_GAIN = 0.1


#: a Gauss-Newton (undamped) step shorter than UNDETERMINED_STEP of its own sigmas that makes
#: chi^2 on the rows it was fitted to grow by more than UNDETERMINED_CHI2 shows measurements
#: that are not linear in the state within its formal uncertainty: the data do not determine
#: the orbit (audit44: one pass of range rate from one station, 16 rows, started at the truth,
#: formal position sigma 2400 km, ran out of its 25 iterations with "start from a better initial
#: state"; in a well-determined fit a sub-sigma step changes chi^2 by round-off)
UNDETERMINED_STEP = 3.0
UNDETERMINED_CHI2 = 1.0
#: ... and the orbit, rather than the estimated burns or coefficients, is blamed when the
#: formal position sigma exceeds this fraction of the radius
UNDETERMINED_RADIUS = 0.01


def undetermined(lm, rms, step, window, P, observations, burns=(), coefficients=()):
    """The message of a fit whose data do not determine its unknowns, or None.

    ``lm`` is the fit's :class:`~visviva.od.damping.Marquardt` just after it rejected an
    iterate of RMS ``rms`` (inf: not evaluated), ``step`` the Gauss-Newton correction that led
    there (in its own sigmas), ``window`` whether an arc window is open, ``P`` the covariance
    of the last accepted iterate (the state in km, km/s, then 3 Δv components (km/s) per
    index in ``burns``, then the estimated ``coefficients`` by name: drag's B in m^2/kg, Cr)
    and ``observations`` the table."""
    import numpy as np

    if (window or lm.used != 0.0 or not np.isfinite(rms) or lm.gain is None
            or not np.isfinite(lm.gain) or not step < UNDETERMINED_STEP or P is None):
        return None
    grew = -lm.gain * lm.predicted  # chi^2 after the step minus before it, on the same rows
    if not grew > UNDETERMINED_CHI2:
        return None
    sigma_km = float(np.sqrt(max(np.trace(P[:3, :3]), 0.0)))
    radius = float(np.linalg.norm(lm.base[2][:3]))
    kinds = observations.kinds
    counts = ", ".join(f"{int(np.sum(kinds == k))} {k}" for k in dict.fromkeys(kinds))
    sites = {id(s) for s in observations.stations if s is not None}
    span = float(np.ptp(observations.offsets_s(observations.times[0])))
    head = (f"a Gauss-Newton step of {step:.2g} of its own sigmas made chi^2 grow by "
            f"{grew:.3g}: the measurements are not linear in the unknowns even within their "
            f"formal uncertainty at the last accepted iterate (position {sigma_km:.3g} km, "
            f"{100 * sigma_km / radius:.2g} % of the radius")
    sig = np.sqrt(np.maximum(np.diag(P), 0.0))
    parts = [f"Δv of burn {i} (sigma {1e3 * np.linalg.norm(sig[6 + 3 * j:9 + 3 * j]):.3g} m/s)"
             for j, i in enumerate(burns)]
    first = 6 + 3 * len(burns)
    parts += [f"{name} coefficient (sigma {sig[first + j]:.3g}"
              + (" m^2/kg)" if name == "drag" else ")") for j, name in enumerate(coefficients)]
    data = (f"The data ({counts} rows from {len(sites)} station(s) over {span:.0f} s)")
    if (burns or coefficients) and sigma_km < UNDETERMINED_RADIUS * radius:
        return (f"the observations do not determine the estimated {', '.join(parts)}: {head}). "
                f"{data} hardly see them: fix them (leave them out of estimate= / "
                "estimate_maneuvers=) or give them an a priori (parameter_sigma=, the burn's "
                "execution covariance), or add data over a longer arc.")
    return (f"the observations do not determine the orbit: {head}"
            + "".join(f"; {p}" for p in parts) + f"). {data} leave it open (one pass of range "
            "or range rate from one station cannot fix it): add angles, another station or "
            "pass, or an a priori state covariance (apriori_covariance=); a better first guess "
            "will not help.")


def stalled(history, gains=()):
    """Whether the accepted iterates at the end of ``history`` (entries of one set of rows)
    have stalled (``STALL_*``): the fit would creep to max_iterations ("flat" or "creeping",
    else False). ``gains``: each accepted
    iterate's drop in chi^2 over the drop its step's linear model promised (None where unknown;
    a damped fit's), the last ``STALL_ITERATIONS`` under ``STALL_GAIN`` after corrections over
    ``STALL_STEP`` sigmas are a stall too (damped steps creeping down a valley)."""
    acc = [h for h in history if h["accepted"]][-(STALL_ITERATIONS + 1):]
    if len(acc) <= STALL_ITERATIONS:
        return False
    rms = [h["rms"] for h in acc]
    if (all(abs(b - a) <= STALL_CHANGE * a for a, b in zip(rms, rms[1:], strict=False))
            and all(h["correction"] > STALL_STEP for h in acc[1:])):
        return "flat"
    last = list(gains)[-STALL_ITERATIONS:]
    if (len(last) == STALL_ITERATIONS and all(g is not None and g < STALL_GAIN for g in last)
            and all(h["correction"] > STALL_STEP for h in acc[:-1])):
        return "creeping"
    return False


def stall_message(it, rms, step, estimated, why="flat"):
    """What a stalled fit (:func:`stalled`, which said ``why``) says: where, and what to do
    (``estimated``: the names of the coefficients it estimates)."""
    todo = ("fix the estimated coefficients (" + ", ".join(estimated) + ": leave them out of "
            "estimate=) or give them an a priori sigma (parameter_sigma=); or " if estimated
            else "")
    how = (f"its RMS ({rms:.4g}) changed by under {100 * STALL_CHANGE:.2g} %" if why == "flat"
           else f"each accepted step lowered chi^2 by under {100 * STALL_GAIN:.2g} % of what "
           f"the Gauss-Newton step promised (RMS now {rms:.4g})")
    return (f"the orbit fit stalled at iteration {it}: over {STALL_ITERATIONS} iterations {how} "
            f"while each correction was {step:.3g} of its own sigmas, so the data barely "
            "determine a direction of the "
            f"estimate: {todo}start from a better initial state (IOD), or fit a shorter arc "
            "first.")


def warn_misfit(rms, n_rejected=0, n_rows=1, stacklevel=3):
    """RuntimeWarning when a converged fit's RMS of normalised residuals exceeds MISFIT_RMS,
    or when it rejected more than MISFIT_REJECTED of its ``n_rows`` rows."""
    if rms > MISFIT_RMS:  # audit20: a local minimum at RMS 68000 came back with a 13 m sigma
        warnings.warn(
            f"the fit converged with an RMS of {rms:.4g}: its residuals are that many times "
            "their sigmas, so the model does not explain the data (a burn, force or "
            "troposphere missing, wrong sigmas or stations, an a priori the data contradict, "
            "or a first guess that led to another minimum) and fit.covariance, scaled to the "
            "sigmas, understates the error about as many times.", RuntimeWarning,
            stacklevel=stacklevel)
    elif n_rejected > MISFIT_REJECTED * n_rows:
        warnings.warn(
            f"the fit rejected {n_rejected} of its {n_rows} observations "
            f"({100 * n_rejected / n_rows:.0f} %) as outliers: the model does not explain a "
            f"large part of the data (RMS {rms:.4g} of those kept). Check the stations' "
            "coordinates (heights in metres on the command line), the time tags, the sigmas "
            "and the force model, or look for a burn; fit.rejected marks the rows.",
            RuntimeWarning, stacklevel=stacklevel)


def failed(history, message):
    """A :class:`~visviva.ConvergenceError` with ``message`` and the fit's per-iteration
    ``history`` attached (``err.history``)."""
    err = ConvergenceError(message)
    err.history = history
    return err
