"""Where a warning points: the user's line, however deep in visviva it was raised.

A fixed ``stacklevel`` is right for one call path only: the same stale-element-set warning is
raised from ``Satellite.teme`` called by the user, by ``GroundStation.look``, by
``ground_track`` or by a pass search, each one or more frames deeper. :func:`outside_stacklevel`
counts the frames instead, up to the first one outside visviva (and outside astropy, ERFA,
numpy and the standard library's contextlib, which visviva calls back through).
"""

from __future__ import annotations

import contextlib
import os
import sys

__all__ = ["outside_stacklevel"]

_INSIDE: tuple[str, ...] | None = None


def _inside() -> tuple[str, ...]:
    """File-name prefixes of the frames a warning should not point at (built once)."""
    global _INSIDE
    if _INSIDE is None:
        import astropy
        import erfa
        import numpy

        import visviva

        _INSIDE = tuple(os.path.dirname(m.__file__) + os.sep
                        for m in (visviva, astropy, erfa, numpy)) + (contextlib.__file__,)
    return _INSIDE


def outside_stacklevel() -> int:
    """The ``stacklevel`` for ``warnings.warn`` called by the caller of this function that
    points at the first frame outside visviva: the user's line.

    Returns
    -------
    int
        1 would be the caller itself; the count goes up one per frame inside visviva (or
        astropy, ERFA, numpy, contextlib). When every frame is inside (visviva's own command
        line), the outermost frame's level plus one: ``warnings`` then names ``sys``.
    """
    inside = _inside()
    frame, level = sys._getframe(1), 1  # the caller of this function: stacklevel 1
    while frame is not None and frame.f_code.co_filename.startswith(inside):
        frame, level = frame.f_back, level + 1
    return level
