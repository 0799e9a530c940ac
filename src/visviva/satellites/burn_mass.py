"""The spacecraft's mass along a Cowell run with burns, for drag and solar radiation pressure.

Drag and SRP take an area-to-mass ratio (:class:`~visviva.AtmosphericDrag`'s Cd A / m,
:class:`~visviva.SolarRadiationPressure`'s A / m) for the mass at the state's epoch. Burns that
know the mass (a :class:`~visviva.satellites.burns.FiniteBurn` with ``mass``, an
:class:`~visviva.satellites.burns.ImpulsiveBurn` with ``mass`` and ``delta_mass``, an OPM's
``MASS`` and ``MAN_DELTA_MASS``) change it, and as GMAT and STK do with the spacecraft's total
mass, the ratio follows: each segment of the run scales both by m(epoch) / m(segment start),
and during a finite burn the compiled force model divides them by m(t) / m(segment start) =
1 - (mdot / m) t (the ``THRUST_MASS_RATE`` slot the thrust already uses), so the ratio is
exact at every instant. Burns that do not know the mass leave it unchanged.
"""

from __future__ import annotations

from ..core import force_block as fb
from ..errors import InvalidInputError

__all__ = ["mass_at", "scale_area", "check_chain"]

#: Relative difference above which a burn's mass at ignition does not follow the one before.
CHAIN_RTOL = 1e-9


def _known(items):
    """(start, end, mass before, mass after, burn) of the burns that know the mass, by start."""
    out = []
    for start, end, burn in items:
        if getattr(burn, "mass_kg", None) is not None:  # a finite burn with thrust and mass
            out.append((start, end, burn.mass_kg, burn.mass_at(end - start), burn))
        elif getattr(burn, "mass", None) is not None:  # an impulse with its mass
            m0 = float(burn.mass.value)
            dm = 0.0 if burn.delta_mass is None else float(burn.delta_mass.value)
            out.append((start, end, m0, m0 + dm, burn))
    return out


def mass_at(items, t: float, after_impulses: bool):
    """The mass (kg) at ``t`` (s from the epoch), or None when no burn knows it.

    Parameters
    ----------
    items : list of (start, end, burn)
        The schedule's burns, by start.
    t : float
        s from the epoch.
    after_impulses : bool
        Whether an impulse at ``t`` has been applied (a segment starting there forwards) or
        not (backwards, or the epoch's own mass).

    Returns
    -------
    float or None
    """
    mass = None
    for start, end, before, after, burn in _known(items):
        finite = end > start
        if finite and start < t < end:
            return burn.mass_at(t - start)
        if end < t or (end == t and (after_impulses or finite)):
            mass = after
        else:
            return before if mass is None else mass
    return mass


def check_chain(items) -> None:
    """Refuse burns whose masses contradict each other: a burn's mass at ignition differs from
    the mass the burn before it left.

    A finite burn's thrust acceleration F / m(t) starts from its own ``mass``, and the
    result's masses and drag and SRP follow the chain, so a second burn given the first one's
    mass at ignition (one engine's settings reused: ``mass=1000 * u.kg`` twice) flew another
    Δv than the spacecraft would, silently (400 N, Isp 300 s, 10 min twice from 1000 kg: the
    second burn gave 250.4 m/s and a final mass of 918.4 kg instead of 273.7 m/s and 836.8 kg).
    A mass dropped between burns (a stage, a probe) is an impulse of no Δv with ``mass`` and
    ``delta_mass``.

    Parameters
    ----------
    items : list of (start, end, burn)
        The schedule's burns, by start (s from the epoch).

    Raises
    ------
    InvalidInputError
        Naming the two burns and both masses.
    """
    known = _known(items)
    for (_, _, _, after, b1), (_, _, before, _, b2) in zip(known, known[1:], strict=False):
        if abs(before - after) > CHAIN_RTOL * after:
            raise InvalidInputError(
                f"{b2!r} starts with {before:.10g} kg but {b1!r} left {after:.10g} kg; a finite "
                "burn's acceleration F / m, the masses reported, drag and SRP follow the "
                "spacecraft's mass, so the burns' masses must follow each other: give each burn "
                f"the mass the one before it left (mass={after:.10g} * u.kg; an OPM's burns() "
                "does). For a mass dropped between them (a stage, a probe) add "
                "vv.ImpulsiveBurn(t, [0, 0, 0] * u.km / u.s, mass=..., delta_mass=...)."
            )


def scale_area(schedule, force, a: float, b: float) -> None:
    """Scale the drag and SRP slots of the segment from ``a`` to ``b`` (s from the epoch) by
    m(epoch) / m(a): the area-to-mass ratios are given for the mass at the epoch.

    Parameters
    ----------
    schedule : visviva.satellites.burn_segments.Schedule
        The burns.
    force : ndarray
        The segment's force block (time origin at ``a``), written in place.
    a, b : float
        The segment, either direction.
    """
    if force[fb.DRAG_ON] == 0.0 and force[fb.SRP_ON] == 0.0:
        return
    scale = area_scale(schedule, a, b)
    if scale is None:
        return
    force[fb.BALLISTIC] *= scale
    force[fb.SRP_COEFFICIENT] *= scale


def area_scale(schedule, a: float, b: float):
    """m(epoch) / m(a), the factor of the drag and SRP slots of the segment from ``a`` to ``b``
    (:func:`scale_area`; also d slot / d slot(epoch) for the coefficients' partials); None
    when the masses are unknown or equal (no scaling)."""
    m_epoch = mass_at(schedule.items, 0.0, False)
    m_seg = mass_at(schedule.items, a, b > a)
    if m_epoch is None or m_seg is None:
        return None
    if m_seg == m_epoch:
        return None
    return m_epoch / m_seg
