#!/usr/bin/env bash
# Training on the GPU path (bidex train --device cuda), on a GPU machine without package
# access. One stage per call, so that a device session can be spent in slices:
#   bench/gpu_learn_run.sh build PARTS
#       join the bundle's parts (scripts/offline-build.sh bundle-gpu + split) and build bidex
#   bench/gpu_learn_run.sh physics OUTDIR TASKS WORLDS CANDIDATE...
#       the GPU's physics candidates side by side (bidex bench warp): each CANDIDATE is
#       SUBSTEPS:NJMAX:JACOBIAN (e.g. 4:128:dense), the gpu block of configs/sim/physics.yaml with
#       that step (1/60 s / SUBSTEPS), room and Jacobian; rates, overflows and rows needed
#       (BIDEX_GPU_PHYSICS=SUBSTEPS:NJMAX:JACOBIAN sets that gpu block for any stage)
#   bench/gpu_learn_run.sh step OUTDIR TASKS WORLDS NAME=FILE...
#       whole physics steps side by side (bidex bench warp --physics FILE): each FILE a physics
#       YAML that both backends step (integrator, substeps, contacts, room); rates of raw MuJoCo
#       Warp and of the whole task step, overflows, faults and rows needed, into
#       OUTDIR/step-NAME.json
#   bench/gpu_learn_run.sh pack OUTDIR [SUITE] [SLOTS]
#       the suite's train split packed on the GPU against each task alone (bidex bench pack)
#   bench/gpu_learn_run.sh profile OUTDIR TASKS SLOTS_LIST [UPDATES]
#       short runs with --profile: slot-steps/s split into physics, task kernels, policy, update
#       (a TASKS entry naming a suite, MT1, MT4 or MT20, trains multi-task PPO on it)
#   bench/gpu_learn_run.sh collect OUTDIR TASKS SLOTS [UPDATES]
#       PPO's collection rate (acting, stepping, copying) against the whole task step alone (bidex
#       bench warp) on each task's scene at SLOTS worlds, one after the other in one call
#   bench/gpu_learn_run.sh train OUTDIR TASK SLOTS SECONDS TARGET [--algo A] [-o key=value ...]
#       trains (or resumes the run of an earlier call) for SECONDS more, then writes the curve and
#       the wall time and slot-steps at which the mean training return first reached TARGET;
#       TASK may name a suite (MT1, MT4, MT20); results go to OUTDIR/TASK-ALGO (ALGO default ppo;
#       with --agents other than hand, OUTDIR/TASK-ALGO-AGENTS)
#   bench/gpu_learn_run.sh reference OUTDIR TASKS SLOTS SECONDS EPISODES [-o key=value ...]
#       single-task PPO ground-truth references: trains every task of TASKS at once, each for
#       SECONDS at SLOTS slots with the task's default configuration, then evaluates each final
#       policy (its mean action, EPISODES episodes on the CPU); OUTDIR/references.json holds
#       per task the slot-steps, the last training returns and the evaluation; a second call
#       with the same TASKS and SLOTS resumes the runs for SECONDS more
#   bench/gpu_learn_run.sh meta OUTDIR SUITE ALGO SLOTS SECONDS EPISODES [-o key=value ...]
#       meta-trains ALGO (maml, promp, rl2) on SUITE's train split for SECONDS (a second call with
#       the same SUITE, ALGO and SLOTS resumes the run), then evaluates the run on both splits
#       (bidex eval --split train|test, EPISODES slots per task, on the CPU; EPISODES 0: no
#       evaluation, for a slice of a longer run); results go to OUTDIR/SUITE-ALGO
# Results go to OUTDIR with the machine, date, commit ($BIDEX_COMMIT) and commands. The run
# folders stay on the machine under /tmp/bidex-gpu-runs ($BIDEX_GPU_RUNS). BIDEX_GPU_BUILD: the
# build folder. BIDEX_PHYSICS=FILE: every stage runs with that physics YAML as the default.
set -uo pipefail
cd "$(dirname "$0")/.."
build=${BIDEX_GPU_BUILD:-build-gpu}
bidex="$build/apps/bidex"
runs=${BIDEX_GPU_RUNS:-/tmp/bidex-gpu-runs}
stage=${1:?stage: build, physics, pack, profile, collect, train, reference or meta}
shift
SECONDS=0

machine() {
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>/dev/null \
    | head -1
}

# stamp FILE: adds machine, date, commit and command to a JSON file
stamp() {
  python3 - "$1" "$(machine)" "${BIDEX_COMMIT:-unknown}" "$2" <<'PY'
import json, sys, datetime
path, machine, commit, command = sys.argv[1:5]
d = json.load(open(path))
d.setdefault("machine", machine)
d["commit"] = commit
d["date"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
d.setdefault("command", command)
json.dump(d, open(path, "w"), indent=2)
PY
}

# gpu_block SUBSTEPS:NJMAX:JACOBIAN IN OUT: the physics YAML IN with its gpu block replaced
gpu_block() {
  python3 - "$@" <<'PY'
import sys
spec, src, dst = sys.argv[1:4]
sub, njmax, jac = spec.split(":")
text = open(src).read()
text = text[:text.index("\ngpu:")] + "\ngpu:\n"
text += f"  timestep: {1 / 60 / int(sub)!r}\n  substeps: {sub}\n  njmax: {njmax}\n"
text += f"  nconmax: 64\n  jacobian: {jac}\n"
open(dst, "w").write(text)
PY
}

if [[ -n ${BIDEX_PHYSICS:-} ]]; then
  cp "$BIDEX_PHYSICS" configs/sim/physics.yaml
  echo "physics: $BIDEX_PHYSICS"
fi

# warp_step OUT PREFIX NAME FILE TASKS WORLDS: bench warp on physics YAML FILE into
# OUT/PREFIX-NAME.json (and .log), stamped, with a line per task and world count
warp_step() {
  local out=$1 prefix=$2 name=$3 file=$4 tasks=$5 worlds=$6
  local json="$out/$prefix-$name.json"
  local cmd="bidex bench warp --task $tasks --worlds $worlds --seconds 1 --rounds 2"
  cmd+=" --determinism-steps 0 --physics $(basename "$file")"
  "$bidex" bench warp --task "$tasks" --worlds "$worlds" --seconds 1 --rounds 2 \
    --determinism-steps 0 --physics "$file" --out "$json" >"${json%.json}.log" 2>&1 \
    || { tail "${json%.json}.log"; return; }
  stamp "$json" "$cmd"
  python3 - "$json" "$name" <<'PY'
import json, sys
for r in json.load(open(sys.argv[1]))["results"]:
  print(f"{sys.argv[2]:>16} {r['task']:<20} {r['worlds']:>6} raw {r['raw_slot_steps_per_s']:>9.0f} "
        f"task {r.get('task_slot_steps_per_s', 0):>9.0f} overflows {r['overflows']} "
        f"faults {r['faults']} rows {r['max_rows']}/{r['njmax']}")
PY
}

# BIDEX_GPU_PHYSICS=SUBSTEPS:NJMAX:JACOBIAN: every stage runs with that gpu block
if [[ -n ${BIDEX_GPU_PHYSICS:-} ]]; then
  gpu_block "$BIDEX_GPU_PHYSICS" configs/sim/physics.yaml configs/sim/physics.yaml
  echo "gpu physics: $BIDEX_GPU_PHYSICS"
fi

case "$stage" in
build)
  parts=${1:?PARTS}
  deps=${BIDEX_GPU_DEPS:-/tmp/bidex-deps}
  scripts/offline-build.sh join "$parts" "$deps" >/tmp/join.log 2>&1 || { cat /tmp/join.log; exit 1; }
  BIDEX_BUILD_TARGETS=bidex scripts/offline-build.sh build "$deps" "$build" >/tmp/build.log 2>&1 \
    || { tail -40 /tmp/build.log; exit 1; }
  echo "build: ${SECONDS}s"
  ;;
physics)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; worlds=${3:?WORLDS}
  shift 3
  mkdir -p "$out"
  for cand in "$@"; do
    IFS=: read -r sub njmax jac <<<"$cand"
    gpu_block "$cand" configs/sim/physics.yaml "$out/physics-$sub-$njmax-$jac.yaml"
    warp_step "$out" physics "$sub-$njmax-$jac" "$out/physics-$sub-$njmax-$jac.yaml" "$tasks" "$worlds"
  done
  echo "physics: ${SECONDS}s"
  ;;
step)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; worlds=${3:?WORLDS}
  shift 3
  mkdir -p "$out"
  for cand in "$@"; do
    warp_step "$out" step "${cand%%=*}" "$(realpath "${cand#*=}")" "$tasks" "$worlds"
  done
  echo "step: ${SECONDS}s"
  ;;
pack)
  out=$(realpath -m "${1:?OUTDIR}"); suite=${2:-MT20}; slots=${3:-16384}
  mkdir -p "$out"
  cmd="bidex bench pack --suite $suite --slots $slots --device cuda --seconds 1 --rounds 1"
  "$bidex" bench pack --suite "$suite" --slots "$slots" --device cuda --seconds 1 --rounds 1 \
    --out "$out/pack-$suite-$slots.json" 2>"$out/pack-$suite-$slots.log" || { tail "$out/pack-$suite-$slots.log"; exit 1; }
  echo "bench pack: ${SECONDS}s"
  ;;
profile)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; slots_list=${3:?SLOTS_LIST}
  updates=${4:-12}
  mkdir -p "$out" "$runs"
  for task in ${tasks//,/ }; do
    for slots in ${slots_list//,/ }; do
      run="$runs/profile-$task-$slots-$(date +%s)"
      if [[ $task == MT* ]]; then target=(--suite "$task" --algo mtppo); else target=(--task "$task"); fi
      args=(train "${target[@]}" --device cuda -o env.slots="$slots" --run "$run" --no-registry
            --stop-after "$updates" --profile)
      "$bidex" "${args[@]}" >"$out/profile-$task-$slots.txt" 2>/dev/null
      cp "$run/profile.json" "$out/profile-$task-$slots.json"
      stamp "$out/profile-$task-$slots.json" "bidex ${args[*]}"
      echo "$task $slots: $(python3 -c "import json;print(round(json.load(open('$out/profile-$task-$slots.json'))['slot_steps_per_s']))") slot-steps/s"
    done
  done
  echo "profile: ${SECONDS}s"
  ;;
collect)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; slots=${3:?SLOTS}; updates=${4:-12}
  mkdir -p "$out" "$runs"
  for task in ${tasks//,/ }; do
    sim="$out/collect-$task-$slots-sim.json"
    "$bidex" bench warp --task "$task" --worlds "$slots" --seconds 3 --rounds 1 \
      --determinism-steps 0 --out "$sim" >/dev/null 2>&1 || { echo "bench warp $task failed"; exit 1; }
    run="$runs/collect-$task-$slots-$(date +%s)"
    args=(train --task "$task" --device cuda -o env.slots="$slots" --run "$run" --no-registry
          --stop-after "$updates" --profile)
    "$bidex" "${args[@]}" >"$out/collect-$task-$slots.log" 2>&1  # a stopped run exits non-zero
    [[ -f "$run/profile.json" ]] || { tail "$out/collect-$task-$slots.log"; exit 1; }
    cp "$run/profile.json" "$out/collect-$task-$slots-profile.json"
    python3 - "$out" "$task" "$slots" "$(machine)" "${BIDEX_COMMIT:-unknown}" "bidex ${args[*]}" <<'PY'
import json, sys, datetime
out, task, slots, machine, commit, command = sys.argv[1:7]
sim = json.load(open(f"{out}/collect-{task}-{slots}-sim.json"))["results"][0]
prof = json.load(open(f"{out}/collect-{task}-{slots}-profile.json"))
sec = prof["seconds"]
rollout = sec["simulation"] + sec["policy"]
collect = prof["slot_steps"] / rollout
d = {
  "what": "PPO's collector on the GPU path (policy acting, the pack's step, the copies of the "
          "rows) against simulation only: the whole task step alone with random inputs (bidex "
          "bench warp) and the pack's own steps inside the same training run",
  "machine": machine, "commit": commit,
  "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
  "commands": [f"bidex bench warp --task {task} --worlds {slots} --seconds 3 --rounds 1 "
               "--determinism-steps 0", command],
  "task": task, "slots": int(slots), "updates": prof["updates"],
  "collect_slot_steps_per_s": collect,
  "sim_only_slot_steps_per_s": sim["task_slot_steps_per_s"],
  "in_run_sim_slot_steps_per_s": prof["slot_steps"] / sec["simulation"],
  "ratio_collect_to_sim_only": collect / sim["task_slot_steps_per_s"],
  "ratio_collect_to_in_run_sim": sec["simulation"] / rollout,
  "profile_seconds": sec,
}
json.dump(d, open(f"{out}/collect-{task}-{slots}.json", "w"), indent=2)
print(task, slots, "collect/sim-only", round(d["ratio_collect_to_sim_only"], 3),
      "collect/in-run sim", round(d["ratio_collect_to_in_run_sim"], 3))
PY
  done
  echo "collect: ${SECONDS}s"
  ;;
train)
  out=$(realpath -m "${1:?OUTDIR}"); task=${2:?TASK}; slots=${3:?SLOTS}; budget=${4:?SECONDS}
  target=${5:?TARGET}
  shift 5
  algo=ppo agents=
  for ((i = 1; i < $#; ++i)); do
    j=$((i + 1))
    [[ ${!i} == --algo ]] && algo=${!j}
    [[ ${!i} == --agents && ${!j} != hand ]] && agents=-$(basename "${!j}" .yaml)
  done
  name="$task-$algo$agents"
  mkdir -p "$out/$name" "$runs"
  run="$runs/$name-$slots"
  if [[ $task == M[TL]* ]]; then target_args=(--suite "$task"); else target_args=(--task "$task"); fi
  if [[ -f "$run/config.yaml" ]]; then
    args=(train --resume "$run" --device cuda --no-registry --time-limit "$budget")
  else
    args=(train "${target_args[@]}" --device cuda -o env.slots="$slots" --run "$run"
          --no-registry --time-limit "$budget" "$@")
  fi
  "$bidex" "${args[@]}" 2>"$out/$name/progress.log" | tee -a "$out/$name/train.txt"
  echo "bidex ${args[*]}" >>"$out/$name/commands.txt"
  cp "$run"/{config.yaml,run.json,metrics.csv,learning_curve.svg,summary.json} "$out/$name/"
  python3 - "$out/$name" "$target" "$(machine)" "${BIDEX_COMMIT:-unknown}" "$algo" <<'PY'
import csv, json, sys, datetime
d, target, machine, commit, algo = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
rows = [r for r in csv.DictReader(open(f"{d}/metrics.csv")) if r["return"] != ""]
hit = next((r for r in rows if float(r["return"]) >= target), None)
last = rows[-10:]
fps = sorted(float(r["fps"]) for r in rows[3:] or rows)
out = {
  "what": f"{algo} with the simulation and the learner on the GPU: mean training return per "
          "update, and the first update whose mean return reached the target",
  "algo": algo,
  "machine": machine, "commit": commit,
  "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
  "commands": open(f"{d}/commands.txt").read().splitlines(),
  "target_return": target,
  "reached": hit is not None,
  "reached_at": None if hit is None else {"wall_s": float(hit["wall_s"]),
                                          "slot_steps": int(float(hit["steps"])),
                                          "return": float(hit["return"])},
  "slot_steps": int(float(rows[-1]["steps"])) if rows else 0,
  "wall_s": float(rows[-1]["wall_s"]) if rows else 0,
  "train_fps_median": fps[len(fps) // 2] if fps else None,
  "return_last_10_updates": sum(float(r["return"]) for r in last) / len(last) if last else None,
}
json.dump(out, open(f"{d}/time_to_target.json", "w"), indent=2)
print(json.dumps(out, indent=1))
PY
  echo "train: ${SECONDS}s"
  ;;
reference)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; slots=${3:?SLOTS}; budget=${4:?SECONDS}
  episodes=${5:?EPISODES}
  shift 5
  mkdir -p "$out" "$runs"
  for task in ${tasks//,/ }; do
    mkdir -p "$out/$task"
    run="$runs/ref-$task-$slots"
    if [[ -f "$run/config.yaml" ]]; then  # an earlier call's run: SECONDS more
      args=(train --resume "$run" --device cuda --no-registry --time-limit "$budget")
    else
      args=(train --task "$task" --device cuda -o env.slots="$slots" --run "$run" --no-registry
            --time-limit "$budget" "$@")
    fi
    echo "bidex ${args[*]}" >>"$out/$task/commands.txt"
    "$bidex" "${args[@]}" >>"$out/$task/train.txt" 2>>"$out/$task/progress.log" &
  done
  wait  # a run stopped by --time-limit exits 130
  for task in ${tasks//,/ }; do
    run="$runs/ref-$task-$slots"
    cp "$run"/{config.yaml,run.json,metrics.csv,learning_curve.svg} "$out/$task/" 2>/dev/null
    args=(eval --run "$run" --episodes "$episodes" --seed 2026 --threads 4
          --json "$out/$task/eval.json")
    echo "bidex ${args[*]}" >>"$out/$task/commands.txt"
    "$bidex" "${args[@]}" >"$out/$task/eval.txt" 2>&1 &
  done
  wait
  python3 - "$out" "$tasks" "$(machine)" "${BIDEX_COMMIT:-unknown}" <<'PY'
import csv, json, os, sys, datetime
out, tasks, machine, commit = sys.argv[1], sys.argv[2].split(","), sys.argv[3], sys.argv[4]
d = {"what": "single-task PPO on the GPU path (all tasks trained at once on one GPU), then "
             "each final policy's mean action evaluated on the CPU: ground-truth references",
     "machine": machine, "commit": commit,
     "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
     "tasks": {}}
for t in tasks:
  f = f"{out}/{t}"
  rows = [r for r in csv.DictReader(open(f"{f}/metrics.csv")) if r["return"] != ""] \
      if os.path.exists(f"{f}/metrics.csv") else []
  ev = json.load(open(f"{f}/eval.json")) if os.path.exists(f"{f}/eval.json") else None
  last = rows[-10:]
  d["tasks"][t] = {
    "commands": open(f"{f}/commands.txt").read().splitlines(),
    "slot_steps": int(float(rows[-1]["steps"])) if rows else 0,
    "wall_s": float(rows[-1]["wall_s"]) if rows else 0,
    "train_return_last_10_updates": sum(float(r["return"]) for r in last) / len(last) if last else None,
    "eval_return": ev["mean_return"] if ev else None,
    "eval_std": ev["std_return"] if ev else None,
    "eval_success": ev["success_rate"] if ev else None,
    "eval_episodes": ev["episodes"] if ev else 0,
    "eval_faults": ev["faults"] if ev else None}
  print(t, json.dumps(d["tasks"][t]))
json.dump(d, open(f"{out}/references.json", "w"), indent=2)
PY
  echo "reference: ${SECONDS}s"
  ;;
meta)
  out=$(realpath -m "${1:?OUTDIR}"); suite=${2:?SUITE}; algo=${3:?ALGO}; slots=${4:?SLOTS}
  budget=${5:?SECONDS}; episodes=${6:?EPISODES}
  shift 6
  name="$suite-$algo"
  mkdir -p "$out/$name" "$runs"
  run="$runs/$name-$slots"
  reg="$runs/registry.sqlite"
  if [[ -f "$run/config.yaml" ]]; then
    args=(train --resume "$run" --device cuda --registry "$reg" --time-limit "$budget")
  else
    args=(train --suite "$suite" --algo "$algo" --device cuda -o env.slots="$slots" --run "$run"
          --registry "$reg" --time-limit "$budget" "$@")
  fi
  "$bidex" "${args[@]}" 2>"$out/$name/progress.log" | tee -a "$out/$name/train.txt"
  echo "bidex ${args[*]}" >>"$out/$name/commands.txt"
  cp "$run"/{config.yaml,run.json,metrics.csv,learning_curve.svg,summary.json} "$out/$name/"
  ((episodes > 0)) || { echo "meta: ${SECONDS}s (not evaluated)"; exit 0; }
  for split in train test; do
    eargs=(eval --run "$run" --split "$split" --episodes "$episodes" --registry "$reg"
           --json "$out/$name/eval-$split.json")
    "$bidex" "${eargs[@]}" | tee -a "$out/$name/eval.txt"
    echo "bidex ${eargs[*]}" >>"$out/$name/commands.txt"
    stamp "$out/$name/eval-$split.json" "bidex ${eargs[*]}"
  done
  echo "meta: ${SECONDS}s"
  ;;
*)
  echo "unknown stage $stage (build, physics, pack, profile, collect, train, reference or meta)" >&2
  exit 2
  ;;
esac
