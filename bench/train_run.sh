#!/usr/bin/env bash
# PPO on a GPU machine without package access (16 cores, one GPU): build from the bundled Debian
# packages against the local PyTorch (CUDA LibTorch), measure the task's simulation-only
# slot-steps/s at the training slot count, then train for a wall-time budget and evaluate; results
# go to OUTDIR/<task>/ (the run's config, metrics, curve and a summary.json; the weights stay on
# the machine, in /tmp/bidex-runs).
#   bench/train_run.sh OUTDIR DEPS TASK SECONDS [SLOTS] [-o key=value ...]
set -uo pipefail
cd "$(dirname "$0")/.."
out=$(realpath -m "$1"); deps=$2; task=$3; budget=$4; slots=${5:-2048}
shift 5 2>/dev/null || shift $#
build=${BIDEX_GPU_BUILD:-/tmp/bidex-gpu-build}
mkdir -p "$out/$task"
SECONDS=0
if [ ! -x "$build/apps/bidex" ] || [ -n "${BIDEX_REBUILD:-}" ]; then
  scripts/offline-build.sh build "$deps" "$build" >"$out/build.log" 2>&1 || { tail -30 "$out/build.log"; exit 1; }
  echo "build: ${SECONDS}s"
fi
bidex="$build/apps/bidex"
run=/tmp/bidex-runs/$task-$(date +%s)
# simulation only (random actions), same slots and threads, just before training
"$bidex" bench task --task "$task" --slots "$slots" --seconds 10 --out "$out/$task/sim_only.json" >/dev/null
"$bidex" train --task "$task" -o env.slots="$slots" -o train.save_interval=50 --run "$run" \
  --time-limit "$budget" "$@" 2>"$out/$task/progress.log" | tee "$out/$task/train.txt"
"$bidex" eval --run "$run" --episodes 256 --json "$out/$task/eval.json" | tee -a "$out/$task/train.txt"
cp "$run"/{config.yaml,run.json,metrics.csv,learning_curve.svg} "$out/$task/"
python3 bench/train_summary.py "$out/$task" "$run" "$out/$task/summary.json"
echo "total: ${SECONDS}s"
