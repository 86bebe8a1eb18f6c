#!/usr/bin/env bash
# One full measurement on a GPU machine without package access: build from the bundled Debian
# packages against the local PyTorch, then run the simulation benchmark, the 1M slot-step soak
# and the test suite, writing every result into OUTDIR (default bench/results/new).
#   bench/gpu_run.sh [OUTDIR] [DEPS]      (DEPS: folder of .debs from scripts/offline-build.sh bundle)
set -uo pipefail
cd "$(dirname "$0")/.."
out=$(realpath -m "${1:-bench/results/new}")
deps=${2:-.deps}
build=${BIDEX_GPU_BUILD:-/tmp/bidex-gpu-build}
mkdir -p "$out"

SECONDS=0
scripts/offline-build.sh build "$deps" "$build" >"$out/build.log" 2>&1 || { tail -30 "$out/build.log"; exit 1; }
echo "build: ${SECONDS}s"
bidex="$build/apps/bidex"

# throughput: batch vs plain mj_step loop at each thread and slot count, memory at 8192 slots
"$bidex" bench sim --threads 1,2,4,8,16 --slots 256,2048,8192 --seconds 1 --rounds 2 \
  --memory-slots 8192 --out "$out/bench_sim.json"
echo "bench sim: ${SECONDS}s"
# faults: one million random-action slot-steps on all cores
"$bidex" bench soak --slots 2048 --slot-steps 1000000 --out "$out/soak.json"
echo "soak: ${SECONDS}s"
# the main job, with tensors on the GPU
"$bidex" sim --slots 2048 --steps 120 2>&1 | tee "$out/sim.txt"
# the test suite must pass here too (it needs no GPU)
(cd "$build" && ctest --output-on-failure -j4) >"$out/ctest.log" 2>&1
tail -3 "$out/ctest.log"
echo "total: ${SECONDS}s"
