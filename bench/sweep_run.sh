#!/usr/bin/env bash
# The PPO sweep of all twenty tasks (tasks/README.md, "The PPO sweep") on a GPU machine without
# package access, in slices that fit one device call each:
#   bench/sweep_run.sh build OUTDIR PARTS
#       join the bundle's parts and build bidex (bench/physics_step_run.sh build)
#   bench/sweep_run.sh start OUTDIR SECONDS LANE...
#       LANE is GPU=RUN,RUN,... and RUN is TASK[/sSEED][/mMILLIONS][/aALGO][/cNAME][/oNAME][/e[NAME]]...
#       (TASK may be a suite of configs/suites: multi-task PPO on its pack at $SWEEP_SUITE_SLOTS
#       slots, default 65,536, evaluated over $SWEEP_SUITE_EPISODES episodes a task, default 64, 0
#       for none, stopping $SWEEP_SUITE_RESERVE seconds before the deadline, default 600; a suite's
#       run is never extended): aALGO trains with `bidex train --algo ALGO` at the slots and
#       settings of configs/train/ALGO.yaml in place of (multi-task) PPO's (e.g.
#       MT4/amtsac/osac_replay); seed (0 by
#       default), slot-steps in millions (default $SWEEP_STEPS), a task YAML bench/sweep/NAME.yaml
#       in place of the task's default (env.task_config) and training overrides
#       bench/sweep/NAME.overrides (KEY=VALUE lines, each given as -o after the sweep's own; the
#       files say why; e: the final policy also scored under the task's own YAML, as
#       eval-default.json, for a run trained under another; eNAME: also under
#       bench/sweep/NAME.yaml, as eval-NAME.json, e.g. a curriculum held at one level; any number
#       of e parts). Each lane runs
#       in its own process session (it outlives the device call), its runs one after the other
#       on that GPU (CUDA_VISIBLE_DEVICES): PPO at the paper's settings with 16,384 slots and 16
#       minibatches (the task's section of configs/train/ppo.yaml applies; one that sets the
#       task's slots keeps its slots and minibatches) to $SWEEP_STEPS
#       slot-steps (default 50M), then the final policy's mean action over 256 episodes on the
#       CPU path (under the task's own YAML when NAME.yaml turns a curriculum on). Once every
#       lane of its GPU is through its runs, a lane that has time left resumes, towards 100M,
#       its runs of fewer slot-steps whose return or success still rose over their last 10M
#       slot-steps, and evaluates them again. Every run stops training $SWEEP_RESERVE s
#       (default 240) before the deadline, SECONDS after this call, whatever it has reached,
#       and is evaluated by the deadline (a suite's run: $SWEEP_SUITE_RESERVE, below). start
#       prints both times.
#   bench/sweep_run.sh wait OUTDIR SECONDS
#       waits up to SECONDS for the lanes, printing each run's slot-steps and return each minute;
#       returns as soon as every lane is done (its last line: "all N lanes done")
#   bench/sweep_run.sh stop OUTDIR RUN...
#       stops those runs for good (their lanes end; each run writes a checkpoint and keeps its
#       folder), to give the GPU to the others; noted in OUTDIR/stopped.txt
#   bench/sweep_run.sh collect OUTDIR
#       per run OUTDIR/RUN/ (which holds its commands, logs and eval.json from the start):
#       config.yaml, run.json, metrics.csv.xz (bench/metrics_io.py), learning_curve.svg, summary.json and
#       time_to_target.json; OUTDIR/sweep.json
#       (bench/sweep_table.py makes the table and the grid figure from it)
#   bench/sweep_run.sh pack OUTDIR DEST
#       OUTDIR as DEST/sweep.tgz, without the training logs, and those logs as DEST/logs.tgz
#   bench/sweep_run.sh keep OUTDIR RUN DEST [FIRST [COUNT]]
#       a run folder to carry into a later lease (run folders do not outlive a lease; copied from
#       the call's files into an ignored folder of the checkout such as .whl/keep, the parts have
#       outlived sessions so far, without a promise that they will; MT20's checkpoint is 86 MB):
#       the folder with its newest checkpoint only, as RUN.tar.partNN of
#       15 MiB in DEST, parts FIRST.. (default 0), COUNT of them (default all; a device call
#       brings back at most 64 MiB in at most 8 files: four parts and their .sha256 leave three
#       files for the rest of $OUT; bench/carry.sh). `bench/carry.sh recut NAME PARTS 25M` (NAME:
#       RUN with - for /) then cuts them into fewer parts for the calls that carry them in
#   bench/sweep_run.sh bring OUTDIR RUN PARTS
#       the parts of `keep` (in PARTS, all of them) joined back into RUN's run folder, which a
#       later `start` of RUN resumes
# Run folders stay on the machine under $SWEEP_RUNS (default /tmp/bidex-sweep). BIDEX_COMMIT
# names the commit in the results: `start` keeps it in OUTDIR/commit for `collect`, which takes
# its own BIDEX_COMMIT first (a later device call's shell no longer has the start's);
# BIDEX_GPU_BUILD is the build folder (default build-gpu).
# $SWEEP_REGISTRY: a registry file the runs and their evaluations are recorded in (put it in
# OUTDIR and `pack` brings it back; `bidex registry scores|evals|report age --registry FILE` then
# read it); unset, nothing is recorded. A meta-RL suite's run (mode: meta, e.g. ML20/apromp) is
# evaluated on both splits before and after adaptation, $SWEEP_META_EPISODES slots a task
# (default 8), as eval-train.json and eval-test.json, the one-episode protocol; with
# $SWEEP_META_ADAPT=N also on the test split after N adaptation episodes (and N gradient steps
# for MAML and ProMP), as eval-test-adaptN.json, a row of its own.
set -uo pipefail
cd "$(dirname "$0")/.."
stage=${1:-}
if [[ -z "$stage" || "$stage" == -h || "$stage" == --help ]]; then
  sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
out=$(realpath -m "${2:?OUTDIR}")
shift 2
build=${BIDEX_GPU_BUILD:-build-gpu}
bidex=$(realpath -m "$build/apps/bidex")
runs=${SWEEP_RUNS:-/tmp/bidex-sweep}
steps=${SWEEP_STEPS:-50000000}
slots=${SWEEP_SLOTS:-16384}    # SWEEP_SLOTS and SWEEP_DEVICE=cpu: a small rehearsal without a GPU
device=${SWEEP_DEVICE:-cuda}
# seconds a run stops before the deadline, for its evaluation (256 episodes on 8 threads: 2-19 s
# each in the eighteenth lease, two at a time on 32 cores, eval.txt in bench/results/sweep-h200x2;
# more with eight lanes evaluating at once); a lease with few lanes can keep less
reserve=${SWEEP_RESERVE:-240}
mkdir -p "$out" "$runs"

suite_slots=${SWEEP_SUITE_SLOTS:-65536}     # a suite's slots in all (the MT20 pack's efficient size)
suite_episodes=${SWEEP_SUITE_EPISODES:-64}  # a suite's evaluation: episodes per task
# seconds a suite's run stops before the deadline, for its evaluation (64 episodes of each of
# twenty tasks on 8 threads takes minutes). Every run gets --wall-limit, which counts its setup
# (the scenes, Warp's kernel compilation) as well: under --time-limit, which counts training
# only, an MT20 run ended 211 s after its planned stop (214 s of setup;
# bench/results/suites-h100x4/README.md) and the seventeenth lease's catch runs 94 s after theirs
suite_reserve=${SWEEP_SUITE_RESERVE:-600}
for v in reserve suite_reserve; do
  [[ ${!v} =~ ^[0-9]+$ ]] && ((${!v} >= 10)) || {
    echo "sweep_run: SWEEP_${v^^} must be a whole number of seconds, at least 10, not '${!v}'" >&2
    exit 2
  }
done

# is_suite NAME: exit 0 when NAME is a suite of configs/suites (MT20: multi-task PPO on its pack)
is_suite() { [[ -f configs/suites/$1.yaml ]]; }

# is_meta NAME: exit 0 when NAME is a meta-RL suite (mode: meta in configs/suites/NAME.yaml)
is_meta() { is_suite "$1" && grep -q '^mode: *meta' "configs/suites/$1.yaml"; }

[[ -z ${SWEEP_REGISTRY:-} ]] || SWEEP_REGISTRY=$(realpath -m "$SWEEP_REGISTRY")
meta_episodes=${SWEEP_META_EPISODES:-8}
meta_adapt=${SWEEP_META_ADAPT:-}

# run_dir RUN: the run folder of TASK or TASK/sSEED
run_dir() { echo "$runs/${1//\//-}"; }

# own_slots TASK: exit 0 when configs/train/ppo.yaml's per_task section sets the task's slots
own_slots() {
  python3 -c 'import sys, yaml
t = yaml.safe_load(open("configs/train/ppo.yaml"))["per_task"].get(sys.argv[1]) or {}
sys.exit(0 if "slots" in (t.get("env") or {}) else 1)' "$1"
}

# still_rising RUN_DIR: exit 0 when the run still rises (bench/sweep_collect.py's rule)
still_rising() { python3 bench/sweep_collect.py --rising "$1/metrics.csv"; }
# run_steps DIR: the slot-steps the run trains to (train.steps of its config.yaml; 0 without one)
run_steps() {
  local n
  n=$(sed -n 's/^  steps: *\([0-9][0-9]*\).*/\1/p' "$1/config.yaml" 2>/dev/null | head -n 1)
  echo "${n:-0}"
}

# eval_yaml RUN: the task's own YAML when the run's bench/sweep/NAME.yaml (cNAME) turns a
# curriculum on, so that its evaluation plays the task itself; else nothing (the run's own YAML)
eval_yaml() {
  local p task=${1%%/*}
  IFS=/ read -ra p <<<"$1"
  for p in "${p[@]:1}"; do
    [[ $p == c* ]] || continue
    python3 -c 'import os, sys, yaml
def enabled(path):  # curriculum.enabled, following extends: as the task loader does
    d = yaml.safe_load(open(path)) or {}
    c = d.get("curriculum") or {}
    if "enabled" in c:
        return bool(c["enabled"])
    return bool(d.get("extends")) and enabled(os.path.join(os.path.dirname(path), d["extends"]))
sys.exit(0 if enabled(sys.argv[1]) else 1)' "bench/sweep/${p#c}.yaml" && echo "tasks/$task/$task.yaml"
  done
}

# lane GPU DEADLINE RUN...: trains and evaluates the runs one after the other, then extends
lane() {
  local gpu=$1 deadline=$2
  shift 2
  export CUDA_VISIBLE_DEVICES=$gpu
  local registry=(--no-registry)  # the registry arguments of every train and eval command
  [[ -z $SWEEP_REGISTRY ]] || registry=(--registry "$SWEEP_REGISTRY")
  local spec task seed msteps cfg algo part p dir log left line
  trained() {  # trained RUN STATUS: a training that failed is said in lanes.log (--wall-limit's
    # stop exits 130; a lane used to log "done" whatever the exit)
    (($2 == 0 || $2 == 130)) ||
      echo "$(date -u +%T) $1: bidex train exited $2 (its progress.log says why)" >>"$out/lanes.log"
  }
  evaluate() {  # evaluate RUN
    local log="$out/${1//\//-}" yaml episodes=256 split args
    if is_meta "${1%%/*}"; then  # before and after adaptation, on each split
      for split in train test; do
        args=(eval --run "$(run_dir "$1")" --split "$split" --episodes "$meta_episodes" --threads 8
              "${registry[@]}" --json "$log/eval-$split.json")
        echo "bidex ${args[*]}" >>"$log/commands.txt"
        "$bidex" "${args[@]}" >>"$log/eval.txt" 2>&1
      done
      if [[ -n $meta_adapt ]]; then  # more adaptation, its own row (RL2 adapts in memory only)
        args=(eval --run "$(run_dir "$1")" --split test --episodes "$meta_episodes" --threads 8
              --adapt-episodes "$meta_adapt" "${registry[@]}" --json "$log/eval-test-adapt$meta_adapt.json")
        grep -q '^algo: *rl2' "$(run_dir "$1")/config.yaml" 2>/dev/null ||
          args+=(--adapt-steps "$meta_adapt")
        echo "bidex ${args[*]}" >>"$log/commands.txt"
        "$bidex" "${args[@]}" >>"$log/eval.txt" 2>&1
      fi
      return 0
    fi
    is_suite "${1%%/*}" && episodes=$suite_episodes
    ((episodes > 0)) || return 0
    args=(eval --run "$(run_dir "$1")" --episodes "$episodes" --seed 2026 --threads 8
                "${registry[@]}" --json "$log/eval.json")
    yaml=$(eval_yaml "$1")
    [[ -z $yaml ]] || args+=(--task-config "$yaml")
    echo "bidex ${args[*]}" >>"$log/commands.txt"
    "$bidex" "${args[@]}" >>"$log/eval.txt" 2>&1
    local part parts task=${1%%/*} name
    IFS=/ read -ra parts <<<"$1"
    for part in "${parts[@]:1}"; do  # e: also under the task's own YAML; eNAME: under NAME.yaml
      [[ $part == e* ]] || continue
      name=${part#e}
      yaml=bench/sweep/$name.yaml
      [[ -n $name ]] || { name=default; yaml=tasks/$task/$task.yaml; }
      args=(eval --run "$(run_dir "$1")" --episodes "$episodes" --seed 2026 --threads 8
            --task-config "$yaml" --no-registry --json "$log/eval-$name.json")
      echo "bidex ${args[*]}" >>"$log/commands.txt"
      "$bidex" "${args[@]}" >>"$log/eval-$name.txt" 2>&1
    done
  }
  for spec in "$@"; do
    IFS=/ read -ra part <<<"$spec"
    task=${part[0]}; seed=0; msteps=$steps; cfg=(); algo=()
    for p in "${part[@]:1}"; do
      case $p in
        s*) seed=${p#s} ;;
        m*) msteps=$((${p#m} * 1000000)) ;;
        a*) algo=(--algo "${p#a}") ;;
        c*) cfg+=(-o env.task_config="bench/sweep/${p#c}.yaml") ;;
        o*) [[ -f bench/sweep/${p#o}.overrides ]] ||
              { echo "$spec: no file bench/sweep/${p#o}.overrides" >>"$out/lanes.log"; continue 2; }
            while read -r line; do
              read -r line <<<"${line%%#*}"  # without its comment and surrounding blanks
              [[ -z $line ]] || cfg+=(-o "$line")
            done <"bench/sweep/${p#o}.overrides" ;;
        e*) [[ $p == e || -f bench/sweep/${p#e}.yaml ]] ||
              { echo "$spec: no file bench/sweep/${p#e}.yaml" >>"$out/lanes.log"; continue 2; } ;;
        *) echo "$spec: unknown part $p (sSEED, mMILLIONS, aALGO, cNAME, oNAME, e or eNAME)" >>"$out/lanes.log"; continue 2 ;;
      esac
    done
    dir=$(run_dir "$spec"); log="$out/${spec//\//-}"
    mkdir -p "$log"
    local r=$reserve
    is_suite "$task" && r=$suite_reserve
    left=$((deadline - $(date +%s) - r))
    ((left > 30)) || { echo "$spec: no time left" >>"$out/lanes.log"; continue; }
    local args
    if [[ -f $dir/config.yaml ]]; then
      args=(train --resume "$dir" --device "$device" "${registry[@]}" --wall-limit "$left")
    elif is_suite "$task"; then  # multi-task PPO on the suite's pack (issue 37)
      local scale=(-o env.slots="$suite_slots")
      ((${#algo[@]} == 0)) || scale=()  # another algorithm: its own YAML's slots
      args=(train --suite "$task" "${algo[@]}" --device "$device" --run "$dir" "${registry[@]}"
            --wall-limit "$left" "${scale[@]}" -o seed="$seed" -o train.steps="$msteps"
            -o train.save_interval=50 "${cfg[@]}")
    else
      # the sweep's slots and minibatches, unless the task's section of ppo.yaml sets its own or
      # another algorithm trains (its own YAML's settings)
      local scale=(-o env.slots="$slots" -o ppo.minibatches=16)
      { own_slots "$task" || ((${#algo[@]} > 0)); } && scale=()
      args=(train --task "$task" "${algo[@]}" --device "$device" --run "$dir" "${registry[@]}"
            --wall-limit "$left" "${scale[@]}" -o seed="$seed" -o train.steps="$msteps"
            -o train.save_interval=50 "${cfg[@]}")
    fi
    echo "bidex ${args[*]}" >>"$log/commands.txt"
    echo "$(date -u +%T) $spec: start on GPU $gpu" >>"$out/lanes.log"
    "$bidex" "${args[@]}" >>"$log/train.txt" 2>>"$log/progress.log"
    trained "$spec" $?
    evaluate "$spec"
    echo "$(date -u +%T) $spec: done" >>"$out/lanes.log"
  done
  # extend only once every lane of this GPU has done its first pass: an extension must not slow
  # down runs that are still short of $steps
  echo "$spec" >>"$out/gpu$gpu.first"
  while (($(wc -l <"$out/gpu$gpu.first") < $(cat "$out/gpu$gpu.lanes"))) &&
        (($(date +%s) < deadline - reserve)); do sleep 10; done
  local rising=()
  for spec in "$@"; do  # a suite's run is not extended: its length is its own (e.g. MT20's 300M)
    is_suite "${spec%%/*}" && continue
    # nor is one whose own length is 100M or more: it has reached it, and the extension once
    # resumed such runs for nothing, evaluated them again and wrote 100M over an m200 run's
    # length in its config.yaml (bench/results/sweep-h200x2/lease25/README.md)
    (($(run_steps "$(run_dir "$spec")") < 100000000)) || continue
    still_rising "$(run_dir "$spec")" && rising+=("$spec")
  done
  local n=${#rising[@]} i=0
  for spec in "${rising[@]}"; do
    dir=$(run_dir "$spec"); log="$out/${spec//\//-}"
    left=$(((deadline - $(date +%s) - reserve * (n - i)) / (n - i)))
    i=$((i + 1))
    ((left > 60)) || continue
    sed -i 's/^  steps: .*/  steps: 100000000/' "$dir/config.yaml"
    local args=(train --resume "$dir" --device "$device" "${registry[@]}" --wall-limit "$left")
    echo "bidex ${args[*]}  # still rising: extended towards 100M" >>"$log/commands.txt"
    echo "$(date -u +%T) $spec: extend for ${left}s on GPU $gpu" >>"$out/lanes.log"
    "$bidex" "${args[@]}" >>"$log/train.txt" 2>>"$log/progress.log"
    trained "$spec" $?
    evaluate "$spec"
    echo "$(date -u +%T) $spec: extended" >>"$out/lanes.log"
  done
}

case "$stage" in
build)
  bench/physics_step_run.sh build "$out" "${1:?PARTS}"
  ;;
start)
  seconds=${1:?SECONDS}; shift
  # every lane runs bidex from this tree's build: refuse at once without it (a lease's start from
  # the device call's copy of the tree, which holds no build, had its lane end on the missing
  # binary only in lanes.log; bench/results/sweep-h200x2/lease24/lease.txt)
  if (($# > 0)) && [[ ! -x $bidex ]]; then
    echo "sweep_run: start: no bidex binary at $bidex (BIDEX_GPU_BUILD=$build in $(pwd)):" \
         "build it first (bench/sweep_run.sh build), or call start in the tree that holds the build" >&2
    exit 1
  fi
  deadline=$(($(date +%s) + seconds))
  echo "$deadline" >"$out/deadline"
  [[ -z ${BIDEX_COMMIT:-} ]] || echo "$BIDEX_COMMIT" >"$out/commit"
  for spec in "$@"; do echo "${spec%%=*}"; done | sort | uniq -c | while read -r n g; do
    echo "$n" >"$out/gpu$g.lanes"
  done
  for spec in "$@"; do
    gpu=${spec%%=*}
    IFS=, read -ra list <<<"${spec#*=}"
    echo "${list[*]}" >>"$out/lanes"
    export -f lane run_dir still_rising run_steps own_slots eval_yaml is_suite is_meta
    export out runs steps slots device bidex reserve suite_slots suite_episodes suite_reserve \
      meta_episodes meta_adapt
    export SWEEP_REGISTRY=${SWEEP_REGISTRY:-}
    setsid bash -c 'lane "$@"; echo done >>"$0"' "$out/lanes.done" "$gpu" "$deadline" "${list[@]}" \
      </dev/null >>"$out/lanes.log" 2>&1 &
  done
  echo "started $# lanes; every run trains until $(date -u -d @$((deadline - reserve)) +%T) UTC at the" \
       "latest (a suite's until $(date -u -d @$((deadline - suite_reserve)) +%T)) and is evaluated by" \
       "$(date -u -d @"$deadline" +%T) UTC"
  ;;
wait)
  limit=$(($(date +%s) + ${1:?SECONDS}))
  total=$(wc -l <"$out/lanes")
  lanes_done() { cat "$out/lanes.done" 2>/dev/null | wc -l; }
  while :; do
    done_n=$(lanes_done)
    date -u +%T
    for spec in $(cat "$out/lanes"); do
      m=$(run_dir "$spec")/metrics.csv
      [[ -f $m ]] || continue
      # its last update, its columns found by the header's names (the physics' load columns
      # added later shifted fixed positions: return showed solver_iters and success the return)
      { head -n 1 "$m"; tail -n 1 "$m"; } | awk -F, -v s="$spec" '
        NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
        function v(k) { return (k in col && $col[k] != "") ? $col[k] : "-" }
        { printf "  %-22s %6.1fM  return %s  success %s  fps %.0f\n", s, $col["steps"] / 1e6, v("return"), v("success"), $col["fps"] }'
    done
    ((done_n >= total)) && { echo "all $total lanes done"; break; }
    (($(date +%s) >= limit)) && { echo "$done_n of $total lanes done"; break; }
    # the next report in a minute, or at once when the last lane ends (a waiting device call
    # returns as soon as there is nothing left to wait for)
    next=$(($(date +%s) + 60)); ((next > limit)) && next=$limit
    while (($(date +%s) < next)) && (($(lanes_done) < total)); do
      sleep 2
    done
  done
  ;;
stop)
  for spec in "$@"; do
    name=${spec//\//-}
    pkill -KILL -f "lanes.done [0-9]+ [0-9]+ ${spec}\$" || { echo "$spec: no lane runs it alone" >&2; continue; }
    pkill -INT -f "$(run_dir "$spec") --" || true  # Ctrl-C: a checkpoint, then the run ends
    echo "$(date -u +%T) $spec: stopped at $(tail -n 1 "$(run_dir "$spec")/metrics.csv" 2>/dev/null | cut -d, -f2) slot-steps" | tee -a "$out/stopped.txt"
  done
  ;;
pack)
  dest=$(realpath -m "${1:?DEST}")
  mkdir -p "$dest"
  tar czf "$dest/sweep.tgz" --exclude=progress.log --exclude=train.txt -C "$(dirname "$out")" "$(basename "$out")"
  (cd "$(dirname "$out")" && find "$(basename "$out")" \( -name progress.log -o -name train.txt \) -print0 |
     tar czf "$dest/logs.tgz" --null -T -)
  ls -l "$dest"
  ;;
collect)
  for spec in $(cat "$out/lanes"); do
    dir=$(run_dir "$spec"); name=${spec//\//-}
    mkdir -p "$out/$name"
    cp "$dir"/{config.yaml,run.json,metrics.csv,learning_curve.svg,summary.json} "$out/$name/" \
      2>/dev/null
  done
  gpus=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null)
  machine="$(grep -c . <<<"$gpus") x $(head -1 <<<"$gpus"), $(nproc) cores"
  [[ -n $gpus ]] || machine="$(nproc) cores, no GPU"
  commit=${BIDEX_COMMIT:-$(cat "$out/commit" 2>/dev/null)}
  python3 bench/sweep_collect.py "$out" "$machine" "${commit:-unknown}" $(cat "$out/lanes")
  python3 bench/metrics_io.py compress "$out" >/dev/null  # as bench/results keeps them
  ;;
keep)
  spec=${1:?RUN}; dest=${2:?DEST}; first=${3:-0}; count=${4:-1000}
  dir=$(run_dir "$spec"); name=${spec//\//-}
  [[ -f $dir/config.yaml ]] || { echo "keep: no run folder $dir" >&2; exit 1; }
  newest=$(ls "$dir"/checkpoints/*.ckpt 2>/dev/null | sort | tail -n 1)
  [[ -n $newest ]] || { echo "keep: $dir has no checkpoint" >&2; exit 1; }
  b=$(basename "$dir")
  mapfile -t files < <(cd "$(dirname "$dir")" && find "$b" -path "$b/checkpoints" -prune -o -type f -print)
  bench/carry.sh out "$name" "$(dirname "$dir")" "$runs/keep-$name" "$dest" "$first" "$count" \
    -- "${files[@]}" "$b/checkpoints/$(basename "$newest")" || exit 1
  echo "keep: $spec at $(basename "$newest")"
  ;;
bring)
  spec=${1:?RUN}; parts=${2:?PARTS}
  dir=$(run_dir "$spec"); name=${spec//\//-}
  [[ ! -e $dir ]] || { echo "bring: $dir exists; not replaced" >&2; exit 1; }
  bench/carry.sh in "$name" "$parts" "$(dirname "$dir")" || exit 1
  ls "$dir" "$dir/checkpoints"
  ;;
*)
  echo "unknown stage $stage (build, start, wait, stop, collect, pack, keep or bring)" >&2
  exit 2
  ;;
esac
