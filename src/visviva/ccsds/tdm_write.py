"""Writing a CCSDS Tracking Data Message (KVN or XML) from a :class:`~visviva.TDM` or from
:class:`~visviva.Observations`.

Observations become one segment per station and measurement family, each with the metadata
that :func:`~visviva.od.tracking_data.to_observations` reads back to the same rows:

* range and range rate: ``PATH = 1,2,1`` (two-way from the station), ``RANGE_UNITS = km``,
  ``RANGE`` and ``DOPPLER_INSTANTANEOUS`` (km/s, positive receding);
* az/el: ``PATH = 2,1`` (downlink), ``ANGLE_TYPE = AZEL``, ``ANGLE_1``/``ANGLE_2`` in degrees;
* RA/Dec: likewise with ``ANGLE_TYPE = RADEC``, ``REFERENCE_FRAME = GCRF``;

all with ``TIMETAG_REF = RECEIVE``, ``MODE = SEQUENTIAL``, ``PARTICIPANT_1`` the station's
name and ``PARTICIPANT_2`` the spacecraft. Numbers are written so that they read back to the
same float64 (degrees: the float nearest the radians' conversion); epochs to the nanosecond.
The TDM carries no sigmas: pass them again to ``to_observations``.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import InvalidInputError
from .grammar import CCSDSFormatError, Record, format_float
from .kvn import KVNWriter
from .layout import write_kvn_section, write_xml_section
from .ndmxml import add_text, new_root, to_text
from .tdm import HEADER, METADATA, TDM, TDMSegment, check_data

__all__ = ["write_tdm", "tdm_from_observations"]

#: visviva kind -> (family, TDM data keywords)
_FAMILIES = {"range": ("ranging", ("RANGE",)), "range_rate": ("ranging", ("DOPPLER_INSTANTANEOUS",)),
             "azel": ("AZEL", ("ANGLE_1", "ANGLE_2")),
             "radec": ("RADEC", ("ANGLE_1", "ANGLE_2"))}


def write_tdm(tdm, path=None, format: str | None = None, *, participant: str = "SATELLITE",  # noqa: A002
              originator: str = "VISVIVA", time_system: str = "UTC") -> str:
    """Write a CCSDS TDM (KVN or XML): a :class:`~visviva.TDM` as read, or Observations.

    Parameters
    ----------
    tdm : TDM or Observations
        What to write. Observations need station rows (range, range_rate, azel, radec) with
        ``light_time=True`` (a TDM holds measured, light-time-delayed data).
    path : str or os.PathLike, optional
        Where to write (the text is returned either way). ``write_tdm(path, observations)``,
        path first, is accepted too.
    format : {"kvn", "xml"}, optional
        Output format. Default: ``"xml"`` for a path ending in ``.xml``, else ``"kvn"``.
    participant : str
        ``PARTICIPANT_2``, the spacecraft's name (Observations only).
    originator : str
        ``ORIGINATOR`` (Observations only).
    time_system : str
        ``TIME_SYSTEM`` of the epochs (Observations only): UTC, TAI, TT, TDB, GPS ...

    Returns
    -------
    str
        The message.

    Raises
    ------
    InvalidInputError
        Position rows (a TDM has no position keyword), ``light_time=False`` observations, two
        different stations with one name.

    Examples
    --------
    >>> import visviva as vv
    >>> from astropy import units as u
    >>> from astropy.time import Time
    >>> site = vv.GroundStation(40 * u.deg, -105 * u.deg, 1600 * u.m, name="DENVER")
    >>> obs = vv.Observations(time=Time("2024-01-01T00:00:00") + [0, 10] * u.s, kind="range",
    ...                       value=[1500.25, 1490.5] * u.km, sigma=0.01 * u.km, station=site)
    >>> text = vv.write_tdm(obs, participant="SAT-1")
    >>> back = vv.read_tdm(text).to_observations({"DENVER": site}, {"range": 0.01 * u.km})
    >>> back.values[:, 0].tolist()
    [1500.25, 1490.5]
    """
    if isinstance(tdm, str | os.PathLike) and not isinstance(path, str | os.PathLike | None):
        tdm, path = path, tdm  # write_tdm(path, observations)
    if format is None:
        format = "xml" if path is not None and os.fspath(path).lower().endswith(".xml") else "kvn"
    if format not in ("kvn", "xml"):
        raise CCSDSFormatError(f"format must be 'kvn' or 'xml', not {format!r}")
    if not isinstance(tdm, TDM):
        tdm = tdm_from_observations(tdm, participant=participant, originator=originator,
                                    time_system=time_system)
    text = _kvn(tdm) if format == "kvn" else _xml(tdm)
    if path is not None:
        from .._text import replace_text_file

        replace_text_file(path, text)  # whole or not at all: a failed write keeps the old file
    return text


def tdm_from_observations(obs, *, participant="SATELLITE", originator="VISVIVA",
                          time_system="UTC") -> TDM:  # fmt: skip
    """A :class:`~visviva.TDM` holding the station rows of an Observations table.

    Parameters
    ----------
    obs : Observations
        The table (``light_time=True``; no position rows).
    participant : str
        The spacecraft's name (``PARTICIPANT_2``).
    originator : str
        ``ORIGINATOR``.
    time_system : str
        ``TIME_SYSTEM`` of the epochs.

    Returns
    -------
    TDM
    """
    from astropy.time import Time

    from .timeframes import time_to_epochs

    if not hasattr(obs, "kinds") or not hasattr(obs, "stations"):
        raise InvalidInputError(f"write_tdm takes a TDM or an Observations table, got "
                                f"{type(obs).__name__}")
    if not obs.light_time:
        raise InvalidInputError(
            "these observations are geometric (light_time=False); a TDM holds measured data, "
            "tagged at reception with the signal's flight time in them")
    if np.any(obs.kinds == "position"):
        raise InvalidInputError("a TDM has no keyword for GCRS positions; write them as an "
                                "OEM (vv.write_oem) or leave the position rows out")
    names: dict = {}
    for s in obs.stations:
        if names.setdefault(s.name, s) is not s and not _same_site(names[s.name], s):
            raise InvalidInputError(f"two different stations are named {s.name!r}; give each "
                                    "GroundStation its own name= (PARTICIPANT_1 names it)")
    epochs = time_to_epochs(obs.times, time_system)
    groups: dict = {}
    seen: dict = {}  # angle epochs of each segment: a reader pairs ANGLE_1/ANGLE_2 by epoch
    for i, (kind, s) in enumerate(zip(obs.kinds, obs.stations, strict=True)):
        family = _FAMILIES[str(kind)][0]
        copy = 0
        if family != "ranging":  # a second angle row at one epoch goes to another segment
            while epochs[i] in seen.setdefault((s.name, family, copy), set()):
                copy += 1
            seen[(s.name, family, copy)].add(epochs[i])
        groups.setdefault((s.name, family, copy), []).append(i)
    segments = []
    for (name, family, _), idx in groups.items():
        meta = Record(values={"TIME_SYSTEM": time_system.upper(), "PARTICIPANT_1": name,
                              "PARTICIPANT_2": participant, "MODE": "SEQUENTIAL"})
        if family == "ranging":
            meta.values.update(PATH="1,2,1", TIMETAG_REF="RECEIVE", RANGE_UNITS="km")
        else:
            meta.values.update(PATH="2,1", TIMETAG_REF="RECEIVE", ANGLE_TYPE=family)
            if family == "RADEC":
                meta.values["REFERENCE_FRAME"] = "GCRF"
                if obs.radec_reference == "stars":
                    meta.comments.append("RA/Dec reduced against catalogue stars: read with "
                                         "radec_reference='stars'")
        meta.comments.extend(_media_notes(obs, family))
        keywords, ep, values = [], [], []
        for i in idx:
            kind = str(obs.kinds[i])
            for k, key in enumerate(_FAMILIES[kind][1]):
                value = obs.values[i, k]
                keywords.append(key)
                ep.append(epochs[i])
                values.append(float(np.degrees(value)) if kind in ("azel", "radec") else value)
        segments.append(TDMSegment(meta, keywords, ep, values))
    header = Record(values={"CCSDS_TDM_VERS": "2.0",
                            "CREATION_DATE": time_to_epochs(Time.now(), "UTC")[0][:23],
                            "ORIGINATOR": originator})
    return TDM(header, segments)


def _media_notes(obs, family: str) -> list:
    """COMMENT lines saying which media the values hold (the table's ``troposphere`` and
    ``ionosphere``: the fit models them, the data are not corrected); a TDM has no keyword for
    that, and a table read back without them fits other numbers (metres of range)."""
    notes = []
    weather = obs.troposphere
    if weather is not None:
        given = dict(weather.given or {})
        if weather.refraction != "optical":
            given["refraction"] = weather.refraction
        notes.append("the values hold the neutral atmosphere (not corrected): read with "
                     f"troposphere={given or True!r}")
    if obs.ionosphere is not None and family == "ranging":
        notes.append(f"the values hold the ionosphere (not corrected; {obs.ionosphere.model} "
                     "model): read with the ionosphere= and frequency_hz= they were fitted with")
    return notes


def _same_site(a, b) -> bool:
    return bool(np.allclose(a.itrs_km, b.itrs_km, rtol=0.0, atol=1e-9))


def _kvn(tdm: TDM) -> str:
    writer = KVNWriter(width=21)  # (the longest keyword written: DOPPLER_INSTANTANEOUS)
    write_kvn_section(writer, HEADER, tdm.header)
    writer.blank()
    for seg in tdm.segments:
        writer.marker("META_START")
        write_kvn_section(writer, METADATA, seg.metadata)
        writer.marker("META_STOP")
        writer.blank()
        writer.marker("DATA_START")
        writer.comment(seg.data_comments)
        check_data(seg)
        width = writer.width
        for key, epoch, value in zip(seg.keywords, seg.epochs, seg.values.tolist(), strict=True):
            writer.data(f"{key:<{width}} = {epoch} {format_float(value)}")
        writer.marker("DATA_STOP")
        writer.blank()
    return writer.text()


def _xml(tdm: TDM) -> str:
    import xml.etree.ElementTree as ET

    root = new_root("tdm", "CCSDS_TDM_VERS", tdm.header["CCSDS_TDM_VERS"])
    write_xml_section(root, HEADER, tdm.header, skip=("CCSDS_TDM_VERS",))
    body = ET.SubElement(root, "body")
    for seg in tdm.segments:
        segment = ET.SubElement(body, "segment")
        write_xml_section(segment, METADATA, seg.metadata)
        data = ET.SubElement(segment, "data")
        for text in seg.data_comments:
            add_text(data, "COMMENT", text)
        check_data(seg)
        for key, epoch, value in zip(seg.keywords, seg.epochs, seg.values.tolist(), strict=True):
            item = ET.SubElement(data, "observation")
            add_text(item, "EPOCH", epoch)
            add_text(item, key, format_float(value))
    return to_text(root)
