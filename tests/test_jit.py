"""The numba decorators of core/_jit.py: one compilation per kernel, inlining, the compile notice."""

import time

import numba
import numpy as np
import pytest

from visviva.core import _jit

pytestmark = pytest.mark.skipif(numba.config.DISABLE_JIT, reason="needs numba's compiler")

_NO_CACHE = {**_jit._FLAGS, "cache": False}


@_jit._njit(**_NO_CACHE)
def _scaled(x, k, flag):
    return x * k if flag else -x * k


@_jit._njit(**_NO_CACHE)
def _caller(x):
    # constants typed Literal[int](2), Literal[bool](True/False), then plain int64 / bool
    n = int(x)
    return _scaled(x, 2, True) + _scaled(x, 3, False) + _scaled(x, n, x > 0.0)


def test_literal_arguments_compile_once():
    assert _caller(1.5) == pytest.approx(1.5 * 2 - 1.5 * 3 + 1.5 * 1)
    # a plain numba dispatcher compiles _scaled three times here (two literal variants)
    assert len(_scaled.signatures) == 1
    assert all(not isinstance(t, numba.types.Literal) for t in _scaled.signatures[0])


def test_inline_kernel_is_llvm_alwaysinline():
    helper = _jit._njit(forceinline=True, **_NO_CACHE)(lambda a, b: a * b + 1.0)
    assert helper(2.0, 3.0) == 7.0
    (llvm,) = helper.inspect_llvm().values()
    assert "alwaysinline" in llvm


def test_kernels_use_the_unliteral_dispatcher():
    from visviva.core import nbody_whfast, universal

    for fn in (universal.propagate_many, universal._stumpff_all, nbody_whfast.whfast_run):
        assert isinstance(fn, _jit._Kernel)


def test_compile_notice_says_once_what_compiles(monkeypatch, capsys):
    monkeypatch.setattr(_jit, "COMPILE_NOTICE_S", 0.01)
    monkeypatch.setitem(_jit.notices, "said", set())
    for name in ("slow_kernel", "slow_kernel", "another_kernel"):
        with _jit.compile_notice(name):
            time.sleep(0.3)
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "compiling slow_kernel" in err and "once" in err and "visviva warmup" in err


def test_compile_notice_silent_when_fast_or_disabled(monkeypatch, capsys):
    monkeypatch.setitem(_jit.notices, "said", set())
    with _jit.compile_notice("fast_kernel"):
        np.zeros(3)
    monkeypatch.setattr(_jit, "COMPILE_NOTICE_S", 0.01)
    monkeypatch.setitem(_jit.notices, "enabled", False)
    with _jit.compile_notice("quiet_kernel"):
        time.sleep(0.2)
    assert capsys.readouterr().err == ""


def test_gravity_paths_share_one_compiled_pair_item():
    from visviva.core import gravity

    rng = np.random.default_rng(3)
    n = 40
    x = rng.normal(size=(n, 3))
    m = np.full(n, 1.0 / n)
    massive = np.arange(n)
    acc_serial = np.zeros((n, 3))
    acc_parallel = np.zeros((n, 3))
    gravity._gravity_pairs_serial(x, m, 1.0, 1e-4, massive, acc_serial)
    gravity._gravity_pairs_parallel(x, m, 1.0, 1e-4, massive, acc_parallel)
    np.testing.assert_array_equal(acc_serial, acc_parallel)  # same items, same order, same bits
    # with an empty cache each helper is compiled for exactly one signature; with numba's cache
    # warm the callers load their machine code and the helpers are not compiled at all (0)
    for fn in (gravity._pair_item, gravity._pair_reduce, gravity._test_rows):
        assert len(fn.signatures) <= 1, (fn, fn.signatures)
