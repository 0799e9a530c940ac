"""The NRLMSIS density table of :class:`visviva.satellites.AtmosphericDrag` (``model="nrlmsis"``):
its cubic B-spline coefficients and the limit of a table held at the state's epoch."""

from __future__ import annotations

import warnings

import numpy as np

from .._callsite import outside_stacklevel

__all__ = ["LONG_RUN_DAYS", "spline_coefficients", "warn_long_run"]

#: Runs longer than this (days) with the NRLMSIS table of their epoch are warned about.
LONG_RUN_DAYS = 10.0


def warn_long_run(span_s) -> None:
    """Warn when a run with NRLMSIS drag spans more than :data:`LONG_RUN_DAYS` days.

    The table is NRLMSIS at the state's epoch: the diurnal bulge follows the Sun, the season,
    the semiannual variation and the space-weather indices do not. Measured with pymsis (400 km,
    F10.7 = 150, local noon): the density changes by up to 11 % in the month after the March
    equinox at high latitudes, and by 16-46 % between the March equinox and the June solstice
    (audit42; before, such runs went on with the epoch's densities silently).

    Parameters
    ----------
    span_s : (float, float)
        The run's first and last times, s after the epoch.
    """
    days = (float(span_s[1]) - float(span_s[0])) / 86400.0
    if days > LONG_RUN_DAYS:
        warnings.warn(
            f"NRLMSIS drag is tabulated once, at the state's epoch, and this run spans "
            f"{days:.0f} days: the season and the semiannual variation are not followed (at "
            "400 km the density changes by up to ~10 % in a month, 16-46 % from the March "
            "equinox to the June solstice). Split the run into pieces of a few days, each "
            "from the last state of the one before, or accept the epoch's atmosphere.",
            UserWarning, stacklevel=outside_stacklevel(),
        )


def spline_coefficients(values: np.ndarray, pad: int = 8) -> np.ndarray:
    """Cubic B-spline coefficients of ``values`` (n_h, n_lat, n_alt) on a global grid: hour
    angles periodic, latitudes -90..90 deg both poles included, altitudes uniform.

    Across a pole the meridian continues at latitude 180 deg - phi on the opposite hour angle,
    so the latitude axis is doubled into a full great circle (n_h even) and filtered as
    periodic, like the hour angle: the spline is then smooth over the poles. The altitude axis
    is padded with ``pad`` nodes continuing ln(rho) linearly (the end differences) before a
    mirrored filter, so that the spline near the ends follows the exponential trend. Returns
    the layout of :func:`visviva.core.perturbations.grid_log_density`.
    """
    from scipy.ndimage import spline_filter1d

    n_h, n_l, n_a = values.shape
    half = n_h // 2
    # latitude node j of the great circle: j < n_l as given; beyond the pole, latitude node
    # 2 (n_l - 1) - j on the hour angle half a turn away
    back = values[(np.arange(n_h) + half) % n_h][:, n_l - 2:0:-1]
    circle = np.concatenate([values, back], axis=1)
    k = np.arange(1, pad + 1)[:, None, None]
    low = circle[..., :1] - k[::-1].transpose(1, 2, 0) * (circle[..., 1:2] - circle[..., :1])
    high = circle[..., -1:] + k.transpose(1, 2, 0) * (circle[..., -1:] - circle[..., -2:-1])
    full = np.concatenate([low, circle, high], axis=2)
    coef = spline_filter1d(full, 3, axis=0, mode="grid-wrap")
    coef = spline_filter1d(coef, 3, axis=1, mode="grid-wrap")
    coef = spline_filter1d(coef, 3, axis=2, mode="mirror")
    coef = coef[np.arange(-1, n_h + 2) % n_h]
    coef = coef[:, np.arange(-1, n_l + 1) % circle.shape[1]]
    coef = coef[..., pad - 1 : pad + n_a + 1]
    return np.ascontiguousarray(coef.reshape((n_h + 3) * (n_l + 2), n_a + 2))

