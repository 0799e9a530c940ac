"""Drag and SRP coefficients as parameters of the variational equations.

Two force-model coefficients can be estimated or considered (:func:`visviva.fit_orbit`'s
``estimate=``/``consider=``, :func:`visviva.propagate_covariance`'s ``consider=``):

* ``"drag"``: the ballistic coefficient B = Cd A / m of the :class:`~visviva.AtmosphericDrag`,
  m^2/kg (Cd and A / m enter the acceleration only as their product, so the data determine B;
  Cd = B / (A / m) for a known area-to-mass ratio);
* ``"srp"``: the reflectivity Cr of the :class:`~visviva.SolarRadiationPressure` (its
  ``area_to_mass`` held), dimensionless.

Both accelerations are linear in their coefficient, so their partials are the accelerations of
a unit coefficient (:func:`visviva.core.force_partials.parameter_accelerations`); the
sensitivities d y(t) / d p are integrated with the STM
(:meth:`visviva.satellites.variational.Dynamics.propagate`, ``parameters=True``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core import force_block as fb
from ..errors import ConvergenceError, InvalidInputError

__all__ = ["NAMES", "Coefficient", "coefficients", "partials", "estimated_perturbations"]

#: the parameters, in the order of their columns (``Dynamics.parameter_partials``)
NAMES = ("drag", "srp")


@dataclasses.dataclass
class Coefficient:
    """One coefficient of a fit: its force (``index`` into the perturbations), its value (B in
    m^2/kg or Cr), the factor from d y / d (force-block slot) to d y / d value, its a priori
    (estimated) or consider sigma (None: no a priori) and its a priori value."""

    name: str
    index: int
    value: float
    factor: float
    sigma: float | None
    prior: float

    @property
    def column(self) -> int:
        return NAMES.index(self.name)

    @property
    def slot(self) -> int:
        """Its force-block slot (which flies ``factor`` times the value)."""
        return fb.BALLISTIC if self.name == "drag" else fb.SRP_COEFFICIENT

    def write(self, dyn, value):
        """Fly ``value`` in the dynamics ``dyn`` (its force block's slot)."""
        dyn.model.force[self.slot] = self.factor * value


def _names(arg, what):
    if arg is None:
        return []
    names = [arg] if isinstance(arg, str) else list(arg)
    for n in names:
        if n not in NAMES:
            raise InvalidInputError(
                f"{what}: {n!r} is not a parameter; the parameters are {NAMES} (drag: the "
                "AtmosphericDrag's ballistic coefficient, srp: the SolarRadiationPressure's "
                "reflectivity Cr).")
    if len(set(names)) != len(names):
        raise InvalidInputError(f"{what} names a parameter twice: {names}.")
    return names


def _sigma(name, value, what):
    from .._units import to_array

    kind = "area_per_mass" if name == "drag" else "dimensionless"
    try:
        s = float(to_array(value, kind, f"{what}[{name!r}]"))
    except TypeError:
        raise InvalidInputError(f"{what}[{name!r}] must be one number; got {value!r}.") from None
    if not (np.isfinite(s) and s > 0):
        raise InvalidInputError(f"{what}[{name!r}] must be > 0; got {value!r}.")
    return s


def coefficients(perturbations, estimate, parameter_sigma, consider):
    """The estimated and the considered :class:`Coefficient` of a fit (two lists), from
    :func:`visviva.fit_orbit`'s ``estimate``, ``parameter_sigma`` and ``consider``."""
    from .perturbations import AtmosphericDrag, SolarRadiationPressure

    est = _names(estimate, "estimate")
    if consider is not None and not isinstance(consider, dict):
        raise InvalidInputError(
            "consider must be a mapping of parameter to sigma, e.g. "
            "consider={'drag': 0.004 * u.m**2 / u.kg, 'srp': 0.2}; got " + repr(consider))
    if parameter_sigma is not None and not isinstance(parameter_sigma, dict):
        raise InvalidInputError(
            "parameter_sigma must be a mapping of parameter to a priori sigma, e.g. "
            "{'drag': 0.005 * u.m**2 / u.kg}; got " + repr(parameter_sigma))
    con = _names(None if consider is None else list(consider), "consider")
    both = set(est) & set(con)
    if both:
        raise InvalidInputError(
            f"{sorted(both)} both estimated and considered: a parameter is one or the other.")
    extra = set(parameter_sigma or {}) - set(est)
    if extra:
        raise InvalidInputError(
            f"parameter_sigma gives {sorted(extra)}, which estimate= does not name (a "
            "considered parameter's sigma goes in consider=).")
    kinds = {"drag": AtmosphericDrag, "srp": SolarRadiationPressure}
    out = ([], [])
    for group, names in enumerate((est, con)):
        for name in NAMES:  # the canonical order
            if name not in names:
                continue
            found = [i for i, p in enumerate(perturbations) if isinstance(p, kinds[name])]
            if len(found) != 1:
                raise InvalidInputError(
                    f"{'estimate' if group == 0 else 'consider'}={name!r} needs exactly one "
                    f"vv.{kinds[name].__name__} in perturbations (its coefficient is the "
                    f"starting value); found {len(found)}.")
            p = perturbations[found[0]]
            if name == "drag":
                value, factor = p.ballistic_coefficient_m2_kg, 1e-6
            else:
                from .perturbations import SOLAR_PRESSURE_1AU_N_M2

                value = p.radiation_pressure_coefficient
                factor = SOLAR_PRESSURE_1AU_N_M2 * p.area_to_mass_m2_kg * 1e-3
            if group == 0:
                given = (parameter_sigma or {}).get(name)
                sigma = None if given is None else _sigma(name, given, "parameter_sigma")
            else:
                sigma = _sigma(name, consider[name], "consider")
            out[group].append(Coefficient(name, found[0], value, factor, sigma, value))
    return out


def partials(dyn, coefs):
    """d y / d p (T, 6, k) of the coefficients ``coefs``, in their own units, from the
    dynamics' last propagation (``parameters=True``)."""
    cols = [dyn.parameter_partials[..., c.column] * c.factor for c in coefs]
    return np.stack(cols, axis=-1) if cols else np.zeros(dyn.parameter_partials.shape[:2] + (0,))


def estimated_perturbations(perturbations, coefs, values):
    """The perturbations with the coefficients ``coefs`` set to ``values``; a value outside
    the force's domain raises :class:`~visviva.ConvergenceError`."""
    from astropy import units as u

    out = list(perturbations)
    for c, v in zip(coefs, values, strict=True):
        p = out[c.index]
        try:
            if c.name == "drag":
                out[c.index] = dataclasses.replace(p, ballistic_coefficient=v * u.m**2 / u.kg)
            else:
                out[c.index] = dataclasses.replace(p, reflectivity=float(v))
        except InvalidInputError as exc:
            raise ConvergenceError(
                f"the estimated {c.name} coefficient {v:.6g} lies outside the force model's "
                f"domain ({exc}): the data do not determine it. Give it an a priori sigma "
                "(parameter_sigma=), consider it instead (consider=), or fit a longer arc."
            ) from exc
    return out


