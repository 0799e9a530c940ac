"""Status codes that compiled kernels return instead of raising.

Kernels never raise and never return NaN silently: each item gets an integer status, ``OK`` when
the result is valid. The public wrappers turn a non-zero status into a typed exception through the
single table in :mod:`visviva.errors`.
"""

OK = 0
#: An iterative solver did not reach machine precision within its bounded number of steps.
NO_CONVERGENCE = 1
#: Eccentricity outside the solver's domain (e < 0, or the wrong side of 1 for the solver).
BAD_ECCENTRICITY = 2
#: Zero angular momentum (radial / rectilinear motion) where elements need h != 0.
RADIAL_ORBIT = 3
#: A NaN or infinite value reached the kernel.
NON_FINITE = 4
#: A zero-length position vector (the body sits on the attractor).
ZERO_POSITION = 5
#: The gravitational parameter is not strictly positive.
BAD_GM = 6
#: The semi-latus rectum is not strictly positive.
BAD_SEMI_LATUS_RECTUM = 7
#: A true anomaly beyond the asymptote of a hyperbola (or at nu = pi on a parabola): unreachable.
UNREACHABLE_ANOMALY = 8
#: The requested state or time lies beyond a collision with the attractor (radial orbits).
HITS_ATTRACTOR = 9
#: Input outside the mathematical domain of the function (generic).
DOMAIN = 10
#: A close encounter between two bodies (N-body).
ENCOUNTER = 11
#: A body left the simulation's escape radius (N-body).
ESCAPE = 12
#: Two bodies collided and the collision mode asks to halt (N-body).
COLLISION = 13
#: The adaptive step size fell below its floor.
STEP_TOO_SMALL = 14
#: Modified equinoctial elements are singular here (i = pi with I = +1, i = 0 with I = -1).
EQUINOCTIAL_SINGULAR = 15
#: The result is too large for float64 (|x| > ~1.8e308) although every input is finite.
OVERFLOW = 16
