"""Central-force tools: vis-viva, energy, apsides, Kepler's laws, effective potential and Binet.

Two kinds of functions live here:

* **Kepler-problem formulas** (``vis_viva``, ``circular_speed``, ``escape_speed``,
  ``orbital_period``, ``mean_motion``, ``semi_major_axis_from_period``, ``apsides``,
  ``specific_energy``, ``specific_angular_momentum``, ``areal_velocity``): astropy Quantities in,
  Quantities out, broadcasting over any shape.
* **Any central force** (``effective_potential``, ``turning_points``, ``orbit_equation``): the
  potential V(r) or the force F(r) per unit mass is a Python callable. They work either with
  Quantities (then the callable receives and returns Quantities for ``effective_potential`` and
  ``turning_points``, and plain floats in km and km/s2 inside the ODE of ``orbit_equation``) or
  with plain numbers in any consistent units (e.g. G = M = 1 for teaching).

References
----------
.. [1] H. Goldstein, C. Poole, J. Safko, *Classical Mechanics*, 3rd ed., ch. 3 (the equivalent
   one-body problem, effective potential, Binet's equation, Bertrand's theorem).
.. [2] D. A. Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., sec. 1.3 and 2.3.
"""

from __future__ import annotations

from .any_force import (
    BinetOrbit,
    bertrand_apsidal_angle,
    effective_potential,
    kepler_potential,
    orbit_equation,
    power_law_force,
    turning_points,
)
from .kepler_problem import (
    apsides,
    areal_velocity,
    circular_speed,
    escape_speed,
    mean_motion,
    orbital_period,
    semi_major_axis_from_period,
    specific_angular_momentum,
    specific_energy,
    vis_viva,
)

__all__ = [
    "vis_viva",
    "circular_speed",
    "escape_speed",
    "orbital_period",
    "mean_motion",
    "semi_major_axis_from_period",
    "apsides",
    "specific_energy",
    "specific_angular_momentum",
    "areal_velocity",
    "kepler_potential",
    "power_law_force",
    "effective_potential",
    "turning_points",
    "orbit_equation",
    "BinetOrbit",
    "bertrand_apsidal_angle",
]
