"""The Conjunction Data Message (CDM, CCSDS 508.0-B-1): keyword tables on the shared grammar.

A CDM is a header, the relative metadata/data of the conjunction (TCA, miss distance, relative
state, screening volume, Pc), then one segment per object (metadata, OD parameters, additional
parameters, state vector, RTN covariance). The sections below describe every keyword with its
unit and mandatory flag; :mod:`visviva.ccsds.layout` reads and writes them in KVN and XML. Read
with :func:`read_cdm`, write with :meth:`ConjunctionDataMessage.to_kvn` / ``to_xml`` or
:func:`write_cdm`.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from .cdm_checks import alt_covariance, check_frames, check_segment_elements
from .grammar import CCSDSFormatError, Record, Section, version_keyword
from .grammar import Keyword as K
from .kvn import KVNCursor, KVNWriter
from .layout import (
    read_kvn_section,
    read_text,
    read_xml_section,
    write_kvn_section,
    write_xml_section,
    xml_child,
)
from .ndmxml import XMLNode, looks_like_xml, message_root, new_root, parse, to_text

__all__ = ["ConjunctionDataMessage", "CDMObject", "read_cdm", "write_cdm", "HEADER", "RELATIVE",
           "SEGMENT_SECTIONS"]

HEADER = Section("header", (
    version_keyword("CDM"), K("CREATION_DATE", "epoch", None, True),
    K("ORIGINATOR", "text", None, True), K("MESSAGE_FOR"), K("MESSAGE_ID", "text", None, True)),
    "header")

#: keywords of the relative state, nested in <relativeStateVector> in XML
_RELATIVE_STATE = ("RELATIVE_POSITION_R", "RELATIVE_POSITION_T", "RELATIVE_POSITION_N",
                   "RELATIVE_VELOCITY_R", "RELATIVE_VELOCITY_T", "RELATIVE_VELOCITY_N")
RELATIVE = Section("relative", (
    K("TCA", "epoch", None, True), K("MISS_DISTANCE", "float", "m", True),
    K("RELATIVE_SPEED", "float", "m/s"),
    K("RELATIVE_POSITION_R", "float", "m"), K("RELATIVE_POSITION_T", "float", "m"),
    K("RELATIVE_POSITION_N", "float", "m"), K("RELATIVE_VELOCITY_R", "float", "m/s"),
    K("RELATIVE_VELOCITY_T", "float", "m/s"), K("RELATIVE_VELOCITY_N", "float", "m/s"),
    K("START_SCREEN_PERIOD", "epoch"), K("STOP_SCREEN_PERIOD", "epoch"),
    K("SCREEN_VOLUME_FRAME"), K("SCREEN_VOLUME_SHAPE"), K("SCREEN_VOLUME_X", "float", "m"),
    K("SCREEN_VOLUME_Y", "float", "m"), K("SCREEN_VOLUME_Z", "float", "m"),
    K("SCREEN_ENTRY_TIME", "epoch"), K("SCREEN_EXIT_TIME", "epoch"),
    K("COLLISION_PROBABILITY", "float"), K("COLLISION_PROBABILITY_METHOD")),
    "body/relativeMetadataData")

METADATA = Section("metadata", (
    K("OBJECT", "text", None, True), K("OBJECT_DESIGNATOR", "text", None, True),
    K("CATALOG_NAME", "text", None, True), K("OBJECT_NAME", "text", None, True),
    K("INTERNATIONAL_DESIGNATOR", "text", None, True), K("OBJECT_TYPE"),
    K("OPERATOR_CONTACT_POSITION"), K("OPERATOR_ORGANIZATION"), K("OPERATOR_PHONE"),
    K("OPERATOR_EMAIL"), K("EPHEMERIS_NAME", "text", None, True),
    K("COVARIANCE_METHOD", "text", None, True), K("MANEUVERABLE", "text", None, True),
    K("ORBIT_CENTER"), K("REF_FRAME", "text", None, True), K("GRAVITY_MODEL"),
    K("ATMOSPHERIC_MODEL"), K("N_BODY_PERTURBATIONS"), K("SOLAR_RAD_PRESSURE"),
    K("EARTH_TIDES"), K("INTRACK_THRUST")), "metadata")
OD_PARAMETERS = Section("od_parameters", (
    K("TIME_LASTOB_START", "epoch"), K("TIME_LASTOB_END", "epoch"),
    K("RECOMMENDED_OD_SPAN", "float", "d"), K("ACTUAL_OD_SPAN", "float", "d"),
    K("OBS_AVAILABLE", "int"), K("OBS_USED", "int"), K("TRACKS_AVAILABLE", "int"),
    K("TRACKS_USED", "int"), K("RESIDUALS_ACCEPTED", "float", "%"), K("WEIGHTED_RMS", "float")),
    "data/odParameters", optional=True)
ADDITIONAL = Section("additional_parameters", (
    K("AREA_PC", "float", "m**2"), K("AREA_DRG", "float", "m**2"),
    K("AREA_SRP", "float", "m**2"), K("MASS", "float", "kg"),
    K("CD_AREA_OVER_MASS", "float", "m**2/kg"), K("CR_AREA_OVER_MASS", "float", "m**2/kg"),
    K("THRUST_ACCELERATION", "float", "m/s**2"), K("SEDR", "float", "W/kg")),
    "data/additionalParameters", optional=True)
STATE = Section("state_vector", (
    K("X", "float", "km", True), K("Y", "float", "km", True), K("Z", "float", "km", True),
    K("X_DOT", "float", "km/s", True), K("Y_DOT", "float", "km/s", True),
    K("Z_DOT", "float", "km/s", True)), "data/stateVector")

#: the lower triangle of the 6x6 RTN covariance, row by row (508.0-B-1 table 3-5)
_RTN = ("R", "T", "N", "RDOT", "TDOT", "NDOT")
_COV6 = tuple((f"C{_RTN[i]}_{_RTN[j]}", i, j) for i in range(6) for j in range(i + 1))


def _cov_unit(i, j):
    return "m**2" if i < 3 and j < 3 else ("m**2/s**2" if i >= 3 and j >= 3 else "m**2/s")


_EXTRA_ROWS = (
    ("CDRG", ("m**3/kg",) * 3 + ("m**3/(kg*s)",) * 3 + ("m**4/kg**2",)),
    ("CSRP", ("m**3/kg",) * 3 + ("m**3/(kg*s)",) * 3 + ("m**4/kg**2",) * 2),
    ("CTHR", ("m**2/s**2",) * 3 + ("m**2/s**3",) * 3 + ("m**3/(kg*s**2)",) * 2
     + ("m**2/s**4",)),
)
_EXTRA_COLS = _RTN + ("DRG", "SRP", "THR")
COVARIANCE = Section("covariance", tuple(
    K(name, "float", _cov_unit(i, j), True) for name, i, j in _COV6) + tuple(
    K(f"{row}_{_EXTRA_COLS[k]}", "float", unit) for row, units in _EXTRA_ROWS
    for k, unit in enumerate(units)), "data/covarianceMatrix")

#: the sections of one object's segment, in KVN order
SEGMENT_SECTIONS = (METADATA, OD_PARAMETERS, ADDITIONAL, STATE, COVARIANCE)


class CDMObject:
    """One object of a CDM: its metadata and state at TCA, with the covariance.

    Attributes
    ----------
    sections : dict
        Section name -> Record (``metadata``, ``od_parameters``, ``additional_parameters``,
        ``state_vector``, ``covariance``).
    """

    def __init__(self, sections: dict):
        self.sections = {k: (v if isinstance(v, Record) else Record(values=dict(v)))
                         for k, v in sections.items()}

    @property
    def name(self) -> str:
        """``OBJECT_NAME``."""
        return self.sections["metadata"]["OBJECT_NAME"]

    @property
    def designator(self) -> str:
        """``OBJECT_DESIGNATOR`` (the catalogue number)."""
        return self.sections["metadata"]["OBJECT_DESIGNATOR"]

    @property
    def frame(self) -> str:
        """``REF_FRAME`` of the state vector (e.g. ``"EME2000"``, ``"GCRF"``, ``"ITRF"``)."""
        return self.sections["metadata"]["REF_FRAME"]

    @property
    def r(self):
        """Position at TCA (Quantity, km) in :attr:`frame`."""
        from astropy import units as u

        s = self.sections["state_vector"]
        return np.array([s["X"], s["Y"], s["Z"]]) * u.km

    @property
    def v(self):
        """Velocity at TCA (Quantity, km/s) in :attr:`frame`."""
        from astropy import units as u

        s = self.sections["state_vector"]
        return np.array([s["X_DOT"], s["Y_DOT"], s["Z_DOT"]]) * u.km / u.s

    @property
    def covariance_rtn(self) -> np.ndarray:
        """The 6x6 position-velocity covariance in the object's RTN frame (m, m/s)."""
        c = self.sections["covariance"]
        out = np.empty((6, 6))
        for name, i, j in _COV6:
            out[i, j] = out[j, i] = c[name]
        return out

    @property
    def covariance(self) -> np.ndarray:
        """The 6x6 covariance rotated to the axes of :attr:`frame` (m, m/s), via the RTN axes of
        the object's inertial state.

        For ``REF_FRAME = ITRF`` the RTN axes are those of the inertial velocity on ITRF axes,
        ``v + omega x r`` (as NASA CARA's ``cdmobj_J2Kstatecov`` converts an ITRF state to J2000
        before rotating the RTN covariance): the Earth-fixed velocity would tilt the in-track and
        cross-track axes by ~3.5 deg in LEO. A ``REF_FRAME`` visviva does not know raises
        :class:`~visviva.errors.InvalidInputError` (it cannot tell whether it rotates), and so
        does ITRF or TEME about another ``ORBIT_CENTER`` than the Earth.
        """
        from ..conjunctions.covariance import rtn_to_inertial
        from .timeframes import visviva_frame

        kind = visviva_frame(self.frame)
        if kind is None:
            raise InvalidInputError(
                f"REF_FRAME = {self.frame!r} of {self.name!r} is not a frame visviva knows "
                "(EME2000, GCRF, ICRF, TEME or ITRF...): whether it rotates with the Earth sets "
                "the RTN axes of the covariance. Rotate covariance_rtn (RTN, m, m/s) yourself "
                "with visviva.conjunctions.rtn_to_inertial, or correct REF_FRAME.")
        from .cdm_states import refuse_earth_frame_off_earth

        refuse_earth_frame_off_earth(self, kind)  # (ITRF about the Moon: not the Earth's ω)
        v = self.v
        if kind == "itrs":
            from astropy import units as u

            from ..constants import EARTH_ROTATION_RAD_S

            omega = np.array([0.0, 0.0, EARTH_ROTATION_RAD_S])
            v = v + np.cross(omega, self.r.to_value(u.km)) * (u.km / u.s)
        return rtn_to_inertial(self.covariance_rtn, self.r, v)

    def __repr__(self):
        return f"CDMObject({self.name!r}, {self.frame})"


class ConjunctionDataMessage:
    """A CCSDS Conjunction Data Message.

    Parameters
    ----------
    sections : dict
        ``"header"`` and ``"relative"`` -> Record (or dict of keyword values),
        ``"object1"`` and ``"object2"`` -> dict of the segment's section records.
    source : str
        Where it was read from.
    """

    def __init__(self, sections: dict, source: str = "<text>"):
        self.header = _rec(sections["header"])
        self.relative = _rec(sections["relative"])
        self.object1 = sections["object1"] if isinstance(sections["object1"], CDMObject) \
            else CDMObject(sections["object1"])
        self.object2 = sections["object2"] if isinstance(sections["object2"], CDMObject) \
            else CDMObject(sections["object2"])
        self.source = source

    @classmethod
    def from_states(cls, tca, r1, v1, cov1, r2, v2, cov2, *, names=("OBJECT1", "OBJECT2"),
                    designators=("UNKNOWN", "UNKNOWN"), frame="GCRF", originator="VISVIVA",
                    message_id=None, collision_probability=None,
                    collision_probability_method=None):  # fmt: skip
        """A CDM from the two objects' states and covariances at TCA (e.g. a screening row).

        Parameters
        ----------
        tca : astropy.time.Time
            Time of closest approach (written in UTC to the nanosecond).
        r1, v1, r2, v2 : Quantity or array_like, shape (3,)
            States of objects 1 and 2 at ``tca`` in one inertial frame (m and m/s when plain,
            as :func:`~visviva.collision_probability` takes them).
        cov1, cov2 : array_like or Quantity, shape (6, 6)
            Their covariances in that frame (m^2, m^2/s, m^2/s^2 when plain), rotated here to
            each object's RTN frame as the CDM stores them.
        names : (str, str)
            ``OBJECT_NAME`` of the two objects.
        designators : (str, str)
            ``OBJECT_DESIGNATOR`` (catalogue numbers).
        frame : {"GCRF", "EME2000"}
            ``REF_FRAME`` of the states, written as given: GCRS numbers (``sat.gcrs(tca)`` for
            SGP4 objects) are ``"GCRF"``; for ``"EME2000"`` give them rotated by the frame bias
            (``visviva.ccsds.timeframes.from_gcrs_axes("EME2000", r, v, cov)``, 4.7 m at GEO).
        originator : str
            ``ORIGINATOR``.
        message_id : str, optional
            ``MESSAGE_ID`` (default: the names and the TCA).
        collision_probability : float, optional
            ``COLLISION_PROBABILITY`` (e.g. from :func:`~visviva.collision_probability`).
        collision_probability_method : str, optional
            ``COLLISION_PROBABILITY_METHOD`` (e.g. ``"FOSTER-1992"``).

        Returns
        -------
        ConjunctionDataMessage
            With the mandatory keywords (the metadata the states do not give are
            ``CATALOG_NAME = SATCAT``, ``INTERNATIONAL_DESIGNATOR = UNKNOWN``,
            ``EPHEMERIS_NAME = NONE``, ``COVARIANCE_METHOD = CALCULATED``,
            ``MANEUVERABLE = N/A``; edit ``msg.object1.sections`` to change them), the miss
            distance, relative speed and relative state in object 1's RTN frame.

        Raises
        ------
        InvalidInputError
            A frame that is not inertial, a covariance that is not 6x6, NaN, a probability
            outside [0, 1].
        """
        from .cdm_build import cdm_sections

        return cls(cdm_sections(
            tca, r1, v1, cov1, r2, v2, cov2, names=names, designators=designators, frame=frame,
            originator=originator, message_id=message_id,
            collision_probability=collision_probability,
            collision_probability_method=collision_probability_method, cov_keywords=_COV6))

    @property
    def tca(self):
        """Time of closest approach (astropy Time, UTC)."""
        from .timeframes import epochs_to_time

        return epochs_to_time(self.relative["TCA"], "UTC", self.relative.line_of("TCA"),
                              self.source)

    @property
    def miss_distance(self):
        """``MISS_DISTANCE`` (Quantity, m)."""
        from astropy import units as u

        return self.relative["MISS_DISTANCE"] * u.m

    @property
    def relative_speed(self):
        """``RELATIVE_SPEED`` (Quantity, m/s), or None when the message has none."""
        from astropy import units as u

        value = self.relative.get("RELATIVE_SPEED")
        return None if value is None else value * u.m / u.s

    @property
    def collision_probability(self):
        """The message's own ``COLLISION_PROBABILITY`` (float), or None."""
        return self.relative.get("COLLISION_PROBABILITY")

    def states(self, frame: str = "GCRF"):
        """Both objects' states and covariances at TCA on one inertial frame.

        Each object's ``REF_FRAME`` may differ (508.0-B-1); this rotates an ITRF or TEME
        object to GCRF at TCA and each RTN covariance with its object's GCRF state
        (:func:`visviva.ccsds.cdm_states.states_on_one_frame`), so that ``r1 - r2`` is the
        miss vector and ``vv.collision_probability(*msg.states(), hbr)`` the Pc.

        Parameters
        ----------
        frame : {"GCRF", "EME2000", "ICRF"}
            The frame of the result.

        Returns
        -------
        r1, v1, cov1, r2, v2, cov2
            Quantity km, Quantity km/s, ndarray (6, 6) in m^2, m^2/s, m^2/s^2.
        """
        from .cdm_states import states_on_one_frame

        return states_on_one_frame(self, frame)

    def probability(self, hard_body_radius, method: str = "foster", **kwargs) -> float:
        """The collision probability computed from the message's states and covariances, both
        put on GCRF first (:meth:`states`); ``kwargs`` as :func:`visviva.collision_probability`.

        Parameters
        ----------
        hard_body_radius : Quantity or float
            Radius of the sphere enclosing both objects (plain numbers: m).
        method : str
            As :func:`visviva.collision_probability`.

        Returns
        -------
        float
        """
        from ..conjunctions.probability import collision_probability

        return collision_probability(*self.states(), hard_body_radius, method, **kwargs)

    def sections(self) -> dict:
        """Every section as a dict of records (what the constructor takes)."""
        return {"header": self.header, "relative": self.relative,
                "object1": self.object1.sections, "object2": self.object2.sections}

    def to_kvn(self) -> str:
        """The message as KVN text."""
        writer = KVNWriter(width=34)
        write_kvn_section(writer, HEADER, self.header)
        writer.blank()
        write_kvn_section(writer, RELATIVE, self.relative)
        writer.blank()
        for obj in (self.object1, self.object2):
            for section in SEGMENT_SECTIONS:
                if section.name in obj.sections:
                    write_kvn_section(writer, section, obj.sections[section.name])
            writer.blank()
        return writer.text()

    def to_xml(self) -> str:
        """The message as NDM/XML text (``<cdm>``)."""
        root = new_root("cdm", "CCSDS_CDM_VERS", self.header["CCSDS_CDM_VERS"])
        write_xml_section(root, HEADER, self.header, skip=("CCSDS_CDM_VERS",))
        body = xml_child(root, "body")
        rel = write_xml_section(body, RELATIVE, self.relative)
        # the relative state sits in its own element, after RELATIVE_SPEED
        moved = [e for e in list(rel) if e.tag in _RELATIVE_STATE]
        if moved:
            import xml.etree.ElementTree as ET

            for e in moved:
                rel.remove(e)
            tags = [e.tag for e in rel]
            at = tags.index("RELATIVE_SPEED") + 1 if "RELATIVE_SPEED" in tags else \
                tags.index("MISS_DISTANCE") + 1
            vec = ET.Element("relativeStateVector")
            vec.extend(moved)
            rel.insert(at, vec)
        for obj in (self.object1, self.object2):
            seg = _et_sub(body, "segment")
            for section in SEGMENT_SECTIONS:
                if section.name in obj.sections:
                    parent = seg
                    for tag in section.xml_path.split("/")[:-1]:
                        parent = xml_child(parent, tag)
                    write_xml_section(parent, section, obj.sections[section.name])
        return to_text(root)

    def __eq__(self, other):
        if not isinstance(other, ConjunctionDataMessage):
            return NotImplemented
        return _values(self.sections()) == _values(other.sections())

    def __repr__(self):
        return (f"ConjunctionDataMessage(TCA {self.relative['TCA']}, "
                f"{self.object1.name!r} x {self.object2.name!r}, "
                f"miss {self.relative['MISS_DISTANCE']} m)")


def _et_sub(parent, tag):
    """Append an empty child element ``tag`` to ``parent`` and return it."""
    import xml.etree.ElementTree as ET

    return ET.SubElement(parent, tag)


def _rec(value):
    return value if isinstance(value, Record) else Record(values=dict(value))


def _values(sections: dict):
    out = {}
    for key, value in sections.items():
        if isinstance(value, dict):
            out[key] = _values(value)
        else:
            out[key] = (dict(value.values), list(value.comments))
    return out


def read_cdm(source) -> ConjunctionDataMessage:
    """Read a CCSDS Conjunction Data Message (508.0-B-1), KVN or XML.

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A path, the message text, or its bytes (UTF-8).

    Returns
    -------
    ConjunctionDataMessage
        ``.tca``, ``.miss_distance``, ``.relative_speed``, ``.collision_probability``,
        ``.object1`` / ``.object2`` (:class:`CDMObject` with ``.name``, ``.r``, ``.v``,
        ``.covariance_rtn``, ``.covariance``).

    Raises
    ------
    CCSDSFormatError
        A malformed message: missing mandatory keyword, wrong unit, bad number or epoch, a
        keyword out of place, a missing object; the message names the line.
    """
    text, name = read_text(source)
    if looks_like_xml(text):
        return _read_xml(text, name)
    cursor = KVNCursor(text, name)
    if cursor.at_end():
        raise CCSDSFormatError("the message is empty", source=name)
    first = cursor.peek()
    if first.kind != "keyword" or first.key != "CCSDS_CDM_VERS":
        raise cursor.error("a CDM starts with CCSDS_CDM_VERS = <version>")
    sections = {}
    for section in (HEADER, RELATIVE):
        record = _read_checked(cursor, section)
        if record is None:
            raise cursor.error(f"the {section.name} section is missing (found "
                               f"{_describe(cursor.peek())})")
        sections[section.name] = record
    for label in ("OBJECT1", "OBJECT2"):
        seg = {}
        for section in SEGMENT_SECTIONS:
            record = _read_checked(cursor, section)
            if record is None:
                if section.optional:
                    continue
                raise cursor.error(f"{label}: the {section.name.replace('_', ' ')} section is "
                                   f"missing (found {_describe(cursor.peek())})")
            seg[section.name] = record
        if seg["metadata"]["OBJECT"] != label:
            raise CCSDSFormatError(f"expected OBJECT = {label}, found "
                                   f"{seg['metadata']['OBJECT']!r}",
                                   line=seg["metadata"].line_of("OBJECT"), source=name)
        sections[label.lower()] = seg
    if not cursor.at_end():
        raise cursor.error(f"unexpected {_describe(cursor.peek())} after the two objects "
                           "(misspelt or out-of-order keyword)")
    _check_values(sections, name)
    return _checked(ConjunctionDataMessage(sections, name))


def _checked(msg: ConjunctionDataMessage) -> ConjunctionDataMessage:
    """``msg``, after a warning when its states contradict its MISS_DISTANCE/RELATIVE_SPEED."""
    from .cdm_states import check_states_against_summary

    check_states_against_summary(msg)
    return msg


#: keywords whose value cannot be negative (CCSDS 508.0-B-1, tables 3-2 and 3-3)
_NON_NEGATIVE = ("MISS_DISTANCE", "RELATIVE_SPEED", "SCREEN_VOLUME_X", "SCREEN_VOLUME_Y",
                 "SCREEN_VOLUME_Z")


#: the diagonal of the covariance (508.0-B-1 table 3-5, and the optional rows 7-9)
_VARIANCES = tuple(name for name, i, j in _COV6 if i == j) + ("CDRG_DRG", "CSRP_SRP", "CTHR_THR")


def _check_values(sections: dict, source: str) -> None:
    """Refuse what the grammar's patterns let through: impossible calendar dates (month 13,
    February 30, hour 25) in any epoch keyword, a probability outside [0, 1], a negative
    distance or speed; each error names the keyword and its line."""
    from .timeframes import epochs_to_time

    records = [(HEADER, sections["header"]), (RELATIVE, sections["relative"])]
    for label in ("object1", "object2"):
        for section in SEGMENT_SECTIONS:
            if section.name in sections[label]:
                records.append((section, sections[label][section.name]))
    for section, record in records:
        for key, value in record.values.items():
            kw = section.by_name.get(key)
            if kw is None:
                continue
            line = record.line_of(key)
            if kw.type == "epoch":
                try:
                    epochs_to_time(value, "UTC", line, source)
                except CCSDSFormatError as exc:
                    reason = " ".join(str(exc).split(": ", 2)[-1].split())
                    raise CCSDSFormatError(f"{key} = {value!r} is not a valid date-time "
                                           f"({reason})", line=line, source=source) from None
            elif key == "COLLISION_PROBABILITY" and not 0.0 <= value <= 1.0:
                raise CCSDSFormatError(f"COLLISION_PROBABILITY = {value!r} is not a probability "
                                       "in [0, 1]", line=line, source=source)
            elif key in _NON_NEGATIVE and value < 0:
                raise CCSDSFormatError(f"{key} = {value!r} is negative; a distance or speed is "
                                       ">= 0", line=line, source=source)
            elif key in _VARIANCES and value < 0:
                raise CCSDSFormatError(f"{key} = {value!r} is a negative variance (a diagonal "
                                       "element of the covariance is a squared sigma, >= 0)",
                                       line=line, source=source)
    _check_spans(sections["relative"], source)
    check_frames(sections, source)


#: (start, stop) keyword pairs of the relative metadata whose span cannot run backwards
_SPANS = (("START_SCREEN_PERIOD", "STOP_SCREEN_PERIOD"), ("SCREEN_ENTRY_TIME", "SCREEN_EXIT_TIME"))


def _check_spans(record, source: str) -> None:
    """Refuse a screening period or a screening-volume passage that ends before it starts."""
    from .timeframes import epochs_to_time

    for start, stop in _SPANS:
        if start in record and stop in record:
            t0, t1 = (epochs_to_time(record[k], "UTC", record.line_of(k), source)
                      for k in (start, stop))
            if (t1 - t0).to_value("s") < 0:
                raise CCSDSFormatError(f"{stop} = {record[stop]} is before {start} = "
                                       f"{record[start]}", line=record.line_of(stop),
                                       source=source)


_ALL = (HEADER, RELATIVE) + SEGMENT_SECTIONS
def _read_checked(cursor, section):
    """Read a section; an unknown keyword right after it is reported as such."""
    from .layout import check_mandatory

    record = read_kvn_section(cursor, section, check=False)
    line = cursor.peek()
    if line is not None and line.kind == "keyword" and not any(s.owns(line.key) for s in _ALL):
        raise cursor.error(alt_covariance(line.key) or f"unexpected {line.key}: not a keyword "
                           "of a CDM (check its spelling)", line=line.line)
    if record is not None:
        check_mandatory(record, section, cursor.source)
    return record


def _describe(line) -> str:
    if line is None:
        return "the end of the message"
    return line.key if line.kind == "keyword" else f"'{line.value[:40]}'"


def _read_xml(text: str, name: str) -> ConjunctionDataMessage:
    from .layout import with_version

    root = message_root(parse(text, name), "cdm", name, ("body", "segment", "data"))
    version = root.attrib.get("version")
    header = root.path("header")
    if not version or not header:
        raise CCSDSFormatError("<cdm> needs a version attribute and a <header>", line=root.line,
                               source=name)
    sections = {"header": read_xml_section(with_version(header[0], "CCSDS_CDM_VERS", root),
                                           HEADER, name)}
    rel = root.path("body/relativeMetadataData")
    if not rel:
        raise CCSDSFormatError("<body><relativeMetadataData> is missing", line=root.line,
                               source=name)
    children = []
    for child in rel[0].children:
        children.extend(child.children if child.tag == "relativeStateVector" else [child])
    flat = XMLNode(rel[0].tag, rel[0].attrib, rel[0].line, rel[0].text, children)
    sections["relative"] = read_xml_section(flat, RELATIVE, name)
    segments = root.path("body/segment")
    if len(segments) != 2:
        raise CCSDSFormatError(f"a CDM has two <segment> elements, found {len(segments)}",
                               line=rel[0].line, source=name)
    for label, node in zip(("OBJECT1", "OBJECT2"), segments, strict=True):
        check_segment_elements(node, SEGMENT_SECTIONS, name)
        seg = {}
        for section in SEGMENT_SECTIONS:
            nodes = node.path(section.xml_path)
            if not nodes:
                if section.optional:
                    continue
                raise CCSDSFormatError(f"{label}: <{section.xml_path}> is missing",
                                       line=node.line, source=name)
            seg[section.name] = read_xml_section(nodes[0], section, name)
        if seg["metadata"]["OBJECT"] != label:
            raise CCSDSFormatError(f"expected OBJECT = {label}, found "
                                   f"{seg['metadata']['OBJECT']!r}",
                                   line=seg["metadata"].line_of("OBJECT"), source=name)
        sections[label.lower()] = seg
    _check_values(sections, name)
    return _checked(ConjunctionDataMessage(sections, name))


def write_cdm(message: ConjunctionDataMessage, path=None, format: str | None = None) -> str:  # noqa: A002
    """Write a CDM as KVN or XML text, to ``path`` when given.

    Parameters
    ----------
    message : ConjunctionDataMessage
        The message.
    path : str or os.PathLike, optional
        File to write.
    format : {"kvn", "xml"}, optional
        Output format. Default: ``"xml"`` for a path ending in ``.xml``, else ``"kvn"`` (as
        the other writers).

    Returns
    -------
    str
        The text.
    """
    if not isinstance(message, ConjunctionDataMessage):
        raise InvalidInputError(
            f"write_cdm needs a ConjunctionDataMessage, got {type(message).__name__} (read one "
            "with vv.read_cdm).")
    import os

    if format is None:  # (a .xml file of KVN text was written before; other tools refuse it)
        format = "xml" if path is not None and os.fspath(path).lower().endswith(".xml") else "kvn"
    if format not in ("kvn", "xml"):
        raise CCSDSFormatError(f"format must be 'kvn' or 'xml', not {format!r}")
    text = message.to_kvn() if format == "kvn" else message.to_xml()
    if path is not None:
        from .._text import replace_text_file

        replace_text_file(path, text)  # whole or not at all: a failed write keeps the old file
    return text
