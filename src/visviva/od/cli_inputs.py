"""What ``visviva od`` reads from its command line: stations, sigmas, forces, the first guess.

Each parser turns one option's text into visviva objects or raises
:class:`~visviva.errors.InvalidInputError` with one line that names the option, what is wrong
and an example, so that the command exits 2 with that line (never a traceback).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import InvalidInputError

__all__ = ["parse_stations", "parse_sigmas", "parse_forces", "parse_estimate", "quantity",
           "read_tracking", "read_initial", "SIGMA_KINDS"]

#: --sigma key -> (observation kinds it sets, physical type, example)
SIGMA_KINDS = {
    "range": (("range",), "length", "range=5m"),
    "range_rate": (("range_rate",), "speed", "range_rate=1mm/s"),
    "doppler": (("range_rate",), "speed", "doppler=1mm/s"),
    "angle": (("azel", "radec"), "angle", "angle=20arcsec"),
    "azel": (("azel",), "angle", "azel=0.01deg"),
    "radec": (("radec",), "angle", "radec=1arcsec"),
}


def quantity(option: str, text: str, physical: str, example: str):
    """``text`` (a number with its unit, ``5m``, ``1 mm/s``) as a Quantity of ``physical`` type
    (``"length"``, ``"speed"``, ``"angle"``, ``"time"``, ``"frequency"``), finite and > 0."""
    from astropy import units as u

    try:
        q = u.Quantity(text.strip())
    except (TypeError, ValueError):
        raise InvalidInputError(f"{option}: {text!r} is not a number with a unit; write e.g. "
                                f"{example}") from None
    want = {"length": u.m, "speed": u.m / u.s, "angle": u.rad, "time": u.s,
            "frequency": u.Hz}[physical]
    if q.unit == u.dimensionless_unscaled:
        raise InvalidInputError(f"{option}: {text!r} has no unit (a plain number could be "
                                f"read in the wrong one); write e.g. {example}")
    if not q.unit.is_equivalent(want):
        raise InvalidInputError(f"{option}: {text!r} is not a {physical} (its unit is "
                                f"'{q.unit}'); write e.g. {example}")
    if not (q.isscalar and np.isfinite(q.value) and q.value > 0):
        raise InvalidInputError(f"{option}: {text!r} must be one finite value > 0; write e.g. "
                                f"{example}")
    return q


def parse_stations(specs):
    """``--station NAME=LAT,LON[,HEIGHT]`` (degrees, degrees east, metres) -> {name: station}."""
    from astropy import units as u

    from ..ground.station import GroundStation

    example = "--station GOLDSTONE=35.43,-116.89,1000"
    out = {}
    for spec in specs or ():
        name, eq, coords = spec.partition("=")
        name = name.strip()
        try:
            numbers = [float(c) for c in coords.split(",")]
        except ValueError:
            numbers = []
        if not eq or not name or len(numbers) not in (2, 3) or not np.all(np.isfinite(numbers)):
            raise InvalidInputError(
                f"--station {spec!r}: write NAME=LAT,LON[,HEIGHT] (geodetic latitude and "
                f"longitude in degrees, height in metres above WGS-84), e.g. {example}")
        if name in out:
            raise InvalidInputError(f"--station {name} is given twice; give each station once")
        lat, lon, height = (numbers + [0.0])[:3]
        try:
            out[name] = GroundStation(lat * u.deg, lon * u.deg, height * u.m, name=name)
        except ValueError as exc:  # (visviva's errors are ValueErrors too)
            raise InvalidInputError(f"--station {spec!r}: {exc}") from None
    return out


def parse_sigmas(specs):
    """``--sigma range=5m,range_rate=1mm/s,angle=20arcsec`` (repeatable) -> {kind: Quantity}."""
    out = {}
    for spec in specs or ():
        for item in filter(None, (s.strip() for s in spec.split(","))):
            key, eq, value = item.partition("=")
            key = key.strip().lower()
            if not eq or key not in SIGMA_KINDS:
                raise InvalidInputError(
                    f"--sigma {item!r}: write KIND=VALUE with KIND one of "
                    f"{', '.join(SIGMA_KINDS)}, e.g. --sigma range=5m,range_rate=1mm/s,"
                    "angle=20arcsec")
            kinds, physical, example = SIGMA_KINDS[key]
            q = quantity(f"--sigma {key}", value, physical, example)
            for kind in kinds:
                out[kind] = q
    return out


def parse_forces(specs):
    """``--force j2,zonal:6,drag:0.022,srp:0.01[:1.3],sun,moon,relativity`` -> list of
    Perturbation (``relativity``: :class:`~visviva.Relativity` of the Earth).

    ``drag:B`` is the ballistic coefficient Cd A / m in m^2/kg (exponential atmosphere),
    ``srp:A/m[:Cr]`` the area-to-mass ratio in m^2/kg and the reflectivity (default 1.3).
    """
    from astropy import units as u

    from ..bodies import EARTH, MOON, SUN
    from ..satellites.perturbations import (
        J2,
        AtmosphericDrag,
        SolarRadiationPressure,
        ThirdBody,
        Zonal,
    )
    from ..satellites.relativity import Relativity

    help_ = ("use j2, zonal:N (J2..JN), drag:B (Cd A/m, m^2/kg), srp:A/m[:Cr] (m^2/kg), sun, "
             "moon, relativity; e.g. --force zonal:6,sun,moon,drag:0.022")
    out, seen = [], set()
    for spec in specs or ():
        for item in filter(None, (s.strip().lower() for s in spec.split(","))):
            name, _, rest = item.partition(":")
            args = rest.split(":") if rest else []
            try:
                numbers = [float(a) for a in args]
            except ValueError:
                raise InvalidInputError(f"--force {item!r}: {args} are not numbers; {help_}") \
                    from None
            if name in seen or (name in ("j2", "zonal") and seen & {"j2", "zonal"}):
                raise InvalidInputError(f"--force {item!r}: that force is given twice")
            want = {"j2": (0, 0), "zonal": (1, 1), "drag": (1, 1), "srp": (1, 2), "sun": (0, 0),
                    "moon": (0, 0), "relativity": (0, 0)}.get(name)
            if want is None or not want[0] <= len(numbers) <= want[1]:
                raise InvalidInputError(f"--force {item!r} is not a force model: {help_}")
            if any(not (np.isfinite(x) and x > 0) for x in numbers):
                raise InvalidInputError(f"--force {item!r}: the values must be > 0; {help_}")
            seen.add(name)
            try:
                if name == "j2":
                    out.append(J2(EARTH))
                elif name == "zonal":
                    if numbers[0] != int(numbers[0]):
                        raise InvalidInputError(f"--force {item!r}: the degree is an integer")
                    out.append(Zonal(EARTH, int(numbers[0])))
                elif name == "drag":
                    out.append(AtmosphericDrag(numbers[0] * u.m**2 / u.kg))
                elif name == "srp":
                    out.append(SolarRadiationPressure(numbers[0] * u.m**2 / u.kg,
                                                      *(numbers[1:] or [1.3])))
                elif name == "relativity":
                    out.append(Relativity())
                else:
                    out.append(ThirdBody(SUN if name == "sun" else MOON))
            except InvalidInputError as exc:
                raise InvalidInputError(f"--force {item!r}: {exc}") from None
    return out


def parse_estimate(text, forces):
    """``--estimate drag[:SIGMA],srp[:SIGMA]`` -> (the list for ``estimate=``, the a priori
    sigmas for ``parameter_sigma=``), checked against the forces. A drag sigma is in m^2/kg
    (of B = Cd A / m), an SRP one is of Cr (dimensionless)."""
    from astropy import units as u

    if not text:
        return None, None
    kinds = {"drag": "AtmosphericDrag", "srp": "SolarRadiationPressure"}
    names, sigmas = [], {}
    for item in filter(None, (s.strip().lower() for s in text.split(","))):
        name, colon, value = item.partition(":")
        if name not in kinds:
            raise InvalidInputError(f"--estimate {item!r}: the coefficients that can be "
                                    "estimated are drag (B = Cd A/m) and srp (Cr), e.g. "
                                    "--estimate drag or --estimate drag:0.005,srp:0.2")
        if name in names:
            raise InvalidInputError(f"--estimate {text!r} names {name} twice")
        if not any(type(f).__name__ == kinds[name] for f in forces):
            raise InvalidInputError(f"--estimate {name} needs that force in the model, with its "
                                    f"starting value: add --force {name}:VALUE")
        names.append(name)
        if colon:
            try:
                sd = float(value)
            except ValueError:
                sd = float("nan")
            if not (np.isfinite(sd) and sd > 0):
                raise InvalidInputError(f"--estimate {item!r}: the a priori sigma must be a "
                                        "number > 0 (m^2/kg for drag, Cr for srp)")
            sigmas[name] = sd * u.m**2 / u.kg if name == "drag" else sd
    return names, (sigmas or None)


def parse_process_noise(text):
    """``--process-noise Q[,FRAME]`` -> (the densities (3,), km^2/s^3, the frame): Q one value
    for every axis or three joined by ``:`` (R:T:N), FRAME RTN (default), TNW, VNB or GCRS."""
    from .._covariance import frame_code

    example = "--process-noise 1e-12 or --process-noise 1e-12:1e-11:1e-12,RTN"
    values, _, frame = text.partition(",")
    frame = frame.strip().upper() or "RTN"
    try:
        q = np.array([float(v) for v in values.split(":")])
    except ValueError:
        q = np.array([np.nan])
    if q.size not in (1, 3) or not (np.all(np.isfinite(q)) and np.all(q >= 0) and q.any()):
        raise InvalidInputError(f"--process-noise {text!r}: the white-noise acceleration's "
                                "spectral density, km^2/s^3 (one number >= 0 for every axis, or "
                                f"three joined by ':'), not all zero; write e.g. {example}")
    try:
        frame_code(frame, "--process-noise")
    except InvalidInputError:
        raise InvalidInputError(f"--process-noise {text!r}: the frame must be RTN, TNW, VNB or "
                                f"GCRS; write e.g. {example}") from None
    return np.repeat(q, 3 // q.size), frame


def parse_parameter_noise(specs, estimate):
    """``--parameter-noise NAME:SIGMA,TAU`` (repeated) -> ``parameter_noise=`` of
    :func:`visviva.filter_orbit`: SIGMA the steady-state 1-sigma (m^2/kg for drag, Cr for srp),
    TAU the correlation time with its unit; NAME one of ``estimate``."""
    from astropy import units as u

    example = "--parameter-noise drag:0.002,3h"
    out = {}
    for text in specs or []:
        name, colon, rest = text.strip().lower().partition(":")
        sigma, comma, tau = rest.partition(",")
        if not (colon and comma):
            raise InvalidInputError(f"--parameter-noise {text!r}: write NAME:SIGMA,TAU, e.g. "
                                    f"{example} (B's steady-state sigma 0.002 m^2/kg, "
                                    "correlation time 3 hours)")
        if name not in (estimate or []):
            raise InvalidInputError(f"--parameter-noise {text!r}: {name!r} is not estimated; "
                                    "the noise goes on a coefficient of --estimate (drag or "
                                    "srp), e.g. --estimate drag:0.005 " + example)
        if name in out:
            raise InvalidInputError(f"--parameter-noise gives {name} twice")
        try:
            sd = float(sigma)
        except ValueError:
            sd = float("nan")
        if not (np.isfinite(sd) and sd >= 0):
            raise InvalidInputError(f"--parameter-noise {text!r}: SIGMA must be a number >= 0 "
                                    "(m^2/kg for drag, Cr for srp)")
        t = quantity("--parameter-noise", tau, "time", example)
        out[name] = (sd * u.m**2 / u.kg if name == "drag" else sd, t)
    return out or None


def parse_ionosphere(spec, frequency):
    """``--ionosphere vtec=TECU[,shell=KM]`` or ``klobuchar=A0,A1,A2,A3,B0,B1,B2,B3`` and
    ``--frequency 2.2GHz`` -> the ``ionosphere`` and ``frequency_hz`` arguments (None, None
    without ``--ionosphere``; the frequency None without ``--frequency``: the TDM's
    ``TRANSMIT_FREQ_n``/``RECEIVE_FREQ_n`` lines give it, else reading it is refused)."""
    example = "--ionosphere vtec=20 --frequency 2.2GHz"
    if spec is None:
        if frequency is not None:
            raise InvalidInputError("--frequency applies to the modelled ionosphere: add "
                                    f"--ionosphere, e.g. {example}")
        return None, None
    freq = None if frequency is None else quantity(
        "--frequency", frequency, "frequency", "--frequency 2.2GHz").to_value("Hz")
    name, _, rest = spec.partition("=")
    parts = [p.strip() for p in rest.split(",")] if rest else []
    try:
        if name == "vtec" and len(parts) in (1, 2):
            out = {"vtec_tecu": float(parts[0])}
            if len(parts) == 2:
                key, _, value = parts[1].partition("=")
                if key != "shell":
                    raise ValueError
                out["shell_km"] = quantity("--ionosphere", value, "length",
                                           "shell=350km").to_value("km")
            return out, freq
        if name == "klobuchar" and len(parts) == 8:
            values = [float(p) for p in parts]
            return {"klobuchar": (values[:4], values[4:])}, freq
    except ValueError:
        pass
    raise InvalidInputError(f"--ionosphere {spec!r}: write vtec=TECU[,shell=KM] (a vertical "
                            "TEC in TEC units on a thin shell, e.g. vtec=20,shell=350km) or "
                            "klobuchar=A0,A1,A2,A3,B0,B1,B2,B3 (the GPS broadcast coefficients)")


def read_tracking(paths, stations, sigmas, troposphere=False, media=None):
    """The observations of the TDM files ``paths`` as one table (their segments together);
    ``media`` the ``ionosphere``, ``frequency_hz``, ``range_seconds`` and ``ignore`` keywords, if
    any."""
    from pathlib import Path

    from .tracking_data import TDM, read_tdm

    tdms = []
    for path in paths:
        if not Path(path).is_file():
            raise InvalidInputError(f"{path}: no such file (the tracking data, a CCSDS TDM)")
        tdms.append(read_tdm(Path(path)))
    segments = [seg for tdm in tdms for seg in tdm.segments]
    for seg in segments:
        path = seg.path
        if path is None or not any(n in seg.participants for n in path):
            continue
        names = [seg.participants[n] for n in dict.fromkeys(path) if n in seg.participants]
        if len(names) > 1 and not any(n in stations for n in names):
            raise InvalidInputError(
                f"{seg.source}, line {seg.metadata.line_of('PATH')}: none of the participants "
                f"{', '.join(names)} is a --station; give the ground station's place, e.g. "
                f"--station {names[0]}=LAT,LON,HEIGHT_M")
    needed = {"RANGE": "range", "DOPPLER_INSTANTANEOUS": "range_rate"}
    for seg in segments:
        present = set(seg.keywords)
        angle = {"AZEL": "azel", "RADEC": "radec"}.get(seg.metadata.get("ANGLE_TYPE"))
        if angle is not None and present & {"ANGLE_1", "ANGLE_2"}:
            present.add(f"ANGLE_TYPE = {seg.metadata.get('ANGLE_TYPE')}")
            needed[f"ANGLE_TYPE = {seg.metadata.get('ANGLE_TYPE')}"] = angle
        for key, kind in needed.items():
            if key in present and kind not in sigmas:
                raise InvalidInputError(f"the tracking data hold {key}: give its sigma, e.g. "
                                        f"--sigma {SIGMA_KINDS[kind][2]}")
    if (media or {}).get("range_seconds") is not None:
        units = {str(seg.metadata.get("RANGE_UNITS", "km")) for seg in segments
                 if "RANGE" in seg.keywords}
        if "s" not in units:
            held = (f"their RANGE is in {', '.join(sorted(units))} (RANGE_UNITS)" if units
                    else "they hold no RANGE")
            raise InvalidInputError(f"--range-seconds reads RANGE in seconds (RANGE_UNITS = s), "
                                    f"but {held}; omit --range-seconds")
    tdm = TDM(tdms[0].header, segments, tdms[0].fmt)
    return tdm.to_observations(stations, sigmas, troposphere=troposphere, **(media or {})), tdm


def read_initial(path, first_time):
    """The first guess from ``--initial``: a dict with ``state``, ``covariance`` (km-based, or
    None), ``burns`` (for ``maneuvers=``, or None), ``maneuvers`` (the OPM's records, to write
    back), ``name`` and ``object_id`` (or None).

    An OPM gives its state (epoch: the OPM's), covariance and manoeuvres; an OEM its state
    interpolated at ``first_time`` (the first observation); a TLE/OMM its SGP4 state there,
    in the GCRS (from a file of several sets of the one object, the set nearest it).
    """
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise InvalidInputError(f"--initial {path}: no such file")
    head = p.read_bytes()[:4096].decode("utf-8", "replace").upper()
    if "CCSDS_OPM_VERS" in head or "<OPM" in head:
        from ..ccsds.opm import read_opm

        opm = read_opm(p)
        state = _gcrs(opm.state, path)
        return {"state": state, "covariance": _inertial_covariance(opm, state, path),
                "burns": opm.burns() if opm.maneuvers else None, "maneuvers": opm.maneuvers,
                "name": str(opm.metadata.get("OBJECT_NAME", "")) or None,
                "object_id": _object_id(opm.metadata)}
    if "CCSDS_OEM_VERS" in head or "<OEM" in head:
        from ..ccsds.oem_io import read_oem

        eph = read_oem(p)
        try:
            state = eph.interpolate(first_time)
        except ValueError as exc:
            raise InvalidInputError(f"--initial {path}: the ephemeris does not cover the first "
                                    f"observation ({first_time.utc.isot} UTC): {exc}") from None
        name = str(eph.segments[0].metadata.get("OBJECT_NAME", "")) or None
        return {"state": _gcrs(state, path), "name": name,
                "object_id": _object_id(eph.segments[0].metadata)}
    from ..satellites.catalog import read_catalog_file

    with warnings.catch_warnings():  # (a history repeats its number: the one set is taken)
        warnings.filterwarnings("ignore", ".*appears more than once", UserWarning)
        cat = read_catalog_file(p)
    if len(set(cat.satnums)) != 1:  # (a history of one object's sets is read: audit49)
        raise InvalidInputError(f"--initial {path} holds element sets of {len(set(cat.satnums))}"
                                " objects; give a file with the one object tracked")
    sat = min(cat, key=lambda s: abs((s.epoch - first_time).jd))  # the set nearest the data
    return {"state": sat.gcrs(first_time), "name": sat.name or None,
            "object_id": sat.to_omm().get("OBJECT_ID") or None}


def _object_id(metadata):
    """``OBJECT_ID`` of the first guess's message, carried to the outputs (audit46: they said
    UNKNOWN)."""
    text = str(metadata.get("OBJECT_ID", "") or "").strip()
    return text if text and text.upper() != "UNKNOWN" else None


def _gcrs(state, path):
    frame = getattr(state, "frame", None)
    if frame not in (None, "gcrs"):
        raise InvalidInputError(
            f"--initial {path}: the state is in {str(frame).upper()}; orbit determination "
            "starts from a GCRS (GCRF, EME2000, ICRF) state: convert it first "
            "(visviva convert)")
    from ..satellites.cowell import central_body

    body = central_body(float(np.ravel(state.gm.to_value("km3 / s2"))[0]), [])
    if body.name != "earth":  # a bad input (exit 2), not a failed fit (audit20)
        raise InvalidInputError(
            f"--initial {path}: the state is centred on the {body.name.capitalize()}; orbit "
            "determination from ground stations starts from a geocentric state "
            "(CENTER_NAME = EARTH)")
    return state


def _inertial_covariance(opm, state, path):
    """The OPM's covariance on the state's inertial axes (km-based): ``opm.covariance``, which
    rotates a local ``COV_REF_FRAME`` (RTN, TNW, VNB ...); None without one."""
    try:
        return opm.covariance
    except InvalidInputError as exc:
        raise InvalidInputError(f"--initial {path}: {exc}") from None
