"""Conjunction assessment: screening, covariance tools, collision probability, plots.

* :func:`screen_conjunctions` finds the close approaches of a catalogue (SGP4) or of
  ephemerides (Cowell, state histories) over a window.
* :func:`collision_probability` computes Pc with Foster's 2-D integral (NASA CARA PcCircle
  convention), Chan's series, Hall's 3D-Nc method (CARA's Pc3D_Hall), a 3-D flux integral or
  Monte Carlo;
  :func:`max_collision_probability` is Alfano's maximum over the covariance size;
  :func:`collision_probabilities` is Foster's (or Chan's) Pc of many conjunctions at once.
* :mod:`visviva.conjunctions.covariance`: RTN <-> inertial, STM propagation, encounter plane.
"""

from __future__ import annotations

from .batch_probability import collision_probabilities
from .covariance import (
    EncounterPlane,
    combined_covariance,
    encounter_plane,
    inertial_to_rtn,
    propagate_covariance,
    rtn_to_inertial,
    state_transition_matrix,
)
from .probability import (
    CovarianceRepairWarning,
    MonteCarloResult,
    collision_probability,
    max_collision_probability,
    monte_carlo_probability,
)
from .screening import screen_conjunctions

__all__ = [
    "screen_conjunctions",
    "collision_probability",
    "collision_probabilities",
    "max_collision_probability",
    "monte_carlo_probability",
    "MonteCarloResult",
    "CovarianceRepairWarning",
    "EncounterPlane",
    "encounter_plane",
    "combined_covariance",
    "rtn_to_inertial",
    "inertial_to_rtn",
    "state_transition_matrix",
    "propagate_covariance",
]
