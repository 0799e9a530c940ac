"""The dynamics of the fits: :class:`visviva.satellites.variational.Dynamics` (its one owner,
shared with covariance propagation), named here for the od modules and their tests."""

from __future__ import annotations

from ..satellites.variational import DEFAULT_ATOL, DEFAULT_RTOL, Dynamics

__all__ = ["Dynamics", "DEFAULT_RTOL", "DEFAULT_ATOL"]
