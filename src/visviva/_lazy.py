"""Lazy package attributes (PEP 562): a package's public names load their module on first use.

Shared by :mod:`visviva` and :mod:`visviva.mechanics`, so that importing either compiles and
imports nothing beyond the tables of names.
"""

from __future__ import annotations
import __future__

import importlib


def lazy_attributes(namespace: dict, public: dict, submodules=frozenset(), prefix: str = ""):
    """The module-level ``__getattr__`` and ``__dir__`` of a package that loads lazily.

    Parameters
    ----------
    namespace : dict
        The package's ``globals()``: its ``__name__`` and ``__all__``, and where every public
        name is cached once it has been looked up (later lookups skip ``__getattr__``).
    public : dict of str to str
        Public name -> the module that defines it, as ``prefix + public[name]``.
    submodules : set of str, optional
        Modules of the package reachable as attributes (``package.name``).
    prefix : str, optional
        Prepended to the module names of ``public``, e.g. ``"visviva.mechanics."``.

    Returns
    -------
    __getattr__, __dir__ : callable
        To be bound to these names at the end of the package's ``__init__.py``.

    Notes
    -----
    PEP 562 (module ``__getattr__`` and ``__dir__``). An unknown name raises AttributeError as
    Python does for any module.
    """
    package = namespace["__name__"]

    def __getattr__(name: str):
        if name in public:
            value = getattr(importlib.import_module(prefix + public[name]), name)
            namespace[name] = value
            return value
        if name in submodules:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        # without the `from __future__ import annotations` binding, which tab completion
        # offered as vv.annotations, a name of no use (audit51)
        names = {n for n, v in namespace.items() if v is not __future__.annotations}
        return sorted(names | set(namespace["__all__"]) | set(submodules))

    return __getattr__, __dir__
