"""Force-model inputs given the other way round (audit42)."""

from __future__ import annotations

import pytest
from astropy import units as u

import visviva as vv


@pytest.mark.parametrize("make, value, reciprocal", [
    (lambda q: vv.AtmosphericDrag(q), 50 * u.kg / u.m**2, "ballistic_coefficient=0.02 "),
    (lambda q: vv.AtmosphericDrag(q), 50 * u.g / u.cm**2, "ballistic_coefficient=0.002 "),
    (lambda q: vv.SolarRadiationPressure(q), 100 * u.kg / u.m**2, "area_to_mass=0.01 "),
])
def test_a_mass_over_an_area_is_refused_with_its_reciprocal(make, value, reciprocal):
    # the ballistic coefficient m / (Cd A) of Vallado and of the US convention (kg/m^2) was
    # refused by astropy's "cannot be converted to area_per_mass" alone
    with pytest.raises(vv.InvalidInputError, match=f"mass over an area .*{reciprocal}"):
        make(value)
    assert make((1 / value).to(u.m**2 / u.kg)) is not None
