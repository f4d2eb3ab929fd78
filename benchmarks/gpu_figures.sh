#!/bin/sh
# Every GPU figure of docs/performance.md in one run, from the repository root of a machine with a GPU:
#
#     sh benchmarks/gpu_figures.sh [OUT]        # OUT: where the table's records go (default /tmp/gpu_figures)
#
# It needs jax with its CUDA plugin, numpy, scipy and matplotlib (and, for the pytorch-mppi column,
# torch and pytorch-mppi); dexpush itself runs from src/ without installing. Printed, in order:
#   1. one MPPI iteration at K = 1024 and 16,384, rect and T, with pytorch-mppi on the same GPU
#      (target: <= 1 ms at both K);
#   2. one batched control step piece by piece (120 lanes, T, Task II): what dominates on the GPU;
#   3. the 720-trial model table (MPPI and MPPI+UKF, known and unknown lambda, Tasks I-III, rect and T,
#      seeds 0-29), its wall time (target: <= 60 s) and its table, to compare with
#      docs/results/benchmark/benchmark.md (same outcomes in distribution).
# About 5 minutes on an H200, most of it compiling. SMOKE=1 runs a tiny version on any device (a check
# of the script itself: K = 1024 only, 8 lanes, 2 seeds).
set -eu
OUT=${1:-/tmp/gpu_figures}
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
export XLA_PYTHON_CLIENT_PREALLOCATE=false     # the table's worker processes share the one GPU
PY=${PYTHON:-python3}
$PY -c "import jax; d = jax.devices()[0]; print('# device:', d.platform, d.device_kind)"
SIZES=1024,16384 LANES=120 TRIALS=30 WORKERS=6 REPEATS=20
if [ "${SMOKE:-0}" = 1 ]; then
    SIZES=1024 LANES=8 TRIALS=2 WORKERS=2 REPEATS=3
else
    $PY -c "import jax, sys; sys.exit(jax.default_backend() != 'gpu')" || { echo "no GPU seen by JAX" >&2; exit 2; }
fi

echo "## 1. one MPPI iteration"
$PY benchmarks/mppi_speed.py --sizes $SIZES --repeats $REPEATS

echo "## 2. one batched control step, piece by piece"
$PY benchmarks/step_breakdown.py --lanes $LANES --shape tee --repeats $REPEATS

echo "## 3. the 720-trial model table"
rm -rf "$OUT/table"
start=$($PY -c "import time; print(time.time())")
$PY -m dexpush.cli bench --tasks I,II,III --shapes rect,tee --params known,unknown --methods mppi,mppi-ukf \
    --trials $TRIALS --lanes $LANES --workers $WORKERS --no-figures --quiet --out "$OUT/table"
$PY -c "import time; print(f'{24 * $TRIALS} trials: {time.time() - $start:.1f} s wall, the whole command (target for 720: <= 60 s)')"
cat "$OUT/table/benchmark.md"
