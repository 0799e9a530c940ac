"""The Orbit Parameter Message (OPM): one state, optional elements, spacecraft, covariance, burns.

CCSDS 502.0-B-3, section 3. Read with :func:`read_opm` (KVN or XML), write with
:func:`write_opm`; the sections are the tables below.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InvalidInputError, ShapeError
from .covariance import (
    COVARIANCE_KEYWORDS,
    check_record_variances,
    matrix_from_values,
    on_state_axes,
    sun_from,
    warn_not_positive_definite,
)
from .grammar import CCSDSFormatError, Record, Section, version_keyword
from .grammar import Keyword as K
from .layout import read_message, write_message
from .opm_checks import check_gm, check_keplerian
from .timeframes import (
    FrameCenterMetadata,
    center_body,
    epochs_to_time,
    refuse_unused_mission_epoch,
)

__all__ = ["OPM", "Maneuver", "read_opm", "write_opm", "SECTIONS", "header_section"]


def header_section(kind: str) -> Section:
    """The header of an ODM (``CCSDS_<KIND>_VERS``, ``CREATION_DATE``, ``ORIGINATOR``, ...).

    Parameters
    ----------
    kind : str
        ``"OPM"``, ``"OMM"``, ``"OEM"``, ``"CDM"``.

    Returns
    -------
    Section
    """
    return Section("header", (
        version_keyword(kind), K("CLASSIFICATION"),
        K("CREATION_DATE", "epoch", None, True), K("ORIGINATOR", "text", None, True),
        K("MESSAGE_ID")), "header")


_DATA = "body/segment/data/"
METADATA = Section("metadata", (
    K("OBJECT_NAME", "text", None, True), K("OBJECT_ID", "text", None, True),
    K("CENTER_NAME", "text", None, True), K("REF_FRAME", "text", None, True),
    K("REF_FRAME_EPOCH", "epoch"), K("TIME_SYSTEM", "text", None, True)),
    "body/segment/metadata")
STATE_VECTOR = Section("state_vector", (
    K("EPOCH", "epoch", None, True), K("X", "float", "km", True), K("Y", "float", "km", True),
    K("Z", "float", "km", True), K("X_DOT", "float", "km/s", True),
    K("Y_DOT", "float", "km/s", True), K("Z_DOT", "float", "km/s", True)),
    _DATA + "stateVector")
KEPLERIAN = Section("keplerian_elements", (
    K("SEMI_MAJOR_AXIS", "float", "km", True), K("ECCENTRICITY", "float", None, True),
    K("INCLINATION", "float", "deg", True), K("RA_OF_ASC_NODE", "float", "deg", True),
    K("ARG_OF_PERICENTER", "float", "deg", True), K("TRUE_ANOMALY", "float", "deg"),
    K("MEAN_ANOMALY", "float", "deg"), K("GM", "float", "km**3/s**2", True)),
    _DATA + "keplerianElements", optional=True)
SPACECRAFT = Section("spacecraft_parameters", (
    K("MASS", "float", "kg"), K("SOLAR_RAD_AREA", "float", "m**2"),
    K("SOLAR_RAD_COEFF", "float"), K("DRAG_AREA", "float", "m**2"), K("DRAG_COEFF", "float")),
    _DATA + "spacecraftParameters", optional=True)
COVARIANCE = Section("covariance", (K("COV_REF_FRAME"),) + COVARIANCE_KEYWORDS,
                     _DATA + "covarianceMatrix", optional=True)
MANEUVER = Section("maneuvers", (
    K("MAN_EPOCH_IGNITION", "epoch", None, True), K("MAN_DURATION", "float", "s", True),
    K("MAN_DELTA_MASS", "float", "kg", True), K("MAN_REF_FRAME", "text", None, True),
    K("MAN_DV_1", "float", "km/s", True), K("MAN_DV_2", "float", "km/s", True),
    K("MAN_DV_3", "float", "km/s", True)), _DATA + "maneuverParameters", optional=True,
    repeat=True)
USER_DEFINED = Section("user_defined", (), _DATA + "userDefinedParameters", optional=True,
                       user_defined=True)
SECTIONS = (header_section("OPM"), METADATA, STATE_VECTOR, KEPLERIAN, SPACECRAFT, COVARIANCE,
            MANEUVER, USER_DEFINED)


@dataclass(frozen=True)
class Maneuver:
    """One manoeuvre of an OPM.

    Attributes
    ----------
    epoch : astropy.time.Time
        Ignition epoch.
    duration : Quantity
        Burn duration (s); 0 for an impulse.
    delta_mass : Quantity
        Mass change (kg), zero or negative.
    frame : str
        ``MAN_REF_FRAME`` of the delta-v (``"RTN"``, ``"TNW"``, ``"EME2000"``, ...).
    delta_v : Quantity, shape (3,)
        Delta-v (km/s) in ``frame``.
    """

    epoch: object
    duration: object
    delta_mass: object
    frame: str
    delta_v: object


class OPM(FrameCenterMetadata):
    """An Orbit Parameter Message as read: every section, plus the physics as visviva objects.

    Parameters
    ----------
    sections : dict
        Section name (``"header"``, ``"metadata"``, ``"state_vector"``,
        ``"keplerian_elements"``, ``"spacecraft_parameters"``, ``"covariance"``,
        ``"maneuvers"`` (a list), ``"user_defined"``) -> Record or dict of keyword values.
    source : str
        Where it was read from.
    mission_epoch : astropy.time.Time, optional
        The epoch a ``TIME_SYSTEM`` of MET or MRT counts from (not carried by the message).
    """

    def __init__(self, sections: dict, source: str = "<text>", mission_epoch=None):
        self.sections = {k: (v if isinstance(v, Record | list) else Record(values=dict(v)))
                         for k, v in sections.items()}
        if "maneuvers" in self.sections:
            self.sections["maneuvers"] = [m if isinstance(m, Record) else Record(values=dict(m))
                                          for m in self.sections["maneuvers"]]
        self.source = source
        self.mission_epoch = mission_epoch
        for name in ("header", "metadata", "state_vector"):
            if name not in self.sections:
                raise InvalidInputError(f"an OPM needs a {name.replace('_', ' ')} section")

    @classmethod
    def from_state(cls, state, *, object_name: str, object_id: str = "UNKNOWN",
                   center: str | None = None, frame: str | None = None,
                   time_system: str = "UTC", maneuvers=(), covariance=None,
                   originator: str = "VISVIVA",
                   mission_epoch=None, mass=None, covariance_frame=None):  # fmt: skip
        """An OPM for one state computed in visviva.

        Parameters
        ----------
        state : StateVectors
            One state (shape ``()``) with its ``epoch``, in ``frame``.
        object_name : str
            ``OBJECT_NAME``.
        object_id : str
            ``OBJECT_ID`` (international designator).
        center : str, optional
            ``CENTER_NAME``. Default: the body whose GM is the state's (``"EARTH"``,
            ``"MOON"``, ``"SUN"`` ...); a centre whose GM is not the state's is refused (the
            message would read back with the centre's GM).
        frame : str, optional
            ``REF_FRAME`` of the state (CCSDS name). Default: the state's own frame when it
            knows it (``sat.teme(t)`` gives ``"TEME"``, ``sat.gcrs(t)`` ``"GCRF"``), else
            ``"GCRF"`` (``"ICRF"`` about another centre than the Earth); a frame that
            contradicts the state's own is refused.
        time_system : str
            ``TIME_SYSTEM`` the epochs are written in.
        maneuvers : iterable of Maneuver or ImpulsiveBurn
            Manoeuvres (``epoch`` a Time, ``duration`` s, ``delta_mass`` kg, ``frame``,
            ``delta_v`` km/s Quantities), written as given; or impulses
            (:class:`visviva.ImpulsiveBurn` at an absolute epoch, what :meth:`burns` gives): a
            local frame's Δv as given, an inertial one (GCRS axes) in ``frame`` when that is on
            the GCRS axes or EME2000 (turned by the frame bias), else in GCRF.
        covariance : array_like or Quantity, shape (6, 6), optional
            Covariance of the state: plain numbers in km and km/s (what ``fit.covariance`` and
            ``propagate_covariance`` give), or an area Quantity (e.g. m^2: the whole matrix in
            its length unit and seconds), converted to km.
        originator : str
            ``ORIGINATOR``.
        mission_epoch : astropy.time.Time, optional
            The epoch MET/MRT count from, for those time systems.
        mass : Quantity, optional
            Spacecraft ``MASS`` (kg, > 0) at the epoch: its spacecraft parameters section.
        covariance_frame : str, optional
            Write ``covariance`` (on the state's axes) in this local orbital frame, as
            ``COV_REF_FRAME``: ``"RTN"``, ``"TNW"``, ``"NTW"``, ``"VNB"`` ... (quasi-inertial),
            SANA's ``"RSW_INERTIAL"``, ``"LVLH_ROTATING"``, ``"PQW_INERTIAL"`` ...
            (:mod:`visviva.ccsds.orbit_frames`,
            :func:`visviva.ccsds.covariance.from_state_axes`). None: the state's axes.

        Returns
        -------
        OPM
        """
        from astropy import units as u

        from .covariance import values_from_matrix
        from .timeframes import center_of, from_gcrs_axes, ref_frame_of, time_to_epochs

        if getattr(state, "shape", None) != () or state.epoch is None:
            raise InvalidInputError("from_state needs one state (shape ()) with an epoch")
        center = center_of(state, center)
        frame = ref_frame_of(state, frame, center)
        # (the state is on the GCRS/ICRF axes: EME2000 is written with the frame bias)
        r, v = from_gcrs_axes(frame, state.r.to_value(u.km), state.v.to_value(u.km / u.s))
        sections = {
            "header": {"CCSDS_OPM_VERS": "3.0", "ORIGINATOR": originator},
            "metadata": {"OBJECT_NAME": object_name, "OBJECT_ID": object_id,
                         "CENTER_NAME": center, "REF_FRAME": frame, "TIME_SYSTEM": time_system},
            "state_vector": {"EPOCH": time_to_epochs(state.epoch, time_system, mission_epoch)[0],
                             **dict(zip(("X", "Y", "Z"), map(float, r), strict=True)),
                             **dict(zip(("X_DOT", "Y_DOT", "Z_DOT"), map(float, v),
                                        strict=True))},
        }
        if mass is not None:
            m_kg = _one(mass, "mass", "mass")
            if not m_kg > 0:
                raise InvalidInputError(f"mass must be > 0 kg; got {mass}.")
            sections["spacecraft_parameters"] = {"MASS": m_kg}
        if covariance is not None:
            from .._covariance import as_covariance, local_axes_of

            # an RTN (TNW ...) matrix of propagate_covariance(output_frame=...) is written as it
            # is, in its frame: taken for one on the state's axes, it was rotated a second time
            axes = local_axes_of(covariance, covariance_frame, "OPM.from_state")
            covariance_frame = axes or covariance_frame
            # an area Quantity (a CDM's m^2) is converted: its numbers were written as km^2
            if np.shape(covariance) != (6, 6):
                raise ShapeError(
                    f"covariance must be the 6 x 6 of the state (km, km/s); got "
                    f"{np.shape(covariance)} (a fit's full_covariance also holds its Δvs and "
                    "coefficients: give fit.covariance).")
            covariance = as_covariance(covariance, "covariance", length_unit="km")
            if axes is None:
                covariance = from_gcrs_axes(frame, covariance)[0]  # (on the state's axes)
            diag = np.diagonal(covariance)
            if not (diag >= 0).all():
                raise InvalidInputError("covariance must be finite with variances >= 0 on its "
                                        f"diagonal; got diagonal {diag}.")
            if covariance_frame is None:
                sections["covariance"] = values_from_matrix(covariance)
            elif axes is not None:
                from .covariance import local_frame

                local_frame(axes)  # (a name the reader takes)
                sections["covariance"] = {"COV_REF_FRAME": axes.upper(),
                                          **values_from_matrix(covariance)}
            else:
                from .covariance import from_state_axes

                local = from_state_axes(covariance, covariance_frame, r, v,
                                        gm=lambda: state.gm.to_value(u.km**3 / u.s**2),
                                        sun=sun_from(state.epoch, center, frame))
                sections["covariance"] = {"COV_REF_FRAME": str(covariance_frame).upper(),
                                          **values_from_matrix(local)}
        elif covariance_frame is not None:
            raise InvalidInputError("covariance_frame is the frame to write covariance in; "
                                    "give covariance= too.")
        records = [_maneuver_record(k, m, time_system, mission_epoch, frame)
                   for k, m in enumerate(maneuvers or ())]  # once: a generator is used up
        if records:
            sections["maneuvers"] = records
        return cls(sections, mission_epoch=mission_epoch)

    def __repr__(self) -> str:
        meta = self.sections["metadata"]
        return (f"<OPM {meta.get('OBJECT_NAME')!r} {self.frame}/{self.center} at "
                f"{self.sections['state_vector'].get('EPOCH')}, {len(self.maneuvers)} manoeuvre(s)>")

    @property
    def header(self) -> Record:
        """The header keywords."""
        return self.sections["header"]

    @property
    def metadata(self) -> Record:
        """The metadata keywords."""
        return self.sections["metadata"]

    def _time(self, text, key, record):
        meta = self.metadata
        return epochs_to_time(text, meta["TIME_SYSTEM"], record.line_of(key), self.source,
                              self.mission_epoch, system_line=meta.line_of("TIME_SYSTEM"))

    @property
    def epoch(self):
        """The state's ``EPOCH`` as an astropy ``Time`` (in ``TIME_SYSTEM``)."""
        sv = self.sections["state_vector"]
        return self._time(sv["EPOCH"], "EPOCH", sv)

    @property
    def gm(self) -> float:
        """GM (km**3/s**2): the message's own (Keplerian section) else that of ``CENTER_NAME``."""
        kep = self.sections.get("keplerian_elements")
        if kep is not None and "GM" in kep:
            return float(kep["GM"])
        body = center_body(self.center)
        if body is None:
            from .timeframes import barycentre_note

            raise InvalidInputError(f"CENTER_NAME = {self.center} is not a body visviva knows"
                                    f"{barycentre_note(self.center)} and the OPM gives no GM")
        return body.gm_km3_s2

    @property
    def state(self):
        """The state vector as :class:`~visviva.states.StateVectors` (km, km/s, GM, epoch); about
        the Earth in GCRS, TEME or ITRF it knows its frame (``.frame``: ``"gcrs"``, ...).

        The state of a message with manoeuvres remembers it: :func:`visviva.propagate_cowell`
        refuses it unless given ``maneuvers=`` (:meth:`burns`, or ``[]`` for none), so that the
        manoeuvres are never left out silently; :meth:`propagate` applies them."""
        from astropy import units as u

        from ..states import StateVectors

        sv = self.sections["state_vector"]
        r = [sv["X"], sv["Y"], sv["Z"]]
        v = [sv["X_DOT"], sv["Y_DOT"], sv["Z_DOT"]]
        checked = StateVectors(r * u.km, v * u.km / u.s, self.gm * u.km**3 / u.s**2,
                               epoch=self.epoch)  # the constructor's checks
        state = self.wrap_states(checked.r.to_value(u.km), checked.v.to_value(u.km / u.s),
                                 self.gm, checked.epoch)
        if self.sections.get("maneuvers"):  # propagate_cowell refuses it without maneuvers=
            from ..satellites.burns import PENDING_ATTRIBUTE

            setattr(state, PENDING_ATTRIBUTE, len(self.sections["maneuvers"]))
        return state

    @property
    def covariance(self) -> np.ndarray | None:
        """The 6 x 6 covariance of :attr:`state` (km, km/s) on the state's axes, or None.

        A ``COV_REF_FRAME`` naming an orbit-relative frame of the state (``RTN``/``RSW``/
        ``RIC``/``QSW``, ``TNW``, ``NTW``, ``VNB``, SANA's ``*_INERTIAL`` and ``*_ROTATING``:
        :mod:`visviva.ccsds.orbit_frames`) is rotated to the axes of ``REF_FRAME`` (the
        velocity block as the position block for the quasi-inertial ones, the CCSDS
        convention; with the frame's rotation for ``*_ROTATING``), so that the matrix goes with
        :attr:`state` wherever a covariance is taken (``vv.propagate_covariance(opm.state,
        opm.covariance, t)``); the matrix as written is ``opm.sections["covariance"]``.

        Raises
        ------
        InvalidInputError
            A ``COV_REF_FRAME`` that is another frame than ``REF_FRAME`` and no local frame
            (the rotation between them is not applied here), or a local frame of a state on
            Earth-fixed axes (its velocity does not give the orbital axes).
        """
        cov = self.sections.get("covariance")
        if cov is None:
            return None
        matrix = matrix_from_values(cov.values)
        frame = cov.get("COV_REF_FRAME")
        sv = self.sections["state_vector"]
        r = [sv["X"], sv["Y"], sv["Z"]]
        v = [sv["X_DOT"], sv["Y_DOT"], sv["Z_DOT"]]
        where = f"{self.source} line {cov.line_of('COV_REF_FRAME')}: COV_REF_FRAME = {frame}"
        from .timeframes import to_gcrs_axes

        m = on_state_axes(matrix, frame, self.frame, self.visviva_frame, r, v, where,
                          "opm.sections['covariance']", gm=lambda: self.gm,
                          sun=sun_from(lambda: self.epoch, self.center, self.frame))
        return to_gcrs_axes(self.frame, m)[0]  # (EME2000: rotated as :attr:`state` is)

    @property
    def maneuvers(self) -> list[Maneuver]:
        """The manoeuvres in the order of the message."""
        from astropy import units as u

        out = []
        for m in self.sections.get("maneuvers", []):
            out.append(Maneuver(
                self._time(m["MAN_EPOCH_IGNITION"], "MAN_EPOCH_IGNITION", m),
                m["MAN_DURATION"] * u.s, m["MAN_DELTA_MASS"] * u.kg, m["MAN_REF_FRAME"],
                [m["MAN_DV_1"], m["MAN_DV_2"], m["MAN_DV_3"]] * (u.km / u.s)))
        return out

    def burns(self) -> list:
        """The manoeuvres as burns for :func:`visviva.propagate_cowell` (``maneuvers=``).

        Returns
        -------
        list of ImpulsiveBurn or FiniteBurn
            In the order of their epochs. ``MAN_DURATION = 0``: an impulse of ``MAN_DV`` in
            ``MAN_REF_FRAME``. ``MAN_DURATION > 0``: a finite burn along ``MAN_DV`` (held fixed
            in that frame) whose thrust integrates to |MAN_DV|: with the spacecraft ``MASS``
            and ``MAN_DELTA_MASS < 0``, thrust and mass flow from the rocket equation
            (mdot = -MAN_DELTA_MASS / MAN_DURATION, F = mdot |Δv| / ln(m0 / m1), m0 the mass at
            ignition: ``MASS``, the mass at ``EPOCH``, less the ``MAN_DELTA_MASS`` of the
            manoeuvres ignited before ``EPOCH``, plus those of the earlier manoeuvres, so that a
            manoeuvre before ``EPOCH``, crossed backwards, starts with the mass it had);
            otherwise a constant acceleration |Δv| / MAN_DURATION.

        Raises
        ------
        InvalidInputError
            A ``MAN_REF_FRAME`` other than RTN, TNW, VNB, EME2000, GCRF, ICRF (named, with its
            line), or a manoeuvre that uses more mass than the spacecraft has.
        """
        return _burns(self)

    def propagate(self, t, perturbations=(), **kwargs):
        """Propagate the state with its manoeuvres: :func:`visviva.propagate_cowell` with
        ``maneuvers=self.burns()``.

        Parameters
        ----------
        t : Quantity or astropy Time
            Output times (offsets from ``EPOCH``, or absolute).
        perturbations : list of Perturbation
            As for :func:`visviva.propagate_cowell`.
        **kwargs
            Other arguments of :func:`visviva.propagate_cowell` (``events``, ``rtol`` ...).

        Returns
        -------
        CowellResult
        """
        from ..satellites.cowell import propagate_cowell

        if "maneuvers" in kwargs:
            raise InvalidInputError(
                "opm.propagate applies the message's own manoeuvres; for other ones call "
                "vv.propagate_cowell(opm.state, t, perturbations, maneuvers=[...]).")
        return propagate_cowell(self.state, t, perturbations, maneuvers=self.burns(), **kwargs)


def _one(value, kind, name) -> float:
    """One value of ``kind`` in visviva's unit (kg, s ...), as :meth:`OPM.from_state` writes it."""
    from .._units import to_array

    arr = to_array(value, kind, name)
    if arr.ndim != 0:
        raise InvalidInputError(f"{name} must be one value; got shape {arr.shape}.")
    return float(arr)


def _maneuver_record(k, m, time_system, mission_epoch, frame) -> dict:
    """The ``MAN_*`` keywords of the manoeuvre ``m`` (``maneuvers[k]`` of
    :meth:`OPM.from_state`, whose ``REF_FRAME`` is ``frame``), checked."""
    from astropy import units as u
    from astropy.time import Time

    from .._units import to_vector
    from ..satellites.burns import INERTIAL, FiniteBurn, ImpulsiveBurn
    from .timeframes import from_gcrs_axes, time_to_epochs, visviva_frame

    if isinstance(m, FiniteBurn):
        raise InvalidInputError(
            f"maneuvers[{k}] is a FiniteBurn, whose thrust law an OPM manoeuvre does not hold; "
            "give a visviva.ccsds.opm.Maneuver(epoch, duration, delta_mass, frame, delta_v).")
    if isinstance(m, ImpulsiveBurn):  # its inertial Δv is on the GCRS axes
        to = (str(frame).upper() if m.code == INERTIAL and visviva_frame(frame) == "gcrs"
              else "GCRF" if m.code == INERTIAL else m.frame)
        dv = from_gcrs_axes(to, m.delta_v_km_s)[0] if m.code == INERTIAL else m.delta_v_km_s
        m = Maneuver(m.start, 0.0 * u.s, 0.0 * u.kg if m.delta_mass is None else m.delta_mass,
                     to, dv * (u.km / u.s))
    elif not isinstance(m, Maneuver):
        raise InvalidInputError(
            f"maneuvers[{k}] must be a visviva.ccsds.opm.Maneuver or a visviva.ImpulsiveBurn; "
            f"got {type(m).__name__}.")

    if not isinstance(m.epoch, Time) or not m.epoch.isscalar:
        raise InvalidInputError(f"maneuvers[{k}]: epoch must be one astropy Time (the ignition); "
                                f"got {m.epoch!r}.")
    duration = _one(m.duration, "time", f"maneuvers[{k}].duration")
    if not duration >= 0:
        raise InvalidInputError(f"maneuvers[{k}]: duration = {m.duration}; a burn lasts "
                                ">= 0 s (0 for an impulse).")
    delta_mass = _one(m.delta_mass, "mass", f"maneuvers[{k}].delta_mass")
    if not delta_mass <= 0:
        raise InvalidInputError(f"maneuvers[{k}]: delta_mass = {m.delta_mass}; a manoeuvre "
                                "spends mass, so the change is <= 0.")
    dv = to_vector(m.delta_v, "speed", f"maneuvers[{k}].delta_v")
    if dv.shape != (3,):
        raise InvalidInputError(f"maneuvers[{k}]: delta_v must have shape (3,); got {dv.shape}.")
    return {"MAN_EPOCH_IGNITION": time_to_epochs(m.epoch, time_system, mission_epoch)[0],
            "MAN_DURATION": duration, "MAN_DELTA_MASS": delta_mass, "MAN_REF_FRAME": m.frame,
            **dict(zip(("MAN_DV_1", "MAN_DV_2", "MAN_DV_3"), map(float, dv), strict=True))}


def _burns(opm) -> list:
    """:meth:`OPM.burns` (see there)."""
    from astropy import units as u

    from ..satellites.burns import FiniteBurn, ImpulsiveBurn, frame_code
    from .timeframes import has_frame_bias, to_gcrs_axes

    sc = opm.sections.get("spacecraft_parameters")
    mass = None if sc is None or sc.get("MASS") is None else float(sc["MASS"])
    from ..satellites.frames import offline_iers

    with offline_iers():  # a UT1 file needs the installed IERS table, never a download
        records = sorted(zip(opm.maneuvers, opm.sections.get("maneuvers", []), strict=True),
                         key=lambda x: x[0].epoch.tai.jd)
        if mass is not None:  # MASS is at EPOCH: manoeuvres before it had spent their mass by then
            mass -= sum(float(m.delta_mass.to_value(u.kg)) for m, _ in records
                        if (m.epoch.tai - opm.epoch.tai).to_value(u.s) < 0)
    out = []
    for man, rec in records:
        where = f"{opm.source} line {rec.line_of('MAN_REF_FRAME')}"
        dv = man.delta_v.to_value(u.km / u.s)
        frame = man.frame
        if str(frame).strip().upper() == "J2000":
            raise InvalidInputError(f"{where}: MAN_REF_FRAME = {frame} is not a CCSDS frame name; "
                                    "the mean equator and equinox of J2000 is EME2000 (SANA).")
        if has_frame_bias(frame):  # EME2000: the Δv turned to the GCRS axes (the frame bias)
            dv, frame = to_gcrs_axes(frame, dv)[0], "GCRF"
            man = replace(man, frame=frame, delta_v=dv * (u.km / u.s))
        try:
            frame_code(frame)
        except InvalidInputError as exc:
            raise InvalidInputError(f"{where}: MAN_REF_FRAME = {rec['MAN_REF_FRAME']}: {exc}"
                                    ) from None
        dt = float(man.duration.to_value(u.s))
        dm = float(man.delta_mass.to_value(u.kg))
        n = float(np.linalg.norm(dv))
        if mass is not None and not mass + dm > 0:
            raise InvalidInputError(
                f"{opm.source} line {rec.line_of('MAN_DELTA_MASS')}: MAN_DELTA_MASS = {dm} kg "
                f"leaves {mass + dm:g} kg of the spacecraft (MASS plus the earlier manoeuvres' "
                "MAN_DELTA_MASS); check the masses.")
        if dt == 0.0 or n == 0.0:
            out.append(ImpulsiveBurn(man.epoch, man.delta_v, man.frame, delta_mass=man.delta_mass,
                                     mass=None if mass is None else mass * u.kg))
        elif mass is not None and dm < 0.0:
            m1 = mass + dm
            mdot = -dm / dt
            thrust = mdot * n / math.log(mass / m1) * 1e3  # F = mdot v_e, v_e = |dv| / ln(m0/m1)
            out.append(FiniteBurn(man.epoch, man.duration, dv / n, man.frame, thrust=thrust * u.N,
                                  mass=mass * u.kg, mass_flow=mdot * u.kg / u.s))
        else:
            out.append(FiniteBurn(man.epoch, man.duration, dv / n, man.frame,
                                  acceleration=n / dt * u.km / u.s**2))
        if mass is not None:
            mass += dm
    return out


def read_opm(source, *, mission_epoch=None) -> OPM:
    """Read a CCSDS Orbit Parameter Message (KVN or XML, detected).

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A path, the message text, or its bytes (UTF-8).
    mission_epoch : astropy.time.Time, optional
        The epoch that ``TIME_SYSTEM = MET`` (launch) or ``MRT`` (the mission's reference)
        counts from; such messages cannot be read without it.

    Returns
    -------
    OPM
        With ``.epoch``, ``.state``, ``.frame``, ``.center``, ``.maneuvers``, ``.covariance``
        and every section's keywords in ``.sections``.

    Raises
    ------
    CCSDSFormatError
        Malformed input; the message names the line.
    """
    sections, _, name = read_message(source, SECTIONS, "opm", "CCSDS_OPM_VERS")
    kep = sections.get("keplerian_elements")
    if kep is not None and ("TRUE_ANOMALY" in kep) == ("MEAN_ANOMALY" in kep):
        raise CCSDSFormatError("the Keplerian elements need exactly one of TRUE_ANOMALY and "
                               "MEAN_ANOMALY", line=kep.line, source=name)
    if sections.get("covariance") is not None:
        check_record_variances(sections["covariance"], name)
        cov = sections["covariance"]
        warn_not_positive_definite([(matrix_from_values(cov.values), cov.line)], name, 3)
    for man in sections.get("maneuvers", []):
        if man["MAN_DURATION"] < 0:
            raise CCSDSFormatError(f"MAN_DURATION = {man['MAN_DURATION']!r} s: a burn lasts >= 0 s "
                                   "(0 for an impulse)", line=man.line_of("MAN_DURATION"),
                                   source=name)
        if man["MAN_DELTA_MASS"] > 0:
            raise CCSDSFormatError(f"MAN_DELTA_MASS = {man['MAN_DELTA_MASS']!r} kg: a manoeuvre "
                                   "spends mass, so the change is <= 0 (write it negative)",
                                   line=man.line_of("MAN_DELTA_MASS"), source=name)
    _check_values(sections, name)
    check_gm(sections, name)  # (opm.state orbits with the message's GM)
    check_keplerian(sections, name)
    opm = OPM(sections, name, mission_epoch)
    refuse_unused_mission_epoch(mission_epoch, [opm.metadata["TIME_SYSTEM"]], name,
                                opm.metadata.line_of("TIME_SYSTEM"))
    opm.epoch  # noqa: B018  (checks TIME_SYSTEM and the epoch now, naming the line)
    opm.maneuvers  # noqa: B018  (and the manoeuvre epochs)
    return opm


#: keywords that cannot be negative (GM must be positive), by section
_NOT_NEGATIVE = {"keplerian_elements": ("ECCENTRICITY",),
                 "spacecraft_parameters": ("MASS", "SOLAR_RAD_AREA", "DRAG_AREA")}


def _check_values(sections, name):
    """Refuse physically impossible values, naming the line."""
    for section, keys in _NOT_NEGATIVE.items():
        rec = sections.get(section)
        for key in keys if rec is not None else ():
            if key in rec and rec[key] < 0:
                raise CCSDSFormatError(f"{key} = {rec[key]!r} cannot be negative",
                                       line=rec.line_of(key), source=name)
    kep = sections.get("keplerian_elements")
    if kep is None:
        return
    if not kep["GM"] > 0:
        raise CCSDSFormatError(f"GM = {kep['GM']!r} km**3/s**2: a gravitational parameter is > 0",
                               line=kep.line_of("GM"), source=name)
    a, e = kep["SEMI_MAJOR_AXIS"], kep["ECCENTRICITY"]
    if a == 0 or (a > 0) != (e < 1):
        raise CCSDSFormatError(f"SEMI_MAJOR_AXIS = {a!r} km does not go with ECCENTRICITY = {e!r} "
                               "(a > 0 for an ellipse, e < 1; a < 0 for a hyperbola, e > 1)",
                               line=kep.line_of("SEMI_MAJOR_AXIS"), source=name)


def write_opm(opm: OPM, path=None, format: str | None = None) -> str:  # noqa: A002
    """Write an OPM (KVN or XML) with every keyword it holds.

    Parameters
    ----------
    opm : OPM
        The message (as read, or built from section dicts).
    path : str or os.PathLike, optional
        File to write; nothing is written when None.
    format : {"kvn", "xml"}, optional
        Default: ``"xml"`` for a path ending in ``.xml``, else ``"kvn"``.

    Returns
    -------
    str
        The message text.
    """
    if not isinstance(opm, OPM):
        raise InvalidInputError(
            f"write_opm needs an OPM, got {type(opm).__name__}: build one from a state with "
            "visviva.ccsds.opm.OPM.from_state(state, object_name=...).")
    return write_sections(opm.sections, SECTIONS, "opm", "CCSDS_OPM_VERS", path, format)


def write_sections(sections, table, root, version_key, path, format):  # noqa: A002
    import os

    if format is None:
        format = "xml" if path is not None and os.fspath(path).lower().endswith(".xml") else "kvn"
    header = sections["header"]
    if "CREATION_DATE" not in header:  # the one keyword a writer may add (on a copy)
        from astropy.time import Time

        header = Record({**header.values, "CREATION_DATE": Time.now().utc.isot},
                        header.comments, header.lines, header.line,
                        header.units, header.attributes)
        sections = {**sections, "header": header}
    text = write_message(sections, table, root, version_key, fmt=format)
    if path is not None:
        from .._text import replace_text_file

        replace_text_file(path, text)  # whole or not at all: a failed write keeps the old file
    return text
