"""Side-by-side benchmarks of visviva against the reference libraries.

Each ``bench_<topic>.py`` defines ``run(quick: bool = False) -> list[dict]`` (rows built with
:func:`benchmarks.common.result`). ``python -m benchmarks`` (or ``visviva bench``) runs them all
and writes ``docs/performance.md``.
"""
