"""The ionosphere in the ground-station measurement models (``Observations(ionosphere=...)``).

The free electrons of the ionosphere delay a radio signal's group (the ranging code or tones)
by ``40.3 TEC / f^2`` metres, TEC in electrons per m^2 along the path and f in Hz: 1 TECU
(1e16 el/m^2) is 0.16 m at GPS L1 (1575.42 MHz), 0.083 m at S band (2.2 GHz), 0.0057 m at X band
(8.4 GHz); a vertical TEC of 5-50 TECU gives 0.4-4 m at the zenith in S band and three times that
near the horizon. The carrier phase is advanced by the same amount. With ``ionosphere`` and
``frequency_hz`` on, the models predict what the station measures:

* ``range``: plus the slant group delay (the same up and down at one frequency, so once in the
  two-way mean). An uplink at ``f_up`` and a downlink at ``f_down`` are each delayed by their
  own ``40.3 TEC / f^2``, and the two-way range (half the round trip) by the mean of the two,
  ``0.5 * 40.3 TEC (1/f_up^2 + 1/f_down^2)``: the delay at the effective frequency
  :func:`two_way_frequency_hz` ``= (0.5 (1/f_up^2 + 1/f_down^2))^-1/2``, which is what
  ``frequency_hz`` holds for such a link (one number, or one per row: a TDM's frequency lines
  give one per row, :mod:`visviva.od.link_frequencies`);
* ``range_rate``: plus the delay's rate along the pass (``"doppler": "group"``, the default:
  a range rate from ranging, whose group delay grows) or minus it (``"doppler": "phase"``:
  Doppler counted on the carrier, whose phase is advanced);
* ``azel``, ``radec`` and ``position`` rows are left alone (the ionosphere bends a radio ray
  by well under 0.01 deg above 10 deg of elevation at S band; optical angles not at all).

Two models of the electron content, each a thin shell:

* ``{"vtec_tecu": V, "shell_km": H}`` (H 350 km by default): a vertical TEC V (TECU) mapped to
  the slant by ``1 / cos z'``, ``sin z' = R / (R + H) sin z`` (z the zenith angle at the
  station, R = 6371 km): the standard single-layer mapping function (Schaer 1999, IGS IONEX);
  it is 1 at the zenith and 1 / sqrt(1 - (R / (R + H))^2) = 3.14 at the horizon for 350 km;
* ``{"klobuchar": (alpha, beta)}``: the GPS broadcast model of IS-GPS-200 (sec.
  20.3.3.5.2.5, figure 20-4; Klobuchar 1987) with the 4 alpha (s, s/semicircle, ...) and 4
  beta (s, s/semicircle, ...) coefficients of a GPS navigation message: the pierce point of a
  shell at 350 km, its geomagnetic latitude, a cosine of local time peaking at 14 h, the
  obliquity factor ``F = 1 + 16 (0.53 - E)^3`` (E in semicircles), and the L1 delay scaled to
  ``frequency_hz`` by ``(1575.42 MHz / f)^2``. The model corrects ~50 % of the ionosphere (RMS)
  by design; fit data with a measured TEC where one exists.

The range partials carry the delay's slope with the elevation and (Klobuchar) the azimuth
through the pierce point (Klobuchar: central differences, one-sided where the stencil
straddles the night switch ``|x| = 1.57``, where the delay jumps); the range rate's partials
are the geometric ones, as the troposphere's (the delay's rate moves them by less than 1e-6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import C_KM_S
from ..errors import InvalidInputError
from .slant import line_of_sight

__all__ = ["Ionosphere", "ionosphere_from", "two_way_frequency_hz", "vtec_mapping",
           "klobuchar_l1_s", "slopes", "apply"]

#: group delay per electron content: 40.3 TEC / f^2 m (TEC in el/m^2, f in Hz), m^3/s^2
K_GROUP = 40.3
#: one TEC unit, electrons per m^2
TECU = 1e16
#: the frequency of the Klobuchar coefficients (GPS L1), Hz
L1_HZ = 1575.42e6
#: the thin shell's radius: the Earth's mean radius, km (the single-layer model's R)
SHELL_EARTH_RADIUS_KM = 6371.0
#: the Klobuchar model's shell height (fixed by its psi formula), km
KLOBUCHAR_SHELL_KM = 350.0
#: steps of the central differences of the Klobuchar delay: rad in az/el, s in time
_STEP_RAD = 1e-6
_STEP_S = 1.0

_FORMS = ("{'vtec_tecu': 20.0, 'shell_km': 350.0} (a vertical TEC in TECU on a thin shell) or "
          "{'klobuchar': (alpha[4], beta[4])} (the GPS broadcast coefficients)")


@dataclass(frozen=True)
class Ionosphere:
    """A checked ionosphere: the model, its numbers and the signal's frequency.

    Attributes
    ----------
    model : {"vtec", "klobuchar"}
    frequency_hz : float or tuple of float
        The signal's frequency, Hz: one for every row, or one per row of the table (NaN on
        rows the ionosphere leaves alone: angles, positions).
    vtec_tecu, shell_km : float
        The vertical TEC (TECU) and the shell's height (km) of ``"vtec"``.
    alpha, beta : tuple of 4 floats
        The Klobuchar coefficients (s, s/semicircle^n) of ``"klobuchar"``.
    doppler : {"group", "phase"}
        The sign of the delay's rate in range rates: + (group) or - (carrier phase).
    """

    model: str
    frequency_hz: float | tuple
    vtec_tecu: float = 0.0
    shell_km: float = 350.0
    alpha: tuple = ()
    beta: tuple = ()
    doppler: str = "group"

    def slant_delay_m(self, lat_rad, lon_rad, az, el, gps_seconds, frequency_hz=None):
        """The slant group delay (m) at the station's geodetic ``lat_rad``, ``lon_rad`` for the
        satellite at azimuth ``az`` and elevation ``el`` (rad), at GPS seconds
        ``gps_seconds`` (only their time of day counts), at ``frequency_hz`` (Hz, one or one
        per element; default: the model's one frequency)."""
        f = self.frequency_hz if frequency_hz is None else frequency_hz
        if self.model == "vtec":
            m, _ = vtec_mapping(el, self.shell_km)
            return K_GROUP * self.vtec_tecu * TECU / np.square(f) * m
        t = klobuchar_l1_s(lat_rad, lon_rad, az, el, gps_seconds, self.alpha, self.beta)
        return t * C_KM_S * 1000.0 * np.square(L1_HZ / np.asarray(f))

    def row_frequencies(self, rows):
        """The frequency (Hz) of each of the table's rows ``rows``."""
        f = np.asarray(self.frequency_hz, dtype=np.float64)
        return np.full(len(rows), float(f)) if f.ndim == 0 else f[np.asarray(rows, dtype=int)]


def _positive(value, name, unit):
    """One finite number > 0 from a float or a Quantity in ``unit``."""
    if hasattr(value, "unit"):
        try:
            value = value.to_value(unit)
        except Exception:
            raise InvalidInputError(f"{name} must be in {unit}; got {value!r}.") from None
    try:
        if isinstance(value, bool | np.bool_ | str):
            raise TypeError
        out = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} must be one number ({unit}); got {value!r}.") from None
    if not np.isfinite(out) or out <= 0:
        raise InvalidInputError(f"{name} must be finite and > 0 ({unit}); got {value!r}.")
    return out


def _coefficients(values, name):
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"ionosphere's Klobuchar {name} must be 4 numbers (the navigation message's "
            f"{name}_0..3); got {values!r}.") from None
    if arr.shape != (4,) or not np.isfinite(arr).all():
        raise InvalidInputError(
            f"ionosphere's Klobuchar {name} must be 4 finite numbers (the navigation message's "
            f"{name}_0..3, s/semicircle^n); got {values!r}.")
    return tuple(float(a) for a in arr)


def two_way_frequency_hz(f_up, f_down):
    """The one frequency (Hz) whose delay ``40.3 TEC / f^2`` is a two-way link's: the mean of the
    uplink's at ``f_up`` and the downlink's at ``f_down``, ``(0.5 (1/f_up^2 + 1/f_down^2))^-1/2``
    (the two-way range is half the round trip; the same TEC both ways)."""
    return 1.0 / np.sqrt(0.5 * (1.0 / np.square(f_up) + 1.0 / np.square(f_down)))


def _frequencies(frequency_hz, kinds):
    """``frequency_hz`` checked: one number > 0, or one per row (> 0 on the range and
    range-rate rows, which the ionosphere delays; NaN allowed elsewhere) as a tuple."""
    if np.ndim(frequency_hz) == 0 or kinds is None:
        return _positive(frequency_hz, "frequency_hz", "Hz")
    f = frequency_hz
    if hasattr(f, "unit"):
        try:
            f = f.to_value("Hz")
        except Exception:
            raise InvalidInputError(f"frequency_hz must be in Hz; got {frequency_hz!r}.") from None
    try:
        if any(isinstance(x, bool | np.bool_ | str) for x in np.ravel(np.asarray(f, dtype=object))):
            raise TypeError
        f = np.asarray(f, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"frequency_hz must be one number (Hz) or one per row; got "
                                f"{frequency_hz!r}.") from None
    if f.shape != (len(kinds),):
        raise InvalidInputError(f"frequency_hz must be one number (Hz) or one per row: it has "
                                f"shape {f.shape} for {len(kinds)} rows.")
    delayed = np.isin(np.asarray(kinds), ["range", "range_rate"])
    bad = delayed & ~(np.isfinite(f) & (f > 0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InvalidInputError(f"frequency_hz of row {i} ({kinds[i]}) must be finite and > 0 "
                                f"(Hz); got {f[i]!r}.")
    return tuple(float(x) for x in f)


def ionosphere_from(ionosphere, frequency_hz, kinds=None):
    """The ``ionosphere`` and ``frequency_hz`` arguments checked: None (off) or an
    :class:`Ionosphere`. A frequency without an ionosphere is accepted and unused. With the
    rows' ``kinds``, ``frequency_hz`` may hold one frequency per row."""
    if ionosphere is None or ionosphere is False:
        return None
    if not isinstance(ionosphere, dict):
        raise InvalidInputError(f"ionosphere must be None (no model), {_FORMS}; got "
                                f"{ionosphere!r}.")
    if frequency_hz is None:
        raise InvalidInputError(
            "the ionosphere's delay depends on the signal's frequency (40.3 TEC / f^2): give "
            "frequency_hz, e.g. 2.2e9 for S band (a Quantity in Hz or a number of Hz).")
    freq = _frequencies(frequency_hz, kinds)
    keys = set(ionosphere)
    doppler = ionosphere.get("doppler", "group")
    if doppler not in ("group", "phase"):
        raise InvalidInputError(f"ionosphere's 'doppler' must be 'group' (range rate from "
                                f"ranging) or 'phase' (carrier Doppler); got {doppler!r}.")
    if keys <= {"vtec_tecu", "shell_km", "doppler"} and "vtec_tecu" in keys:
        tec = ionosphere["vtec_tecu"]
        try:
            bad = isinstance(tec, bool | np.bool_) or not isinstance(
                tec, int | float | np.integer | np.floating) or not np.isfinite(float(tec)) \
                or float(tec) < 0
        except (TypeError, ValueError):
            bad = True
        if bad:
            raise InvalidInputError(f"ionosphere's vtec_tecu must be one finite number >= 0 "
                                    f"(TEC units, 1e16 electrons/m^2); got {tec!r}.")
        shell = _positive(ionosphere.get("shell_km", 350.0), "ionosphere's shell_km", "km")
        return Ionosphere("vtec", freq, vtec_tecu=float(tec), shell_km=shell, doppler=doppler)
    if keys <= {"klobuchar", "doppler"} and "klobuchar" in keys:
        pair = ionosphere["klobuchar"]
        if not isinstance(pair, list | tuple) or len(pair) != 2:
            raise InvalidInputError(f"ionosphere's 'klobuchar' must be (alpha[4], beta[4]); "
                                    f"got {pair!r}.")
        return Ionosphere("klobuchar", freq, alpha=_coefficients(pair[0], "alpha"),
                          beta=_coefficients(pair[1], "beta"), doppler=doppler)
    raise InvalidInputError(f"ionosphere must be {_FORMS} (with an optional 'doppler': "
                            f"'group' or 'phase'); got the keys {sorted(keys)}.")


def vtec_mapping(el, shell_km=350.0):
    """The thin-shell mapping function ``1 / cos z'`` and its slope ``d / dE`` at elevations
    ``el`` (rad), with ``sin z' = R / (R + H) cos E`` (R = 6371 km, H = ``shell_km``)."""
    k = SHELL_EARTH_RADIUS_KM / (SHELL_EARTH_RADIUS_KM + shell_km)
    s = k * np.cos(el)  # sin z'
    c = np.sqrt(1.0 - s * s)  # cos z'
    return 1.0 / c, -s * k * np.sin(el) / c**3


def klobuchar_l1_s(lat_rad, lon_rad, az, el, gps_seconds, alpha, beta):
    """The GPS broadcast (Klobuchar) ionospheric delay at L1, s (IS-GPS-200, 20.3.3.5.2.5).

    Parameters
    ----------
    lat_rad, lon_rad : float or ndarray
        The user's geodetic latitude and longitude (east), rad.
    az, el : float or ndarray
        The satellite's azimuth and elevation at the user, rad.
    gps_seconds : float or ndarray
        GPS time, s (its time of day is used: the GPS time of week works as well).
    alpha, beta : sequence of 4 floats
        The navigation message's coefficients.

    Returns
    -------
    float or ndarray
        The vertical delay at the pierce point times the obliquity factor, s.
    """
    return _klobuchar(lat_rad, lon_rad, az, el, gps_seconds, alpha, beta)[0]


def _klobuchar(lat_rad, lon_rad, az, el, gps_seconds, alpha, beta):
    """:func:`klobuchar_l1_s` and the branch of each element: the day (``|x| < 1.57``) or
    night form, and the day count of the local time before its ``mod 86400`` (the model jumps
    between branches, so a difference across two branches is no derivative)."""
    e = np.asarray(el) / np.pi  # semicircles
    psi = 0.0137 / (e + 0.11) - 0.022  # Earth's central angle user-pierce point, semicircles
    phi_i = np.clip(lat_rad / np.pi + psi * np.cos(az), -0.416, 0.416)
    lam_i = lon_rad / np.pi + psi * np.sin(az) / np.cos(phi_i * np.pi)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * np.pi)  # geomagnetic latitude
    local = 4.32e4 * lam_i + gps_seconds
    t = np.mod(local, 86400.0)  # local time at the pierce point
    amp = np.maximum(sum(a * phi_m**n for n, a in enumerate(alpha)), 0.0)
    per = np.maximum(sum(b * phi_m**n for n, b in enumerate(beta)), 72000.0)
    x = 2.0 * np.pi * (t - 50400.0) / per
    f = 1.0 + 16.0 * (0.53 - e) ** 3  # obliquity factor
    is_day = np.abs(x) < 1.57
    day = np.where(is_day, amp * (1.0 - x * x / 2.0 + x**4 / 24.0), 0.0)
    return f * (5e-9 + day), 2 * np.floor_divide(local, 86400.0) + is_day


def _station_lat_lon(stations):
    out = np.zeros((len(stations), 2))
    for i, s in enumerate(stations):
        if s is None:
            continue
        try:
            out[i] = (np.radians(s.lat.to_value("deg")), np.radians(s.lon.to_value("deg")))
        except AttributeError:
            raise InvalidInputError(
                f"the ionosphere needs each station's geodetic lat and lon (a "
                f"vv.GroundStation); {s!r} has none.") from None
    return out


def slopes(iono, lat, lon, az, el, gps, frequency_hz=None):
    """The delay (m) and its partials ``d / d(az, el)`` (m/rad, (N, 2)) and ``d / dt`` (m/s),
    at ``frequency_hz`` (Hz, one per element; default: the model's one frequency)."""
    f = iono.frequency_hz if frequency_hz is None else frequency_hz
    d0 = iono.slant_delay_m(lat, lon, az, el, gps, f)
    n = np.shape(d0)[0]
    grad = np.zeros((n, 2))
    if iono.model == "vtec":
        _, dm = vtec_mapping(el, iono.shell_km)
        grad[:, 1] = K_GROUP * iono.vtec_tecu * TECU / np.square(f) * dm
        return d0, grad, np.zeros(n)
    scale = C_KM_S * 1000.0 * np.square(L1_HZ / np.asarray(f))  # s at L1 -> m at f

    def delay(*point):  # (m, branch) of the Klobuchar delay
        t, branch = _klobuchar(*point, iono.alpha, iono.beta)
        return t * scale, branch

    centre = (lat, lon, az, el, gps)
    d0, b0 = delay(*centre)
    grad[:, 0] = _difference(delay, d0, b0, _STEP_RAD, centre, 2)
    grad[:, 1] = _difference(delay, d0, b0, _STEP_RAD, centre, 3)
    dt = _difference(delay, d0, b0, _STEP_S, centre, 4)
    return d0, grad, dt


def _difference(delay, d0, b0, h, centre, k):
    """The derivative of ``delay`` in argument ``k`` of ``centre`` (2: az, 3: el, 4: time):
    central, or one-sided on the centre's branch where the stencil straddles the night switch
    (``|x| = 1.57``, where the Klobuchar delay jumps) or the local time's wrap (0 if both
    sides are other branches, a stencil wider than a branch)."""
    lo, hi = list(centre), list(centre)
    lo[k], hi[k] = centre[k] - h, centre[k] + h
    (d_lo, b_lo), (d_hi, b_hi) = delay(*lo), delay(*hi)
    lo_same, hi_same = b_lo == b0, b_hi == b0
    return np.where(lo_same & hi_same, (d_hi - d_lo) / (2 * h),
                    np.where(hi_same, (d_hi - d0) / h, np.where(lo_same, (d0 - d_lo) / h, 0.0)))


def apply(observations, kinds, y, site_r, site_v, enu, h, H, rows):
    """Add the ionosphere to the predicted values ``h`` (and the range partials ``H``) of the
    rows ``rows`` of ``observations``, in place; ``enu`` holds each row's east-north-up axes."""
    iono = observations.ionosphere
    media = (kinds == "range") | (kinds == "range_rate")
    if not media.any():
        return
    idx = np.flatnonzero(media)
    sight = line_of_sight(y[idx], site_r[idx], site_v[idx], enu[idx])
    ll = _station_lat_lon([observations.stations[i] for i in np.asarray(rows)[idx]])
    gps = observations.gps_seconds()[np.asarray(rows)[idx]]
    freq = iono.row_frequencies(np.asarray(rows)[idx])
    delay, grad, d_dt = slopes(iono, ll[:, 0], ll[:, 1], sight.az, sight.el, gps, freq)
    delay, grad, d_dt = delay / 1000.0, grad / 1000.0, d_dt / 1000.0  # km
    ranged = kinds[idx] == "range"
    r = idx[ranged]
    h[r, 0] += delay[ranged]
    if H is not None:
        H[r, 0, :3] += np.einsum("nk,nkj->nj", grad[ranged], sight.d_dr[ranged])
    rated = ~ranged
    if rated.any():
        rate = np.einsum("nk,nk->n", grad[rated], sight.rate[rated]) + d_dt[rated]
        h[idx[rated], 0] += rate if iono.doppler == "group" else -rate
