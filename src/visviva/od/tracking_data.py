"""From a CCSDS TDM to an :class:`~visviva.Observations` table: what each keyword means to OD.

The rules (CCSDS 503.0-B-2, sections 3.3 and 3.5; Orekit's and ODTK's readings where the
standard leaves a choice), each applied or refused with a message saying what to do:

* **Participants and path.** ``stations`` maps the names of ``PARTICIPANT_n`` to
  :class:`~visviva.GroundStation`; the participant not in it is the spacecraft. ``MODE`` must be
  ``SEQUENTIAL``. Range and Doppler need a two-way path from one station (``PATH = 1,2,1``):
  visviva models two-way ranging (:mod:`visviva.od.light_time`); a one-way (``1,2``, ``2,1``)
  or three-way path, and ``RANGE_MODE = ONE_WAY``, need clocks it does not model, and are
  refused. Angles are measured by the one station on the path (one-way downlink model).
* **Time tags.** ``TIMETAG_REF = RECEIVE`` (also the reading when absent) is what
  :class:`~visviva.Observations` holds. ``TRANSMIT`` range is re-tagged exactly at reception,
  ``t_r = t_t + 2 rho / c`` (the round trip is the measurement itself); ``TRANSMIT`` Doppler
  and angles are refused (their flight time needs the orbit).
* **RANGE** in ``RANGE_UNITS`` (default ``km``): km is visviva's range (half the round-trip
  light path, as Orekit's two-way ``Range``). ``s`` is ambiguous: 503.0-B-2 names the unit
  (seconds) but not whose light time it is, and readers differ (Orekit's
  ``ObservationType.RANGE`` multiplies by c; Nyx divides c t by the path's legs, 2 on
  ``1,2,1``); it is refused unless ``range_seconds=`` says which:
  ``"round_trip"`` (``c t / 2``) or ``"one_way"`` (``c t``). ``RU`` (mission-defined range
  units) needs ``range_units_km=`` (km per RU, or a function). A ``RANGE_MODULUS`` (ambiguous
  range) is refused unless listed in ``ignore``.
* **DOPPLER_INSTANTANEOUS** (km/s) is the range rate, positive when the range grows
  (receding), as visviva's ``"range_rate"`` (two-way). **DOPPLER_INTEGRATED** is the mean range
  rate over ``INTEGRATION_INTERVAL``; visviva models the instantaneous rate, and the mean
  differs from the rate at the interval's middle by ``T^2 (d^3 rho / dt^3) / 24`` (measured:
  3.7 cm/s for T = 1 s and 3.7 m/s for T = 10 s on a 500 km LEO pass peaking at 60 deg;
  negligible for deep space): refused unless ``integrated_doppler="midpoint"``, which re-tags
  it at the middle (``INTEGRATION_REF``).
* **ANGLE_1/ANGLE_2** (deg) at one epoch make one row: ``ANGLE_TYPE = AZEL`` azimuth and
  elevation (``"azel"``), ``RADEC`` right ascension and declination (``"radec"``, with
  ``REFERENCE_FRAME`` GCRF or ICRF: the GCRS axes; EME2000: turned to them by the frame bias,
  up to 23 mas); XEYN and
  XSYE are refused. A lone ANGLE_1 or ANGLE_2 is an error naming its line.
* **Corrections.** ``CORRECTION_RANGE`` (in ``RANGE_UNITS``), ``CORRECTION_DOPPLER``,
  ``CORRECTION_ANGLE_1/2`` are what "has been added or should be added" to the data:
  ``CORRECTIONS_APPLIED = YES`` leaves the data, ``NO`` adds them; absent while a correction is
  nonzero is ambiguous and refused (pass ``corrections_applied=``). Aberration corrections
  (RADEC) and nonzero ``TRANSMIT_DELAY_n``/``RECEIVE_DELAY_n`` (range) are refused unless listed
  in ``ignore`` (say so when they are already in ``CORRECTION_RANGE``).
* **DATA_QUALITY** is kept on each segment; ``quality=("VALIDATED",)`` keeps only those.
* **Frequencies.** With ``ionosphere=``, the delay of each range and Doppler row is at the
  link's frequency read from the segment's ``TRANSMIT_FREQ_n`` / ``RECEIVE_FREQ_n`` lines
  (``RECEIVE_FREQ`` plus ``FREQ_OFFSET``; ``TURNAROUND_NUMERATOR/DENOMINATOR``; the last line
  at or before the row's epoch, ramped by ``TRANSMIT_FREQ_RATE_n``; the two-way frequency of uplink and downlink:
  :mod:`visviva.od.link_frequencies`), else at ``frequency_hz``; both given and more than 1 %
  apart is refused, naming the line.
* Every other data keyword (frequencies without ``ionosphere=``, phase counts, ``CLOCK_*``,
  ``TROPO_*``, ``STEC``, ``PC_N0``, ``MAG``, ``RCS`` ...) stays in the :class:`~visviva.TDM`
  and is named, with its line count, in one :class:`~visviva.errors.TrackingDataWarning`.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..ccsds import tdm as _tdm
from ..ccsds.grammar import CCSDSFormatError
from ..constants import C_KM_S
from ..errors import InvalidInputError, TrackingDataWarning

__all__ = ["TDM", "read_tdm", "to_observations", "MODELLED"]

#: data keyword -> visviva observation kind
MODELLED = {"RANGE": "range", "DOPPLER_INSTANTANEOUS": "range_rate",
            "DOPPLER_INTEGRATED": "range_rate", "ANGLE_1": None, "ANGLE_2": None}
_ANGLE_KIND = {"AZEL": "azel", "RADEC": "radec"}
_CORRECTION = {"RANGE": "CORRECTION_RANGE", "DOPPLER_INSTANTANEOUS": "CORRECTION_DOPPLER",
               "DOPPLER_INTEGRATED": "CORRECTION_DOPPLER", "ANGLE_1": "CORRECTION_ANGLE_1",
               "ANGLE_2": "CORRECTION_ANGLE_2"}
_QUALITIES = ("RAW", "VALIDATED", "DEGRADED")


class TDM(_tdm.TDM):
    """A CCSDS Tracking Data Message: a header and segments of tracking data, and the
    measurements visviva models as :class:`~visviva.Observations`.

    Parameters
    ----------
    header : Record or dict
        ``CCSDS_TDM_VERS``, ``CREATION_DATE``, ``ORIGINATOR``, optional ``MESSAGE_ID``.
    segments : list of TDMSegment
        The segments (:class:`visviva.ccsds.tdm.TDMSegment`: ``.metadata``, ``.keywords``,
        ``.epochs``, ``.values``, ``.times``, ``.select(keyword)``).
    fmt : {"kvn", "xml"}
        The format read.

    Attributes
    ----------
    header : Record
    segments : list of TDMSegment
    fmt : str
    """

    def to_observations(self, stations, sigma, **options):
        """The range, Doppler and angle data as an :class:`~visviva.Observations` table.

        Parameters
        ----------
        stations : dict
            Participant name -> :class:`~visviva.GroundStation`.
        sigma : dict
            Observation kind (``"range"``, ``"range_rate"``, ``"azel"``, ``"radec"``) ->
            standard deviation (Quantity, or km, km/s, rad).
        **options
            ``quality``, ``range_units_km``, ``range_seconds``, ``integrated_doppler``,
            ``corrections_applied``, ``ignore``, ``radec_reference``, ``troposphere``, ``ionosphere``,
            ``frequency_hz``: see :func:`to_observations`.

        Returns
        -------
        Observations
        """
        return to_observations(self, stations, sigma, **options)


def read_tdm(source, *, mission_epoch=None) -> TDM:
    """Read a CCSDS Tracking Data Message (KVN or XML, detected) for orbit determination.

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A path, the message text, or its bytes (UTF-8).
    mission_epoch : astropy.time.Time, optional
        The epoch that ``TIME_SYSTEM = MET`` or ``MRT`` counts from.

    Returns
    -------
    TDM
        ``.header``, ``.segments`` (every line kept), ``.to_observations(stations, sigma)``
        for :func:`~visviva.fit_orbit`.

    Raises
    ------
    CCSDSFormatError
        Malformed input, naming the line (see :func:`visviva.ccsds.tdm.read_tdm`).
    """
    return _tdm.read_tdm(source, mission_epoch=mission_epoch, cls=TDM)


def to_observations(tdm, stations, sigma, *, quality=None, range_units_km=None,
                    range_seconds=None,
                    integrated_doppler="refuse", corrections_applied=None, ignore=(),
                    radec_reference="gcrs", troposphere=False, ionosphere=None,
                    frequency_hz=None):  # fmt: skip
    """The range, Doppler and angle data of a TDM as an :class:`~visviva.Observations` table.

    Parameters
    ----------
    tdm : TDM
        As :func:`~visviva.read_tdm` returns.
    stations : dict
        ``PARTICIPANT_n`` name -> :class:`~visviva.GroundStation` (every station on a path of
        a segment with measurements visviva uses).
    sigma : dict
        Standard deviation per observation kind present: ``"range"`` (km or length Quantity),
        ``"range_rate"`` (km/s or speed Quantity), ``"azel"``, ``"radec"`` (rad or angle
        Quantity). The TDM carries no weights.
    quality : sequence of str, optional
        Keep only segments whose ``DATA_QUALITY`` is one of these (``"RAW"``,
        ``"VALIDATED"``, ``"DEGRADED"``); a segment without it counts as ``"RAW"``. None
        (default): every segment.
    range_units_km : float, length Quantity or callable, optional
        For ``RANGE_UNITS = RU``: km per range unit (plain: km), or ``f(segment, times, values_ru)``
        returning the ranges in km (visviva's range: half the round-trip light path).
    range_seconds : {"round_trip", "one_way"}, optional
        For ``RANGE_UNITS = s`` (required there, since CCSDS 503.0-B-2 does not say whose
        light time the seconds are): ``"round_trip"`` reads t as the round-trip light time
        (range ``c t / 2``); ``"one_way"`` as the one-way light time (range ``c t``, Orekit's
        reading). ``CORRECTION_RANGE`` in seconds is read the same way.
    integrated_doppler : {"refuse", "midpoint"}
        What to do with ``DOPPLER_INTEGRATED`` (see the module notes): refuse it (default), or
        take it as the range rate at the middle of its integration interval.
    corrections_applied : bool, optional
        Overrides ``CORRECTIONS_APPLIED`` in every segment (True: the data already hold the
        corrections; False: add them).
    ignore : sequence of str
        Keywords to leave out knowingly: metadata that would otherwise be refused
        (``RANGE_MODULUS``, ``TRANSMIT_DELAY_1``, ``CORRECTION_ABERRATION_YEARLY`` ...) or data
        keywords to drop (``"DOPPLER_INTEGRATED"``). They are named in the warning.
    radec_reference : {"gcrs", "stars"}
        What the RA/Dec data are (see :class:`~visviva.Observations`).
    troposphere : bool or dict
        Model the neutral atmosphere in the fit (see :class:`~visviva.Observations`): for data
        whose tropospheric delay is neither in the data nor in ``CORRECTION_RANGE``.
    ionosphere : dict, optional
        Model the ionosphere's delay in the fit (``{"vtec_tecu": V}`` or ``{"klobuchar":
        (alpha, beta)}``; see :class:`~visviva.Observations`), for radio data not corrected
        for it (single frequency, no ``CORRECTION_RANGE``).
    frequency_hz : float or Quantity, optional
        The signal's frequency (Hz), for ``ionosphere`` in segments without frequency lines.
        Where a segment has ``TRANSMIT_FREQ_n`` / ``RECEIVE_FREQ_n`` lines, each range and
        Doppler row is delayed at the link's two-way frequency read from them (see the module
        notes and :mod:`visviva.od.link_frequencies`), and a ``frequency_hz`` more than 1 %
        from both that row's downlink and its two-way frequency is refused.

    Returns
    -------
    Observations
        Rows sorted by reception time, ``light_time=True``.

    Raises
    ------
    CCSDSFormatError
        A segment whose data cannot be used as written (one-way path, lone angle, missing
        ``ANGLE_TYPE`` ...), or a frequency that disagrees with ``frequency_hz``, naming the line.
    InvalidInputError
        A participant without a station, a kind without a sigma, no usable measurement, an
        ``ionosphere`` with range or Doppler in a segment without frequency lines and no
        ``frequency_hz``.

    Warns
    -----
    TrackingDataWarning
        Keywords read but not used, each with its number of lines.
    """
    if not isinstance(stations, dict):
        raise InvalidInputError("stations must be a dict {participant name: GroundStation}, "
                                f"got {type(stations).__name__}")
    if not isinstance(sigma, dict):
        raise InvalidInputError("sigma must be a dict {kind: standard deviation}, e.g. "
                                "{'range': 0.01 * u.km, 'azel': 0.01 * u.deg}")
    if range_seconds not in (None, "round_trip", "one_way"):
        raise InvalidInputError(
            f"range_seconds must be 'round_trip' or 'one_way', got {range_seconds!r}")
    if integrated_doppler not in ("refuse", "midpoint"):
        raise InvalidInputError(
            f"integrated_doppler must be 'refuse' or 'midpoint', got {integrated_doppler!r}")
    if quality is not None:
        quality = (quality,) if isinstance(quality, str) else tuple(quality)
        bad = [q for q in quality if q not in _QUALITIES]
        if bad:
            raise InvalidInputError(f"quality {bad[0]!r} is none of {', '.join(_QUALITIES)}")
    ignore = frozenset((ignore,) if isinstance(ignore, str) else ignore)
    unknown = sorted(str(k) for k in ignore
                     if k not in _tdm.DATA_KEYWORDS and k not in _tdm.METADATA.by_name)
    if unknown:  # (a misspelt or lower-case keyword left the data it named in, silently)
        raise InvalidInputError(
            f"ignore: {unknown[0]!r} is not a TDM data or metadata keyword (503.0-B-2, sections "
            "3.3 and 3.5); write it as in the file, in capitals, e.g. ignore=('RANGE_MODULUS',)")
    if range_units_km is not None and not callable(range_units_km):
        from .._units import require_positive, to_array

        # (km per RU: a length Quantity such as 1 * u.m is converted; it raised a bare TypeError)
        range_units_km = to_array(range_units_km, "length", "range_units_km", allow_plain=True)
        if range_units_km.shape != ():
            raise InvalidInputError("range_units_km must be one number (km per RU) or a "
                                    f"function; got shape {range_units_km.shape}")
        require_positive(range_units_km, "range_units_km")
    link = _link_option(ionosphere, frequency_hz)
    unused: dict = {}
    parts = []
    for seg in tdm.segments:
        if quality is not None and (seg.data_quality or "RAW") not in quality:
            _count(unused, f"segments with DATA_QUALITY {seg.data_quality or '(none)'}", 1)
            continue
        parts += _segment_rows(seg, stations, ignore, unused,
                               (range_units_km, range_seconds), integrated_doppler,
                               corrections_applied, link)
    dropped = {k: n for k, n in unused.items() if k.startswith("segments with DATA_QUALITY")}
    if not parts and dropped:
        raise InvalidInputError(
            f"quality={quality} left out every segment (" + ", ".join(
                f"{n} {k}" for k, n in dropped.items()) + "; a segment without DATA_QUALITY "
            "counts as RAW); widen quality, or pass quality=None to keep them all")
    if not parts:
        raise InvalidInputError(
            "the TDM holds no measurement visviva models (RANGE, DOPPLER_INSTANTANEOUS, "
            "ANGLE_1/ANGLE_2 on a usable path); it has "
            + ", ".join(f"{k} ({n})" for k, n in tdm.keyword_counts().items()))
    if unused:
        warnings.warn("read but not used for orbit determination: " + ", ".join(
            f"{k} ({n})" for k, n in unused.items()), TrackingDataWarning, stacklevel=3)
    if link is not None and link["read"]:  # some segment's frequency lines were read
        frequency_hz = np.concatenate([p[4] for p in parts])  # one per row, sorted in _table
    return _table(parts, sigma, radec_reference, troposphere,
                  {"ionosphere": ionosphere, "frequency_hz": frequency_hz})


def _link_option(ionosphere, frequency_hz):
    """None (no ionosphere: frequency lines unused), or ``{"hz": the checked frequency_hz or
    None, "read": whether a segment's frequency lines were read}``."""
    if ionosphere is None or ionosphere is False:
        return None
    from .ionosphere import ionosphere_from

    hz = None if frequency_hz is None else ionosphere_from(ionosphere, frequency_hz).frequency_hz
    return {"hz": hz, "read": False}


def _count(unused, key, n):
    unused[key] = unused.get(key, 0) + n
    if unused[key] == 0:
        del unused[key]


def _segment_rows(seg, stations, ignore, unused, range_units, integrated_doppler,
                  corrections_applied, link=None):  # fmt: skip
    """[(times (TT), kinds, values, stations, frequencies (Hz, NaN where none))] of one
    segment ([] if none); unused lines counted."""
    use = []
    for key in dict.fromkeys(seg.keywords):
        n = seg.keywords.count(key)
        if key not in MODELLED or key in ignore:
            _count(unused, key, n)
        else:
            use.append(key)
    if not use:
        return []
    meta = seg.metadata
    src = seg.source
    for key in sorted(ignore):
        if key in meta:
            _count(unused, key, 1)
    station, two_way, index = _station(seg, stations, src)
    ranging = [k for k in use if MODELLED[k] is not None]
    if ranging and not two_way:
        raise CCSDSFormatError(
            f"{ranging[0]} on PATH = {meta.get('PATH')}, which is not two-way from the "
            "station: visviva models two-way range and Doppler (e.g. PATH = 1,2,1 with "
            "PARTICIPANT_1 the station); one-way data need the clocks' offsets. Drop them "
            f"with ignore=({ranging[0]!r},)",
            line=meta.line_of("PATH"), source=src)
    if ranging and meta.get("RANGE_MODE") == "ONE_WAY":
        raise CCSDSFormatError(
            "RANGE_MODE = ONE_WAY: visviva models two-way (coherent) ranging only",
            line=meta.line_of("RANGE_MODE"), source=src)
    applied = _applied(meta, use, ignore, corrections_applied, src)
    times = seg.times
    values = seg.values.copy()
    keys = np.array(seg.keywords)
    lines = np.array([ln if ln is not None else -1 for ln in seg.lines])
    shift = np.zeros(len(keys))  # seconds added to each time tag
    if not applied:
        for key in use:
            corr = meta.get(_CORRECTION[key])
            if corr:
                values[keys == key] += corr
    rows = []
    if "RANGE" in use:
        m = keys == "RANGE"
        km = _range_km(seg, times[m], values[m], range_units, ignore, src)
        if np.any(km < 0):
            i = int(np.flatnonzero(km < 0)[0])
            raise CCSDSFormatError(f"RANGE = {float(values[m][i])!r} is negative", line=int(lines[m][i]),
                                   source=src)
        values[m] = km
        if meta.get("TIMETAG_REF") == "TRANSMIT":
            shift[m] = 2.0 * km / C_KM_S
    doppler = [k for k in use if k.startswith("DOPPLER")]
    if doppler:
        _check_doppler_tags(seg, doppler, integrated_doppler, keys, shift, src)
    for key in [k for k in use if MODELLED[k] is not None]:
        for i in np.flatnonzero(keys == key):
            rows.append((i, MODELLED[key], values[i], station))
    if "ANGLE_1" in use or "ANGLE_2" in use:
        rows += _angle_rows(seg, keys, values, lines, station, use, src)
    idx = np.array([r[0] for r in rows])
    freqs = _row_frequencies(seg, link, index, idx, [r[1] for r in rows], unused, ignore, src)
    from ..satellites.frames import offline_iers

    with offline_iers():  # times in UT1 need the installed IERS table, never a download
        t = times[idx].tt
    if np.any(shift[idx]):
        from astropy import units as u

        t = t + shift[idx] * u.s
    return [(t, [r[1] for r in rows], [r[2] for r in rows], [r[3] for r in rows], freqs)]


def _row_frequencies(seg, link, index, idx, kinds, unused, ignore, src):
    """The frequency (Hz) of each row for the ionosphere (NaN where none is needed)."""
    freqs = np.full(len(idx), np.nan)
    delayed = np.flatnonzero(np.isin(kinds, ["range", "range_rate"]))
    if link is None or delayed.size == 0:
        return freqs
    from .link_frequencies import link_frequencies

    path = seg.path
    f, used = link_frequencies(seg, index, path[1], idx[delayed], link["hz"], src, ignore)
    link["read"] = link["read"] or f is not None
    for key in used:
        _count(unused, key, -seg.keywords.count(key))
    if f is None and link["hz"] is None:
        meta = seg.metadata
        raise InvalidInputError(
            f"{src}, line {meta.line}: the segment has range or Doppler data but no "
            "TRANSMIT_FREQ_n / RECEIVE_FREQ_n lines: the ionosphere's delay (40.3 TEC / f^2) "
            "needs the link's frequency; give frequency_hz, e.g. 2.2e9 for S band (--frequency "
            "2.2GHz on the command line)")
    freqs[delayed] = link["hz"] if f is None else f
    return freqs


def _station(seg, stations, src):
    """The GroundStation of the segment's path, whether the path is two-way from it, and its
    participant number."""
    meta = seg.metadata
    mode = meta.get("MODE", "SEQUENTIAL")
    if mode != "SEQUENTIAL":
        raise CCSDSFormatError(
            f"MODE = {mode}: visviva models SEQUENTIAL paths (differenced data need a model "
            "of both paths)", line=meta.line_of("MODE"), source=src)
    path = seg.path
    if path is None:
        raise CCSDSFormatError(
            "the segment has measurements but no PATH (e.g. PATH = 1,2,1 for two-way from "
            "participant 1): who transmitted and who received is needed",
            line=meta.line, source=src)
    names = seg.participants
    known = [n for n in dict.fromkeys(path) if names[n] in stations]
    if len(known) != 1 or len(set(path)) != 2:
        given = ", ".join(f"{n} = {names[n]!r}" for n in dict.fromkeys(path))
        if not known:
            raise InvalidInputError(
                f"{src}, line {meta.line_of('PATH')}: no participant of PATH = "
                f"{meta['PATH']} ({given}) is in stations (keys {sorted(stations)}); pass "
                "stations={name: vv.GroundStation(...)} for the ground station")
        raise CCSDSFormatError(
            f"PATH = {meta['PATH']} ({given}): visviva models a path between one ground "
            "station (a key of stations) and the spacecraft", line=meta.line_of("PATH"),
            source=src)
    station = stations[names[known[0]]]
    if not hasattr(station, "gcrs_position_velocity"):
        raise InvalidInputError(f"stations[{names[known[0]]!r}] is a "
                                f"{type(station).__name__}, not a GroundStation")
    two_way = len(path) == 3 and path[0] == path[2] == known[0]
    return station, two_way, known[0]


def _applied(meta, use, ignore, override, src):
    """Whether the data already hold the corrections (refusing what is ambiguous)."""
    for key in ("CORRECTION_ABERRATION_YEARLY", "CORRECTION_ABERRATION_DIURNAL"):
        if meta.get(key) and key not in ignore and ("ANGLE_1" in use or "ANGLE_2" in use):
            raise CCSDSFormatError(
                f"{key} = {meta[key]}: visviva's RA/Dec are the natural direction (see "
                "radec_reference); it cannot tell what the aberration correction did to "
                f"these angles. Pass ignore=({key!r},) if it does not matter",
                line=meta.line_of(key), source=src)
    if "RANGE" in use:
        for key in [k for k in meta.values if k.startswith(("TRANSMIT_DELAY_",
                                                            "RECEIVE_DELAY_"))]:
            if meta[key] and key not in ignore:
                raise CCSDSFormatError(
                    f"{key} = {meta[key]} s: visviva does not model equipment delays; correct "
                    f"the ranges, or pass ignore=({key!r},) when CORRECTION_RANGE already "
                    "holds it", line=meta.line_of(key), source=src)
    if override is not None:
        return bool(override)
    flag = meta.get("CORRECTIONS_APPLIED")
    if flag is not None:
        return flag == "YES"
    pending = [_CORRECTION[k] for k in use if meta.get(_CORRECTION[k])]
    if pending:
        raise CCSDSFormatError(
            f"{pending[0]} = {meta[pending[0]]} but CORRECTIONS_APPLIED is not given: say "
            "whether the data hold it (CORRECTIONS_APPLIED = YES or NO), or pass "
            "corrections_applied=True/False", line=meta.line_of(pending[0]), source=src)
    return True


def _range_km(seg, times, values, range_units, ignore, src):
    range_units_km, range_seconds = range_units
    meta = seg.metadata
    if meta.get("RANGE_MODULUS") and "RANGE_MODULUS" not in ignore:
        raise CCSDSFormatError(
            f"RANGE_MODULUS = {meta['RANGE_MODULUS']}: the ranges are ambiguous (known modulo "
            "that value); resolve them, or pass ignore=('RANGE_MODULUS',) if they are whole",
            line=meta.line_of("RANGE_MODULUS"), source=src)
    units = meta.get("RANGE_UNITS", "km")
    if units == "km":
        return values
    if units == "s":
        if range_seconds is None:
            raise CCSDSFormatError(
                "RANGE_UNITS = s: CCSDS 503.0-B-2 does not say whether the seconds are the "
                "round-trip or the one-way light time (readers differ by a factor 2); pass "
                "range_seconds='round_trip' (range c t / 2) or 'one_way' (range c t); "
                "--range-seconds on the command line",
                line=meta.line_of("RANGE_UNITS"), source=src)
        return (0.5 if range_seconds == "round_trip" else 1.0) * C_KM_S * values
    if range_units_km is None:
        raise CCSDSFormatError(
            "RANGE_UNITS = RU: range units are defined by the mission's ICD; pass "
            "range_units_km= (km per RU, or a function f(segment, times, values) -> km)",
            line=meta.line_of("RANGE_UNITS"), source=src)
    km = range_units_km(seg, times, values) if callable(range_units_km) else (
        values * float(range_units_km))
    km = np.asarray(km, dtype=np.float64).reshape(values.shape)
    if not np.isfinite(km).all():
        raise InvalidInputError("range_units_km gave a non-finite range")
    return km


def _check_doppler_tags(seg, doppler, integrated_doppler, keys, shift, src):
    meta = seg.metadata
    if meta.get("TIMETAG_REF") == "TRANSMIT":
        raise CCSDSFormatError(
            "Doppler tagged at transmission (TIMETAG_REF = TRANSMIT): its reception time "
            "needs the orbit; re-tag the data at reception", line=meta.line_of("TIMETAG_REF"),
            source=src)
    if "DOPPLER_INTEGRATED" not in doppler:
        return
    if integrated_doppler == "refuse":
        raise CCSDSFormatError(
            "DOPPLER_INTEGRATED is the mean range rate over INTEGRATION_INTERVAL, which "
            "visviva does not model (the rate at the interval's middle differs by about "
            "T^2/24 times the range's third derivative: cm/s for LEO at T = 1 s); pass "
            "integrated_doppler='midpoint' to use it that way, or ignore=('DOPPLER_INTEGRATED',)",
            line=seg.lines[seg.keywords.index("DOPPLER_INTEGRATED")], source=src)
    interval, ref = meta.get("INTEGRATION_INTERVAL"), meta.get("INTEGRATION_REF")
    if interval is None or ref is None:
        raise CCSDSFormatError(
            "DOPPLER_INTEGRATED needs INTEGRATION_INTERVAL and INTEGRATION_REF (START, MIDDLE "
            "or END) to place its time tag", line=meta.line, source=src)
    if interval <= 0:
        raise CCSDSFormatError(f"INTEGRATION_INTERVAL = {interval} s must be > 0",
                               line=meta.line_of("INTEGRATION_INTERVAL"), source=src)
    shift[keys == "DOPPLER_INTEGRATED"] = {"START": 0.5, "MIDDLE": 0.0, "END": -0.5}[ref] * interval


def _angle_rows(seg, keys, values, lines, station, use, src):
    meta = seg.metadata
    first = int(lines[np.flatnonzero(np.isin(keys, ["ANGLE_1", "ANGLE_2"]))[0]])
    angle_type = meta.get("ANGLE_TYPE")
    if angle_type is None:
        raise CCSDSFormatError("angle data need ANGLE_TYPE (AZEL or RADEC) in the metadata",
                               line=first, source=src)
    kind = _ANGLE_KIND.get(angle_type)
    if kind is None:
        raise CCSDSFormatError(
            f"ANGLE_TYPE = {angle_type}: visviva models AZEL and RADEC angles; drop these "
            "with ignore=('ANGLE_1', 'ANGLE_2')", line=meta.line_of("ANGLE_TYPE"), source=src)
    if kind == "radec":
        from ..ccsds.timeframes import visviva_frame

        frame = meta.get("REFERENCE_FRAME")
        if frame is None or visviva_frame(frame) != "gcrs":
            raise CCSDSFormatError(
                f"RADEC angles in REFERENCE_FRAME {frame}: visviva's RA/Dec are in EME2000, "
                "GCRF or ICRF axes (give one of these)",
                line=meta.line_of("REFERENCE_FRAME") if frame else meta.line, source=src)
    if meta.get("TIMETAG_REF") == "TRANSMIT":
        raise CCSDSFormatError(
            "angles tagged at transmission (TIMETAG_REF = TRANSMIT): visviva's angles are "
            "tagged at reception", line=meta.line_of("TIMETAG_REF"), source=src)
    t0 = seg.times[0]
    ns = np.round((seg.times - t0).sec * 1e9).astype(np.int64)
    pairs: dict = {}
    for i in np.flatnonzero(np.isin(keys, ["ANGLE_1", "ANGLE_2"])):
        slot = pairs.setdefault(int(ns[i]), {})
        if keys[i] in slot:
            raise CCSDSFormatError(f"a second {keys[i]} at {seg.epochs[i]} (the first is on "
                                   f"line {lines[slot[keys[i]]]})", line=int(lines[i]),
                                   source=src)
        slot[keys[i]] = i
    rows = []
    for slot in pairs.values():
        if len(slot) != 2:
            (key, i), = slot.items()
            other = "ANGLE_2" if key == "ANGLE_1" else "ANGLE_1"
            raise CCSDSFormatError(f"{key} at {seg.epochs[i]} has no {other} at the same "
                                   "epoch: an angle row needs both", line=int(lines[i]),
                                   source=src)
        i1, i2 = slot["ANGLE_1"], slot["ANGLE_2"]
        if not -90.0 <= values[i2] <= 90.0:
            name = "elevation" if kind == "azel" else "declination"
            raise CCSDSFormatError(f"ANGLE_2 ({name}) = {float(values[i2])!r} deg is outside "
                                   "[-90, 90]", line=int(lines[i2]), source=src)
        if not -360.0 <= values[i1] <= 360.0:  # (audit44: blamed plain numbers as radians)
            name = "azimuth" if kind == "azel" else "right ascension"
            raise CCSDSFormatError(f"ANGLE_1 ({name}) = {float(values[i1])!r} deg is outside "
                                   "[-360, 360]", line=int(lines[i1]), source=src)
        angles = np.radians([values[i1], values[i2]])
        if kind == "radec":
            angles = _radec_on_gcrs_axes(meta.get("REFERENCE_FRAME"), angles)
        rows.append((i1, kind, angles, station))
    return rows


def _radec_on_gcrs_axes(frame, angles):
    """Right ascension and declination (rad) on the axes of ``frame``, on the GCRS axes:
    EME2000 turned by the frame bias (:func:`visviva.ccsds.timeframes.to_gcrs_axes`, up to
    23 mas), GCRF/ICRF as given; the right ascension keeps its branch."""
    from ..ccsds.timeframes import to_gcrs_axes

    ra, dec = angles
    u = np.array([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)])
    (g,) = to_gcrs_axes(frame, u)
    if g is u:
        return angles
    turn = np.arctan2(g[1], g[0]) - ra
    return np.array([ra + (turn + np.pi) % (2 * np.pi) - np.pi,
                     np.arcsin(np.clip(g[2], -1.0, 1.0))])


def _table(parts, sigma, radec_reference, troposphere=False, media=None):
    from astropy.time import Time

    from .observations import Observations, sigma_value

    kinds = [k for p in parts for k in p[1]]
    known = ("range", "range_rate", "azel", "radec")
    unknown = [k for k in sigma if k not in known]
    if unknown:  # (sigma={'doppler': ...} or {'angle': ...}: blamed the TDM for a missing kind)
        raise InvalidInputError(
            f"sigma has the key {unknown[0]!r}, which is no observation kind; use "
            f"{', '.join(known)} (range_rate for Doppler, azel or radec for angles)")
    for k in dict.fromkeys(kinds):
        if k not in sigma:
            raise InvalidInputError(
                f"the TDM has {k!r} data but sigma has no {k!r}: give its standard deviation, "
                f"e.g. sigma={{{k!r}: ...}} (the TDM carries no weights)")
        sigma_value(sigma[k], k, f"sigma[{k!r}]")  # named by its kind, not by a row
    jd1 = np.concatenate([np.atleast_1d(p[0].jd1) for p in parts])
    jd2 = np.concatenate([np.atleast_1d(p[0].jd2) for p in parts])
    times = Time(jd1, jd2, format="jd", scale="tt")
    order = np.argsort((jd1 - jd1[0]) + jd2, kind="stable")
    times = times[order]
    times.format = "isot"
    times.precision = 9
    values = [v for p in parts for v in p[2]]
    sites = [s for p in parts for s in p[3]]
    media = dict(media or {})
    if np.ndim(media.get("frequency_hz")) == 1:  # one per row: sorted with the rows
        media["frequency_hz"] = np.asarray(media["frequency_hz"])[order]
    return Observations(
        time=times, kind=[kinds[i] for i in order], value=[values[i] for i in order],
        sigma=[sigma[kinds[i]] for i in order], station=[sites[i] for i in order],
        light_time=True, radec_reference=radec_reference, troposphere=troposphere,
        **(media or {}))
