"""Machine instructions per pair of the GPU direct-sum kernels, counted without a GPU.

Compiles :data:`visviva.core.cuda.kernels.accelerations` and its variants to PTX (numba-cuda's
``compile_ptx``), the PTX to sm_90 machine code (``ptxas`` of the ``nvidia-cuda-nvcc-cu12`` wheel
that the ``gpu`` extra installs) and disassembles it (``nvdisasm``: ``pip install
"cuda-toolkit[nvdisasm]"``, or on PATH, or named by ``$NVDISASM``). In each loop that contains
reciprocal-square-root instructions (``MUFU.RSQ64H``, one per pair: the hardware seed of both
``sqrt`` and ``rsqrt``) it counts the instructions and the fp64 ones (DADD, DMUL, DFMA, DSETP)
per pair. An H100/H200 SM issues one instruction per clock on each of its 4 schedulers and
retires 64 fp64 operations per clock, so a pair costs at least max(instructions, 2 x fp64)
scheduler cycles per warp: a static bound that the measured rows of ``bench_gpu`` test.

Run: ``.venv/bin/python -m benchmarks.gpu_instructions``.
"""

from __future__ import annotations

import glob
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import types

KERNELS = ("accelerations", "accelerations_rsqrt")
_INSTRUCTION = re.compile(r"\s*/\*[0-9a-f]{4}\*/")
_FP64 = re.compile(r"\b(DFMA|DMUL|DADD|DSETP)\b")


def _tool(name: str, env: str) -> str | None:
    found = os.environ.get(env) or shutil.which(name)
    if found:
        return found
    site = sysconfig.get_paths()["purelib"]
    hits = glob.glob(os.path.join(site, "nvidia", "**", "bin", name), recursive=True)
    return hits[0] if hits else None


def loops_per_pair(sass: str) -> list[tuple[float, float]]:
    """(instructions, fp64 instructions) per pair of every loop of ``sass`` (nvdisasm text)
    that contains ``MUFU.RSQ64H``."""
    lines = sass.splitlines()
    labels = {line.split(":")[0][1:]: k for k, line in enumerate(lines) if line.startswith(".L")}
    out = []
    for k, line in enumerate(lines):
        m = re.search(r"BRA\s+(?:!?P\d,\s*)?`\(\.(L_x_\d+)\)", line)
        if m and labels.get(m.group(1), k) < k:  # a backward branch closes a loop
            body = [x for x in lines[labels[m.group(1)]:k + 1] if _INSTRUCTION.match(x)]
            pairs = sum("MUFU.RSQ64H" in x for x in body)
            if pairs:
                fp64 = sum(bool(_FP64.search(x)) for x in body)
                out.append((len(body) / pairs, fp64 / pairs))
    return out


def main() -> int:
    ptxas, nvdisasm = _tool("ptxas", "PTXAS"), _tool("nvdisasm", "NVDISASM")
    if not (ptxas and nvdisasm):
        print("needs ptxas (the gpu extra) and nvdisasm (pip install 'cuda-toolkit[nvdisasm]')")
        return 1
    from numba import cuda, float64, int64

    # no device here: name the compute capability numba-cuda would ask the device for
    sys.modules["numba.cuda.dispatcher"].get_current_device = (
        lambda: types.SimpleNamespace(compute_capability=(9, 0)))
    from visviva._text import replace_text_file
    from visviva.core.cuda import kernels

    a2 = float64[:, ::1]
    signature = (a2, a2, float64[::1], int64[::1], float64, a2)
    with tempfile.TemporaryDirectory() as tmp:
        for name in KERNELS:
            ptx, _ = cuda.compile_ptx(getattr(kernels, name).py_func, signature, cc=(9, 0))
            src, cubin = os.path.join(tmp, f"{name}.ptx"), os.path.join(tmp, f"{name}.cubin")
            replace_text_file(src, ptx)
            subprocess.run([ptxas, "-arch=sm_90", "-O3", src, "-o", cubin], check=True)
            sass = subprocess.run([nvdisasm, "-c", cubin], check=True, capture_output=True,
                                  text=True).stdout
            for per_pair, fp64 in loops_per_pair(sass):
                print(f"{name}: loop of {per_pair:.1f} instructions, {fp64:.1f} fp64 per pair")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
