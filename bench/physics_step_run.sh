#!/usr/bin/env bash
# The physics-step study's GPU half (sim/README.md, "The physics step"), on a GPU machine
# without package access, in slices that fit one device call each:
#   bench/physics_step_run.sh speed OUTDIR PARTS
#       build from the bundle's parts, then each candidate step of bench/results/physics-step/
#       (physics-NAME.yaml) on catch_underarm and hand_over at 16,384 worlds (bench warp: raw
#       MuJoCo Warp and the whole task step), and the CPU path on the machine's cores (bench
#       task, 2,048 slots), the old step against the new
#   bench/physics_step_run.sh learn OUTDIR NAME SECONDS TASK...
#       PPO at the paper's settings (16,384 slots, 16 minibatches; hand_over without its goal
#       bonus, as the original) on candidate NAME's step, the tasks side by side on the GPU
#   bench/physics_step_run.sh check OUTDIR NAME TASKS
#       candidate NAME's step: CPU and GPU agree under a random policy and 1M fault-checked
#       random-action slot-steps per task on the GPU (bench/gpu_check.sh)
# BIDEX_COMMIT names the commit in the results.
set -uo pipefail
cd "$(dirname "$0")/.."
stage=${1:?stage: speed, learn or check}
out=$(realpath -m "${2:?OUTDIR}")
shift 2
dir=bench/results/physics-step
build=${BIDEX_GPU_BUILD:-build-gpu}
mkdir -p "$out"
case "$stage" in
speed)
  parts=${1:?PARTS}
  BIDEX_CMAKE_ARGS="${BIDEX_CMAKE_ARGS:--DBIDEX_RENDER_GL=NONE}" bench/gpu_learn_run.sh build "$parts" || exit 1
  cands=()
  for f in "$dir"/physics-*.yaml; do n=$(basename "$f" .yaml); cands+=("${n#physics-}=$f"); done
  bench/gpu_learn_run.sh step "$out" catch_underarm,hand_over 16384 "${cands[@]}"
  for c in "${cands[@]}"; do
    n=${c%%=*}
    "$build/apps/bidex" bench task --task catch_underarm,hand_over --slots 2048 --seconds 3 \
      --no-profile --physics "${c#*=}" --out "$out/cpu-$n.json" 2>/dev/null
    python3 -c "import json,sys;[print('$n cpu',r['task'],round(r['slot_steps_per_s'])) for r in json.load(open('$out/cpu-$n.json'))['results']]"
  done
  ;;
learn)
  name=${1:?NAME}; seconds=${2:?SECONDS}; shift 2
  sed 's/^\(  goal_bonus:\) *[0-9.]*/\1 0/' tasks/hand_over/hand_over.yaml >/tmp/hand_over-nobonus.yaml
  for task in "$@"; do
    extra=(); [[ $task == hand_over ]] && extra=(-o env.task_config=/tmp/hand_over-nobonus.yaml)
    target=$(python3 -c "print({'hand_over': 30.8, 'catch_underarm': 17.8}.get('$task', 1e9))")
    BIDEX_PHYSICS="$dir/physics-$name.yaml" BIDEX_GPU_RUNS="/tmp/bidex-gpu-runs/$name" \
      bench/gpu_learn_run.sh train "$out/$name" "$task" 16384 "$seconds" "$target" \
      -o ppo.minibatches=16 -o train.save_interval=20 "${extra[@]}" >"$out/$name-$task.log" 2>&1 &
    sleep 20  # one process at a time writes configs/sim/physics.yaml
  done
  wait
  tail -n 3 "$out"/*.log
  ;;
check)
  name=${1:?NAME}; tasks=${2:?TASKS}
  cp "$dir/physics-$name.yaml" configs/sim/physics.yaml
  BIDEX="$build/apps/bidex" bench/gpu_check.sh "$out" "$tasks"
  ;;
*)
  echo "unknown stage $stage (speed, learn or check)" >&2
  exit 2
  ;;
esac
