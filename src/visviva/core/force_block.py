"""The layout of the Cowell force parameter block: one name per slot, used by both sides.

:func:`visviva.core.perturbations.cowell_rhs` (and the event functions of
:mod:`visviva.core.cowell`) read a flat float64 array ``force`` of :data:`FORCE_SIZE` values; the
perturbation classes of :mod:`visviva.satellites.perturbations` write it (each its own slots,
:meth:`~visviva.satellites.perturbations.Perturbation.pack`). The indices below are the only
place the layout is written down; kernels and classes use the names, never bare numbers. Flags
are 0.0 / 1.0. Module-level integers are compile-time constants for numba.

:data:`LAYOUT` lists every slot as ``(name, first index, size, unit, meaning)``; a test checks
that the slots tile the block and that each has exactly one writer (a perturbation class or the
force model's shared slots).
"""

from __future__ import annotations

__all__ = [
    "FORCE_SIZE",
    "LAYOUT",
    "GM",
    "RADIUS",
    "ZONAL_DEGREE",
    "DRAG_ON",
    "BALLISTIC",
    "ROTATION_RATE",
    "FLATTENING",
    "SRP_ON",
    "SRP_COEFFICIENT",
    "SHADOW_MODEL",
    "SUN_RADIUS",
    "AU",
    "SUN_ROW",
    "N_THIRD_BODIES",
    "EPH_T0",
    "EPH_STEP",
    "EPH_N",
    "HARMONICS_DEGREE",
    "FRAME_MATRIX",
    "DENSITY_MODEL",
    "DENSITY_GRID",
    "DENSITY_GRID_SIZES",
    "THRUST_ON",
    "THRUST_ACCEL",
    "THRUST_MASS_RATE",
    "THRUST_FRAME",
    "THRUST_DIRECTION",
    "DENSITY_BAND",
    "RELATIVITY_ON",
    "LENSE_THIRRING_J",
    "POLE",
    "ELLIPSOID_RADIUS",
    "TIME_DEPENDENT",
    "with_time_origin",
]

#: GM of the central body, km^3/s^2.
GM = 0
#: Reference (equatorial) radius of the central body, km.
RADIUS = 1
#: Highest zonal degree n_max (0: no zonal terms); ``zonal[n]`` holds J_n.
ZONAL_DEGREE = 2
#: Drag on/off.
DRAG_ON = 3
#: Ballistic coefficient Cd A / m, km^2/kg.
BALLISTIC = 4
#: Rotation rate of the central body, rad/s: about its pole (:data:`POLE`) for the co-rotating
#: atmosphere, about the body-fixed z axis for the spherical-harmonic field.
ROTATION_RATE = 5
#: Flattening f of the central body (geodetic altitude to first order in f).
FLATTENING = 6
#: Solar radiation pressure on/off.
SRP_ON = 7
#: SRP coefficient P_sun(1 AU) Cr A / m, km/s^2.
SRP_COEFFICIENT = 8
#: Shadow model: 0 none, 1 cylindrical, 2 conical (penumbra fraction).
SHADOW_MODEL = 9
#: Radius of the Sun, km.
SUN_RADIUS = 10
#: Astronomical unit, km.
AU = 11
#: Row of the Sun in the ephemeris tables (-1: none).
SUN_ROW = 12
#: Number of tabulated third bodies whose attraction is added.
N_THIRD_BODIES = 13
#: Ephemeris grid start, s from the propagation epoch.
EPH_T0 = 14
#: Ephemeris grid step, s.
EPH_STEP = 15
#: Number of ephemeris grid points.
EPH_N = 16
#: Degree N of the full spherical-harmonic field (0: none).
HARMONICS_DEGREE = 17
#: First of 9 slots: the 3x3 matrix A (row-major) of the body-fixed frame at t = 0 after the
#: pole's own motion: r_bf = A R3(w t) C(p(t)) r, C(p) taking the pole of :data:`POLE` to z
#: (:func:`visviva.core.geodetic.body_fixed_matrix`; the body turns about its pole at
#: :data:`ROTATION_RATE`).
FRAME_MATRIX = 18
#: Density model: 0 exponential table, 1 gridded log-density (NRLMSIS tabulated at the epoch).
DENSITY_MODEL = 27
#: First of 6 slots: first altitude km, altitude step km, first latitude rad, latitude step rad,
#: first solar hour angle rad, hour-angle step rad.
DENSITY_GRID = 28
#: First of 3 slots: grid sizes (altitudes, latitudes, hour angles).
DENSITY_GRID_SIZES = 34
#: Thrust of a finite burn on/off (on only over the burn's segment of a run).
THRUST_ON = 37
#: Thrust acceleration F / m at t = 0 (the burn's start), km/s^2.
THRUST_ACCEL = 38
#: Mass flow over the mass at t = 0, mdot / m0, 1/s: a(t) = THRUST_ACCEL / (1 - rate t).
THRUST_MASS_RATE = 39
#: Frame of the thrust direction (:mod:`visviva.core.local_frames`: 0 inertial, 1 RTN, 2 TNW,
#: 3 VNB).
THRUST_FRAME = 40
#: First of 3 slots: the unit thrust direction in that frame.
THRUST_DIRECTION = 41
#: The exponential table's band held during a step, plus one (0: the band of the altitude);
#: written 0 by the drag class, set only in the integrators' copies of the block
#: (:mod:`visviva.core.drag_bands`).
DENSITY_BAND = 44
#: The post-Newtonian (Schwarzschild) term of the central body on/off
#: (:mod:`visviva.core.relativity`).
RELATIVITY_ON = 45
#: The central body's angular momentum per unit mass along its pole (:data:`POLE`), km^2/s, for
#: the Lense-Thirring term (0: none).
LENSE_THIRRING_J = 46
#: First of 4 slots: the table of the central body's pole (the axis of its zonal harmonics,
#: of its co-rotating atmosphere, of its geodetic altitude and of its Lense-Thirring spin) in
#: the propagation frame, kept in the block itself after its :data:`FORCE_SIZE` values: time of
#: its first knot (s from t = 0), knot step (s), number of knots (0: the frame's z axis), index
#: of the first knot's x in the block (knots hold x, y of the unit vector; z = sqrt(1 - x^2 -
#: y^2); :func:`visviva.core.geodetic.body_pole`).
POLE = 47
#: Equatorial radius of the central body's ellipsoid of geodetic heights, km (WGS-84's for the
#: Earth, 0.7 m longer than :data:`RADIUS`, EGM2008's reference radius; the body's radius
#: otherwise): the altitude of drag and of altitude events (:mod:`visviva.core.geodetic`).
ELLIPSOID_RADIUS = 51
#: Length of the block's fixed slots (the pole's table, when there is one, follows them).
FORCE_SIZE = 52
#: Slots that depend on where t = 0 is (see :func:`with_time_origin`).
TIME_DEPENDENT = ("EPH_T0", "FRAME_MATRIX", "POLE")

#: ``(name, first index, size, unit, meaning)`` of every slot, in index order.
LAYOUT = (
    ("GM", GM, 1, "km3/s2", "GM of the central body"),
    ("RADIUS", RADIUS, 1, "km", "reference (equatorial) radius of the central body"),
    ("ZONAL_DEGREE", ZONAL_DEGREE, 1, "", "highest zonal degree (0: none)"),
    ("DRAG_ON", DRAG_ON, 1, "flag", "drag on/off"),
    ("BALLISTIC", BALLISTIC, 1, "km2/kg", "ballistic coefficient Cd A / m"),
    ("ROTATION_RATE", ROTATION_RATE, 1, "rad/s", "rotation rate of the central body"),
    ("FLATTENING", FLATTENING, 1, "", "flattening of the central body"),
    ("SRP_ON", SRP_ON, 1, "flag", "solar radiation pressure on/off"),
    ("SRP_COEFFICIENT", SRP_COEFFICIENT, 1, "km/s2", "P_sun(1 AU) Cr A / m"),
    ("SHADOW_MODEL", SHADOW_MODEL, 1, "", "0 none, 1 cylindrical, 2 conical"),
    ("SUN_RADIUS", SUN_RADIUS, 1, "km", "radius of the Sun"),
    ("AU", AU, 1, "km", "astronomical unit"),
    ("SUN_ROW", SUN_ROW, 1, "", "row of the Sun in the ephemeris tables (-1: none)"),
    ("N_THIRD_BODIES", N_THIRD_BODIES, 1, "", "number of attracting tabulated bodies"),
    ("EPH_T0", EPH_T0, 1, "s", "ephemeris grid start from the epoch"),
    ("EPH_STEP", EPH_STEP, 1, "s", "ephemeris grid step"),
    ("EPH_N", EPH_N, 1, "", "number of ephemeris grid points"),
    ("HARMONICS_DEGREE", HARMONICS_DEGREE, 1, "", "degree of the spherical-harmonic field"),
    ("FRAME_MATRIX", FRAME_MATRIX, 9, "", "body-fixed frame at t = 0 about the pole of date"),
    ("DENSITY_MODEL", DENSITY_MODEL, 1, "", "0 exponential table, 1 NRLMSIS grid"),
    ("DENSITY_GRID", DENSITY_GRID, 6, "km, rad", "grid starts and steps (altitude, latitude, "
     "hour angle)"),
    ("DENSITY_GRID_SIZES", DENSITY_GRID_SIZES, 3, "", "grid sizes (altitude, latitude, "
     "hour angle)"),
    ("THRUST_ON", THRUST_ON, 1, "flag", "finite-burn thrust on/off"),
    ("THRUST_ACCEL", THRUST_ACCEL, 1, "km/s2", "thrust acceleration F / m at t = 0"),
    ("THRUST_MASS_RATE", THRUST_MASS_RATE, 1, "1/s", "mass flow over the mass at t = 0"),
    ("THRUST_FRAME", THRUST_FRAME, 1, "", "0 inertial, 1 RTN, 2 TNW, 3 VNB"),
    ("THRUST_DIRECTION", THRUST_DIRECTION, 3, "", "unit thrust direction in that frame"),
    ("DENSITY_BAND", DENSITY_BAND, 1, "", "exponential band held in a step + 1 (0: none)"),
    ("RELATIVITY_ON", RELATIVITY_ON, 1, "flag", "post-Newtonian Schwarzschild term on/off"),
    ("LENSE_THIRRING_J", LENSE_THIRRING_J, 1, "km2/s",
     "angular momentum per unit mass of the central body along z (Lense-Thirring; 0: none)"),
    ("POLE", POLE, 4, "s, s", "the body's pole, a table after the block's slots: first "
     "knot's time, step, number of knots (0: the frame's z axis), index"),
    ("ELLIPSOID_RADIUS", ELLIPSOID_RADIUS, 1, "km", "equatorial radius of the ellipsoid of "
     "geodetic heights"),
)


def with_time_origin(force, t0_s: float):
    """A copy of the block for a run whose t = 0 lies ``t0_s`` after the block's t = 0.

    Parameters
    ----------
    force : ndarray (FORCE_SIZE + 2 K,)
        The block (and its pole's table of K knots).
    t0_s : float
        The new origin, s after the old one.

    Returns
    -------
    ndarray (FORCE_SIZE,)
        The ephemeris grid's and the pole table's starts moved by ``-t0_s`` and the
        body-fixed frame matrix at t = 0 turned by the body's rotation over ``t0_s``
        (r_bf = A Rz(w (t' + t0)) C r = [A Rz(w t0)] Rz(w t') C r), the only slots that depend
        on the origin (:data:`TIME_DEPENDENT`).
    """
    import math

    import numpy as np

    out = force.copy()
    out[EPH_T0] = force[EPH_T0] - t0_s
    th = force[ROTATION_RATE] * t0_s
    c, s = math.cos(th), math.sin(th)
    rz = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    m = force[FRAME_MATRIX:FRAME_MATRIX + 9].reshape(3, 3)
    out[FRAME_MATRIX:FRAME_MATRIX + 9] = (m @ rz).ravel()
    if force[POLE + 2] > 0.0:
        out[POLE] = force[POLE] - t0_s
    return out
