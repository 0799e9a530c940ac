"""Satellite states: :class:`SatelliteStates`, state vectors about the Earth that know their frame."""

from __future__ import annotations

import numpy as np
from astropy import units as u

from ..errors import (
    InvalidInputError,
)
from ..states import StateVectors

__all__ = ["SatelliteStates", "require_gcrs", "framed_states", "with_frame"]


def framed_states(r_km, v_km_s, gm_km3_s2, times, frame):
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

    Returns
    -------
    StateVectors
    """
    if frame not in ("gcrs", "teme", "itrs"):
        return StateVectors._from_canonical(r_km, v_km_s, gm_km3_s2, times)
    obj = SatelliteStates._from_canonical(r_km, v_km_s, gm_km3_s2, times)
    obj.frame = frame
    return obj


def with_frame(states, frame):
    """``states`` (any :class:`~visviva.StateVectors`) labelled with ``frame`` as in
    :func:`framed_states` (None leaves them plain)."""
    return framed_states(states.r.to_value(u.km), states.v.to_value(u.km / u.s),
                         states.gm.to_value(u.km**3 / u.s**2), states.epoch, frame)


def require_gcrs(states, what: str) -> None:
    """Refuse satellite states that say they are not in the GCRS (``what`` works there).

    Plain :class:`~visviva.StateVectors` carry no frame and pass (they are taken as GCRS).
    """
    frame = getattr(states, "frame", None)
    if frame is not None and frame != "gcrs":
        raise InvalidInputError(
            f"{what} works in the GCRS (where the Sun, the Moon and the Earth's pole are "
            f"placed), but these states are in {str(frame).upper()}: pass sat.gcrs(t) instead."
        )


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------
class SatelliteStates(StateVectors):
    """Positions and velocities of a satellite in one frame at an array of times.

    A :class:`visviva.StateVectors` about the Earth (``gm`` = ``vv.EARTH.gm``) that also knows
    its frame, so ``.to_elements()`` gives osculating elements in that frame (meaningful in the
    quasi-inertial TEME and GCRS, not in the rotating ITRS).

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

    frame = "teme"

    @classmethod
    def _wrap(cls, r_km, v_km_s, times, frame):
        from ..constants import GM_EARTH_KM3_S2

        obj = cls._from_canonical(r_km, v_km_s, np.float64(GM_EARTH_KM3_S2), times)
        obj.frame = frame
        return obj

    def _in_my_frame(self, states: StateVectors) -> SatelliteStates:
        """``states`` (a result computed from these) labelled with this frame."""
        return with_frame(states, self.frame)

    def __getitem__(self, key):
        return self._in_my_frame(super().__getitem__(key))

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
            The states are in the rotating ITRS, where Kepler motion does not hold.
        """
        if self.frame == "itrs":
            raise InvalidInputError(
                "ITRS rotates with the Earth, so Kepler motion does not hold in it: propagate "
                "sat.gcrs(t) or sat.teme(t) instead."
            )
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
        """These states as a plain :class:`visviva.StateVectors` (TEME or GCRS only)."""
        if self.frame == "itrs":
            raise InvalidInputError(
                "ITRS rotates with the Earth, so its velocities are not inertial; convert "
                "sat.gcrs(t) or sat.teme(t) instead."
            )
        return StateVectors._from_canonical(self._r, self._v, self._gm, self.epoch)

    def __repr__(self):
        return f"<SatelliteStates frame={self.frame!r} shape={self.shape}>"
