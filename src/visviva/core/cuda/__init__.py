"""GPU kernels (numba-cuda) beside their CPU twins; importing this package compiles nothing.

The per-pair and per-member arithmetic is written once, as plain Python functions in
:mod:`visviva.core.cuda.arith`, and compiled twice: with ``numba.njit`` for the CPU and with
``numba.cuda.jit(device=True)`` for the GPU (:mod:`visviva.core.cuda.kernels`, imported only when
a ``backend="cuda"`` run starts). Tests run the GPU kernels under numba's CUDA simulator
(``NUMBA_ENABLE_CUDASIM=1``) and compare them with the CPU backend.

:func:`missing` says what prevents GPU runs on this machine (None when nothing does).
"""

from __future__ import annotations

import importlib.util
import os

__all__ = ["missing", "simulator"]


def simulator() -> bool:
    """True when numba's CUDA simulator is switched on (``NUMBA_ENABLE_CUDASIM=1``)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0")


def missing() -> str | None:
    """What is missing for ``backend="cuda"``, in words, or None when a GPU run can start."""
    if importlib.util.find_spec("numba_cuda") is None:
        return ("the numba-cuda package is not installed: pip install 'visviva[gpu]' (on a "
                "machine with an NVIDIA GPU and driver)")
    if simulator():
        return None
    try:
        from numba import cuda

        available = bool(cuda.is_available())
    except Exception as exc:  # a broken driver or toolkit
        return f"numba-cuda could not use the CUDA driver: {exc}"
    if not available:
        return ("no usable NVIDIA GPU was found (numba.cuda.is_available() is False): run on a "
                "machine with an NVIDIA GPU and its driver, or use backend='cpu'")
    return None
