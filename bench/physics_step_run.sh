#!/usr/bin/env bash
# The physics-step study's GPU half (sim/README.md, "The physics step"), on a GPU machine
# without package access, in slices that fit one device call each:
#   bench/physics_step_run.sh speed OUTDIR PARTS
#       build from the bundle's parts, then each candidate step of bench/results/physics-step/
#       (physics-NAME.yaml) on catch_underarm and hand_over at 16,384 worlds (bench warp: raw
#       MuJoCo Warp and the whole task step), and the CPU path on the machine's cores (bench
#       task, 2,048 slots), the old step against the new
#   bench/physics_step_run.sh build OUTDIR PARTS
#       join the bundle's parts and build bidex (bench/gpu_learn_run.sh build)
#   bench/physics_step_run.sh phases OUTDIR TASKS NAME...
#       candidate NAME's step on TASKS at 16,384 worlds (bench warp --phases): rates, and the
#       shares of a substep's GPU time in collision, constraint rows and the solver
#   bench/physics_step_run.sh learn OUTDIR NAME SEED STEPS TASK...
#       PPO at the paper's settings (16,384 slots, 16 minibatches; hand_over without its goal
#       bonus, as the original) on candidate NAME's step (env.physics), seed SEED, STEPS
#       slot-steps, the tasks side by side on the GPU (CUDA_VISIBLE_DEVICES picks it); then each
#       final policy's mean action on the CPU path (bidex eval, 256 episodes, the run's step)
#   bench/physics_step_run.sh check OUTDIR NAME TASKS
#       candidate NAME's step: CPU and GPU agree under a random policy and 1M fault-checked
#       random-action slot-steps per task on the GPU (bench/gpu_check.sh), faults by kind
# BIDEX_COMMIT names the commit in the results.
set -uo pipefail
cd "$(dirname "$0")/.."
stage=${1:?stage: build, phases, speed, learn or check}
out=$(realpath -m "${2:?OUTDIR}")
shift 2
dir=bench/results/physics-step
build=${BIDEX_GPU_BUILD:-build-gpu}
mkdir -p "$out"
# build_from PARTS: the bundle's parts joined and bidex built, without the renderer
build_from() {
  BIDEX_CMAKE_ARGS="${BIDEX_CMAKE_ARGS:--DBIDEX_RENDER_GL=NONE}" bench/gpu_learn_run.sh build "$1"
}
case "$stage" in
build)
  build_from "${1:?PARTS}"
  ;;
phases)
  tasks=${1:?TASKS}; shift
  for name in "$@"; do
    json="$out/phases-$name.json"
    "$build/apps/bidex" bench warp --task "$tasks" --worlds 16384 --seconds 1 --rounds 1 \
      --determinism-steps 0 --phases 20 --physics "$dir/physics-$name.yaml" --out "$json" \
      >"$out/phases-$name.log" 2>&1 || { tail "$out/phases-$name.log"; continue; }
    python3 - "$json" "$name" <<'PY'
import json, sys
for r in json.load(open(sys.argv[1]))["results"]:
  ms = r["phase_ms"]
  print(f"{sys.argv[2]:>10} {r['task']:<18} raw {r['raw_slot_steps_per_s']:>8.0f} "
        f"task {r.get('task_slot_steps_per_s', 0):>8.0f} substep {ms.get('step', 0):.3f} ms: "
        f"collision {r['collision_share']:.2f} constraints {r['make_constraint_share']:.2f} "
        f"solver {r['solver_share']:.2f} faults {r['faults']}/{r.get('task_faults')} "
        f"{r['fault_kinds']}{r.get('task_fault_kinds', {})}")
PY
  done
  ;;
speed)
  build_from "${1:?PARTS}" || exit 1
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
  name=${1:?NAME}; seed=${2:?SEED}; steps=${3:?STEPS}; shift 3
  physics=$(realpath "$dir/physics-$name.yaml")
  sed 's/^\(  goal_bonus:\) *[0-9.]*/\1 0/' tasks/hand_over/hand_over.yaml >/tmp/hand_over-nobonus.yaml
  runs=/tmp/bidex-gpu-runs/$name-s$seed
  for task in "$@"; do
    extra=(); [[ $task == hand_over ]] && extra=(-o env.task_config=/tmp/hand_over-nobonus.yaml)
    target=$(python3 -c "print({'hand_over': 30.8, 'catch_underarm': 17.8}.get('$task', 1e9))")
    ( BIDEX_GPU_RUNS=$runs bench/gpu_learn_run.sh train "$out/$name-s$seed" "$task" 16384 100000 \
        "$target" -o ppo.minibatches=16 -o train.save_interval=20 -o seed="$seed" \
        -o train.steps="$steps" -o env.physics="$physics" "${extra[@]}" >"$out/$name-s$seed-$task.log" 2>&1
      "$build/apps/bidex" eval --run "$runs/$task-ppo-16384" --episodes 256 \
        --json "$out/$name-s$seed/$task-ppo/eval-cpu.json" >>"$out/$name-s$seed-$task.log" 2>&1 ) &
  done
  wait
  tail -n 4 "$out"/$name-s$seed-*.log
  ;;
check)
  name=${1:?NAME}; tasks=${2:?TASKS}
  cp "$dir/physics-$name.yaml" configs/sim/physics.yaml
  BIDEX="$build/apps/bidex" bench/gpu_check.sh "$out" "$tasks"
  ;;
*)
  echo "unknown stage $stage (build, phases, speed, learn or check)" >&2
  exit 2
  ;;
esac
