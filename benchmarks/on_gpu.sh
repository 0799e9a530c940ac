#!/bin/bash
# The real-GPU checks and benchmarks of issue 16 in one command, for a machine with an NVIDIA GPU
# and numba-cuda (e.g. a lent data-centre GPU whose Python lacks some of visviva's dependencies).
#
#   bash benchmarks/on_gpu.sh [WHEELS_DIR]
#
# WHEELS_DIR (optional): wheels installed into /tmp/site first (no network needed), e.g. made
# beforehand, elsewhere, with
#   pip download --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#     --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 -d WHEELS_DIR \
#     astropy==8.0.2 pyerfa==2.0.1.5 astropy-iers-data==0.2026.11.2.0.34.55 sgp4==2.27 numpy==2.4.6 \
#     pytest==9.2.0 pluggy==1.7.0 iniconfig==2.3.1 packaging==26.3 pygments==2.21.0
# (numpy 2.5 removed np.row_stack, which numba-cuda 0.30.4 still uses at import: pin 2.4.)
# Output goes to $OUT (default ./gpu-out; see below): versions, the real-GPU check scripts' key=value
# lines (tests/gpu/check_*.py, all at once) and exit codes, the gpu-marked tests' verdict on
# them (pytest-gpu.txt), and one JSON line per benchmark row (rows.jsonl), written as each row
# is measured.
# Environment: CHECK_S / BENCH_S (time limits, s; the defaults, 280 + 260, fit one 10-minute call
# with the start; BENCH_S=0 measures nothing), SECTIONS (bench_gpu sections, comma-separated;
# gpu-ensemble first: its rows with the resident kernels, VISVIVA_GPU_RESIDENT=1 for those rows
# only, are the ones awaited), CHECKS (which scripts of tests/gpu/ to run, globs without .py;
# default "check_*"; the diagnose_* scripts found the democratic heliocentric WHFast ensembles'
# fault, fixed 2026-11-28: docs/nbody.md). The next lease's first call: every check once, after
# the changes not yet run on a GPU (megnocold's run bodies, nbodyleft's mid-run step checks):
#   CHECKS="check_*" BENCH_S=0 bash benchmarks/on_gpu.sh .whl
set -u
# the files are written in a work folder and bundled into $OUT/gpu-out.tgz every 30 s and at the
# end (a lent machine sends back a few files only, and what a cut-off call left); rows.jsonl
# and pytest-gpu.txt are copied beside it at the end
BACK=${OUT:-gpu-out}
OUT=${GPU_WORK:-/tmp/gpu-work}
mkdir -p "$OUT" "$BACK"
( while sleep 30; do tar czf "$BACK/gpu-out.tgz" -C "$(dirname "$OUT")" "$(basename "$OUT")"; done ) &
BUNDLER=$!
bundle() {
    kill "$BUNDLER" 2>/dev/null
    tar czf "$BACK/gpu-out.tgz" -C "$(dirname "$OUT")" "$(basename "$OUT")"
    cp "$OUT/rows.jsonl" "$OUT/pytest-gpu.txt" "$BACK/" 2>/dev/null
}
trap bundle EXIT
export PYTHONUNBUFFERED=1
if [ $# -ge 1 ]; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/site "$1"/*.whl || exit 3
    export PYTHONPATH=/tmp/site:$PWD/src:$PWD
else
    export PYTHONPATH=$PWD/src:$PWD
fi
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-/tmp/numba_cache}
{ nvidia-smi -L; lscpu | grep -i "model name"; nproc
  python3 -c "import numba, numpy, numba_cuda; print('numba', numba.__version__, 'numpy', numpy.__version__, 'numba-cuda', numba_cuda.__version__); from visviva.core import cuda; print('missing:', cuda.missing())"
} 2>&1 | tee "$OUT/versions.txt"
SECONDS=0
# every real-GPU check script at once (the GPU and 16 host cores take them together; most of
# each is numba compiling), each with its output and exit status in $OUT; and the diagnosis of
# the general WHFast ensemble kernel (wrong on an H200, refused on real GPUs until found:
# tests/gpu/diagnose_whfast_general.py; `--inline` by hand for the inlined Kepler solver;
# tests/gpu/diagnose_dh_pieces.py: each democratic heliocentric piece alone, device vs CPU)
SCRIPTS=""
for pattern in ${CHECKS:-check_*}; do
    SCRIPTS="$SCRIPTS $(ls tests/gpu/$pattern.py 2>/dev/null)"
done
PIDS=""
for check in $SCRIPTS; do
    name=$OUT/$(basename "$check" .py)
    ( timeout "${CHECK_S:-280}" python3 "$check" > "$name.txt" 2>&1; echo $? > "$name.rc" ) &
    PIDS="$PIDS $!"
done
wait $PIDS  # (not the bundler)
echo "checks: $SECONDS s"
for check in $SCRIPTS; do
    name=$OUT/$(basename "$check" .py)
    echo "$check rc=$(cat "$name.rc")"; grep "=" "$name.txt"
done
# the tolerances of the gpu-marked tests, applied to those outputs (pytest among the wheels;
# check_ensemble_events: events and forces in leapfrog and IAS15 ensembles at 1e-12;
# check_whfast_general: WHFast ensembles, democratic heliocentric, correctors, events at 1e-12;
# check_whfast_forces: WHFast ensembles with additional forces at 1e-12;
# check_resident: the resident ensemble kernels, VISVIVA_GPU_RESIDENT=1, at 1e-12)
if [[ "$SCRIPTS" == *check_* ]] && python3 -c "import pytest" 2>/dev/null; then
    VISVIVA_GPU_OUTPUTS=$OUT python3 -m pytest -q -p no:cacheprovider -m gpu -o addopts="" \
        tests/test_nbody_gpu.py tests/test_nbody_gpu_events.py tests/test_nbody_gpu_whfast.py \
        tests/test_nbody_gpu_resident.py 2>&1 \
        | tee "$OUT/pytest-gpu.txt" | tail -15
fi
[ "${BENCH_S:-260}" = 0 ] && exit 0
SECONDS=0
VISVIVA_BENCH_ROWS=$OUT/rows.jsonl timeout "${BENCH_S:-260}" python3 -c "
import sys
import benchmarks.bench_gpu as b
print('GPU:', b.gpu_model(), file=sys.stderr)
b.run(sections=tuple(sys.argv[1].split(',')))" "${SECTIONS:-gpu-ensemble,direct,kepler,whfast,ias15}" 2>&1 \
    | grep -v "NumbaPerformanceWarning\|warn(errors" | tee "$OUT/bench.log"
echo "bench: $SECONDS s"
