"""The Dormand-Prince 8(5,3) tableau for the compiled integrators (Cowell, orbit determination)."""

from __future__ import annotations

import functools
import math
import numbers

import numpy as np

__all__ = ["dop853_tableau", "integration_tolerances", "RTOL_FLOOR"]

#: The smallest relative tolerance accepted: the float64 precision (rtol = 1e-20 with atol = 1e-20
#: ran a LEO day's 10 million steps, then raised "raise max_steps").
RTOL_FLOOR = float(np.finfo(np.float64).eps)


def integration_tolerances(rtol, atol) -> tuple[float, float]:
    """``(rtol, atol)`` as floats, after checking 0 < rtol < 1 and atol > 0, both finite.

    atol bounds the local error of every component of the state (km, km/s) alike, so it is a
    plain number: a Quantity is refused, not read by its value (``atol=1 * u.m`` was taken as
    1 km, a tolerance 1000 times looser than meant), nor converted (a length says nothing of
    the velocity components).

    Raises
    ------
    InvalidInputError
        A Quantity, a boolean, something not a real number, or a value out of range (rtol
        below :data:`RTOL_FLOOR` too).
    """
    from astropy import units as u

    from ..errors import InvalidInputError

    values = []
    for name, value in (("rtol", rtol), ("atol", atol)):
        if isinstance(value, u.Quantity):
            hint = ""
            if name == "atol" and value.unit.physical_type in ("length", "speed"):
                km = value.to_value(u.km if value.unit.physical_type == "length" else u.km / u.s)
                hint = f" (atol={km:g} for {value})"
            what = "km for positions, km/s for velocities" if name == "atol" else "relative"
            raise InvalidInputError(
                f"{name} is a plain number ({what}); got the Quantity {value}. Give the "
                f"number{hint}."
            )
        real = isinstance(value, numbers.Real) or (
            isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"
        )
        number = float(value) if real and not isinstance(value, bool | np.bool_) else math.nan
        values.append(number)
    rtol_f, atol_f = values
    if not (np.isfinite(rtol_f) and 0 < rtol_f < 1 and np.isfinite(atol_f) and atol_f > 0):
        raise InvalidInputError(f"need 0 < rtol < 1 and atol > 0; got rtol={rtol!r}, atol={atol!r}.")
    if rtol_f < RTOL_FLOOR:
        raise InvalidInputError(
            f"rtol = {rtol_f:g} is below the float64 precision ({RTOL_FLOOR:.3g}), which no "
            "step can meet: the steps shrink until the step budget is spent (10 million steps, "
            "minutes). Give rtol >= 1e-15 (1e-13 to 1e-14 is the integrator's accuracy floor)."
        )
    return rtol_f, atol_f


@functools.lru_cache(maxsize=1)
def dop853_tableau():
    """The DOP853 coefficients (Hairer & Wanner), as contiguous float64 arrays.

    Taken from scipy, which transcribes Hairer's Fortran DOP853; scipy is a dependency of
    visviva, and the compiled integrator in :mod:`visviva.core.cowell` receives them as arrays.
    The module (plain numpy arrays) is loaded from its file: importing it by name would first
    import ``scipy.integrate`` and with it ``scipy.optimize`` (0.2 s of a first call's process).
    """
    dc = _scipy_dop853_module()

    def arr(a):
        return np.ascontiguousarray(a, dtype=np.float64)

    return (arr(dc.A), arr(dc.B), arr(dc.C), arr(dc.E3), arr(dc.E5), arr(dc.D))


def _scipy_dop853_module():
    """scipy's ``dop853_coefficients`` module, executed from its file (it imports numpy only)."""
    import importlib.util
    import sys
    from pathlib import Path

    name = "scipy.integrate._ivp.dop853_coefficients"
    if name in sys.modules:  # scipy.integrate already imported: the same module
        return sys.modules[name]
    scipy_dir = Path(importlib.util.find_spec("scipy").origin).parent
    path = scipy_dir / "integrate" / "_ivp" / "dop853_coefficients.py"
    if not path.is_file():  # another scipy layout: import it by name (slower, same arrays)
        import importlib

        return importlib.import_module(name)
    spec = importlib.util.spec_from_file_location("_visviva_scipy_dop853", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
