"""The unit of the validation suite: one named comparison with a metric and a tolerance."""

from __future__ import annotations

from dataclasses import dataclass, field

#: Tolerances in physical units (km), shared by the check modules.
ONE_MM_KM = 1e-6
ONE_M_KM = 1e-3
TEN_M_KM = 1e-2


@dataclass
class Check:
    """One comparison of visviva against a reference.

    Parameters
    ----------
    name : str
        Short unique name, e.g. ``"elements vs skyfield: position round trip"``.
    metric : str
        What ``measured`` is, e.g. ``"max |dr| (km)"`` or ``"max relative energy error"``.
    measured : float
        The measured value of the metric.
    tolerance : float
        The check passes when ``measured <= tolerance``.
    reference : str
        The reference library and version, or the published source.
    details : dict
        Anything worth showing in the report (sample sizes, settings, arrays for plots).
    """

    name: str
    metric: str
    measured: float
    tolerance: float
    reference: str = ""
    details: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return bool(self.measured <= self.tolerance)  # NaN fails
