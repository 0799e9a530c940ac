"""CCSDS and TLE export: the SGP4 verification set through to_tle/to_omm, OEMs against sgp4.

* Every element set of the SGP4 verification set (``SGP4-VER.TLE`` in the installed ``sgp4``
  package) through ``Satellite.to_tle()`` and back through sgp4's own TLE parser: the record's
  elements must come back exactly.
* The same element sets through ``Satellite.to_omm()`` and sgp4's own OMM reader
  (``sgp4.omm.initialize``): elements within one unit in the last place, and the positions one
  day later within 5 mm of the TLE's (the OMM epoch is rounded to the microsecond: 0.5 us at
  up to 10 km/s).
* An OEM of SGP4 states (``visviva convert``'s sampling, 60 s) written and read back in KVN and
  XML: every number bit for bit; its Lagrange-7 interpolation between the samples against sgp4
  itself.
"""

from __future__ import annotations

import math

import numpy as np

from .base import Check

__all__ = ["checks"]

_ELEMENTS = ("no_kozai", "ecco", "inclo", "nodeo", "argpo", "mo", "bstar", "ndot", "nddot",
             "satnum", "jdsatepoch", "jdsatepochF")


def _ref() -> str:
    import sgp4

    return f"sgp4 {sgp4.__version__} (twoline2rv, omm.initialize; SGP4-VER.TLE)"


def _export() -> list[Check]:
    from sgp4 import omm
    from sgp4.api import WGS72, Satrec

    import visviva as vv

    from .checks_satellites import verification_set

    tle_mismatch = 0
    omm_ulps = 0.0
    dr_km = 0.0
    n = 0
    for line1, line2, *_ in verification_set():
        sat = vv.Satellite.from_tle(line1, line2, verify_checksum=False)
        ref = Satrec.twoline2rv(line1, line2, WGS72)
        if ref.error:  # sets that SGP4 cannot initialise have no record to export
            continue
        n += 1
        back = Satrec.twoline2rv(*sat.to_tle(), WGS72)
        tle_mismatch += sum(getattr(back, k) != getattr(ref, k) for k in _ELEMENTS)
        again = Satrec()
        fields = sat.to_omm()
        fields["OBJECT_ID"] = fields["OBJECT_ID"] or "UNKNOWN"
        omm.initialize(again, fields, WGS72)
        for key in _ELEMENTS[:9]:
            a, b = getattr(again, key), getattr(ref, key)
            omm_ulps = max(omm_ulps, abs(a - b) / math.ulp(b) if b else abs(a) / math.ulp(1.0))
        e1, r1, _ = ref.sgp4_tsince(1440.0)
        e2, r2, _ = again.sgp4(ref.jdsatepoch + 1.0, ref.jdsatepochF)
        if e1 == 0 and e2 == 0:
            dr_km = max(dr_km, float(np.abs(np.subtract(r1, r2)).max()))
    details = {"element_sets": n}
    return [
        Check("to_tle: SGP4 verification set back through sgp4's TLE parser",
              "elements that differ", float(tle_mismatch), 0.0, _ref(), dict(details, why=(
                  "to_tle writes the fields the TLE was read from: sgp4 must rebuild the same "
                  "record, every element bit for bit"))),
        Check("to_omm: SGP4 verification set back through sgp4's OMM reader",
              "max |d element| (ulp)", omm_ulps, 1.0, _ref(), dict(details, why=(
                  "the OMM carries the elements as decimal text in other units (deg, rev/day): "
                  "one conversion each way, so one rounding (1 ulp)"))),
        # the OMM epoch is rounded to the microsecond: 0.5 us at up to 10 km/s is 5 mm
        Check("to_omm: position one day after epoch, OMM record vs TLE record",
              "max |dr| (km)", dr_km, 5e-6, _ref(), dict(details, why=(
                  "the OMM's EPOCH is written to the microsecond: 0.5 us at up to 10 km/s is "
                  "5 mm"))),
    ]


def _oem() -> list[Check]:
    from astropy import units as u

    import visviva as vv
    from visviva.ccsds.oem import Ephemeris, OEMSegment

    from .checks_satellites import ISS

    sat = vv.Satellite.from_tle(*ISS)
    t = sat.epoch + np.arange(0, 6 * 3600 + 1, 60.0) * u.s
    teme = sat.teme(t)
    seg = OEMSegment.from_states(t, teme.r.to_value(u.km), teme.v.to_value(u.km / u.s),
                                 object_name="ISS", object_id="1998-067A", frame="TEME",
                                 interpolation="LAGRANGE", degree=7)
    eph = Ephemeris([seg])
    worst = 0.0
    for fmt in ("kvn", "xml"):
        back = vv.read_oem(vv.write_oem(eph, format=fmt)).segments[0]
        worst = max(worst, float(np.abs(back.r_km - seg.r_km).max()),
                    float(np.abs(back.v_km_s - seg.v_km_s).max()))
    tq = sat.epoch + np.arange(30.0, 6 * 3600 - 60, 37.0) * u.s
    got = seg.interpolate(tq)
    ref = sat.teme(tq)
    dr = float(np.abs(got.r.to_value(u.km) - ref.r.to_value(u.km)).max())
    details = {"states": len(seg), "queries": tq.size, "step_s": 60.0}
    return [
        Check("OEM of SGP4 states: KVN and XML read back", "max |d| (km, km/s)", worst, 0.0,
              _ref(), dict(details, why=(
                  "numbers are written with 17 significant digits (repr) and read by float(): "
                  "the same doubles, bit for bit"))),
        Check("OEM Lagrange-7 interpolation of 60 s SGP4 samples vs sgp4", "max |dr| (km)", dr,
              1e-7, _ref(), dict(details, why=(
                  "the Lagrange remainder r (omega h)^8 prod|x - x_i| / 8!: (omega h)^8 r = 3 mm "
                  "for the ISS at h = 60 s, times 0.013 at the ephemeris' ends (the 8 nodes on "
                  "one side) and 0.001 inside: 0.04 mm at most"))),
    ]


def checks(full: bool = False) -> list[Check]:
    """Run the CCSDS/TLE export comparisons live (a few seconds)."""
    return _export() + _oem()
