"""Physical constants as plain floats whose names carry their units.

Quantities for the solar-system bodies live in :mod:`visviva.bodies`; the numbers here are the raw
values kernels and tests use. Every value names its source.
"""

#: Astronomical unit in km (IAU 2012 Resolution B2, exact).
AU_KM = 149_597_870.7
#: Seconds in one day (exact).
DAY_S = 86_400.0
#: Seconds in one Julian year of 365.25 days (exact).
JULIAN_YEAR_S = 365.25 * DAY_S
#: Seconds in one Julian century.
JULIAN_CENTURY_S = 36_525.0 * DAY_S
#: Speed of light in km/s (exact, SI).
C_KM_S = 299_792.458
#: Newtonian constant of gravitation in km^3 / (kg s^2) (CODATA 2018: 6.67430e-11 m^3 kg^-1 s^-2).
G_KM3_KG_S2 = 6.67430e-20
#: Julian date of the J2000.0 epoch (TDB/TT).
J2000_JD = 2_451_545.0

#: GM values in km^3/s^2, JPL DE440 (NAIF gm_de440.tpc). Bodies, not system barycentres,
#: except Mercury and Venus (no moons).
GM_SUN_KM3_S2 = 132_712_440_041.27942
GM_MERCURY_KM3_S2 = 22_031.868551400003
GM_VENUS_KM3_S2 = 324_858.592
GM_EARTH_KM3_S2 = 398_600.43550702266
GM_MOON_KM3_S2 = 4_902.80011845755
GM_MARS_KM3_S2 = 42_828.37362069909
GM_JUPITER_KM3_S2 = 126_686_531.9003704
GM_SATURN_KM3_S2 = 37_931_206.23436167
GM_URANUS_KM3_S2 = 5_793_951.256527211
GM_NEPTUNE_KM3_S2 = 6_835_103.145462294
GM_PLUTO_KM3_S2 = 869.6138177608748

#: Equatorial radii in km: IAU WGCCRE 2015 (Archinal et al. 2018) and IAU 2015 B3 for the Sun.
R_SUN_KM = 695_700.0
R_MERCURY_KM = 2_440.53
R_VENUS_KM = 6_051.8
R_EARTH_KM = 6_378.1363  # EGM2008 reference radius, consistent with the zonal harmonics below
R_MOON_KM = 1_737.4
R_MARS_KM = 3_396.19
R_JUPITER_KM = 71_492.0
R_SATURN_KM = 60_268.0
R_URANUS_KM = 25_559.0
R_NEPTUNE_KM = 24_764.0
R_PLUTO_KM = 1_188.3

#: Earth's unnormalised zonal harmonics J2..J6 from EGM2008 (tide-free), J_n = -sqrt(2n+1) C̄_n0
#: with C̄_20 = -4.84165143790815e-4, C̄_30 = 9.57161207093473e-7, C̄_40 = 5.39965866638991e-7,
#: C̄_50 = 6.86702913736681e-8, C̄_60 = -1.49953927978527e-7 (Pavlis et al. 2012).
EARTH_J2 = 1.0826261738522227e-3
EARTH_J3 = -2.5324105185677225e-6
EARTH_J4 = -1.6198975999169731e-6
EARTH_J5 = -2.2775359073083618e-7
EARTH_J6 = 5.406665762838132e-7

#: Earth's rotation rate in rad/s (IERS 2010 nominal mean angular velocity).
EARTH_ROTATION_RAD_S = 7.292115e-5
#: Rate of the Earth rotation angle, rad per UT1 second: 2 pi x 1.00273781191135448 / 86400
#: (IERS Conventions 2010, eq. 5.15), the rotation of the ITRS about the celestial intermediate
#: pole; the nominal 7.292115e-5 above is 1.47e-12 rad/s less (0.024" a day).
EARTH_ROTATION_ANGLE_RATE_RAD_S = 2.0 * 3.141592653589793 * 1.00273781191135448 / 86400.0
#: WGS-84 flattening of the Earth.
EARTH_FLATTENING = 1.0 / 298.257223563
#: WGS-84 semi-major axis (equatorial radius of the ellipsoid of geodetic heights), km; the
#: gravity field's reference radius (EGM2008, 6378.1363 km) is 0.7 m shorter.
EARTH_ELLIPSOID_RADIUS_KM = 6378.137
