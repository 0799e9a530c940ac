"""Device twins of the CPU's scalar kernels: the same Python source compiled for the GPU.

:func:`device_twin` takes a compiled scalar kernel (a numba dispatcher whose helpers are other
dispatchers) and returns ``numba.cuda.jit(device=True)`` of the same source, with every helper it
calls replaced by its own device twin (recursively, each built once), the fused multiply-add
intrinsic by libdevice's ``fma`` and ``np.fmod`` by libdevice's ``fmod``. The arithmetic is then written once: the CPU keeps its kernels
as they are, the GPU compiles the same functions. ``replace`` swaps named helpers (at any depth)
for device functions of the same signature: IAS15's step, for instance, calls the few-body
gravity sum directly instead of the CPU's dispatch through its additional-force argument.
"""

from __future__ import annotations

import types

import numpy as np
from numba import cuda
from numba.core.registry import CPUDispatcher

from .. import _intrinsics

__all__ = ["device_twin", "never_inlined"]

_TWINS: dict = {}
#: ids of the twins :func:`never_inlined` has marked (twins live as long as ``_TWINS``)
_NEVER_INLINED: set = set()


def _fma():
    """The device's fused multiply-add: libdevice's on a GPU; under the simulator (device code
    runs as Python) the exact pure-Python one."""
    from . import simulator

    if simulator():
        return _intrinsics.fma_py
    from numba.cuda import libdevice

    return libdevice.fma


def _numpy():
    """What the device code sees as ``np``: numpy under the simulator; on a GPU a module whose
    ``fmod`` is libdevice's (numba-cuda compiles no ``np.fmod`` ufunc; both are IEEE's exact
    remainder) and whose other names are numpy's (constants such as ``np.pi``)."""
    from . import simulator

    if simulator():
        return np
    if "np" not in _TWINS:
        from numba.cuda import libdevice

        module = types.ModuleType("numpy_on_device")
        module.__dict__.update({k: v for k, v in vars(np).items() if not k.startswith("_")})
        module.fmod = libdevice.fmod
        _TWINS["np"] = module
    return _TWINS["np"]


def _names(code):
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names(const)
    return names


def device_twin(dispatcher, replace=None):
    """``cuda.jit(device=True)`` of ``dispatcher``'s Python source, helpers rebound to twins;
    ``replace`` maps helpers (CPU dispatchers) to the device functions that take their place in
    the whole tree below ``dispatcher``."""
    replace = replace or {}
    swaps = {id(cpu): dev for cpu, dev in replace.items()}
    key = (id(dispatcher), tuple(sorted((k, id(v)) for k, v in swaps.items())))
    if key in _TWINS:
        return _TWINS[key]
    fn = dispatcher.py_func
    scope = dict(fn.__globals__)
    for name in _names(fn.__code__):
        value = scope.get(name)
        if id(value) in swaps:
            scope[name] = swaps[id(value)]
        elif value is _intrinsics.fma:
            scope[name] = _fma()
        elif value is np:
            scope[name] = _numpy()
        elif isinstance(value, CPUDispatcher):
            scope[name] = device_twin(value, replace)
    source = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
    twin = cuda.jit(device=True)(source)
    _TWINS[key] = twin
    return twin


def never_inlined(twin):
    """Keep NVVM from inlining the device function ``twin`` into its callers: each overload
    compiled from now on carries LLVM's ``noinline`` attribute, so a kernel that calls it from
    many sites holds one copy of its code (a ``.func`` and calls) instead of one per site.
    A kernel whose PTX would otherwise be megabytes (the general WHFast run body inlines the
    Kepler solver at 23 sites) compiles in a fraction of the time. Returns ``twin``; under the
    simulator (nothing is compiled) it is returned untouched."""
    from . import simulator

    if simulator() or id(twin) in _NEVER_INLINED:
        return twin
    compile_device = twin.compile_device

    def compile_never_inlined(args, return_type=None):
        fresh = args not in twin.overloads
        cres = compile_device(args, return_type)
        if fresh:
            cres.library.get_function(cres.fndesc.llvm_func_name).attributes.add("noinline")
        return cres

    twin.compile_device = compile_never_inlined
    _NEVER_INLINED.add(id(twin))
    return twin
