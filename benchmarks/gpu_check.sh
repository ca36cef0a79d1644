#!/usr/bin/env bash
# The GPU measurements of issue 44 in one device run (at most 12 minutes: the limits below):
#   1. the CUDA kernels against the CPU kernels, ordered and atomic sums (pytest -m gpu);
#   2. step throughput at 1e5 and 1e6 tetrahedra, both sums (benchmarks/gpu.py --quick);
#   3. whole-run same answers on the small 3D hybrid slab, both sums;
#   4. the 100 mm cube (Case 3 hybrid, growing fluid step) for up to 200 s, time split.
# Usage, from the repository root: OUT=/some/dir bash benchmarks/gpu_check.sh
# (PYTHONPATH defaults to src). Each part is time-limited so that one slow part
# leaves the others their turn; the printed outputs go to $OUT (default gpu-check/),
# the run directories (snapshots of a 1e6-tetrahedron model) to $RUNS.
set -u
export PYTHONPATH="${PYTHONPATH:-src}"
out="${OUT:-gpu-check}"
runs="${RUNS:-/tmp/gpu-check-runs}"
mkdir -p "$out" "$runs"
run() {  # run LIMIT_S NAME COMMAND...: the command's output to the screen and $out/NAME.txt
    local limit=$1 name=$2
    shift 2
    echo "## $name: $*"
    timeout "$limit" "$@" 2>&1 | tee "$out/$name.txt"
}
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv | tee "$out/card.txt"
if python3 -c "import pytest" 2>/dev/null; then
    run 120 kernels python3 -m pytest -q -m gpu tests/test_cuda_backend.py
fi
run 150 throughput python3 benchmarks/gpu.py --quick
run 180 same-answers python3 benchmarks/gpu_runs.py same-answers --out "$runs"
run 240 cube python3 benchmarks/gpu_runs.py cube --limit-s 200 --cpu-steps 10 --out "$runs"
