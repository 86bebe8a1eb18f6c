#!/usr/bin/env bash
# The GPU backend's measurements on a GPU machine without package access: join the bundle's
# parts (scripts/offline-build.sh bundle-gpu + split), build once, then `bidex bench warp` on the
# given tasks' scenes and world counts; results and logs go to OUTDIR.
#   bench/warp_run.sh PARTS OUTDIR [TASKS] [WORLDS]
# The first MuJoCo Warp run on a fresh machine compiles its kernels (minutes; cached under
# ~/.cache/warp). BIDEX_GPU_BUILD: the build folder (default build-gpu, kept between calls).
set -uo pipefail
cd "$(dirname "$0")/.."
parts=${1:?PARTS: the folder of bidex-deps.tar.part* files}
out=$(realpath -m "${2:-bench/results/new}")
tasks=${3:-catch_underarm,hand_over}
worlds=${4:-2048,8192,16384}
build=${BIDEX_GPU_BUILD:-build-gpu}
deps=${BIDEX_GPU_DEPS:-/tmp/bidex-deps}
mkdir -p "$out"

SECONDS=0
if [[ ! -x "$build/apps/bidex" ]]; then
  scripts/offline-build.sh join "$parts" "$deps" >"$out/join.log" 2>&1 || { cat "$out/join.log"; exit 1; }
  BIDEX_BUILD_TARGETS=bidex scripts/offline-build.sh build "$deps" "$build" >"$out/build.log" 2>&1 \
    || { tail -40 "$out/build.log"; exit 1; }
  echo "build: ${SECONDS}s"
fi
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader >"$out/gpu.txt" 2>&1
"$build/apps/bidex" bench warp --task "$tasks" --worlds "$worlds" ${BIDEX_WARP_ARGS:-} \
  --out "$out/warp-$(echo "$tasks" | tr ',' '.')-$(echo "$worlds" | tr ',' '.').json"
echo "bench warp: ${SECONDS}s"
