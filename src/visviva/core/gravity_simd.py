"""The inner loops of the large-N gravity kernel, written as explicit 8-double vectors.

:mod:`visviva.core.gravity` evaluates each massive pair once from :data:`~visviva.core.gravity.PAIR_MIN_N`
massive particles on; the time goes into three loops over a range of columns ``j`` (a row of pairs,
the masked head of a row, a test particle's one-sided row). This module emits them as LLVM IR on
``<8 x double>`` vectors (numba intrinsics), for one reason: the first guess of ``1/sqrt(r2)``.

Why explicit vectors
--------------------
CPUs with AVX-512 have an estimate of ``1/sqrt`` for doubles, ``vrsqrt14pd`` (relative error
below ``2**-14``), one instruction in place of the bit-level guess and its first refinement step
(:func:`visviva.core.gravity.inv_r3`: eight vector operations). LLVM's loop vectoriser cannot use
it (its reciprocal-estimate lowering covers float32 only, and an x86 intrinsic in a scalar loop
stops vectorisation), so the loop is written here as vector code: loads of 8 columns, the
arithmetic, the reaction subtracted from the accumulators of the ``j``, and the three sums kept in
8 lanes. 19 vector multiply-adds or multiplies, 3 subtractions and the estimate per 8 pairs
instead of about 25 multiply-adds, measured 1.3-1.8x faster for the whole large-N kernel on an
AMD EPYC (Zen 4) than with the auto-vectorised loops of the scalar references.

``r**-3`` from the estimate ``y`` (AVX-512): with ``e = 1 - r2 y**2`` (``|e| < 1.3e-4``),
``r2**-1.5 = y**3 (1 - e)**-3/2 = y**3 (1 + 3e/2 + 15 e**2/8 + 35 e**3/16 + 315 e**4/128)``,
truncation below ``1e-19``: one step, folded into the cube. Without AVX-512 (or with numba's
target CPU set to one without it) the same loops use the bit-level guess and the two steps of
:func:`~visviva.core.gravity.inv_r3` (the same arithmetic on 8 lanes; LLVM splits the vectors into
the registers the CPU has). Either way ``r**-3`` is within about one ulp (tested).

Summation order: lane ``l`` accumulates the columns ``j = lo + l (mod 8)``, in increasing ``j``;
at the end the lanes are added as ``((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7))``. The order
is fixed by the code, never by the data or the threads. The scalar reference of each loop is in
:mod:`visviva.core.gravity` (``pair_row``, ``pair_row_head``, ``row_acceleration_fast``): it is
what runs under ``NUMBA_DISABLE_JIT`` and what the tests compare with.

Column ranges: ``lo`` is a multiple of 8 (and the rows of ``p``, ``b`` start on 64-byte
boundaries, see :func:`visviva.core.gravity._aligned_rows`); the loops run in steps of 8 while
``j < hi``, so the columns up to the next multiple of 8 at or above ``hi`` must exist (the
massless padding of :func:`visviva.core.gravity._pad_massive`).

The module also holds :func:`ticket`, the atomic counter with which the parallel kernel's
threads share its work items.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import errors
from numba.extending import intrinsic

__all__ = ["pair_row", "pair_row_head", "one_sided_row", "inv_r3_x8", "has_rsqrt14", "ticket",
           "RSQRT_MAGIC"]

_F64 = ir.DoubleType()
_V8 = ir.VectorType(_F64, 8)
_I64 = ir.IntType(64)
_VI8 = ir.VectorType(_I64, 8)
_I32 = ir.IntType(32)
#: Bit-level first guess of ``1/sqrt(x)`` for doubles (Lomont 2003), here and in
#: :func:`visviva.core.gravity.inv_r3`.
RSQRT_MAGIC = 0x5FE6EB50C7B537A9
_RSQRT14 = "llvm.x86.avx512.rsqrt14.pd.512"


def has_rsqrt14(context=None):
    """Whether numba compiles for a CPU with AVX-512F (``vrsqrt14pd``): the features of numba's
    target machine (``NUMBA_CPU_FEATURES`` if set, else the host's)."""
    if context is None:
        from numba.core.registry import cpu_target

        context = cpu_target.target_context
    features = getattr(context.codegen(), "_tm_features", "") or ""
    return "+avx512f" in features.split(",")


# ---- IR helpers ---------------------------------------------------------------------------------
def _const(x):
    return ir.Constant(_V8, [float(x)] * 8)


def _splat(builder, x):
    v = builder.insert_element(ir.Constant(_V8, ir.Undefined), x, ir.Constant(_I32, 0))
    return builder.shuffle_vector(v, ir.Constant(_V8, ir.Undefined),
                                  ir.Constant(ir.VectorType(_I32, 8), [0] * 8))


def _function(module, name, ret, args):
    fn = module.globals.get(name)
    return fn if fn is not None else ir.Function(module, ir.FunctionType(ret, args), name)


def _fma(builder, a, b, c):
    return builder.call(_function(builder.module, "llvm.fma.v8f64", _V8, [_V8] * 3), [a, b, c])


def _poly(builder, e, coefs):
    # coefs[0] + e (coefs[1] + e (...)), Horner with multiply-adds
    q = _const(coefs[-1])
    for c in coefs[-2::-1]:
        q = _fma(builder, e, q, _const(c))
    return q


def _inv_r3(builder, r2, rsqrt14):
    """IR for ``r2**-1.5`` on 8 lanes (see the module docstring)."""
    # 512-bit operations stay legal in the caller even where LLVM prefers 256-bit registers
    # (llvmlite's attribute set knows a fixed list of names: add the string directly)
    set.add(builder.function.attributes, '"min-legal-vector-width"="512"')
    if rsqrt14:
        fn = _function(builder.module, _RSQRT14, _V8, [_V8, _V8, ir.IntType(8)])
        y = builder.call(fn, [r2, _const(0.0), ir.Constant(ir.IntType(8), 255)])
        fold = (1.5, 1.875, 2.1875, 2.4609375)
    else:  # inv_r3's guess and first step: y (1 + e/2 + 3 e**2/8 + 5 e**3/16)
        bits = builder.lshr(builder.bitcast(r2, _VI8), ir.Constant(_VI8, [1] * 8))
        y = builder.bitcast(builder.sub(ir.Constant(_VI8, [RSQRT_MAGIC] * 8), bits), _V8)
        e = _fma(builder, builder.fneg(r2), builder.fmul(y, y), _const(1.0))
        y = _fma(builder, y, builder.fmul(e, _poly(builder, e, (0.5, 0.375, 0.3125))), y)
        fold = (1.5, 1.875, 2.1875)
    y2 = builder.fmul(y, y)
    e = _fma(builder, builder.fneg(r2), y2, _const(1.0))
    y3 = builder.fmul(y2, y)
    return _fma(builder, y3, builder.fmul(e, _poly(builder, e, fold)), y3)


def _row_ptr(builder, arr, row, j):
    # &arr[row, j] as <8 x double>* (rows contiguous, stride in bytes)
    base = builder.bitcast(arr.data, ir.IntType(8).as_pointer())
    stride = builder.extract_value(arr.strides, 0)
    rowp = builder.bitcast(builder.gep(base, [builder.mul(stride, ir.Constant(_I64, row))]),
                           _F64.as_pointer())
    return builder.bitcast(builder.gep(rowp, [j]), _V8.as_pointer())


def _lane_sum(builder, v):
    # ((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7)), always in this order
    def half(x, idx):
        return builder.shuffle_vector(x, x, ir.Constant(ir.VectorType(_I32, len(idx)), idx))

    s4 = builder.fadd(half(v, [0, 1, 2, 3]), half(v, [4, 5, 6, 7]))
    s2 = builder.fadd(half(s4, [0, 1]), half(s4, [2, 3]))
    return builder.fadd(builder.extract_element(s2, ir.Constant(_I32, 0)),
                        builder.extract_element(s2, ir.Constant(_I32, 1)))


def _emit_loop(context, builder, pa, ba, xyz, gmi, soft2, lo, hi, i, guard, rsqrt14):
    """One loop over j in [lo, hi) in steps of 8; returns the three lane vectors.

    ``ba`` None: no reaction (one-sided row). ``i`` not None: only the j > i count (head).
    ``guard``: an r2 of exactly 0 is replaced by 1 (its term is 0 since d = 0).
    """
    X, Y, Z = (_splat(builder, v) for v in xyz)
    S2 = _splat(builder, soft2)
    NG = builder.fneg(_splat(builder, gmi)) if ba is not None else None
    entry = builder.block
    loop = builder.append_basic_block("pairs.loop")
    done = builder.append_basic_block("pairs.done")
    builder.cbranch(builder.icmp_signed("<", lo, hi), loop, done)

    builder.position_at_end(loop)
    j = builder.phi(_I64)
    acc = [builder.phi(_V8) for _ in range(3)]
    j.add_incoming(lo, entry)
    for a in acc:
        a.add_incoming(_const(0.0), entry)
    col = [builder.load(_row_ptr(builder, pa, r, j), align=8) for r in range(4)]
    d = [builder.fsub(col[0], X), builder.fsub(col[1], Y), builder.fsub(col[2], Z)]
    r2 = _fma(builder, d[0], d[0], _fma(builder, d[1], d[1], _fma(builder, d[2], d[2], S2)))
    if guard:
        r2 = builder.select(builder.fcmp_ordered("==", r2, _const(0.0)), _const(1.0), r2)
    r3 = _inv_r3(builder, r2, rsqrt14)
    if i is not None:
        lanes = builder.add(_splat_i(builder, j), ir.Constant(_VI8, list(range(8))))
        r3 = builder.select(builder.icmp_signed(">", lanes, _splat_i(builder, i)), r3, _const(0.0))
    si = builder.fmul(col[3], r3)
    new = [_fma(builder, d[k], si, acc[k]) for k in range(3)]
    if ba is not None:
        sj = builder.fmul(NG, r3)
        for k in range(3):
            ptr = _row_ptr(builder, ba, k, j)
            builder.store(_fma(builder, d[k], sj, builder.load(ptr, align=8)), ptr, align=8)
    jn = builder.add(j, ir.Constant(_I64, 8))
    tail = builder.block
    j.add_incoming(jn, tail)
    for a, n in zip(acc, new, strict=True):
        a.add_incoming(n, tail)
    builder.cbranch(builder.icmp_signed("<", jn, hi), loop, done)

    builder.position_at_end(done)
    out = []
    for n in new:
        ph = builder.phi(_V8)
        ph.add_incoming(_const(0.0), entry)
        ph.add_incoming(n, tail)
        out.append(ph)
    return out


def _splat_i(builder, n):
    v = builder.insert_element(ir.Constant(_VI8, ir.Undefined), n, ir.Constant(_I32, 0))
    return builder.shuffle_vector(v, ir.Constant(_VI8, ir.Undefined),
                                  ir.Constant(ir.VectorType(_I32, 8), [0] * 8))


def _check_rows(name, *arrays):
    for a in arrays:
        if not (isinstance(a, types.Array) and a.ndim == 2 and a.dtype == types.float64
                and a.layout == "C"):
            raise errors.TypingError(f"{name}: p and b must be C-contiguous 2-d float64 arrays, "
                                     f"got {a}")


def _finish(context, builder, sig, lanes):
    # the sums of three lane vectors as a (float64, float64, float64) tuple
    tot = [_lane_sum(builder, v) for v in lanes]
    return context.make_tuple(builder, sig.return_type, tot)


@intrinsic
def pair_row(typingctx, xi, yi, zi, gmi, p, lo, hi, soft2, b):
    """Explicit-vector :func:`visviva.core.gravity.pair_row` (same arguments, same result to
    about one ulp per term; ``lo`` a multiple of 8)."""
    _check_rows("pair_row", p, b)
    f8 = types.float64
    sig = types.UniTuple(f8, 3)(f8, f8, f8, f8, p, types.int64, types.int64, f8, b)

    def codegen(context, builder, signature, args):
        xi, yi, zi, gmi, parr, lo, hi, soft2, barr = args
        pa = context.make_array(signature.args[4])(context, builder, parr)
        ba = context.make_array(signature.args[8])(context, builder, barr)
        fast = has_rsqrt14(context)
        # soft2 > 0: r2 >= soft2 > 0, no guard; else a coincident pair gets r2 = 1
        soft = builder.fcmp_ordered(">", soft2, ir.Constant(_F64, 0.0))
        results = []
        with builder.if_else(soft) as (then, otherwise):
            with then:
                lanes = _emit_loop(context, builder, pa, ba, (xi, yi, zi), gmi, soft2, lo, hi,
                                   None, False, fast)
                results.append((_finish(context, builder, signature, lanes), builder.block))
            with otherwise:
                lanes = _emit_loop(context, builder, pa, ba, (xi, yi, zi), gmi, soft2, lo, hi,
                                   None, True, fast)
                results.append((_finish(context, builder, signature, lanes), builder.block))
        out = builder.phi(context.get_value_type(signature.return_type))
        for val, blk in results:
            out.add_incoming(val, blk)
        return out

    return sig, codegen


@intrinsic
def pair_row_head(typingctx, xi, yi, zi, gmi, i, p, lo, hi, soft2, b):
    """Explicit-vector :func:`visviva.core.gravity.pair_row_head`: the columns ``j > i`` of
    ``[lo, hi)`` only (``lo`` a multiple of 8)."""
    _check_rows("pair_row_head", p, b)
    f8 = types.float64
    i64 = types.int64
    sig = types.UniTuple(f8, 3)(f8, f8, f8, f8, i64, p, i64, i64, f8, b)

    def codegen(context, builder, signature, args):
        xi, yi, zi, gmi, i, parr, lo, hi, soft2, barr = args
        pa = context.make_array(signature.args[5])(context, builder, parr)
        ba = context.make_array(signature.args[9])(context, builder, barr)
        lanes = _emit_loop(context, builder, pa, ba, (xi, yi, zi), gmi, soft2, lo, hi, i, True,
                           has_rsqrt14(context))
        return _finish(context, builder, signature, lanes)

    return sig, codegen


@intrinsic
def one_sided_row(typingctx, xi, yi, zi, p, nm, soft2):
    """Explicit-vector :func:`visviva.core.gravity.row_acceleration_fast`: the acceleration of a
    particle from the first ``nm`` columns of ``p`` (the columns up to the next multiple of 8
    must be massless padding)."""
    _check_rows("one_sided_row", p)
    f8 = types.float64
    sig = types.UniTuple(f8, 3)(f8, f8, f8, p, types.int64, f8)

    def codegen(context, builder, signature, args):
        xi, yi, zi, parr, nm, soft2 = args
        pa = context.make_array(signature.args[3])(context, builder, parr)
        zero = ir.Constant(_I64, 0)
        lanes = _emit_loop(context, builder, pa, None, (xi, yi, zi), None, soft2, zero, nm, None,
                           True, has_rsqrt14(context))
        return _finish(context, builder, signature, lanes)

    return sig, codegen


@intrinsic
def inv_r3_x8(typingctx, r2, out, k):
    """``out[k:k+8] = r2[k:k+8]**-1.5`` with the loops' ``r**-3`` (for the tests)."""
    for a in (r2, out):
        if not (isinstance(a, types.Array) and a.ndim == 1 and a.dtype == types.float64
                and a.layout == "C"):
            raise errors.TypingError(f"inv_r3_x8: C-contiguous 1-d float64 arrays, got {a}")
    sig = types.void(r2, out, types.int64)

    def codegen(context, builder, signature, args):
        src = context.make_array(signature.args[0])(context, builder, args[0])
        dst = context.make_array(signature.args[1])(context, builder, args[1])
        ps = builder.bitcast(builder.gep(src.data, [args[2]]), _V8.as_pointer())
        pd = builder.bitcast(builder.gep(dst.data, [args[2]]), _V8.as_pointer())
        builder.store(_inv_r3(builder, builder.load(ps, align=8), has_rsqrt14(context)), pd,
                      align=8)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def ticket(typingctx, counter, slot):
    """Atomically ``counter[slot] += 1``; returns the value before (a ticket).

    Threads that take work items this way share them dynamically: one that the operating system
    pauses (another process on its core) takes fewer. Which thread runs an item never changes
    the item's result. The increment is a full barrier for memory (``acq_rel``): a thread that
    draws the last "item done" ticket sees every buffer the other items wrote before theirs.
    """
    if not (isinstance(counter, types.Array) and counter.ndim == 1
            and counter.dtype == types.int64):
        raise errors.TypingError(f"ticket: a 1-d int64 array, got {counter}")
    sig = types.int64(counter, types.int64)

    def codegen(context, builder, signature, args):
        arr = context.make_array(signature.args[0])(context, builder, args[0])
        ptr = builder.gep(arr.data, [args[1]])
        return builder.atomic_rmw("add", ptr, ir.Constant(_I64, 1), "acq_rel")

    return sig, codegen


def ticket_py(counter, slot):
    """:func:`ticket` in pure Python (``NUMBA_DISABLE_JIT``: one thread)."""
    k = int(counter[slot])
    counter[slot] = k + 1
    return k
