"""Satellite states and elements that know their frame: :class:`SatelliteStates`,
:class:`SatelliteElements`, :class:`SatelliteEquinoctialElements`.

One owner for the frame label: :func:`with_frame` attaches it (or drops it) on any two-body
container, and every method of the framed classes that builds a new container (indexing,
propagation, states <-> elements) passes its result through it.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._containers import FOREIGN_FRAME_ATTRIBUTE, carry_marks, refuse_pending, refuse_rotating
from ..elements import KeplerianElements
from ..equinoctial import ModifiedEquinoctialElements
from ..errors import (
    InvalidInputError,
)
from ..states import StateVectors

__all__ = ["SatelliteStates", "SatelliteElements", "SatelliteEquinoctialElements",
           "require_gcrs", "require_kepler_frame", "frame_of", "framed_states", "with_frame"]

#: visviva's Earth frames, the labels a framed container may carry
FRAMES = ("gcrs", "teme", "itrs")




def framed_states(r_km, v_km_s, gm_km3_s2, times, frame, *, foreign=None):
    """States that know their frame (:class:`SatelliteStates`) when ``frame`` is one of visviva's
    Earth frames (``"gcrs"``, ``"teme"``, ``"itrs"``), else plain :class:`~visviva.StateVectors`.

    Parameters
    ----------
    r_km, v_km_s : ndarray (..., 3)
        Positions (km) and velocities (km/s).
    gm_km3_s2 : float
        Central GM, km^3/s^2.
    times : astropy Time or None
        The states' times.
    frame : str or None
        Their frame; None (or another name) leaves them unlabelled.
    foreign : str, optional
        For unlabelled Earth-centred states: the name of their frame (``"TOD"``), which
        :func:`require_gcrs` names when it refuses them.

    Returns
    -------
    StateVectors
    """
    if frame not in FRAMES:
        plain = StateVectors._from_canonical(r_km, v_km_s, gm_km3_s2, times)
        if foreign is not None:
            setattr(plain, FOREIGN_FRAME_ATTRIBUTE, str(foreign))
        return plain
    obj = SatelliteStates._from_canonical(r_km, v_km_s, gm_km3_s2, times)
    obj.frame = frame
    return obj


def with_frame(obj, frame):
    """``obj`` labelled with ``frame``, sharing its arrays.

    Parameters
    ----------
    obj : StateVectors, KeplerianElements or ModifiedEquinoctialElements
        Any two-body container about the Earth (framed or plain).
    frame : str or None
        ``"gcrs"``, ``"teme"`` or ``"itrs"`` give the framed class (:class:`SatelliteStates`,
        :class:`SatelliteElements`, :class:`SatelliteEquinoctialElements`); None (or another
        name) gives the plain one.

    Returns
    -------
    StateVectors, KeplerianElements or ModifiedEquinoctialElements
        A new container with the same values (the same arrays, no copy).
    """
    plain = next((base for base in _FRAMED if isinstance(obj, base)), None)
    if plain is None:
        raise InvalidInputError(
            f"only state vectors and element sets carry a frame; got {type(obj).__name__}."
        )
    cls = _FRAMED[plain] if frame in FRAMES else plain
    new = cls.__new__(cls)
    new.__dict__.update(vars(obj))
    new.__dict__.pop("frame", None)
    if cls is not plain:
        new.frame = frame
    return new


#: J2000 is no CCSDS REF_FRAME (SANA lists EME2000) and means either of two frames 23 mas apart
_J2000_HINT = (
    " (J2000 is no CCSDS REF_FRAME, and tools mean two frames by it: if it is the mean equator "
    "and equinox of J2000, as in STK, GMAT and Orekit, write REF_FRAME = EME2000, which visviva "
    "turns to the GCRS by the 23 mas frame bias; if it is SPICE's J2000, which SPICE takes for "
    "the ICRF, write ICRF).")


def require_gcrs(states, what: str) -> None:
    """Refuse satellite states that say they are not in the GCRS (``what`` works there).

    Plain :class:`~visviva.StateVectors` carry no frame and pass (they are taken as GCRS),
    unless they were read as Earth-centred in a frame visviva cannot rotate (``REF_FRAME = TOD``).
    """
    foreign = getattr(states, FOREIGN_FRAME_ATTRIBUTE, None)
    if foreign is not None and str(foreign) in FRAMES:  # (sat.teme(t).to_state_vectors())
        raise InvalidInputError(
            f"{what} works in the GCRS, but these states are in {str(foreign).upper()} (they "
            "came from sat.teme(t).to_state_vectors()): use sat.gcrs(t), or rotate them with "
            "visviva.satellites.frames.teme_to_gcrs first.")
    if foreign is not None:
        raise InvalidInputError(
            f"{what} works in the GCRS, but these states are Earth-centred in REF_FRAME = "
            f"{foreign}, which visviva cannot rotate to the GCRS (it reads EME2000, GCRF, ICRF, "
            "TEME, ITRF): convert them to one of those first"
            + (_J2000_HINT if str(foreign).strip().upper() == "J2000" else ".")
        )
    frame = getattr(states, "frame", None)
    if frame is not None and frame != "gcrs":
        raise InvalidInputError(
            f"{what} works in the GCRS (where the Sun, the Moon and the Earth's pole are "
            f"placed), but these states are in {str(frame).upper()}: pass sat.gcrs(t) instead."
        )


def frame_of(states):
    """The frame that ``states`` say they are in, or None for plain states (taken as GCRS).

    Parameters
    ----------
    states : StateVectors or element set
        Framed (``.frame``: ``"gcrs"``, ``"teme"``, ``"itrs"``), marked with a frame visviva
        cannot rotate (an OEM's or OPM's ``REF_FRAME = TOD``: ``"TOD"``), or plain.

    Returns
    -------
    str or None
    """
    frame = getattr(states, "frame", None)
    if frame is not None:
        return str(frame)
    foreign = getattr(states, FOREIGN_FRAME_ATTRIBUTE, None)
    return None if foreign is None else str(foreign)


def require_kepler_frame(states, what: str) -> str:
    """Refuse states that two-body (Kepler) motion cannot carry; return the frame it runs in.

    Kepler motion holds in an inertial frame (GCRS, TEME, or one visviva cannot rotate such as
    TOD, which the result keeps), not in the rotating ITRS; states read from an OPM with
    manoeuvres are refused too (:func:`visviva._containers.refuse_pending`).

    Parameters
    ----------
    states : StateVectors
        The initial states (framed, marked or plain).
    what : str
        The function that propagates them, for the message.

    Returns
    -------
    str
        The frame of the states, lower case: ``.frame``, else the foreign frame's name
        (``"tod"``), else ``"gcrs"`` (plain states are taken as GCRS).

    Raises
    ------
    InvalidInputError
        ITRS states, or states carrying an OPM's manoeuvres.
    """
    frame = frame_of(states)
    if frame == "itrs":
        raise InvalidInputError(
            f"{what}: ITRS rotates with the Earth, so Kepler motion does not hold in it: use "
            "sat.gcrs(t) or sat.teme(t) instead."
        )
    refuse_pending(states, what)
    refuse_rotating(states, what)
    return (frame or "gcrs").lower()


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------
class _Framed:
    """What the framed containers share: ``.frame``, and indexing that keeps it."""

    frame = "teme"

    def _in_my_frame(self, result):
        """``result`` (a container computed from this one) labelled with this frame."""
        return with_frame(result, self.frame)

    def __getitem__(self, key):
        return self._in_my_frame(super().__getitem__(key))


class SatelliteStates(_Framed, StateVectors):
    """Positions and velocities of a satellite in one frame at an array of times.

    A :class:`visviva.StateVectors` about the Earth (``gm`` = ``vv.EARTH.gm``) that also knows
    its frame, so ``.to_elements()`` gives osculating elements in that frame
    (:class:`SatelliteElements`; TEME and GCRS only: in the rotating ITRS they mean nothing and
    are refused).

    Attributes
    ----------
    r : Quantity, shape (..., 3)
        Position, km.
    v : Quantity, shape (..., 3)
        Velocity, km/s (relative to the rotating Earth in ITRS).
    t : astropy Time, shape (...)
        The times (same as ``epoch``).
    frame : str
        ``"teme"``, ``"gcrs"`` or ``"itrs"``.
    """

    @classmethod
    def _wrap(cls, r_km, v_km_s, times, frame):
        from ..constants import GM_EARTH_KM3_S2

        obj = cls._from_canonical(r_km, v_km_s, np.float64(GM_EARTH_KM3_S2), times)
        obj.frame = frame
        return obj

    def _refuse_itrs(self, what: str) -> None:
        if self.frame == "itrs":
            raise InvalidInputError(
                f"ITRS rotates with the Earth, so {what}: use sat.gcrs(t) or sat.teme(t) instead."
            )

    def to_elements(self) -> SatelliteElements:
        """Osculating classical elements in this frame (TEME or GCRS).

        Returns
        -------
        SatelliteElements
            As :meth:`visviva.StateVectors.to_elements`, with ``.frame``; their ``.to_state()``
            gives satellite states in the same frame.

        Raises
        ------
        InvalidInputError
            The states are in the rotating ITRS, where osculating elements mean nothing.
        """
        self._refuse_itrs("osculating elements in it mean nothing")
        return self._in_my_frame(super().to_elements())

    def to_equinoctial(self, retrograde: bool = False) -> SatelliteEquinoctialElements:
        """Modified equinoctial elements in this frame (TEME or GCRS).

        Parameters
        ----------
        retrograde : bool
            As :meth:`visviva.StateVectors.to_equinoctial`.

        Returns
        -------
        SatelliteEquinoctialElements
            With ``.frame``, kept by ``.to_state()`` and ``.to_keplerian()``.

        Raises
        ------
        InvalidInputError
            The states are in the rotating ITRS.
        """
        self._refuse_itrs("osculating elements in it mean nothing")
        return self._in_my_frame(super().to_equinoctial(retrograde=retrograde))

    def propagate(self, dt):
        """States after two-body motion for a time ``dt``, in this frame.

        Parameters
        ----------
        dt : Quantity
            Time of flight (as :meth:`visviva.StateVectors.propagate`).

        Returns
        -------
        SatelliteStates
            In the same frame (TEME or GCRS).

        Raises
        ------
        InvalidInputError
            The states are in the rotating ITRS, where Kepler motion does not hold, or come
            from an OPM with manoeuvres (:meth:`visviva.ccsds.opm.OPM.propagate` applies them).
        """
        require_kepler_frame(self, "two-body propagation")
        return self._in_my_frame(super().propagate(dt))

    @property
    def t(self):
        """The times of the states (astropy Time)."""
        return self.epoch

    @property
    def altitude(self):
        """Height above the WGS-84 ellipsoid (Quantity, km; shape of the states).

        The geodetic height of :func:`visviva.satellites.frames.itrs_to_geodetic`, after a
        rotation to ITRS at :attr:`t` (astropy's matrices) when the states are in TEME or GCRS.
        """
        from .frames import altitude_km

        return altitude_km(self._r, self._v, self.epoch, self.frame) << u.km

    def to_state_vectors(self) -> StateVectors:
        """These states as a plain :class:`visviva.StateVectors` (TEME or GCRS only).

        Plain states are taken as GCRS; TEME ones keep their frame as a mark (:func:`frame_of`
        gives ``"teme"``), so that what works in the GCRS refuses them (:func:`require_gcrs`)
        and ``vv.fit_tle`` and the CCSDS writers take them as TEME (they were taken for GCRS
        before audit55: the TEME axes are 0.34 deg from the GCRS's in 2024, 40 km in LEO).
        """
        if self.frame == "itrs":
            raise InvalidInputError(
                "ITRS rotates with the Earth, so its velocities are not inertial; convert "
                "sat.gcrs(t) or sat.teme(t) instead."
            )
        plain = carry_marks(self, StateVectors._from_canonical(self._r, self._v, self._gm,
                                                               self.epoch))
        if self.frame != "gcrs":
            setattr(plain, FOREIGN_FRAME_ATTRIBUTE, self.frame)
        return plain

    def __repr__(self):
        return f"<SatelliteStates frame={self.frame!r} shape={self.shape}>"


class _FramedElements(_Framed):
    """Element sets that know their frame: their states (and indexing) keep it."""

    def to_state(self) -> SatelliteStates:
        """State vectors in the frame of these elements.

        Returns
        -------
        SatelliteStates
            As the plain element set's ``to_state()``, labelled with :attr:`frame`.
        """
        return self._in_my_frame(super().to_state())

    def __repr__(self):
        return f"{super().__repr__()} in {self.frame!r}"


class SatelliteElements(_FramedElements, KeplerianElements):
    """Osculating classical elements of satellite states, in their frame (TEME or GCRS).

    What :meth:`SatelliteStates.to_elements` returns: a :class:`visviva.KeplerianElements` that
    also knows its frame, so that ``.to_state()``, indexing, ``.to_equinoctial()`` and
    :func:`visviva.propagate_j2_secular` give results in the same frame, and what works in the
    GCRS only refuses TEME elements' states instead of taking them for GCRS.

    Attributes
    ----------
    frame : str
        ``"teme"`` or ``"gcrs"``.
    """


class SatelliteEquinoctialElements(_FramedElements, ModifiedEquinoctialElements):
    """Modified equinoctial elements of satellite states, in their frame (TEME or GCRS).

    What :meth:`SatelliteStates.to_equinoctial` returns: a
    :class:`visviva.ModifiedEquinoctialElements` whose ``.to_state()``, ``.to_keplerian()`` and
    indexing keep :attr:`frame`.

    Attributes
    ----------
    frame : str
        ``"teme"`` or ``"gcrs"``.
    """


#: plain container -> its framed subclass (what :func:`with_frame` chooses between)
_FRAMED = {
    StateVectors: SatelliteStates,
    KeplerianElements: SatelliteElements,
    ModifiedEquinoctialElements: SatelliteEquinoctialElements,
}
