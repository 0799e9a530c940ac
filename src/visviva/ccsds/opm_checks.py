"""Checks of an OPM as read that compare its sections: the Keplerian ``GM`` against the centre's
(an OMM's mean-element ``GM`` too, which warns: SGP4 does not use it), and the osculating Keplerian elements against the state vector (CCSDS 502.0-B-3, 3.2.4: the
elements are an optional second description of the same state, about the same ``REF_FRAME``).
"""

from __future__ import annotations

import math

from .grammar import CCSDSFormatError

__all__ = ["gm_misfit", "check_gm", "warn_omm_gm", "check_keplerian"]

#: relative difference above which an OPM's GM is not the centre's (the published values of a
#: body's GM differ by < 1e-6: Earth 398600.4415 (EGM-96) / 398600.4418 (WGS-84); a GM in
#: m**3/s**2 is 1e9 times the right one, and opm.state would take it as the GM)
GM_TOLERANCE = 1e-2
#: relative distance (of |r|, |v|) above which the Keplerian elements and the state vector
#: describe different states (elements written to 1e-4 deg and 1e-4 km stay below 1e-5)
KEPLERIAN_TOLERANCE = 1e-3


def gm_misfit(record, center) -> str:
    """Why the ``GM`` of ``record`` is not that of ``center`` (more than 1 % from the GM of the
    body ``CENTER_NAME`` names, when visviva knows it), or ``""``."""
    from .timeframes import center_body

    if record is None or "GM" not in record:
        return ""
    body = center_body(str(center))
    if body is None:
        return ""
    gm, known = float(record["GM"]), body.gm_km3_s2
    if abs(gm / known - 1.0) <= GM_TOLERANCE:
        return ""
    return (f"GM = {record['GM']!r} km**3/s**2 is {gm / known:.6g} times the GM of CENTER_NAME = "
            f"{str(center).strip()} ({known!r} km**3/s**2); GM is in km**3/s**2 (a value in "
            "m**3/s**2 is 1e9 times too large)")


def check_gm(sections, name: str) -> None:
    """Refuse a Keplerian ``GM`` more than 1 % from that of ``CENTER_NAME`` (when visviva
    knows the body), naming its line: ``opm.gm`` and ``opm.state`` use the message's GM."""
    kep = sections.get("keplerian_elements")
    why = gm_misfit(kep, sections["metadata"]["CENTER_NAME"])
    if why:
        raise CCSDSFormatError(f"{why}, and opm.state would orbit with it: correct it",
                               line=kep.line_of("GM"), source=name)


def warn_omm_gm(sections, name: str) -> None:
    """Warn, naming its line, when an OMM's ``GM`` is more than 1 % from that of ``CENTER_NAME``:
    SGP4 does not use it (its WGS-72 GM is built in), but a GM 1e9 times the Earth's says the
    message was written in other units than it states, its other values too, perhaps."""
    import warnings

    mean = sections.get("mean_elements")
    why = gm_misfit(mean, sections["metadata"]["CENTER_NAME"])
    if why:
        warnings.warn(f"{name}, line {mean.line_of('GM')}: {why}. SGP4 does not use it "
                      "(omm['GM'] is kept as written), but check the message's units and correct "
                      "GM.", UserWarning, stacklevel=3)


def _kepler_state(a, e, inc, raan, argp, anomaly, mean, gm):
    """Position and velocity (km, km/s) of osculating elements (angles in rad), or None."""
    from ..core.elements import coe_to_rv
    from ..core.kepler import mean_to_true_anomaly
    from ..core.status import OK

    nu = anomaly
    if mean:
        nu, status = mean_to_true_anomaly(anomaly, e)
        if status != OK:
            return None
    *rv, status = coe_to_rv(a * (1.0 - e * e), e, inc, raan, argp, nu, gm)
    return (rv[:3], rv[3:]) if status == OK else None


def check_keplerian(sections, name: str) -> None:
    """Warn when the osculating Keplerian elements do not describe the state vector (by more
    than 0.1 % of its |r| or |v|), saying how far apart they are and whether swapping
    TRUE_ANOMALY and MEAN_ANOMALY would reconcile them. ``opm.state`` is the state vector's."""
    import warnings

    kep = sections.get("keplerian_elements")
    if kep is None:
        return
    sv = sections["state_vector"]
    r = [float(sv[k]) for k in ("X", "Y", "Z")]
    v = [float(sv[k]) for k in ("X_DOT", "Y_DOT", "Z_DOT")]
    mean = "MEAN_ANOMALY" in kep
    angles = [math.radians(float(kep[k])) for k in (
        "INCLINATION", "RA_OF_ASC_NODE", "ARG_OF_PERICENTER",
        "MEAN_ANOMALY" if mean else "TRUE_ANOMALY")]
    a, e, gm = float(kep["SEMI_MAJOR_AXIS"]), float(kep["ECCENTRICITY"]), float(kep["GM"])

    def misfit(as_mean):
        state = _kepler_state(a, e, *angles, as_mean, gm)
        if state is None:
            return math.inf, math.inf
        return math.dist(state[0], r), math.dist(state[1], v)

    dr, dv = misfit(mean)
    r_norm, v_norm = math.hypot(*r), math.hypot(*v)
    if dr <= KEPLERIAN_TOLERANCE * r_norm and dv <= KEPLERIAN_TOLERANCE * v_norm:
        return
    which = "MEAN_ANOMALY" if mean else "TRUE_ANOMALY"
    other = "TRUE_ANOMALY" if mean else "MEAN_ANOMALY"
    dr_swap, dv_swap = misfit(not mean)
    hint = (f"; read as {other}, the {which} would agree (it is written as the wrong anomaly)"
            if dr_swap <= KEPLERIAN_TOLERANCE * r_norm
            and dv_swap <= KEPLERIAN_TOLERANCE * v_norm else
            "; check the elements' units (km, deg), their REF_FRAME, the anomaly and GM")
    where = "cannot be placed on an orbit" if math.isinf(dr) else (
        f"place the object {dr:.6g} km and {dv:.6g} km/s from the state vector "
        f"(|r| = {r_norm:.6g} km, |v| = {v_norm:.6g} km/s)")
    warnings.warn(
        f"{name}, line {kep.line}: the osculating Keplerian elements (with GM = {gm!r}) {where}: "
        "they do not describe the state vector's orbit, and opm.state is the state vector's"
        f"{hint}.", UserWarning, stacklevel=3)
