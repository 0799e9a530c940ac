"""The Orbit Ephemeris Message (OEM): an ephemeris of segments that interpolates.

:class:`Ephemeris` holds the header and a list of :class:`OEMSegment`; each segment its metadata,
its states (and optional accelerations), its covariance matrices, and the interpolation named in
the file. Reading and writing are in :mod:`visviva.ccsds.oem_io`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidInputError
from . import timeframes as tf
from .grammar import Keyword as K
from .grammar import Record, Section, version_keyword
from .interpolation import check_degree, hermite, lagrange
from .timeframes import FrameCenterMetadata, center_body, epochs_to_time, time_to_epochs

__all__ = ["Ephemeris", "OEMSegment", "OEMCovariance", "HEADER", "METADATA", "COVARIANCE_META"]

HEADER = Section("header", (
    version_keyword("OEM"), K("CLASSIFICATION"),
    K("CREATION_DATE", "epoch", None, True), K("ORIGINATOR", "text", None, True),
    K("MESSAGE_ID")), "header")
METADATA = Section("metadata", (
    K("OBJECT_NAME", "text", None, True), K("OBJECT_ID", "text", None, True),
    K("CENTER_NAME", "text", None, True), K("REF_FRAME", "text", None, True),
    K("REF_FRAME_EPOCH", "epoch"), K("TIME_SYSTEM", "text", None, True),
    K("START_TIME", "epoch", None, True), K("USEABLE_START_TIME", "epoch"),
    K("USEABLE_STOP_TIME", "epoch"), K("STOP_TIME", "epoch", None, True),
    K("INTERPOLATION"), K("INTERPOLATION_DEGREE", "int")), "body/segment/metadata")
COVARIANCE_META = Section("covariance", (
    K("EPOCH", "epoch", None, True), K("COV_REF_FRAME")), "covarianceMatrix")

#: default interpolation when the file names none (CCSDS leaves it to the user): Lagrange
#: assumes nothing about how the velocities relate to the positions (SGP4's do not match the
#: derivative of its positions, and Hermite then degrades with the degree; see
#: examples/ccsds_oem_interpolation.py)
DEFAULT_INTERPOLATION = ("LAGRANGE", 7)
#: the interpolation methods visviva reads and writes
INTERPOLATION_METHODS = ("LAGRANGE", "HERMITE", "LINEAR")


@dataclass
class OEMCovariance:
    """One covariance matrix of an OEM segment.

    Attributes
    ----------
    epoch : str
        Its epoch as written (in the segment's time system).
    matrix : ndarray, shape (6, 6)
        Symmetric covariance of (x, y, z, vx, vy, vz) in km and km/s (km**2, km**2/s, km**2/s**2),
        marked as such (:class:`visviva._covariance.KilometreCovariance`).
    frame : str or None
        ``COV_REF_FRAME`` (None: the segment's ``REF_FRAME``).
    comments : list of str
        Its COMMENT lines.
    """

    epoch: str
    matrix: np.ndarray
    frame: str | None = None
    comments: list = field(default_factory=list)

    def __post_init__(self):
        from .._covariance import km_covariance

        self.matrix = km_covariance(self.matrix)  # km: converted where m^2 is read


class OEMSegment(FrameCenterMetadata):
    """One segment of an OEM: metadata, states at increasing epochs, covariances.

    Parameters
    ----------
    metadata : Record or dict
        The metadata keywords (``OBJECT_NAME``, ``CENTER_NAME``, ``REF_FRAME``, ``TIME_SYSTEM``,
        ``START_TIME``, ``STOP_TIME``, ``INTERPOLATION``, ...).
    epochs : list of str
        The epochs as written (CCSDS format, in ``TIME_SYSTEM``).
    r_km : ndarray, shape (N, 3)
        Positions (km).
    v_km_s : ndarray, shape (N, 3)
        Velocities (km/s).
    a_km_s2 : ndarray, shape (N, 3), optional
        Accelerations (km/s**2), when the file gives them.
    covariances : list of OEMCovariance, optional
        The covariance matrices.
    data_comments : list of str, optional
        COMMENT lines at the start of the data.
    state_comments : dict, optional
        COMMENT lines among the state lines, keyed by the number of state lines before them:
        ``{k: [...]}`` sits between state ``k - 1`` and state ``k``, ``{len(epochs): [...]}``
        after the last one. Read from files that put notes there and written back in place, so
        that no line of a user's file is lost.
    mission_epoch : astropy.time.Time, optional
        The epoch a ``TIME_SYSTEM`` of MET or MRT counts from (not carried by the message).
    """

    def __init__(self, metadata, epochs, r_km, v_km_s, a_km_s2=None, covariances=(),
                 data_comments=(), state_comments=None, mission_epoch=None):
        self.metadata = metadata if isinstance(metadata, Record) else Record(values=dict(metadata))
        self.epochs = list(epochs)
        from .._units import to_array

        # Quantities are converted (a position in m was taken as km); plain numbers are km, km/s
        self.r_km = to_array(r_km, "length", "r_km", allow_plain=True, finite=False).reshape(-1, 3)
        self.v_km_s = to_array(v_km_s, "speed", "v_km_s", allow_plain=True,
                               finite=False).reshape(-1, 3)
        self.a_km_s2 = None if a_km_s2 is None else to_array(
            a_km_s2, "accel", "a_km_s2", allow_plain=True, finite=False).reshape(-1, 3)
        self.covariances = list(covariances)
        self.data_comments = list(data_comments)
        self.state_comments = {int(k): list(v) for k, v in (state_comments or {}).items() if v}
        self.mission_epoch = mission_epoch
        self._times = None
        self._seconds = None

    @classmethod
    def from_states(cls, times, r_km=None, v_km_s=None, *, object_name: str,
                    object_id: str = "UNKNOWN",
                    center: str | None = None, frame: str | None = None,
                    time_system: str = "UTC",
                    interpolation: str = "HERMITE", degree: int = 5, a_km_s2=None,
                    mission_epoch=None, covariance=None, covariance_frame=None):  # fmt: skip
        """A segment from arrays (what a writer needs to make an OEM from computed states).

        Parameters
        ----------
        times : astropy.time.Time, shape (N,), or StateVectors
            Increasing epochs; or the states themselves (shape ``(N,)`` with their ``epoch``,
            e.g. ``sat.teme(t)`` or an OEM's ``seg.states``), whose own frame is then written.
        r_km : array_like, shape (N, 3)
            Positions (km) in ``frame`` (not given with states).
        v_km_s : array_like, shape (N, 3)
            Velocities (km/s) (not given with states).
        object_name : str
            ``OBJECT_NAME``.
        object_id : str
            ``OBJECT_ID`` (international designator, e.g. ``"1998-067A"``).
        center : str, optional
            ``CENTER_NAME``. Default: for states, the body whose GM is theirs (``"EARTH"``,
            ``"MOON"``, ``"SUN"`` ...; a centre whose GM is not theirs is refused, as the file
            would read back with the centre's GM); for arrays ``"EARTH"``.
        frame : str, optional
            ``REF_FRAME`` (CCSDS name: ``"GCRF"``, ``"EME2000"``, ``"TEME"``, ``"ITRF"``).
            Default: the states' own frame when given states that know it (TEME states are
            written ``TEME``), else ``"GCRF"`` (``"ICRF"`` about another centre than the
            Earth); a frame that contradicts the states' is refused. States (their covariance,
            accelerations) are on the GCRS/ICRF axes: ``"EME2000"`` writes them turned by the
            frame bias (``timeframes.FRAME_BIAS``); arrays are written as given.
        time_system : str
            ``TIME_SYSTEM`` the epochs are written in.
        interpolation : {"HERMITE", "LAGRANGE"}
            ``INTERPOLATION``.
        degree : int
            ``INTERPOLATION_DEGREE``.
        a_km_s2 : array_like, shape (N, 3), optional
            Accelerations (km/s**2).
        mission_epoch : astropy.time.Time, optional
            The epoch MET/MRT count from, for those time systems.
        covariance : array_like or Quantity, shape (N, 6, 6), optional
            A covariance at each epoch (km^2, km^2/s, km^2/s^2 when plain, or an area Quantity),
            e.g. ``.covariance`` of :func:`visviva.propagate_covariance` (in its frame, RTN with
            ``output_frame="RTN"``); written as the segment's covariance blocks.
        covariance_frame : str, optional
            ``COV_REF_FRAME`` of those blocks (``"RTN"``, ``"TNW"``, ...; ``"GCRS"`` is written
            ``"GCRF"``); None: a propagated covariance's own frame, else the axes of ``frame``.

        Returns
        -------
        OEMSegment
        """
        from .._units import to_array
        from .timeframes import center_of, ref_frame_of

        states = None
        if hasattr(times, "r") and hasattr(times, "v"):  # states, with their epoch and frame
            states = times
            if r_km is not None or v_km_s is not None or getattr(states, "epoch", None) is None:
                raise InvalidInputError(
                    "from_states(states, ...) takes states with their epochs (and no r_km, "
                    "v_km_s); or pass from_states(times, r_km, v_km_s, ...).")
            frame = ref_frame_of(states, frame, center_of(states, center))
            times, r_km = states.epoch, states.r.to_value("km")  # (GCRS/ICRF axes: EME2000
            r_km, v_km_s = tf.from_gcrs_axes(frame, r_km, states.v.to_value("km/s"))  # is biased)
            a_km_s2 = None if a_km_s2 is None else tf.from_gcrs_axes(
                frame, to_array(a_km_s2, "accel", "a_km_s2", allow_plain=True))[0]
        elif r_km is None or v_km_s is None:
            raise InvalidInputError("from_states needs times, r_km and v_km_s (or states with "
                                    "their epochs).")
        center = center_of(states, center)
        if frame is None:  # (the GCRF is geocentric: about another centre, the ICRF's axes)
            frame = "GCRF" if str(center).strip().upper() == "EARTH" else "ICRF"
        if int(degree) != degree or degree < 1:
            raise InvalidInputError(f"degree = {degree!r}: the interpolation degree is an "
                                    "integer >= 1 (a reader refuses anything else).")
        if str(interpolation).upper() not in INTERPOLATION_METHODS:
            raise InvalidInputError(f"interpolation = {interpolation!r}: use one of "
                                    f"{', '.join(INTERPOLATION_METHODS)} (a reader refuses "
                                    "anything else).")
        epochs = time_to_epochs(times, time_system, mission_epoch)
        meta = {"OBJECT_NAME": object_name, "OBJECT_ID": object_id, "CENTER_NAME": center,
                "REF_FRAME": frame, "TIME_SYSTEM": time_system, "START_TIME": epochs[0],
                "STOP_TIME": epochs[-1], "INTERPOLATION": interpolation,
                "INTERPOLATION_DEGREE": int(degree)}
        covs = ()
        if covariance is not None:
            from .._covariance import as_covariance, local_axes_of, require_psd

            covariance_frame = local_axes_of(covariance, covariance_frame, "OEMSegment."
                                             "from_states") or covariance_frame  # (its RTN)
            c = as_covariance(covariance, "covariance", length_unit="km")
            if c.shape != (len(epochs), 6, 6):
                raise InvalidInputError(
                    f"covariance must hold one 6x6 matrix per epoch, shape ({len(epochs)}, 6, "
                    f"6); got {c.shape}.")
            for k, m in enumerate(c):
                require_psd(m, f"covariance[{k}]")
            if states is not None and covariance_frame is None:  # (on the states' axes)
                c = tf.from_gcrs_axes(frame, c)[0]
            cf = covariance_frame
            cf = "GCRF" if cf is not None and str(cf).upper() == "GCRS" else cf
            if cf is not None:
                from .covariance import local_frame

                local_frame(cf)  # refuses an ambiguous name (plain LVLH) a reader would refuse
            covs = [OEMCovariance(e, m, None if cf is None else str(cf).upper())
                    for e, m in zip(epochs, c, strict=True)]
        seg = cls(meta, epochs, r_km, v_km_s, a_km_s2, covs, mission_epoch=mission_epoch)
        seg.check()
        body = center_body(str(center))
        if body is not None:
            from .._containers import warn_implausible_velocity

            warn_implausible_velocity(seg.r_km, seg.v_km_s, body.gm.to_value("km3 / s2"),
                                      "OEMSegment.from_states")
        return seg

    # ---- metadata (frame, visviva_frame, center: FrameCenterMetadata) --------------------
    @property
    def time_system(self) -> str:
        """``TIME_SYSTEM`` as written."""
        return self.metadata["TIME_SYSTEM"]

    @property
    def interpolation(self) -> tuple[str, int]:
        """(method, degree) from the metadata.

        LAGRANGE when the file names no method, degree 7 when it names no degree (fewer on a
        segment of fewer than 8 states).
        """
        method = self.metadata.get("INTERPOLATION") or DEFAULT_INTERPOLATION[0]
        degree = self.metadata.get("INTERPOLATION_DEGREE")
        if degree is None:  # not named: the default, or less on a short segment
            degree = max(1, min(DEFAULT_INTERPOLATION[1], len(self) - 1))
        return method.upper(), degree

    # ---- states --------------------------------------------------------------------------
    @property
    def times(self):
        """The epochs as an astropy ``Time`` (in the segment's time system)."""
        if self._times is None:
            self._times = epochs_to_time(self.epochs, self.time_system,
                                         line=self.metadata.line_of("TIME_SYSTEM"),
                                         mission_epoch=self.mission_epoch)
        return self._times

    def _seconds_since(self, t0) -> np.ndarray:
        from ..satellites.frames import offline_iers

        with offline_iers():  # a UT1 file needs the installed IERS table, never a download
            return (self.times - t0).to_value("s")

    @property
    def states(self):
        """The states as :class:`~visviva.states.StateVectors` (GM of ``CENTER_NAME``); about the
        Earth in GCRS, TEME or ITRF they know their frame (``.frame``: ``"gcrs"``, ...)."""
        return self.wrap_states(self.r_km, self.v_km_s, self.gm_km3_s2, self.times)

    def states_in(self, frame: str):
        """The states rotated to a visviva frame (``"gcrs"``, ``"teme"`` or ``"itrs"``).

        Parameters
        ----------
        frame : {"gcrs", "teme", "itrs"}
            Target frame; the segment's ``REF_FRAME`` must map to one of them too.

        Returns
        -------
        StateVectors
            Positions (km) and velocities (km/s) in ``frame``, at :attr:`times`.

        Notes
        -----
        The rotation is astropy's (:func:`visviva.satellites.frames.transform_batch`), with the
        Earth-orientation data installed with astropy; ICRF/GCRF are the GCRS, EME2000 the GCRS
        rotated by the frame bias (:func:`~visviva.ccsds.timeframes.to_gcrs_axes`).
        """
        from ..satellites.frames import transform_batch
        from ..satellites.satellite_states import framed_states

        source = self.visviva_frame
        if source is None or frame not in ("gcrs", "teme", "itrs"):
            raise InvalidInputError(
                f"states_in: from REF_FRAME {self.frame} to {frame!r} is not supported; "
                "visviva rotates between 'gcrs' (EME2000/ICRF/GCRF), 'teme' and 'itrs' (ITRF)")
        if str(self.center).strip().upper() != "EARTH":
            # (the three are geocentric frames: about another centre the rotation is on the
            # wrong origin, the Earth's spin term v - w x r meaningless, and the result labelled
            # Earth-centred for everything downstream)
            raise InvalidInputError(
                f"states_in: CENTER_NAME = {self.center}, but 'gcrs', 'teme' and 'itrs' are "
                "Earth-centred frames; translate the states to the Earth's centre first (use "
                ".r_km and .v_km_s with an ephemeris of the centre)")
        if frame == source:
            return self.states
        from ..satellites.frames import offline_iers

        with offline_iers():  # a UT1 file needs the installed IERS table, never a download
            times = self.times.utc
        r, v = self.visviva_axes(self.r_km, self.v_km_s, self.times)  # (EME2000: frame bias)
        r, v = transform_batch(r[None], v[None], times, source, frame)
        return framed_states(r[0], v[0], self.gm_km3_s2, self.times, frame)

    @property
    def gm_km3_s2(self) -> float:
        """GM of ``CENTER_NAME``, km^3/s^2 (raises for a centre visviva does not know)."""
        body = center_body(self.center)
        if body is None:
            from .timeframes import barycentre_note

            raise InvalidInputError(
                f"CENTER_NAME = {self.center} is not a body visviva knows"
                f"{barycentre_note(self.center)}, so the states have no GM; use .r_km and "
                ".v_km_s, or a centre such as EARTH, MOON, SUN, MARS.")
        return body.gm_km3_s2

    @property
    def start(self):
        """``USEABLE_START_TIME`` (else ``START_TIME``) as a Time."""
        text = self.metadata.get("USEABLE_START_TIME") or self.metadata["START_TIME"]
        return epochs_to_time(text, self.time_system, mission_epoch=self.mission_epoch)

    @property
    def stop(self):
        """``USEABLE_STOP_TIME`` (else ``STOP_TIME``) as a Time."""
        text = self.metadata.get("USEABLE_STOP_TIME") or self.metadata["STOP_TIME"]
        return epochs_to_time(text, self.time_system, mission_epoch=self.mission_epoch)

    def span_problem(self, source: str = "<text>"):
        """What is wrong with the segment's spans, or None: ``STOP_TIME`` before
        ``START_TIME``, a useable span outside them or reversed (502.0-B-3, table 5-3), a state
        outside ``START_TIME .. STOP_TIME`` (to the microsecond).

        Parameters
        ----------
        source : str
            File name, for errors in the epochs themselves.

        Returns
        -------
        (str or int, str) or None
            The keyword (or the index of the state) at fault and the message.
        """
        meta = self.metadata
        t = self.times
        sec = (t - t[0]).to_value("s")

        def offset(key):
            return (epochs_to_time(meta[key], self.time_system, meta.line_of(key), source,
                                   self.mission_epoch) - t[0]).to_value("s")

        start, stop = offset("START_TIME"), offset("STOP_TIME")
        if stop < start:
            return "STOP_TIME", "STOP_TIME is before START_TIME"
        useable_start = offset("USEABLE_START_TIME") if "USEABLE_START_TIME" in meta else start
        useable_stop = offset("USEABLE_STOP_TIME") if "USEABLE_STOP_TIME" in meta else stop
        for key, bad in (("USEABLE_START_TIME", useable_start < start - 1e-6),
                         ("USEABLE_STOP_TIME", useable_stop > stop + 1e-6)):
            if bad:
                return key, (f"{key} = {meta[key]} lies outside START_TIME .. STOP_TIME "
                             f"({meta['START_TIME']} .. {meta['STOP_TIME']}); the useable span "
                             "is part of the segment's span")
        if useable_stop < useable_start:
            return "USEABLE_STOP_TIME", "USEABLE_STOP_TIME is before USEABLE_START_TIME"
        outside = (sec < start - 1e-6) | (sec > stop + 1e-6)
        if outside.any():
            k = int(np.flatnonzero(outside)[0])
            return k, (f"the epoch {self.epochs[k]} lies outside START_TIME .. STOP_TIME "
                       f"({meta['START_TIME']} .. {meta['STOP_TIME']})")
        return None

    def covered_seconds(self, t0) -> tuple[float, float]:
        """The span interpolation serves, in seconds of the file's scale since ``t0``: the
        useable span (``USEABLE_START_TIME`` .. ``USEABLE_STOP_TIME``, else ``START_TIME`` ..
        ``STOP_TIME``) cut to the states' own span, since nothing outside it is interpolated
        (a ``START_TIME`` before the first state would have the polynomial extrapolate).

        Parameters
        ----------
        t0 : astropy.time.Time
            The origin (in the segment's scale).

        Returns
        -------
        (float, float)
        """
        from ..satellites.frames import offline_iers

        times = self.times
        with offline_iers():  # a UT1 file needs the installed IERS table, never a download
            first = (times[0] - t0).to_value("s")
            last = (times[-1] - t0).to_value("s")
            lo, hi = ((x - t0).to_value("s") for x in (self.start, self.stop))
        return max(float(lo), float(first)), min(float(hi), float(last))

    def __len__(self) -> int:
        return len(self.epochs)

    def __repr__(self) -> str:
        return (f"<OEMSegment {self.metadata.get('OBJECT_NAME')!r} {self.frame}/{self.center} "
                f"{len(self)} states {self.epochs[0] if self.epochs else ''} .. "
                f"{self.epochs[-1] if self.epochs else ''}>")

    def check(self, where: str = "OEM segment") -> None:
        """Raise unless the arrays agree in length, are finite and the times increase.

        Parameters
        ----------
        where : str
            Which segment, for the message.
        """
        n = len(self.epochs)
        arrays = [("r_km", self.r_km), ("v_km_s", self.v_km_s), ("a_km_s2", self.a_km_s2)]
        for name, arr in arrays[:2] if self.a_km_s2 is None else arrays:
            if arr.shape != (n, 3):
                raise InvalidInputError(f"{where}: {name} has shape {arr.shape}, expected ({n}, 3)")
            if not np.isfinite(arr).all():
                raise InvalidInputError(f"{where}: {name} holds NaN or infinite values")
        if n == 0:
            raise InvalidInputError(f"{where} has no states")
        steps = np.diff(self._seconds_since(self.times[0]))
        if (steps <= 0).any():
            k = int(np.flatnonzero(steps <= 0)[0])
            raise InvalidInputError(f"{where}: the epochs must increase; {self.epochs[k + 1]} "
                                    f"follows {self.epochs[k]}")
        missing = [k.name for k in METADATA.keywords if k.mandatory and k.name not in self.metadata]
        if missing:  # (what the reader refuses, a writer does not write)
            raise InvalidInputError(f"{where}: the metadata lacks {', '.join(missing)}")
        from ..satellites.frames import offline_iers

        with offline_iers():
            problem = self.span_problem()
        if problem is not None:
            raise InvalidInputError(f"{where}: {problem[1]}")

    def _span_text(self) -> str:
        """The covered span in words, saying when the states end before the metadata's span."""
        from astropy import units as u

        t0 = self.times[0]
        lo, hi = self.covered_seconds(t0)
        text = f"{(t0 + lo * u.s).isot} .. {(t0 + hi * u.s).isot}, {self.time_system}"
        start, stop = self.start, self.stop
        if lo > (start - t0).to_value("s") + 1e-6 or hi < (stop - t0).to_value("s") - 1e-6:
            text += (f"; its metadata says {start.isot} .. {stop.isot}, but its states span "
                     f"only {self.epochs[0]} .. {self.epochs[-1]}, and visviva does not "
                     "extrapolate")
        return text

    def covariance(self, k: int) -> np.ndarray:
        """Covariance ``k`` (km, km/s) on the axes of the segment's states, as
        :attr:`visviva.ccsds.OPM.covariance` gives the OPM's.

        A ``COV_REF_FRAME`` naming an orbit-relative frame (``RTN``/``RSW``/``RIC``/``QSW``,
        ``TNW``, ``NTW``, ``VNB``, SANA's ``LVLH_ROTATING``, ``PQW_INERTIAL`` ...:
        :mod:`visviva.ccsds.orbit_frames`) is rotated to the axes of ``REF_FRAME`` with the
        segment's state at the covariance's epoch (the state there, else interpolated); the
        matrix as written is ``seg.covariances[k].matrix``.

        Parameters
        ----------
        k : int
            Index into :attr:`covariances`.

        Returns
        -------
        ndarray, shape (6, 6)

        Raises
        ------
        InvalidInputError
            A ``COV_REF_FRAME`` that is neither ``REF_FRAME`` nor a local frame, a local frame
            of states on Earth-fixed axes, axes the state does not define (``PQW_INERTIAL``
            of a circular orbit ...), or an epoch the states do not cover.
        """
        from .covariance import on_state_axes, sun_from

        cov = self.covariances[k]
        if cov.frame is None:  # (EME2000: rotated by the frame bias, as :attr:`states` are)
            return tf.to_gcrs_axes(self.frame, cov.matrix)[0]
        if cov.epoch in self.epochs:
            i = self.epochs.index(cov.epoch)
            r, v = self.r_km[i], self.v_km_s[i]
        else:
            t = epochs_to_time(cov.epoch, self.time_system, mission_epoch=self.mission_epoch)
            r, v = (a[0] for a in self.interpolate_arrays(t))
        where = f"covariance {k} (EPOCH = {cov.epoch}): COV_REF_FRAME = {cov.frame}"
        m = on_state_axes(cov.matrix, cov.frame, self.frame, self.visviva_frame, r, v, where,
                          f"seg.covariances[{k}].matrix", gm=lambda: self.gm_km3_s2,
                          sun=sun_from(lambda: epochs_to_time(
                              cov.epoch, self.time_system, mission_epoch=self.mission_epoch),
                              self.center, self.frame))
        return tf.to_gcrs_axes(self.frame, m)[0]

    def interpolate(self, t):
        """States at times ``t`` by the interpolation named in the segment's metadata.

        Parameters
        ----------
        t : astropy.time.Time
            Scalar or array of times within the segment's useable span.

        Returns
        -------
        StateVectors
            Positions (km) and velocities (km/s) in the segment's frame, shape of ``t``.

        Raises
        ------
        InvalidInputError
            A time outside the segment, an unsupported method, or too few states for the degree.
        """
        r, v = self.interpolate_arrays(t)
        return self.wrap_states(r.reshape(t.shape + (3,)), v.reshape(t.shape + (3,)),
                            self.gm_km3_s2, t)

    def interpolate_arrays(self, t):
        """Positions and velocities at ``t`` as plain arrays: what :meth:`interpolate` wraps.

        Parameters
        ----------
        t : astropy.time.Time
            Times within the segment's useable span (any shape).

        Returns
        -------
        r_km : ndarray, shape (M, 3)
            Positions (km) in the segment's frame, M = ``t.size`` (flattened).
        v_km_s : ndarray, shape (M, 3)
            Velocities (km/s).

        Raises
        ------
        InvalidInputError
            A time outside the segment, an unsupported method, or too few states for the degree.
        """
        from astropy.time import Time

        if not isinstance(t, Time):
            raise InvalidInputError(f"t must be an astropy Time, got {type(t).__name__}")
        from ..satellites.frames import offline_iers

        t0 = self.times[0]
        nodes = self._seconds_since(t0)
        # seconds of the file's own time scale: a query in another scale is converted first
        # (TDB - UTC differences in TDB would drift from the file's by up to 1e-7 s per hour)
        with offline_iers():  # a UT1 file needs the installed IERS table, never a download
            t = getattr(t, t0.scale)
            query = np.atleast_1d((t - t0).to_value("s")).ravel()
        lo, hi = self.covered_seconds(t0)
        tol = 1e-6  # s: epochs written to the microsecond
        outside = (query < lo - tol) | (query > hi + tol)
        if outside.any():
            bad = np.atleast_1d(t.ravel())[int(np.flatnonzero(outside)[0])]
            raise InvalidInputError(
                f"{bad.isot} lies outside the segment ({self._span_text()}); interpolate only "
                "within it.")
        method, degree = self.interpolation
        if method == "LINEAR":
            method, degree = "LAGRANGE", 1
        check_degree(method, degree, len(self), f"segment {self.metadata.get('OBJECT_NAME')!r}")
        if method == "LAGRANGE":
            out = lagrange(nodes, np.hstack([self.r_km, self.v_km_s]), query, degree)
            return out[:, :3], out[:, 3:]
        r, v = hermite(nodes, self.r_km, self.v_km_s, query, degree,
                       want_derivative=self.a_km_s2 is None)
        if self.a_km_s2 is not None:
            v, _ = hermite(nodes, self.v_km_s, self.a_km_s2, query, degree, False)
        return r, v


class Ephemeris:
    """An OEM: a header and one or more segments; interpolates across them.

    Parameters
    ----------
    segments : list of OEMSegment
        In time order.
    header : Record or dict, optional
        ``CCSDS_OEM_VERS``, ``CREATION_DATE``, ``ORIGINATOR`` and optional ``MESSAGE_ID``;
        written by :func:`~visviva.ccsds.oem_io.write_oem` (version 3.0, now, visviva) when
        absent.
    """

    def __init__(self, segments, header=None):
        if isinstance(segments, OEMSegment):
            segments = [segments]
        self.segments = list(segments)
        if not self.segments:
            raise InvalidInputError("an OEM needs at least one segment")
        for k, seg in enumerate(self.segments):
            if not isinstance(seg, OEMSegment):
                raise InvalidInputError(f"segments[{k}] is a {type(seg).__name__}, not an "
                                        "OEMSegment (build one with OEMSegment.from_states).")
        if header is None:
            from astropy.time import Time

            header = {"CCSDS_OEM_VERS": "3.0", "CREATION_DATE": Time.now().utc.isot,
                      "ORIGINATOR": "visviva"}
        self.header = header if isinstance(header, Record) else Record(values=dict(header))

    def __repr__(self) -> str:
        return f"<Ephemeris {len(self.segments)} segment(s), {sum(map(len, self.segments))} states>"

    @property
    def frame(self) -> str:
        """The ``REF_FRAME`` shared by the segments (raises when they differ)."""
        return self._shared("frame")

    @property
    def center(self) -> str:
        """The ``CENTER_NAME`` shared by the segments (raises when they differ)."""
        return self._shared("center")

    def _shared(self, attr):  # (upper case: a keyword; an OEM gives one object's states)
        values = {str(s.metadata.get(attr)).strip() if attr.isupper() else getattr(s, attr)
                  for s in self.segments}
        if len(values) > 1:
            raise InvalidInputError(f"the segments differ in {attr} ({sorted(values)}); use "
                                    "the segments one by one")
        return values.pop()

    def interpolate(self, t):
        """States at times ``t``, each from the segment that covers it.

        Where two segments meet (a manoeuvre), a time on the boundary takes the later segment;
        segments of different frames, centres or objects (``OBJECT_ID``) are refused.

        Parameters
        ----------
        t : astropy.time.Time
            Times within the span of the segments.

        Returns
        -------
        StateVectors
            Positions (km) and velocities (km/s) in the shared frame, shape of ``t``.
        """
        from astropy.time import Time

        if not isinstance(t, Time):
            raise InvalidInputError(f"t must be an astropy Time, got {type(t).__name__}")
        from ..satellites.frames import offline_iers

        frame, center, _ = self.frame, self.center, self._shared("OBJECT_ID")  # noqa: F841
        flat = t.reshape(-1) if t.ndim else t.reshape(1)
        which = np.full(flat.shape, -1)
        with offline_iers():  # a UT1 file needs the installed IERS table, never a download
            for k, seg in enumerate(self.segments):
                t0 = seg.times[0]
                lo, hi = seg.covered_seconds(t0)
                offset = (getattr(flat, t0.scale) - t0).to_value("s")
                inside = (offset >= lo - 1e-6) & (offset <= hi + 1e-6)
                which[inside] = k
        if (which < 0).any():
            bad = flat[int(np.flatnonzero(which < 0)[0])]
            spans = "; ".join(s._span_text() for s in self.segments)
            raise InvalidInputError(f"{bad.isot} is covered by no segment ({spans}).")
        r = np.empty(flat.shape + (3,))
        v = np.empty(flat.shape + (3,))
        for k in np.unique(which):
            sel = which == k
            r[sel], v[sel] = self.segments[k].interpolate_arrays(flat[sel])
        return self.segments[0].wrap_states(r.reshape(t.shape + (3,)),
                                            v.reshape(t.shape + (3,)), self.segments[0].gm_km3_s2, t)
