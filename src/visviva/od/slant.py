"""The line of sight from a ground station to the satellite, for the media models.

The troposphere (:mod:`visviva.od.troposphere`) and the ionosphere
(:mod:`visviva.od.ionosphere`) both delay the signal by an amount that depends on where the
satellite is in the station's sky; this module gives them the azimuth and the elevation, their
partials with respect to the satellite's GCRS position and their rates along the pass (the
station's east-north-up axes turning with the Earth, ``d e_i / dt = omega x e_i``), once.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..constants import EARTH_ROTATION_RAD_S
from .measurements import angles

__all__ = ["Sight", "line_of_sight"]


class Sight(NamedTuple):
    """The station-to-satellite geometry of N rows.

    Attributes
    ----------
    rho : ndarray (N, 3)
        Satellite minus station, GCRS, km.
    rng : ndarray (N,)
        ``|rho|``, km.
    az, el : ndarray (N,)
        Azimuth (from north through east, [0, 2 pi)) and geometric elevation, rad.
    d_dr : ndarray (N, 2, 3)
        ``d(az, el) / d r`` of the satellite's GCRS position, rad/km.
    rate : ndarray (N, 2)
        ``d(az, el) / dt`` along the pass (satellite and station moving), rad/s.
    """

    rho: np.ndarray
    rng: np.ndarray
    az: np.ndarray
    el: np.ndarray
    d_dr: np.ndarray
    rate: np.ndarray


def line_of_sight(y, site_r, site_v, enu):
    """The :class:`Sight` of states ``y`` (N, 6; km, km/s) from stations at GCRS ``site_r``,
    ``site_v`` (N, 3) with east-north-up rows ``enu`` (N, 3, 3) in GCRS axes."""
    rho = y[:, :3] - site_r
    rhod = y[:, 3:] - site_v
    local = np.einsum("nij,nj->ni", enu, rho)  # (e, n, u)
    # azimuth from north through east: atan2(e, n), the longitude of (n, e, u)
    az, el, d = angles(local[:, [1, 0, 2]])
    d_local = d[:, :, [1, 0, 2]]
    omega = np.array([0.0, 0.0, EARTH_ROTATION_RAD_S])
    turning = np.cross(omega, enu)  # each axis turns with the Earth
    local_rate = np.einsum("nij,nj->ni", enu, rhod) + np.einsum("nij,nj->ni", turning, rho)
    return Sight(rho, np.linalg.norm(rho, axis=-1), az, el,
                 np.einsum("nij,njk->nik", d_local, enu),
                 np.einsum("nij,nj->ni", d_local, local_rate))
