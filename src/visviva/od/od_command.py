"""``visviva od TDM [TDM ...]``: the daily orbit determination run from the command line.

Tracking data (CCSDS TDM) and the stations' places in; a batch least-squares fit
(:func:`~visviva.fit_orbit`) or a Kalman filter (:func:`~visviva.filter_orbit`) from a first
guess (an OPM, an OEM, a TLE/OMM, or initial orbit determination from the data); out: a
summary on standard output, an OPM with the state and its covariance, an OEM ephemeris with
covariance blocks, and a CSV of the residuals. Exit codes: 0 done, 1 the fit failed (did not
converge, or the data do not determine the orbit), 2 bad arguments or unreadable input.
"""

from __future__ import annotations

import sys

import numpy as np

#: the residuals' units in the CSV report: kind -> (unit name, factor from km, km/s, rad)
_REPORT_UNITS = {"range": ("m", 1e3), "range_rate": ("m/s", 1e3),
                 "azel": ("arcsec", np.degrees(1.0) * 3600.0),
                 "radec": ("arcsec", np.degrees(1.0) * 3600.0), "position": ("m", 1e3)}


def add_parser(sub) -> None:
    """Add the ``od`` sub-command to an argparse sub-parser group.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The group.
    """
    p = sub.add_parser(
        "od", help="orbit determination: tracking data (TDM) in, an orbit with its covariance "
        "out (OPM, OEM, residuals)",
        description="Fit an orbit to the range, Doppler and angle data of CCSDS TDM files "
        "(batch least squares, or an extended/unscented Kalman filter with --filter), from a "
        "first guess (--initial OPM, OEM, TLE or OMM; without it, initial orbit determination "
        "from the first pass). Prints the estimate, its 1-sigma, the RMS of the normalised "
        "residuals and the rejected rows; writes an OPM (state and covariance), an OEM "
        "ephemeris with covariance blocks, and the residuals as CSV.",
        epilog="Example: visviva od passes.tdm --station KIRUNA=67.86,20.96,400 "
        "--sigma range=5m,range_rate=1mm/s,angle=0.01deg --force zonal:6,sun,moon "
        "--opm orbit.opm --oem orbit.oem --span 2d --step 60s")
    p.add_argument("tdm", nargs="+", metavar="TDM", help="tracking data files (CCSDS TDM, KVN "
                   "or XML); their segments are fitted together")
    p.add_argument("--station", action="append", metavar="NAME=LAT,LON[,HEIGHT]",
                   help="a ground station named as a PARTICIPANT of the TDM: geodetic latitude "
                   "and longitude (deg, east positive), height above WGS-84 (m, default 0); "
                   "repeat for each station")
    p.add_argument("--sigma", action="append", metavar="KIND=VALUE[,...]",
                   help="measurement noise per kind, with units: range=5m, range_rate=1mm/s "
                   "(or doppler=), angle=20arcsec (or azel=, radec=); required for each kind "
                   "in the data (a TDM carries no weights)")
    p.add_argument("--initial", default=None, metavar="FILE",
                   help="first guess: an OPM (its state, epoch, covariance and manoeuvres), an "
                   "OEM (its state at the first observation), or a TLE/OMM (its SGP4 state "
                   "there); default: initial orbit determination from the data")
    p.add_argument("--force", action="append", metavar="MODEL[,...]",
                   help="dynamics beyond two-body: j2, zonal:N, drag:B (Cd A/m in m^2/kg, "
                   "exponential atmosphere), srp:A/m[:Cr], sun, moon, relativity (default: two-body)")
    p.add_argument("--troposphere", action="store_true",
                   help="model the neutral atmosphere (range delay, refraction; standard "
                   "atmosphere at each station) for data not corrected for it")
    p.add_argument("--refraction", default=None, choices=("optical", "radio"),
                   help="with --troposphere: the refraction of AZEL angles, optical (default; "
                   "light) or radio (antennas: the bending of the air's radio refractivity)")
    p.add_argument("--ionosphere", default=None,
                   metavar="vtec=TECU[,shell=KM] | klobuchar=A0,..,A3,B0,..,B3",
                   help="model the ionosphere's delay in range and range-rate data not "
                   "corrected for it: a vertical TEC (TEC units) on a thin shell (350 km "
                   "default), or the GPS broadcast (Klobuchar) coefficients; at --frequency, or at the "
                   "TDM's TRANSMIT_FREQ/RECEIVE_FREQ lines")
    p.add_argument("--frequency", default=None, metavar="FREQ",
                   help="with --ionosphere: the signal's frequency with its unit, e.g. 2.2GHz "
                   "(for TDM segments without frequency lines; checked against them)")
    p.add_argument("--range-seconds", default=None, choices=("round_trip", "one_way"),
                   help="for TDM range in seconds (RANGE_UNITS = s, which CCSDS 503.0-B-2 does "
                   "not define further): round-trip light time (range c t / 2) or one-way "
                   "(c t); such data are refused without it")
    p.add_argument("--radec-reference", default=None, choices=("gcrs", "stars"),
                   help="what the TDM's RADEC angles are: the natural direction of the light in "
                   "the GCRS (gcrs, as radio or Orekit's AngularRaDec), or astrometry reduced "
                   "against catalogue stars (stars: optical telescopes; the Earth's orbital "
                   "motion moves it up to 20.5 arcsec). RADEC data without it are read as gcrs, "
                   "with a warning")
    p.add_argument("--ignore", default=None, metavar="KEYWORD[,...]",
                   help="TDM keywords to leave out: data (e.g. ANGLE_1,ANGLE_2 of an angle type "
                   "visviva does not model, one-way RANGE, RANGE_MODULUS) or corrections; the "
                   "messages that refuse a keyword name it")
    p.add_argument("--estimate", default=None, metavar="drag[:SIGMA],srp[:SIGMA]",
                   help="also estimate the drag coefficient B = Cd A/m and/or the SRP Cr, "
                   "starting from the --force values; SIGMA, their a priori 1-sigma (m^2/kg "
                   "for B; required with --filter), keeps a poorly observed one near its start")
    p.add_argument("--filter", default=None, choices=("ekf", "ukf"),
                   help="a sequential filter instead of batch least squares; the estimate is at "
                   "the last observation")
    p.add_argument("--process-noise", default=None, metavar="Q[,FRAME]",
                   help="with --filter: white-noise acceleration for the dynamics the model "
                   "leaves out, spectral density in km^2/s^3 (one value, or R:T:N), on the axes "
                   "of FRAME (RTN default, TNW, VNB, GCRS), e.g. 1e-12")
    p.add_argument("--parameter-noise", action="append", metavar="NAME:SIGMA,TAU",
                   help="with --filter: a Gauss-Markov process for an estimated coefficient "
                   "(drag or srp of --estimate): steady-state 1-sigma (m^2/kg for B, Cr) and "
                   "correlation time, e.g. drag:0.002,3h; repeat for each")
    p.add_argument("--smooth", action="store_true",
                   help="with --filter: run the RTS smoother; the estimate is then the smoothed "
                   "state where the filter starts (the first guess's epoch, or the first "
                   "observation when the guess is later)")
    p.add_argument("--apriori", default=None, metavar="SIGMA_R,SIGMA_V",
                   help="with --filter and a first guess without covariance: its 1-sigma per "
                   "axis (default 1km,10m/s)")
    p.add_argument("--no-apriori", action="store_true",
                   help="ignore the --initial OPM's covariance: the batch fit then uses the "
                   "data alone (by default it combines them with the OPM's state and "
                   "covariance), a filter starts from --apriori")
    p.add_argument("--name", default=None,
                   help="OBJECT_NAME of the outputs (default: the --initial file's, else the "
                   "TDM's spacecraft participant)")
    p.add_argument("--opm", default=None, metavar="OUT", help="write the estimate and its "
                   "covariance as an OPM (KVN; XML for a name ending in .xml)")
    p.add_argument("--oem", default=None, metavar="OUT", help="write an ephemeris from the "
                   "estimate's epoch over --span, with covariance blocks")
    p.add_argument("--span", default=None, metavar="DURATION",
                   help="length of the OEM (default 1d; e.g. 2d, 12h)")
    p.add_argument("--step", default=None, metavar="DURATION",
                   help="step of the OEM (default 60s)")
    p.add_argument("--residuals", default=None, metavar="OUT.csv",
                   help="write one row per observation: time, station, kind, residuals (m, m/s, "
                   "arcsec), sigma, normalised residuals, rejected")
    from ..cli_window import add_overwrite_argument

    add_overwrite_argument(p)


def run(args) -> int:
    """Run ``visviva od``; returns the exit code (0 on success, 1 on a failed fit, 2 for bad
    arguments, unreadable input or an output that cannot be written).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of :func:`add_parser`.
    """
    from ..ccsds.grammar import CCSDSFormatError
    from ..cli_window import check_outputs
    from ..errors import ConvergenceError, VisvivaError

    try:
        check_outputs([args.opm, args.oem, args.residuals], [*args.tdm, args.initial],
                      args.overwrite)
        setup = _setup(args)
    except (VisvivaError, CCSDSFormatError, ValueError, OSError) as exc:
        return _fail(str(exc), 2)
    try:
        result = _estimate(args, setup)
    except ConvergenceError as exc:
        return _fail(str(exc), 1)  # "the orbit fit did not converge ..." / "... diverged ..."
    except (VisvivaError, ValueError) as exc:
        return _fail(f"the orbit determination failed: {exc}", 1)
    print(_summary(setup, result))
    try:
        return _write(args, setup, result)
    except (VisvivaError, ValueError) as exc:
        return _fail(str(exc), 1)


def _fail(message: str, code: int) -> int:
    print("visviva od: " + _shell_advice(" ".join(message.split())), file=sys.stderr)
    return code


#: keywords of TDM.to_observations that the command line does not take
_PYTHON_ONLY = ("range_units_km=", "integrated_doppler=", "corrections_applied=", "quality=")


def _shell_advice(message: str) -> str:
    """The readers' advice in the command's words: ``ignore=('A', 'B')`` is ``--ignore A,B``
    (audit24: the shell user was told to pass Python keywords)."""
    import re

    def option(match):
        keys = re.findall(r"['\"]([A-Z0-9_]+)['\"]", match.group(1))
        return f"--ignore {','.join(keys)}"

    message = re.sub(r"ignore=\(([^)]*)\)", option, message)
    message = message.replace("(see radec_reference)", "(see --radec-reference)")
    message = message.replace("pass initial=vv.StateVectors(...) yourself",
                              "give a first guess with --initial FILE (an OPM, OEM, TLE or OMM)")
    if any(key in message for key in _PYTHON_ONLY):
        message += (" (that keyword is an option of vv.read_tdm(path).to_observations(...) in "
                    "Python; visviva od does not take it: convert the file, or fit in Python)")
    return message


def _setup(args) -> dict:
    """Everything read and checked before any fitting: observations, first guess, dynamics."""
    from ..errors import InvalidInputError
    from .cli_inputs import (
        parse_estimate,
        parse_forces,
        parse_ionosphere,
        parse_parameter_noise,
        parse_process_noise,
        parse_sigmas,
        parse_stations,
        quantity,
        read_initial,
        read_tracking,
    )

    if args.smooth and not args.filter:
        raise InvalidInputError("--smooth goes with --filter ekf|ukf (a batch fit needs no "
                                "smoother)")
    stations = parse_stations(args.station)
    if not stations:
        raise InvalidInputError("give the ground stations of the tracking data, e.g. "
                                "--station KIRUNA=67.86,20.96,400 (NAME as in the TDM's "
                                "PARTICIPANT_n; degrees, metres)")
    sigmas = parse_sigmas(args.sigma)
    forces = parse_forces(args.force)
    estimate, parameter_sigma = parse_estimate(args.estimate, forces)
    for option, given in (("--process-noise", args.process_noise),
                          ("--parameter-noise", args.parameter_noise)):
        if given and not args.filter:
            raise InvalidInputError(f"{option} goes with --filter ekf|ukf (the batch fit "
                                    "estimates constants and has no process noise)")
    noise = parse_process_noise(args.process_noise) if args.process_noise else (None, "RTN")
    parameter_noise = parse_parameter_noise(args.parameter_noise, estimate)
    span = step = None
    if not args.oem and (args.span is not None or args.step is not None):
        given = " and ".join(o for o, v in (("--span", args.span), ("--step", args.step)) if v)
        verb = "shape" if " and " in given else "shapes"
        raise InvalidInputError(f"{given} {verb} the ephemeris of --oem OUT; give --oem (without "
                                "it nothing reads them)")
    if args.oem:
        args.span, args.step = args.span or "1d", args.step or "60s"
        span = quantity("--span", args.span, "time", "--span 2d")
        step = quantity("--step", args.step, "time", "--step 60s")
        if step > span:
            raise InvalidInputError(f"--step {args.step} is longer than --span {args.span}")
        if (span / step).decompose().value > 200_000:
            raise InvalidInputError(f"--span {args.span} at --step {args.step} is more than "
                                    "200000 states; choose a longer step")
    if args.filter and estimate and set(estimate) - set(parameter_sigma or ()):
        raise InvalidInputError("with --filter, each estimated coefficient needs its a priori "
                                "sigma (the filter's initial uncertainty), e.g. --estimate "
                                "drag:0.005 (m^2/kg) or srp:0.2 (Cr)")
    apriori = None
    apriori_given = args.apriori is not None
    if apriori_given and not args.filter:
        raise InvalidInputError("--apriori is the starting uncertainty of --filter ekf|ukf; the "
                                "batch fit takes an a priori only from an --initial OPM's "
                                "covariance (without one it fits the data alone)")
    if args.filter:
        args.apriori = args.apriori or "1km,10m/s"
        parts = args.apriori.split(",")
        if len(parts) != 2:
            raise InvalidInputError(f"--apriori {args.apriori!r}: write SIGMA_R,SIGMA_V, e.g. "
                                    "--apriori 1km,10m/s")
        apriori = (quantity("--apriori", parts[0], "length", "--apriori 1km,10m/s"),
                   quantity("--apriori", parts[1], "speed", "--apriori 1km,10m/s"))
    if args.refraction is not None and not args.troposphere:
        raise InvalidInputError("--refraction applies to the modelled troposphere: add "
                                "--troposphere (data not corrected for the atmosphere)")
    troposphere = ({"refraction": args.refraction} if args.troposphere and args.refraction
                   else args.troposphere)
    iono, freq = parse_ionosphere(args.ionosphere, args.frequency)
    media = {"ionosphere": iono, "frequency_hz": freq} if iono is not None else {}
    if args.range_seconds is not None:
        media["range_seconds"] = args.range_seconds
    if args.ignore:
        media["ignore"] = tuple(k.strip().upper() for k in args.ignore.split(",") if k.strip())
    if args.radec_reference is not None:
        media["radec_reference"] = args.radec_reference
    obs, tdm = read_tracking(args.tdm, stations, sigmas, troposphere, media)
    if args.radec_reference is None and np.any(obs.kinds == "radec"):
        # audit59: the command had no way to say so, and fitted star-reduced astrometry as the
        # natural GCRS direction (a LEO fit from 2-arcsec data landed 80 m off, formal 4 m)
        import warnings

        from ..errors import TrackingDataWarning

        warnings.warn("the tracking data hold RADEC angles, read as the natural direction in "
                      "the GCRS (--radec-reference gcrs). Optical astrometry reduced against "
                      "catalogue stars differs by up to 20.5 arcsec (the Earth's orbital motion "
                      "times the light time): pass --radec-reference stars for such data, or "
                      "--radec-reference gcrs to say the default is meant", TrackingDataWarning,
                      stacklevel=2)
    guess = read_initial(args.initial, obs.times[0]) if args.initial else {}
    initial, covariance = guess.get("state"), guess.get("covariance")
    ignored = covariance is not None and args.no_apriori
    if ignored:
        covariance = None
    if covariance is not None and args.filter and apriori_given:
        raise InvalidInputError(f"--initial {args.initial} has a covariance, which the filter "
                                "starts from; --apriori is used only without one: pass "
                                "--no-apriori as well to start from --apriori instead")
    if covariance is not None and not args.filter and np.any(np.diag(covariance) == 0):
        raise InvalidInputError(f"--initial {args.initial}: its covariance has a zero variance, "
                                "which the batch fit cannot take as an a priori; pass "
                                "--no-apriori to fit the data alone")
    maneuvers, name = guess.get("burns"), guess.get("name")
    if name is None:
        craft = {n for seg in tdm.segments for n in seg.participants.values()} - set(stations)
        name = sorted(craft)[0] if len(craft) == 1 else "UNKNOWN"
    return {"obs": obs, "initial": initial, "covariance": covariance, "maneuvers": maneuvers,
            "opm_maneuvers": guess.get("maneuvers") or (),
            "forces": forces, "estimate": estimate, "parameter_sigma": parameter_sigma,
            "process_noise": noise, "parameter_noise": parameter_noise,
            "name": args.name or name, "object_id": guess.get("object_id") or "UNKNOWN",
            "span": span, "step": step, "apriori": apriori,
            "note": "its covariance ignored: --no-apriori" if ignored else None}


def _estimate(args, s) -> dict:
    """Run the fit or the filter; a dict with the estimate (state, covariance km-based), the
    residuals and what the summary reports."""
    from astropy import units as u

    obs = s["obs"]
    if not args.filter:
        from .batch import fit_orbit

        if s["covariance"] is not None:
            s["note"] = "combined with the data as an a priori; --no-apriori to fit the data alone"
        fit = fit_orbit(obs, s["initial"], s["forces"], maneuvers=s["maneuvers"],
                        estimate=s["estimate"], parameter_sigma=s["parameter_sigma"],
                        apriori_covariance=s["covariance"])
        return {"method": "batch least squares", "state": fit.state,
                "covariance": np.asarray(fit.covariance), "fit": fit,
                "residuals": fit.residuals, "normalized": fit.normalized_residuals,
                "rejected": fit.rejected, "rms": fit.rms, "rms_by_kind": fit.rms_by_kind,
                "iterations": fit.iterations, "parameters": fit.parameters,
                "parameter_sigma": fit.parameter_sigma, "perturbations": fit.perturbations,
                "maneuvers": fit.maneuvers}
    from .sequential import filter_orbit

    initial = s["initial"]
    if initial is None:
        from ..bodies import EARTH
        from .first_orbit import initial_orbit

        initial = initial_orbit(obs, EARTH)
    cov = s["covariance"]
    if cov is None:
        sr, sv = s["apriori"]
        cov = np.diag([sr.to_value(u.km) ** 2] * 3 + [sv.to_value(u.km / u.s) ** 2] * 3)
    if s["covariance"] is None:
        s["note"] = ", ".join(filter(None, [
            s.get("note"), f"a priori sigma {s['apriori'][0]}, {s['apriori'][1]} per axis"]))
    if np.any(obs.offsets_s(initial.epoch) < 0.0):  # a filter starts at or before the data
        initial, cov = _back_to(initial, cov, obs.times[0], s["forces"], s["maneuvers"])
        s["note"] = ", ".join(filter(None, [s.get("note"),
                                            "carried back to the first observation"]))
    res = filter_orbit(obs, initial, cov, s["forces"], maneuvers=s["maneuvers"],
                       smoother=args.smooth, method=args.filter, estimate=s["estimate"],
                       parameter_sigma=s["parameter_sigma"], process_noise=s["process_noise"][0],
                       process_noise_frame=s["process_noise"][1],
                       parameter_noise=s["parameter_noise"])
    if args.smooth:
        state, covariance = res.first_state, np.asarray(res.first_covariance)
    else:
        state, covariance = res.state, np.asarray(res.covariance)
    z = res.postfit_residuals
    zn = z / obs.sigmas[:, None]
    use = (np.arange(3)[None, :] < obs.dims[:, None]) & ~res.rejected[:, None]
    by_kind = {k: float(np.sqrt(np.mean(zn[(obs.kinds == k)[:, None] & use] ** 2)))
               for k in dict.fromkeys(obs.kinds) if np.any((obs.kinds == k)[:, None] & use)}
    last = {k: v[-1] for k, v in res.parameters.items()}
    return {"method": f"{args.filter.upper()}{' + RTS smoother' if args.smooth else ''}"
                      + res.noise_summary(),
            "state": state, "covariance": covariance, "fit": None, "residuals": z,
            "normalized": zn, "rejected": res.rejected,
            "rms": float(np.sqrt(np.mean(zn[use] ** 2))), "rms_by_kind": by_kind,
            "iterations": None, "parameters": last,
            "parameter_sigma": {k: v[-1] for k, v in res.parameter_sigma.items()},
            "perturbations": res.perturbations, "maneuvers": s["maneuvers"]}


def _back_to(state, cov, t, forces, maneuvers):
    """A first guess (state, covariance) after the first observation carried back to ``t``."""
    from ..satellites.covariance import propagate_covariance
    from ..states import StateVectors

    out = propagate_covariance(state, cov, t, forces, maneuvers=maneuvers)
    back = StateVectors(out.r.reshape(3), out.v.reshape(3), state.gm, epoch=t)
    return back, np.asarray(out.covariance).reshape(6, 6)


def _iso(t) -> str:
    """A time as ISO UTC to the millisecond."""
    t = t.utc.copy()
    t.precision = 3
    return t.isot


def _summary(s, res) -> str:
    """The lines printed on standard output."""
    from astropy import units as u

    obs = s["obs"]
    state = res["state"]
    counts = ", ".join(f"{k} {int(np.sum(obs.kinds == k))}" for k in dict.fromkeys(obs.kinds))
    names = sorted({st.name for st in obs.stations if st is not None})
    t0, t1 = _iso(obs.times[0]), _iso(obs.times[-1])
    sig = np.sqrt(np.clip(np.diag(res["covariance"]), 0.0, None)) * 1e3
    r = state.r.to_value(u.km).reshape(3)
    v = state.v.to_value(u.km / u.s).reshape(3)
    iters = f", {res['iterations']} iterations" if res["iterations"] is not None else ""
    rej = int(np.sum(res["rejected"]))
    by_kind = ", ".join(f"{k} {x:.3f}" for k, x in res["rms_by_kind"].items())
    lines = [
        f"object      {s['name']}",
        f"method      {res['method']}{iters}",
        f"data        {len(obs)} observations ({counts}) from {len(names)} station(s) "
        f"({', '.join(names)}), {t0} to {t1} UTC",
        f"first guess {_guess_text(s)}",
        f"RMS         {res['rms']:.3f} (normalised; {by_kind}), {rej} rejected",
        f"epoch       {_iso(state.epoch)} UTC",
        "position    " + " ".join(f"{x:16.6f}" for x in r) + " km (GCRF)",
        "velocity    " + " ".join(f"{x:16.9f}" for x in v) + " km/s",
        "sigma r     " + " ".join(f"{x:16.3f}" for x in sig[:3]) + " m",
        "sigma v     " + " ".join(f"{x:16.6f}" for x in sig[3:]) + " m/s",
    ]
    for k, value in res["parameters"].items():
        sd = res["parameter_sigma"].get(k)
        if k == "drag":
            lines.append(f"drag B      {u.Quantity(value).to_value(u.m**2 / u.kg):.6g} +- "
                         f"{u.Quantity(sd).to_value(u.m**2 / u.kg):.2g} m^2/kg (Cd A/m)")
        else:
            lines.append(f"srp Cr      {float(value):.6g} +- {float(sd):.2g}")
    return "\n".join(lines)


def _guess_text(s) -> str:
    if s["initial"] is None:
        text = "initial orbit determination from the data"
    else:
        text = f"{_iso(s['initial'].epoch)} UTC" + (
            " with covariance" if s["covariance"] is not None else "")
    return text + (f" ({s['note']})" if s.get("note") else "")


def _write(args, s, res) -> int:
    """Write the requested outputs; the exit code."""
    from ..cli_window import write_output

    if args.opm:
        code = write_output("od", args.opm, _opm_text(args.opm, s, res))
        if code:
            return code
    if args.oem:
        code = write_output("od", args.oem, _oem_text(args.oem, s, res))
        if code:
            return code
    if args.residuals:
        code = write_output("od", args.residuals, _residual_csv(s["obs"], res))
        if code:
            return code
    return 0


def _fmt(path) -> str:
    return "xml" if str(path).lower().endswith(".xml") else "kvn"


def _opm_text(path, s, res) -> str:
    """The estimate as an OPM: the state and its covariance (km, km/s: the OPM's units)."""
    from ..ccsds.opm import OPM, write_opm

    opm = OPM.from_state(res["state"], object_name=s["name"], object_id=s["object_id"],
                         frame="GCRF", covariance=res["covariance"], maneuvers=s["opm_maneuvers"])
    opm.sections["header"].comments.append(
        f"visviva od: {res['method']}, RMS {res['rms']:.3f}, {len(s['obs'])} observations")
    return write_opm(opm, format=_fmt(path))


def _oem_text(path, s, res) -> str:
    """An ephemeris from the estimate's epoch over --span, with a covariance at each state."""
    from ..ccsds.oem import OEMSegment
    from ..ccsds.oem_io import write_oem
    from ..satellites.covariance import propagate_covariance

    n = int(np.floor((s["span"] / s["step"]).decompose().value + 1e-9))
    times = res["state"].epoch + np.arange(n + 1) * s["step"]
    if res["fit"] is not None:
        out = res["fit"].propagate(times)
    else:
        out = propagate_covariance(res["state"], res["covariance"], times,
                                   res["perturbations"], maneuvers=res["maneuvers"] or None)
    r = np.reshape(out.r.to_value("km"), (-1, 3))
    v = np.reshape(out.v.to_value("km/s"), (-1, 3))
    seg = OEMSegment.from_states(times, r, v, object_name=s["name"], object_id=s["object_id"],
                                 frame="GCRF",
                                 covariance=np.reshape(np.asarray(out.covariance), (-1, 6, 6)))
    return write_oem(seg, format=_fmt(path))


def _residual_csv(obs, res) -> str:
    """One line per observation: residuals in m, m/s or arcsec."""
    lines = ["time_utc,station,kind,residual_1,residual_2,unit,sigma,normalized_1,"
             "normalized_2,rejected"]
    times = obs.times.utc.isot
    for i, kind in enumerate(obs.kinds):
        unit, f = _REPORT_UNITS[str(kind)]
        d = int(obs.dims[i])
        z = [f"{res['residuals'][i, k] * f:.6g}" if k < d else "" for k in range(2)]
        zn = [f"{res['normalized'][i, k]:.4f}" if k < d else "" for k in range(2)]
        station = obs.stations[i].name if obs.stations[i] is not None else ""
        lines.append(f"{times[i]},{station},{kind},{z[0]},{z[1]},{unit},"
                     f"{obs.sigmas[i] * f:.6g},{zn[0]},{zn[1]},"
                     f"{'yes' if res['rejected'][i] else 'no'}")
    return "\n".join(lines) + "\n"
