"""Skyfield set up like with like for the check modules: one timescale, one time conversion.

Skyfield's builtin timescale carries no polar motion, while astropy (so visviva) applies it
from the offline IERS table of ``astropy-iers-data``: :func:`timescale` installs that same
table into Skyfield (left out, the two differ by the polar motion itself: 1.6" and 14 m at the
ground). :func:`sky_time` keeps both parts of astropy's two-part Julian date;
``ts.from_astropy`` sums them into one float (a resolution of ~20 us in 2024: 0.15 m in LEO).
"""

from __future__ import annotations

__all__ = ["sky_time", "timescale"]


def timescale():
    """Skyfield's builtin timescale with astropy's offline polar motion (finals2000A.all)."""
    import astropy_iers_data
    from skyfield.api import load
    from skyfield.data import iers as sky_iers

    ts = load.timescale(builtin=True)
    with open(astropy_iers_data.IERS_A_FILE, "rb") as f:
        sky_iers.install_polar_motion_table(ts, sky_iers.parse_x_y_dut1_from_finals_all(f))
    return ts


def sky_time(ts, t):
    """Skyfield Time from an astropy Time, both parts of the TT Julian date kept."""
    tt = t.tt
    return ts.tt_jd(tt.jd1, tt.jd2)
