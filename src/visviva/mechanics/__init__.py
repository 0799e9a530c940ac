"""Classical mechanics done right: particles, constraints, energy, Lagrangian and Hamiltonian
mechanics, rigid bodies, oscillations and collisions.

Functions take plain numbers in any consistent units (SI in the examples) or astropy Quantities
(converted to SI through :mod:`visviva._units`); when any input is a Quantity the results are SI
Quantities. Submodules load on first use (PEP 562); sympy is imported only by the Lagrangian and
Hamiltonian tools. See docs/mechanics.md.
"""

from __future__ import annotations

from .. import _lazy

#: public name -> submodule of visviva.mechanics that defines it
_PUBLIC = {
    # oscillations
    "simple_harmonic": "oscillations",
    "damped_oscillator": "oscillations",
    "damped_oscillator_velocity": "oscillations",
    "damping_regime": "oscillations",
    "driven_response": "oscillations",
    "driven_oscillator": "oscillations",
    "amplitude_resonance_frequency": "oscillations",
    "normal_modes": "oscillations",
    "chain_matrices": "oscillations",
    "beats": "oscillations",
    # collisions
    "elastic_collision_1d": "collisions",
    "inelastic_collision_1d": "collisions",
    "perfectly_inelastic_collision_1d": "collisions",
    "explosive_separation_1d": "collisions",
    "collision_impulse": "collisions",
    "kinetic_energy": "collisions",
    # rigid bodies
    "inertia_tensor": "inertia",
    "inertia_solid_sphere": "inertia",
    "inertia_spherical_shell": "inertia",
    "inertia_solid_cylinder": "inertia",
    "inertia_thin_rod": "inertia",
    "inertia_box": "inertia",
    "parallel_axis": "inertia",
    "principal_axes": "inertia",
    "rotation_matrix_313": "rigid_body",
    "euler_angles_313": "rigid_body",
    "euler_equations": "rigid_body",
    "integrate_rigid_body": "rigid_body",
    "RigidBodyTrajectory": "rigid_body",
    "torque_free_precession_rate": "rigid_body",
    "heavy_top_torque": "rigid_body",
    "heavy_top_precession_rate": "rigid_body",
    # particles
    "solve_particles": "particles",
    "Trajectory": "particles",
    "uniform_gravity": "particles",
    "linear_drag": "particles",
    "quadratic_drag": "particles",
    "projectile_linear_drag": "particles",
    "projectile": "particles",
    # constraints
    "solve_constrained": "constraints",
    "ConstrainedTrajectory": "constraints",
    "pendulum_constraint": "constraints",
    # work and energy
    "UniformGravity": "energy",
    "Spring": "energy",
    "InverseSquare": "energy",
    "Coulomb": "energy",
    "InverseSquarePairs": "energy",
    "work": "energy",
    "cumulative_work": "energy",
    "work_along_curve": "energy",
    "conservation_report": "energy",
    # Lagrangian and Hamiltonian
    "LagrangianSystem": "lagrangian",
    "LagrangianTrajectory": "lagrangian",
    "pendulum": "lagrangian",
    "double_pendulum": "lagrangian",
    "spring_pendulum": "lagrangian",
    "central_potential": "lagrangian",
    "HamiltonianSystem": "hamiltonian",
    "legendre_transform": "hamiltonian",
    "leapfrog": "hamiltonian",
    "yoshida4": "hamiltonian",
    "symplectic_integrate": "hamiltonian",
    "SymplecticTrajectory": "hamiltonian",
    "phase_portrait": "hamiltonian",
    "poincare_section": "hamiltonian",
}

_SUBMODULES = {
    "oscillations",
    "collisions",
    "rigid_body",
    "inertia",
    "particles",
    "constraints",
    "energy",
    "lagrangian",
    "hamiltonian",
}

__all__ = sorted(_PUBLIC)


__getattr__, __dir__ = _lazy.lazy_attributes(globals(), _PUBLIC, _SUBMODULES, prefix=f"{__name__}.")
