"""The general-relativistic correction for :func:`visviva.propagate_cowell`: :class:`Relativity`.

>>> import visviva as vv
>>> vv.Relativity()
Relativity(earth, lense_thirring=True)
"""

from __future__ import annotations

from dataclasses import dataclass

from ..bodies import EARTH, Body
from ..core import force_block as fb
from ..errors import InvalidInputError
from .perturbations import Perturbation, require_body

__all__ = ["Relativity", "EARTH_ANGULAR_MOMENTUM_KM2_S"]

#: The Earth's angular momentum per unit mass, km^2/s (9.8e8 m^2/s; IERS Conventions 2010,
#: sec. 10.3), along its pole.
EARTH_ANGULAR_MOMENTUM_KM2_S = 980.0


@dataclass(frozen=True, repr=False)
class Relativity(Perturbation):
    """The post-Newtonian correction of the central body's gravity (IERS Conventions 2010,
    eq. 10.12, general relativity: PPN beta = gamma = 1), what GMAT's ``RelativisticCorrection``
    and Orekit's ``Relativity`` add.

    Parameters
    ----------
    body : Body or str
        The central body (its GM is the state's). Default ``vv.EARTH``.
    lense_thirring : bool
        Add the Lense-Thirring (frame-dragging) term of the Earth's rotation. Default True;
        only the Earth's angular momentum is known here, so give False for another body.

    Notes
    -----
    The Schwarzschild term ``GM / (c^2 r^3) [(4 GM / r - v^2) r + 4 (r . v) v]`` turns perigee
    forwards by ``6 pi GM / (c^2 a (1 - e^2))`` per revolution (1.2e-8 rad in LEO, about 3 m of
    along-track position after a day of a LEO orbit's 1.7e-8 m/s^2). The Lense-Thirring term
    ``2 GM / (c^2 r^3) [3 / r^2 (r x v)(r . J) + v x J]`` (about 2e-10 m/s^2 in LEO) takes the
    Earth's angular momentum per unit mass ``J`` = 9.8e8 m^2/s along the Earth's pole: for a
    GCRS state with an epoch the celestial intermediate pole of the run's table
    (:func:`visviva.satellites.perturbations.earth_pole_table`, shared with the zonal field and
    drag; 0.134 deg from the GCRS z axis in 2024, whose use before the eighteenth session was a
    2e-3 error of the term), without an epoch the frame's z axis. The de Sitter term (about 5e-11 m/s^2 in LEO) is left
    out. Both terms have their analytic partials in the state-transition matrix
    (:func:`visviva.core.relativity.add_relativity_partials`).

    References
    ----------
    G. Petit and B. Luzum (eds.), IERS Conventions (2010), IERS Technical Note 36, sec. 10.3;
    O. Montenbruck and E. Gill (2000), Satellite Orbits, sec. 3.7.3.
    """

    body: Body = EARTH
    lense_thirring: bool = True

    PARAMETERS = ("RELATIVITY_ON", "LENSE_THIRRING_J")

    @property
    def uses_pole(self) -> bool:
        """The Lense-Thirring spin lies along the Earth's pole (the force model's table)."""
        return self.lense_thirring

    def __post_init__(self):
        body = require_body(self.body, "Relativity")
        object.__setattr__(self, "body", body)
        if not isinstance(self.lense_thirring, bool):
            raise InvalidInputError(
                f"Relativity's lense_thirring is True or False; got {self.lense_thirring!r}."
            )
        if self.lense_thirring and body.name != EARTH.name:
            raise InvalidInputError(
                f"the Lense-Thirring term needs {body.name}'s angular momentum, which visviva "
                "knows for the Earth only: give Relativity(body, lense_thirring=False) for the "
                "Schwarzschild term alone."
            )

    @property
    def central_body(self) -> Body:
        return self.body

    def pack(self, model) -> None:
        model.force[fb.RELATIVITY_ON] = 1.0
        model.force[fb.LENSE_THIRRING_J] = (
            EARTH_ANGULAR_MOMENTUM_KM2_S if self.lense_thirring else 0.0
        )

    def __repr__(self):
        return f"Relativity({self.body.name}, lense_thirring={self.lense_thirring})"
