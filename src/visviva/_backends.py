"""The compute backends (``backend="cpu"`` or ``"cuda"``) and the one check that names what is
missing; used by N-body simulations and ensembles and by the batch two-body propagation."""

from __future__ import annotations

from .errors import BackendUnavailableError, InvalidInputError

__all__ = ["BACKENDS", "check_backend"]

#: The backends: numba on the CPU, numba-cuda on an NVIDIA GPU.
BACKENDS = ("cpu", "cuda")


def check_backend(backend: str) -> str:
    """The canonical backend name; raises when it cannot run here.

    Parameters
    ----------
    backend : str
        ``"cpu"`` or ``"cuda"`` (case-insensitive).

    Returns
    -------
    str
        ``"cpu"`` or ``"cuda"``.

    Raises
    ------
    InvalidInputError
        An unknown backend.
    BackendUnavailableError
        ``"cuda"`` without numba-cuda or without a usable GPU (the message says which).
    """
    name = str(backend).lower()
    if name not in BACKENDS:
        raise InvalidInputError(f"backend must be one of {BACKENDS}; got {backend!r}.")
    if name == "cuda":
        from .core import cuda

        problem = cuda.missing()
        if problem is not None:
            raise BackendUnavailableError(f"backend='cuda' cannot run: {problem}.")
    return name
