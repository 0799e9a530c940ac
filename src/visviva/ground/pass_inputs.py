"""What a pass search says when it is given states or an ephemeris instead of element sets.

Passes are searched on SGP4 element sets (:mod:`visviva.ground.search`); the refusals of
:func:`visviva.ground.search.as_catalog` and ``GroundStation.passes`` share this advice.
"""

from __future__ import annotations


def ephemeris_hint(obj) -> str:
    """What to do where states or an ephemeris (``.r`` and ``.v``, or ``.segments``) are given
    to a pass search, which runs on SGP4 element sets; "" for anything else (audit46)."""
    if not (hasattr(obj, "segments") or (hasattr(obj, "r") and hasattr(obj, "v"))):
        return ""
    return (" Passes are searched on SGP4 element sets: fit one to the states with "
            "vv.fit_tle(states) (an OEM: vv.fit_tle(vv.read_oem(path)), or visviva fit-tle "
            "FILE), or sample station.look(states) for their look angles.")
