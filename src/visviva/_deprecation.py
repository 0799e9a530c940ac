"""Deprecated names kept for one release: one helper, one message format."""

from __future__ import annotations

import warnings

__all__ = ["warn_renamed", "deprecated_alias"]


def warn_renamed(old: str, new: str, stacklevel: int = 3) -> None:
    """Emit the ``DeprecationWarning`` for a name renamed to ``new`` (removed next release)."""
    warnings.warn(
        f"{old} is deprecated and will be removed in the next release; use {new} instead.",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def deprecated_alias(old: str, new: str, obj):
    """Return ``obj`` after warning that ``old`` is its deprecated name (module ``__getattr__``)."""
    warn_renamed(old, new, stacklevel=4)
    return obj
