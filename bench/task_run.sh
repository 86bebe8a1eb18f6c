#!/usr/bin/env bash
# Task throughput on a GPU machine without package access (16 cores): build from the bundled
# Debian packages against the local PyTorch, then measure slot-steps/s of every task at 2,048 and
# 8,192 slots with a profile, and run the test suite; results go to OUTDIR.
#   bench/task_run.sh [OUTDIR] [DEPS]   (DEPS: folder of .debs from scripts/offline-build.sh bundle)
set -uo pipefail
cd "$(dirname "$0")/.."
out=$(realpath -m "${1:-bench/results/new}")
deps=${2:-.deps}
build=${BIDEX_GPU_BUILD:-/tmp/bidex-gpu-build}
tasks=${BIDEX_TASKS:-hand_over,catch_underarm,catch_over2underarm,catch_abreast,two_catch_underarm}
mkdir -p "$out"

SECONDS=0
scripts/offline-build.sh build "$deps" "$build" >"$out/build.log" 2>&1 || { tail -30 "$out/build.log"; exit 1; }
echo "build: ${SECONDS}s"
bidex="$build/apps/bidex"
"$bidex" bench task --task "$tasks" --slots 2048,8192 --seconds 3 --out "$out/bench_task.json"
echo "bench task: ${SECONDS}s"
if [ -n "${BIDEX_CTEST:-}" ]; then
  (cd "$build" && ctest --output-on-failure -j8) >"$out/ctest.log" 2>&1
  tail -3 "$out/ctest.log"
fi
echo "total: ${SECONDS}s"
