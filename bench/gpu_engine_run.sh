#!/usr/bin/env bash
# The GPU engine on a GPU machine without package access, in one go: build from the bundled
# Debian packages against the local PyTorch (scripts/offline-build.sh), run the engine's parity
# checks on the GPU (every stage against MuJoCo 2.2.2, both precisions, every lane width; one
# step; a 1 s trajectory), the engine's host parity tests, and the throughput benchmark of the
# contact-free two-hand scene at 1k, 4k, 16k and 64k worlds. Everything lands in OUTDIR as JSON
# and logs; the exit status is that of the parity check (0: all stages within tolerance).
#   bench/gpu_engine_run.sh OUTDIR [DEPS] [PARTS]
#     DEPS   folder of .debs from `scripts/offline-build.sh bundle` (default .deps)
#     PARTS  comma list of parity, tests, bench (default all three; the build is incremental in
#            $BIDEX_GPU_BUILD, so a second call on a warm machine can run the rest)
set -uo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
out=$(realpath -m "$1")
deps=${2:-.deps}
parts=",${3:-parity,tests,bench},"
build=${BIDEX_GPU_BUILD:-/tmp/bidex-gpu-engine-build}
mkdir -p "$out"
SECONDS=0
parity=0

# build (CUDA code for the machine's GPU: sm_90 on H100 and H200 unless told otherwise; PyTorch's
# CMake config compiles its CUDA flags for TORCH_CUDA_ARCH_LIST, kept to the same one)
arch=${BIDEX_CUDA_ARCHITECTURES:-90}
export BIDEX_CMAKE_ARGS="-DBIDEX_CUDA_ARCHITECTURES=$arch ${BIDEX_CMAKE_ARGS:-}"
export TORCH_CUDA_ARCH_LIST=${TORCH_CUDA_ARCH_LIST:-9.0}
scripts/offline-build.sh build "$deps" "$build" >"$out/gpu_engine_build.log" 2>&1 || {
  tail -30 "$out/gpu_engine_build.log"; exit 1; }
tool="$build/sim/gpu/bidex_gpu_engine"
[ -x "$tool" ] || { echo "no $tool: was nvcc found? (see $out/gpu_engine_build.log)"; exit 1; }
echo "build: ${SECONDS}s"
nvidia-smi >"$out/nvidia-smi.txt" 2>&1

# parity on the GPU (exit status kept for the end)
if [[ $parts == *,parity,* ]]; then
  timeout 1200 "$tool" parity --out "$out/gpu_engine_parity.json" >"$out/gpu_engine_parity.txt" 2>&1
  parity=$?
  tail -1 "$out/gpu_engine_parity.txt"
  grep -E "FAIL|error" "$out/gpu_engine_parity.txt" | head -20
  echo "parity: ${SECONDS}s"
fi

# the same stages on the host (the CI tests of the engine)
if [[ $parts == *,tests,* ]]; then
  (cd "$build" && timeout 600 ./tests/bidex_tests "[gpu]") >"$out/gpu_engine_host_tests.log" 2>&1
  tail -2 "$out/gpu_engine_host_tests.log"
fi

# throughput: lanes per world and grid cap compared at 16k worlds, then 1k..64k worlds
if [[ $parts == *,bench,* ]]; then
  timeout 1800 "$tool" bench --out "$out/gpu_engine_bench.json" 2>&1 |
    tee "$out/gpu_engine_bench.txt"
fi
echo "total: ${SECONDS}s"
exit $parity
