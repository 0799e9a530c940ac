"""The Orbit Mean-Elements Message (OMM): mean elements (SGP4 and others) with TLE parameters.

CCSDS 502.0-B-3, section 4. :func:`read_omm` gives an :class:`OMM`, a ``dict`` of every keyword
(what :meth:`visviva.Satellite.from_omm` takes), which also keeps the comments per section for
:func:`write_omm`.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from .covariance import (
    COVARIANCE_KEYWORDS,
    check_record_variances,
    local_frame,
    matrix_from_values,
    on_state_axes,
    sun_from,
    warn_not_positive_definite,
)
from .grammar import Keyword as K
from .grammar import Record, Section
from .layout import read_message
from .opm import header_section, write_sections

__all__ = ["OMM", "read_omm", "write_omm", "write_omm_ndm", "SECTIONS"]

_DATA = "body/segment/data/"
SECTIONS = (
    header_section("OMM"),
    Section("metadata", (
        K("OBJECT_NAME", "text", None, True), K("OBJECT_ID", "text", None, True),
        K("CENTER_NAME", "text", None, True), K("REF_FRAME", "text", None, True),
        K("REF_FRAME_EPOCH", "epoch"), K("TIME_SYSTEM", "text", None, True),
        K("MEAN_ELEMENT_THEORY", "text", None, True)), "body/segment/metadata"),
    Section("mean_elements", (
        K("EPOCH", "epoch", None, True), K("SEMI_MAJOR_AXIS", "float", "km"),
        K("MEAN_MOTION", "float", "rev/day"), K("ECCENTRICITY", "float", None, True),
        K("INCLINATION", "float", "deg", True), K("RA_OF_ASC_NODE", "float", "deg", True),
        K("ARG_OF_PERICENTER", "float", "deg", True), K("MEAN_ANOMALY", "float", "deg", True),
        K("GM", "float", "km**3/s**2")), _DATA + "meanElements"),
    Section("spacecraft_parameters", (
        K("MASS", "float", "kg"), K("SOLAR_RAD_AREA", "float", "m**2"),
        K("SOLAR_RAD_COEFF", "float"), K("DRAG_AREA", "float", "m**2"),
        K("DRAG_COEFF", "float")), _DATA + "spacecraftParameters", optional=True),
    Section("tle_parameters", (
        K("EPHEMERIS_TYPE", "int"), K("CLASSIFICATION_TYPE"), K("NORAD_CAT_ID", "int"),
        K("ELEMENT_SET_NO", "int"), K("REV_AT_EPOCH", "int"), K("BSTAR", "float", "1/ER"),
        K("BTERM", "float", "m**2/kg"), K("MEAN_MOTION_DOT", "float", "rev/day**2"),
        K("MEAN_MOTION_DDOT", "float", "rev/day**3"), K("AGOM", "float", "m**2/kg")),
        _DATA + "tleParameters", optional=True),
    Section("covariance", (K("COV_REF_FRAME"),) + COVARIANCE_KEYWORDS,
            _DATA + "covarianceMatrix", optional=True),
    Section("user_defined", (), _DATA + "userDefinedParameters", optional=True,
            user_defined=True),
)
_USER = "USER_DEFINED_"


class OMM(dict):
    """An OMM as a mapping of its keywords (``OBJECT_NAME``, ``EPOCH``, ``MEAN_MOTION``, ...).

    User-defined parameters appear as ``USER_DEFINED_<name>``. Pass it to
    :meth:`visviva.Satellite.from_omm` or :func:`write_omm`; ``.comments`` maps each section
    name to its COMMENT lines, ``.lines`` each keyword to the line it was read from, ``.units``
    each user-defined parameter written with a unit to that unit, ``.attributes`` each keyword
    read from XML with attributes the schema does not define to them (written back on XML).
    """

    comments: dict
    lines: dict
    units: dict
    attributes: dict
    source: str

    @classmethod
    def from_sections(cls, sections: dict, source: str) -> OMM:
        """An OMM from the parsed sections of a message (what :func:`read_omm` builds).

        Parameters
        ----------
        sections : dict
            Section name -> :class:`visviva.ccsds.grammar.Record` (values, comments, lines),
            as :func:`visviva.ccsds.layout.read_message` returns them.
        source : str
            Where the message came from (a path or ``"<text>"``), for messages.

        Returns
        -------
        OMM
        """
        out = cls()
        out.comments, out.lines, out.units, out.source = {}, {}, {}, source
        out.attributes = {}
        for name, record in sections.items():
            prefix = _USER if name == "user_defined" else ""
            for key, value in record.values.items():
                out[prefix + key] = value
                out.lines[prefix + key] = record.lines.get(key)
            out.comments[name] = list(record.comments)
            out.units.update({prefix + key: unit for key, unit in record.units.items()})
            out.attributes.update({prefix + key: dict(a) for key, a in record.attributes.items()})
        return out

    def _satellite(self, why: str):
        """The SGP4 satellite of these elements, refused (saying ``why`` it was needed) for
        elements of another theory, frame or time system."""
        from ..satellites.tle import Satellite

        try:
            return Satellite.from_omm(self)
        except InvalidInputError as exc:
            raise InvalidInputError(f"{why} needs the state at EPOCH, which visviva gets from "
                                    f"SGP4 elements only: {exc}") from None

    @property
    def state(self):
        """The osculating TEME state at ``EPOCH`` of SGP4 mean elements (SGP4 itself at its
        epoch, WGS-72 GM), as ``Satellite.from_omm(omm).teme(0 * u.s)``: the state the
        covariance goes with, as :attr:`visviva.ccsds.OPM.state` is the OPM's.

        Returns
        -------
        SatelliteStates
            Scalar, ``frame == "teme"``.

        Raises
        ------
        InvalidInputError
            Elements that are not SGP4's (``MEAN_ELEMENT_THEORY``, ``REF_FRAME`` ...).
        """
        from astropy import units as u

        return self._satellite("omm.state").teme(0.0 * u.s)

    @property
    def covariance(self) -> np.ndarray | None:
        """The 6 x 6 covariance (km, km/s) on the axes of ``REF_FRAME`` (TEME for SGP4 mean
        elements; ``EME2000`` turned to the GCRS axes by the frame bias,
        :func:`~visviva.ccsds.timeframes.to_gcrs_axes`, as every reader does), or None when the
        message has none: as :attr:`visviva.ccsds.OPM.covariance`.

        A ``COV_REF_FRAME`` naming an orbit-relative frame (``RTN``/``RSW``/``RIC``/``QSW``,
        ``TNW``, ``NTW``, ``VNB``, SANA's ``*_INERTIAL`` and ``*_ROTATING``:
        :mod:`visviva.ccsds.orbit_frames`) is rotated to the axes of ``REF_FRAME`` about
        :attr:`state`, SGP4's osculating state at ``EPOCH`` (the rotating frames with SGP4's
        WGS-72 GM), so that the matrix goes with ``omm.state``; none, or ``REF_FRAME`` itself,
        is the matrix as written (the 21 ``CX_X`` ... ``CZ_DOT_Z_DOT`` keywords of the OMM).

        Raises
        ------
        InvalidInputError
            A ``COV_REF_FRAME`` that is another frame than ``REF_FRAME`` and no local frame
            (``EME2000`` or ``GCRF`` about ``TEME``: visviva does not rotate a covariance
            between them), a local frame of elements that are not SGP4's (no state at
            ``EPOCH``), or one the state does not define (``NSW_*``: the Sun is known on ICRF
            axes only, not TEME's; ``PQW_INERTIAL`` of a circular orbit).
        """
        if "CX_X" not in self:
            return None
        matrix = matrix_from_values(self)
        frame, ref = self.get("COV_REF_FRAME"), self.get("REF_FRAME", "")
        from .timeframes import to_gcrs_axes, visviva_frame

        line = (getattr(self, "lines", None) or {}).get("COV_REF_FRAME")
        where = (f"{getattr(self, 'source', '<mapping>')}"
                 f"{f' line {line}' if line else ''}: COV_REF_FRAME = {frame}")
        r = v = np.zeros(3)  # (read only when the frame is a local one)
        gm = None
        if frame is not None and str(frame).strip().upper() != str(ref).strip().upper():
            try:
                local = local_frame(str(frame).strip().upper()) is not None
            except InvalidInputError:
                local = False  # (on_state_axes names the frame and why)
            if local:
                sat = self._satellite(f"{where}, a local orbital frame,")
                from astropy import units as u

                state = sat.teme(0.0 * u.s)
                r, v = state.r.to_value("km"), state.v.to_value("km/s")
                gm = float(sat.satrec.mu)
        m = on_state_axes(matrix, frame, ref, visviva_frame(ref), r, v, where,
                          "the OMM's CX_X ... CZ_DOT_Z_DOT", gm=gm,
                          sun=sun_from(lambda: self.state.epoch, self.get("CENTER_NAME"), ref))
        return to_gcrs_axes(ref, m)[0]  # (EME2000: the frame bias, as opm.covariance)


def read_omm(source) -> OMM:
    """Read a CCSDS Orbit Mean-Elements Message (KVN or XML, detected).

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A path, the message text, or its bytes (UTF-8).

    Returns
    -------
    OMM
        A ``dict`` of every keyword (floats, ints, text; epochs as written), ready for
        :meth:`visviva.Satellite.from_omm`.

    Raises
    ------
    CCSDSFormatError
        Malformed input, such as a ``NORAD_CAT_ID`` that is not a catalogue number (digits,
        at most nine); the message names the line.
    """
    from .grammar import CCSDSFormatError
    from .opm_checks import warn_omm_gm

    sections, _, name = read_message(source, SECTIONS, "omm", "CCSDS_OMM_VERS")
    mean = sections["mean_elements"]
    if ("SEMI_MAJOR_AXIS" in mean) == ("MEAN_MOTION" in mean):
        raise CCSDSFormatError("the mean elements need exactly one of SEMI_MAJOR_AXIS and "
                               "MEAN_MOTION", line=mean.line, source=name)
    if sections.get("covariance") is not None:
        check_record_variances(sections["covariance"], name)
        cov = sections["covariance"]
        warn_not_positive_definite([(matrix_from_values(cov.values), cov.line)], name, 3)
    warn_omm_gm(sections, name)
    tle = sections.get("tle_parameters")
    if tle is not None and "NORAD_CAT_ID" in tle:
        from ..satellites.catalog_numbers import catalogue_number

        try:
            catalogue_number(tle["NORAD_CAT_ID"])
        except ValueError as exc:
            raise CCSDSFormatError(str(exc), line=tle.lines.get("NORAD_CAT_ID"),
                                   source=name) from None
    return OMM.from_sections(sections, name)


def write_omm(omm, path=None, format: str | None = None, *, originator: str | None = None,  # noqa: A002
              version: str = "3.0") -> str:
    """Write an OMM (KVN or XML) from a mapping of its keywords.

    Parameters
    ----------
    omm : OMM or dict
        The keywords (as :func:`read_omm` or :meth:`visviva.Satellite.to_omm` give them).
    path : str or os.PathLike, optional
        File to write; nothing is written when None.
    format : {"kvn", "xml"}, optional
        Default: ``"xml"`` for a path ending in ``.xml``, else ``"kvn"``.
    originator : str, optional
        ``ORIGINATOR`` for a mapping that lacks it (``Satellite.to_omm()`` has no header).
    version : str
        ``CCSDS_OMM_VERS`` for a mapping that lacks it.

    Returns
    -------
    str
        The message text.

    Raises
    ------
    InvalidInputError
        A keyword that is not an OMM keyword, or a mandatory one missing.
    """
    parsed = _sections(omm, originator, version)
    return write_sections(parsed, SECTIONS, "omm", "CCSDS_OMM_VERS", path, format)


def write_omm_ndm(omms, path=None, *, originator: str | None = None,
                  version: str = "3.0") -> str:
    """Write several OMMs as one XML ``<ndm>`` of ``<omm>`` elements (a catalogue, as
    CelesTrak's GP data in XML; :func:`visviva.read_catalog_file` reads it back).

    KVN has no container for several messages (one OMM after another is not a CCSDS file):
    write them as XML this way, or one file per object with :func:`write_omm`.

    Parameters
    ----------
    omms : iterable of OMM or dict
        The messages' keywords, each as for :func:`write_omm`.
    path : str or os.PathLike, optional
        File to write; nothing is written when None.
    originator : str, optional
        ``ORIGINATOR`` for a mapping that lacks it.
    version : str
        ``CCSDS_OMM_VERS`` for a mapping that lacks it.

    Returns
    -------
    str
        The XML text.

    Raises
    ------
    InvalidInputError
        No message, or a message :func:`write_omm` refuses (naming its position).
    """
    from astropy.time import Time

    from .layout import message_element
    from .ndmxml import new_ndm, to_text

    now = Time.now().utc.isot  # one CREATION_DATE for the messages that lack one
    elements = []
    for k, omm in enumerate(omms):
        if hasattr(omm, "items") and "CREATION_DATE" not in omm:
            omm = {**omm, "CREATION_DATE": now}
        try:
            parsed = _sections(omm, originator, version)
        except InvalidInputError as exc:
            raise InvalidInputError(f"OMM {k}: {exc}") from None
        elements.append(message_element(parsed, SECTIONS, "omm", "CCSDS_OMM_VERS"))
    if not elements:
        raise InvalidInputError("write_omm_ndm needs at least one OMM.")
    text = to_text(new_ndm(elements))
    if path is not None:
        from .._text import replace_text_file

        replace_text_file(path, text)  # whole or not at all: a failed write keeps the old file
    return text


def _sections(omm, originator, version) -> dict:
    """The section records of an OMM from a mapping of its keywords (checked)."""
    from .layout import check_mandatory

    if not hasattr(omm, "items"):
        raise InvalidInputError(f"write_omm needs a mapping of OMM keywords, got "
                                f"{type(omm).__name__} (for a Satellite, pass sat.to_omm()).")
    comments = getattr(omm, "comments", {}) or {}
    units = getattr(omm, "units", {}) or {}  # (of the user-defined parameters, as read)
    attributes = getattr(omm, "attributes", {}) or {}  # (XML attributes kept, as read)
    records = {s.name: Record(comments=list(comments.get(s.name, []))) for s in SECTIONS}
    for key, value in omm.items():
        if key == "COMMENT":
            records["header"].comments.append(str(value))
            continue
        if key.startswith(_USER):
            records["user_defined"].values[key[len(_USER):]] = value
            if key in units:
                records["user_defined"].units[key[len(_USER):]] = units[key]
            if key in attributes:
                records["user_defined"].attributes[key[len(_USER):]] = attributes[key]
            continue
        owner = next((s for s in SECTIONS if key in s.by_name), None)
        if owner is None:
            raise InvalidInputError(f"{key} is not an OMM keyword; remove it or write it as "
                                    f"{_USER}{key}")
        records[owner.name].values[key] = _coerce(owner.by_name[key], value)
        if key in attributes:
            records[owner.name].attributes[key] = attributes[key]
    mean = records["mean_elements"].values
    if ("SEMI_MAJOR_AXIS" in mean) == ("MEAN_MOTION" in mean):  # (what read_omm refuses)
        raise InvalidInputError(
            "an OMM gives exactly one of SEMI_MAJOR_AXIS and MEAN_MOTION (read_omm refuses "
            f"{'both' if 'MEAN_MOTION' in mean else 'neither'}); remove one: SGP4 elements "
            "(Satellite.to_omm) are MEAN_MOTION.")
    header = records["header"].values
    header.setdefault("CCSDS_OMM_VERS", version)
    if originator is not None:
        header.setdefault("ORIGINATOR", originator)
    parsed = {}
    for section in SECTIONS:
        record = records[section.name]
        if not record.values and section.optional:
            continue
        if section.name != "header":
            check_mandatory(record, section, "<mapping>")
        parsed[section.name] = record
    if "ORIGINATOR" not in header:
        raise InvalidInputError("the OMM has no ORIGINATOR; pass originator='...'")
    return parsed


def _coerce(keyword, value):
    """A value from a mapping checked and converted to the keyword's type."""
    import math

    from .grammar import parse_value

    try:
        if keyword.type == "float":
            value = float(value)
            if not math.isfinite(value):
                raise ValueError("not finite")
            return value
        if keyword.name == "NORAD_CAT_ID":
            from ..satellites.catalog_numbers import catalogue_number

            return catalogue_number(value)
        if keyword.type == "int":
            if isinstance(value, float) and not value.is_integer():
                raise ValueError("not an integer")
            return int(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{keyword.name} = {value!r} is not a valid "
                                f"{keyword.type}: {exc}") from None
    text = str(value).strip()
    if not text:
        raise InvalidInputError(f"{keyword.name} is empty; give it a value (OBJECT_ID: the "
                                "international designator such as 1998-067A, or UNKNOWN)")
    return parse_value(keyword, text, None, None, "<mapping>")
