"""The one place that sets numba flags for every kernel in visviva.

Every compiled function in :mod:`visviva.core` (and the few kernels elsewhere) is decorated with
one of the decorators below, so that caching, the error model and threading are decided once.

* ``cache=True``: compiled machine code is written next to the source and reused across processes.
  numba keys a cached kernel by the contents of the file that defines it; a kernel's callees in
  other files of :mod:`visviva.core` are compiled into it, so the key here also holds a digest
  of every source file of :mod:`visviva.core` (:class:`_CoreStampedCache`): an edit to a callee's
  file recompiles its callers instead of loading their stale machine code.
* ``error_model="numpy"``: a division by zero gives ``inf``/``nan`` instead of raising inside the
  kernel; kernels check degenerate cases explicitly and return a status code instead
  (see :mod:`visviva.core.status`).
* ``fastmath`` is never used, except by :data:`simd_kernel`: iterative solvers rely on IEEE
  semantics.
* :data:`simd_kernel` (added for the N-body gravity sum) allows only ``reassoc`` and ``contract``:
  a floating-point reduction (``s += f(j)``) vectorises only when the compiler may reassociate
  the sum, and ``contract`` allows fused multiply-adds. No ``nnan``/``ninf``/``arcp``: NaN, inf and
  comparisons keep IEEE meaning. The result is deterministic for a given compiled function (the
  order of the partial sums is fixed by the code, not by the data or the threads) but differs in
  the last bits from a strict left-to-right sum. Use it only for a reduction in a leaf function;
  never for iterative solvers (Newton, Kepler, predictor-corrector loops).
* :func:`prefer_wide_vectors` (called first thing in the large-N gravity loops) makes LLVM use
  the CPU's widest SIMD registers for the calling function (512-bit on AVX-512, where LLVM's
  default is 256): the one per-function code-generation flag, so it lives here too.
* Nothing is compiled at import: no eager signatures are given, so the first call compiles
  (or loads from the cache).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import sys
import threading
import time
import types as pytypes

import numba
from numba import types
from numba.core import sigutils
from numba.core.caching import CompileResultCacheImpl, FunctionCache
from numba.core.compiler_lock import global_compiler_lock
from numba.core.registry import CPUDispatcher
from numba.extending import intrinsic

__all__ = ["compile_notice", "kernel", "parallel_kernel", "prange", "inline_kernel", "simd_kernel",
           "step_kernel", "prefer_wide_vectors", "interpreted"]

_FLAGS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": False}


@functools.cache
def core_sources_stamp() -> str:
    """A digest of the names and contents of visviva.core's source files (~0.4 MB, ~1 ms once
    per process; contents, as numba hashes a kernel's own file: touching a file changes
    nothing)."""
    directory = os.path.dirname(os.path.abspath(__file__))
    digest = hashlib.sha256()
    for name in sorted(os.listdir(directory)):
        if name.endswith(".py"):
            with open(os.path.join(directory, name), "rb") as handle:
                digest.update(name.encode() + b"\0" + hashlib.sha256(handle.read()).digest())
    return digest.hexdigest()[:20]


class _StampedLocator:
    """numba's cache locator of one kernel, its source stamp joined by :func:`core_sources_stamp`."""

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def get_source_stamp(self):
        return self._inner.get_source_stamp(), core_sources_stamp()


class _CoreStampedCacheImpl(CompileResultCacheImpl):
    def __init__(self, py_func):
        super().__init__(py_func)
        self._locator = _StampedLocator(self._locator)


class _CoreStampedCache(FunctionCache):
    """numba's on-disk cache of a kernel, invalidated by an edit to any file of visviva.core
    (numba's own key is the defining file alone: a stale callee was loaded from the cache)."""

    _impl_class = _CoreStampedCacheImpl


class _Kernel(CPUDispatcher):
    """numba's CPU dispatcher, except that a call from compiled code never specialises on literals.

    A constant argument in compiled code (``_corrector(0, False, ...)``) is typed by numba as
    ``Literal[int](0)`` / ``Literal[bool](False)``, and a plain dispatcher compiles one more
    specialisation of the callee, with all its callees linked in, for every literal value and
    again for the non-literal type: WHFast's ``_corrector`` was compiled four times and
    ``_kepler_drift`` three. This dispatcher types such calls with the plain types
    (``int64``, ``bool``), so each kernel is compiled once per array layout. No kernel in visviva
    dispatches on a literal value (none uses ``numba.literally``).
    """

    def get_call_template(self, args, kws):
        args = tuple(types.unliteral(a) for a in args)
        kws = {k: types.unliteral(a) for k, a in kws.items()}
        return super().get_call_template(args, kws)

    def enable_caching(self):
        self._cache = _CoreStampedCache(self.py_func)

    def load_cached(self, sig) -> bool:
        """True when machine code for ``sig`` is in memory, or is in numba's on-disk cache (then
        it is loaded, in milliseconds, as a call would); False when a call would compile."""
        args, _ = sigutils.normalize_signature(sig)
        if tuple(args) in self.overloads:
            return True
        _threads_up()
        with global_compiler_lock:  # the steps of numba's Dispatcher.compile up to compiling
            cres = self._cache.load_overload(sig, self.targetctx)
            if cres is None:
                return False
            self._cache_hits[sig] += 1
            self.targetctx.insert_user_function(cres.entry_point, cres.fndesc, [cres.library])
            self.add_overload(cres)
        return True

    def compile(self, sig):
        # no compiled version in memory: load it from numba's on-disk cache (milliseconds) or
        # compile it (seconds to a minute with an empty cache); say so when it takes longer
        # than COMPILE_NOTICE_S. Only the outermost compilation is announced: the callees a
        # kernel compiles on the way are part of it.
        _threads_up()
        if notices["depth"] or sig in self.overloads:
            return super().compile(sig)
        notices["depth"] += 1
        try:
            with compile_notice(self.py_func.__name__):
                return super().compile(sig)
        finally:
            notices["depth"] -= 1


def _threads_up() -> None:
    """Start numba's threading layer once per process (about 20 ms) before any kernel is
    compiled or loaded from the cache: a serial kernel whose tree links a parallel one (e.g.
    ``gravity`` calling ``gravity_parallel``) refers to the layer's functions, and loaded from
    the cache before the layer is up it would call address 0 (a crash)."""
    if not _THREADS["up"]:
        from numba.np.ufunc import parallel as numba_parallel

        numba_parallel._launch_threads()
        _THREADS["up"] = True


_THREADS = {"up": False}


#: A call from Python that is still compiling after this many seconds says so on stderr.
COMPILE_NOTICE_S = 2.0
#: After that first line, a compilation still running says so again once this many seconds have
#: passed without a line: a cold ``find_passes`` compiles six kernels one after another for
#: about 25 s, and one line at 2 s followed by 20 s of silence looks like a hang.
STILL_COMPILING_S = 10.0
#: ``enabled``: set to False to print nothing (``visviva warmup`` does: its bar says what is
#: compiling); ``write``: an optional function that prints the line instead of stderr (``visviva
#: validate`` routes it through its progress bar); ``last``: when the last line was written
#: (``time.perf_counter``); ``compiling_s``: seconds spent in announced compilations so far.
notices = {"enabled": True, "said": set(), "depth": 0, "last": None, "compiling_s": 0.0}


def _write(text: str) -> None:
    write = notices.get("write") or sys.stderr.write
    write(text)
    if write is sys.stderr.write:
        sys.stderr.flush()
    notices["last"] = time.perf_counter()


def _say(name: str, t0: float) -> None:
    if not notices["enabled"] or notices["said"]:
        return  # one line per process: the first long compilation says it for all
    notices["said"].add(name)
    _write(
        f"visviva: compiling {name} for its first use ({time.perf_counter() - t0:.0f} s so "
        "far; numba's cache was empty). This happens once: the machine code is cached on disk. "
        "Run `visviva warmup` after installing to compile every kernel ahead.\n")


def _say_still(name: str, t0: float) -> None:
    """A short line when a compilation runs on STILL_COMPILING_S after the last line."""
    last = notices["last"]
    if (not notices["enabled"] or not notices["said"] or last is None
            or time.perf_counter() - last < STILL_COMPILING_S):
        return
    total = notices["compiling_s"] + time.perf_counter() - t0
    _write(f"visviva: still compiling ({name}; {total:.0f} s of first-use compiling in this "
           "process); once only, the machine code is cached.\n")


@contextlib.contextmanager
def compile_notice(name: str):
    """Print one line on stderr if the block (a kernel's compilation) runs past COMPILE_NOTICE_S.

    The line names the kernel and says that the compilation happens once; it is printed once
    per process (the first kernel to compile for long speaks for the ones after it). After it,
    a compilation that is still running STILL_COMPILING_S after the last line adds a short
    "still compiling" line, so that a first call that compiles for half a minute never sits
    silent for long. Loading the machine code from numba's cache takes milliseconds and prints
    nothing. Nested compilations (a kernel's callees) happen inside the outer block and add no
    line.
    """
    t0 = time.perf_counter()
    done = threading.Event()

    def watch():
        if done.wait(COMPILE_NOTICE_S):
            return
        _say(name, t0)
        while not done.wait(min(1.0, STILL_COMPILING_S)):
            _say_still(name, t0)

    watcher = threading.Thread(target=watch, name="visviva-compile-notice", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        done.set()
        notices["compiling_s"] += time.perf_counter() - t0


def _njit(**flags):
    """A decorator like ``numba.njit(**flags)`` that builds a :class:`_Kernel`."""
    options = {k: v for k, v in flags.items() if k != "cache"}
    options.update(nopython=True, boundscheck=None)

    def decorate(fn):
        if numba.config.DISABLE_JIT:
            return fn
        disp = _Kernel(py_func=fn, locals={}, targetoptions=dict(options))
        if flags.get("cache"):
            disp.enable_caching()
        return disp

    return decorate


#: Decorator for a serial compiled kernel (scalar or array).
kernel = _njit(**_FLAGS)

#: Decorator for a kernel whose outer loop uses :func:`prange` over independent items.
parallel_kernel = _njit(parallel=True, **_FLAGS)


#: Decorator for a serial leaf kernel whose float reduction must vectorise (see above): the
#: flags of :data:`kernel` plus ``fastmath={"reassoc", "contract"}``.
simd_kernel = _njit(**{**_FLAGS, "fastmath": {"reassoc", "contract"}})


def inline_kernel(fn):
    """Decorator for a small scalar helper that LLVM always inlines into its callers.

    ``forceinline=True`` sets LLVM's ``alwaysinline`` attribute; the helper is compiled once as
    its own function and LLVM inlines its machine-independent code into every caller. numba's
    own ``inline="always"`` (which inlines numba IR and types the result again in every caller)
    gave the same machine code but took 41 s of CPU to compile ``_propagate_unscaled``, which
    inlines the universal-variable solver three times; with ``forceinline`` it takes 2 s
    (docs/design.md, "Compile time").
    """
    return _njit(forceinline=True, **_FLAGS)(fn)


def step_kernel(fn):
    """Decorator for a function that numba merges into its caller (an integrator's run body).

    ``inline="always"``: numba splices the function's IR into each caller before typing, so it
    is never compiled as a function of its own. Every function numba compiles links in the
    code of all its callees and runs LLVM's optimisation and machine-code emission over the whole
    tree again, so a compiled level costs as much as the tree below it. Each N-body integrator
    has one run body and two thin kernels around it (``<name>_run``, every gravity path, and
    ``<name>_run_few``, the serial few-body path alone); with the body merged into them the
    variants add no level. Also used for a two-line helper (``accelerations``) and for IAS15's
    step (one call site).

    Use it only with one or two call sites: the IR is typed again at every site. Merging all of
    WHFast's orchestration (the corrector inlined seven times) took 45 s of CPU against 17 s
    for the levels it removed, and numba's inlining of numeric helpers was what made
    ``_propagate_unscaled`` slow to compile (see :func:`inline_kernel`). Called from Python, it
    compiles like any kernel.
    """
    return _njit(inline="always", **_FLAGS)(fn)


prange = numba.prange


_INTERPRETED: dict = {}
#: Intrinsic (or kernel) -> the plain Python function that gives the same bits as its machine
#: code (:func:`interpreted`).
PYTHON_EQUIVALENTS: dict = {}


def _interpreted_value(value):
    # what a kernel's global or closure variable becomes in the interpreted copy
    try:
        if value in PYTHON_EQUIVALENTS:
            return PYTHON_EQUIVALENTS[value]
    except TypeError:  # unhashable: not an intrinsic or a kernel
        return value
    if isinstance(value, _Kernel):
        return interpreted(value)
    return value


def interpreted(fn):
    """The Python function behind the kernel ``fn``, calling the interpreted copies of the
    kernels it calls (:mod:`visviva.nbody.tier`, the interpreter tier of a cold first run).

    The copy runs the kernel's own source in the interpreter: the same operations in the same
    order on IEEE doubles, so the same bits as the machine code, because no kernel on the paths
    it is used for allows reassociation or contraction (no ``fastmath``; :func:`simd_kernel`
    only on the large-N paths) and ``x**n`` with an integer ``n > 2`` is not used there
    (numba multiplies, Python calls ``pow``). Tests compare the two bit for bit. Where Python
    and numba differ, Python raises (a division by zero, ``math.sqrt`` of a negative number,
    an overflow in ``math.exp``) while the machine code returns ``inf``/``nan``: the caller
    then runs the machine code instead. Not one of visviva's kernels (a user's ``numba.njit``
    force, which may use fast-math flags): ``fn`` itself, called compiled.
    """
    if not isinstance(fn, _Kernel):
        return fn
    if fn in _INTERPRETED:
        return _INTERPRETED[fn]
    py = fn.py_func
    globals_ = dict(py.__globals__)
    closure = None
    if py.__closure__:
        closure = tuple(pytypes.CellType() for _ in py.__closure__)
    copy = pytypes.FunctionType(py.__code__, globals_, py.__name__, py.__defaults__, closure)
    _INTERPRETED[fn] = copy  # before the callees: kernels that call each other terminate
    for name in _names(py.__code__):
        if name in globals_:
            globals_[name] = _interpreted_value(globals_[name])
    if closure:
        for new, old in zip(closure, py.__closure__, strict=True):
            new.cell_contents = _interpreted_value(old.cell_contents)
    return copy


def _names(code) -> set[str]:
    # the global names a function and its nested code objects refer to
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, pytypes.CodeType):
            names |= _names(const)
    return names


@intrinsic
def prefer_wide_vectors(typingctx):
    """Compile the calling function for the widest SIMD registers the CPU has (no-op call).

    LLVM's default on AVX-512 CPUs is to vectorise with 256-bit registers; this sets the function
    attribute ``"prefer-vector-width"="512"`` on the caller, so its loops use 512-bit ones (8
    doubles). Targets without such registers ignore it.
    """
    def codegen(context, builder, signature, args):
        # llvmlite knows only a fixed list of function attributes: add the string one directly
        set.add(builder.function.attributes, '"prefer-vector-width"="512"')
        return context.get_dummy_value()

    return types.none(), codegen


def _no_op():
    return None


PYTHON_EQUIVALENTS[prefer_wide_vectors] = _no_op

if numba.config.DISABLE_JIT:  # pure Python (coverage runs): the intrinsic is a plain no-op
    prefer_wide_vectors = _no_op  # noqa: F811
