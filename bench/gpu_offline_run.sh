#!/usr/bin/env bash
# The offline table on a GPU machine (issue: hand_over and door_open_outward, four datasets, four
# algorithms), one stage per call so that a device session can be spent in slices. Build first
# with bench/gpu_learn_run.sh build PARTS.
#   bench/gpu_offline_run.sh experts OUTDIR TASKS SLOTS SECONDS STEPS REPLAY_STEPS
#       online PPO on each task at once on the GPU (the experts, and the 100 of the normalised
#       score), checkpoints every 10 updates; the first call records the replay dataset
#       (--record-replay); a later call resumes the runs for SECONDS more
#   bench/gpu_offline_run.sh datasets OUTDIR TASKS STEPS SLOTS
#       per task, at once: random, medium and expert (bidex collect on the GPU), then
#       medium-expert (--merge); their metadata and checksums go to OUTDIR/datasets.json
#   bench/gpu_offline_run.sh offline OUTDIR TASKS ALGOS QUALITIES GRADIENT_STEPS PER_UPDATE SLOTS
#                                    PARALLEL SECONDS
#       every algorithm on every dataset, PARALLEL runs at once (learners on the GPU, their
#       evaluation packs of SLOTS slots on the CPU; one CPU thread each for the simulation and
#       LibTorch), GRADIENT_STEPS in all with an evaluation every PER_UPDATE, each stopped after
#       SECONDS of training if not done; then the table (bench/offline_table.py) over every run
#       so far, so that the runs may be spread over several calls (one per task, say)
#   bench/gpu_offline_run.sh probe OUTDIR TASK ALGOS GRADIENT_STEPS PARALLEL_LIST
#       how fast offline learners share the machine: a random dataset of TASK (200,000
#       transitions), then for each P of PARALLEL_LIST and each algorithm, P identical runs at
#       once (learners on the GPU, as above), two updates of GRADIENT_STEPS each; the second
#       update's seconds give gradient steps/s per run and in all (OUTDIR/probe.json)
# Everything lives under /tmp/bidex-offline (runs, datasets, the registry); results go to OUTDIR
# with the machine, date, commit ($BIDEX_COMMIT) and commands, and each stage's wall seconds in
# OUTDIR/seconds.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
build=${BIDEX_GPU_BUILD:-build-gpu}
bidex=$(realpath "$build/apps/bidex")
root=/tmp/bidex-offline
reg="$root/registry.sqlite"
stage=${1:?stage: experts, datasets, offline or probe}
shift
SECONDS=0
mkdir -p "$root/runs" "$root/datasets"

machine() { nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1; }

# done_in STAGE: the stage's wall seconds, printed and kept in $out/seconds.txt
done_in() { echo "$1: ${SECONDS}s" | tee -a "$out/seconds.txt"; }

# One offline run: learner on the GPU, its evaluation pack on the CPU, one CPU thread each for
# the simulation and LibTorch; the command goes to $cmdlog when that is set.
#   offline_run RUN DATASET ALGO GRADIENT_STEPS PER_UPDATE SLOTS [more bidex train options]
offline_run() {
  local run=$1 data=$2 algo=$3 steps=$4 per=$5 slots=$6
  shift 6
  local args=(train --algo "$algo" --dataset "$data" --device cpu -o train.device=cuda
              -o train.steps="$steps" -o "$algo.gradient_steps=$per" -o env.slots="$slots"
              -o env.threads=1 -o train.torch_threads=1 --run "$run" "$@")
  [[ -n ${cmdlog:-} ]] && echo "bidex ${args[*]}" >>"$cmdlog"
  "$bidex" "${args[@]}"
}

case "$stage" in
experts)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; slots=${3:?SLOTS}; budget=${4:?SECONDS}
  steps=${5:?STEPS}; replay=${6:?REPLAY_STEPS}
  mkdir -p "$out"
  for task in ${tasks//,/ }; do
    run="$root/runs/$task-ppo"
    if [[ -f "$run/config.yaml" ]]; then
      args=(train --resume "$run" --device cuda --registry "$reg" --time-limit "$budget")
    else
      args=(train --task "$task" --device cuda -o env.slots="$slots" -o train.steps="$steps"
            -o train.save_interval=10 -o train.keep_checkpoints=1000 --run "$run"
            --registry "$reg" --time-limit "$budget"
            --record-replay "$root/datasets/$task/replay-v0" --replay-steps "$replay")
    fi
    echo "bidex ${args[*]}" >>"$out/commands.txt"
    "$bidex" "${args[@]}" >"$out/ppo-$task.txt" 2>"$out/ppo-$task.progress" &
  done
  wait
  for task in ${tasks//,/ }; do
    tail -4 "$out/ppo-$task.txt"
    cp "$root/runs/$task-ppo/metrics.csv" "$out/ppo-$task-metrics.csv"
    cp "$root/runs/$task-ppo/learning_curve.svg" "$out/ppo-$task-curve.svg"
  done
  done_in experts
  ;;
datasets)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; steps=${3:?STEPS}; slots=${4:?SLOTS}
  mkdir -p "$out"
  for task in ${tasks//,/ }; do
    (
      run="$root/runs/$task-ppo"
      d="$root/datasets/$task"
      for q in random medium expert; do
        if [[ $q == random ]]; then src=(--task "$task" --expert "$run"); else src=(--run "$run"); fi
        args=(collect --quality "$q" "${src[@]}" --out "$d/$q-v0" --steps "$steps"
              --slots "$slots" --device cuda --registry "$reg")
        echo "bidex ${args[*]}" >>"$out/commands-$task.txt"
        "$bidex" "${args[@]}" >>"$out/collect-$task.txt" 2>/dev/null || echo "FAILED $task $q"
      done
      args=(collect --quality medium-expert --merge "$d/medium-v0" "$d/expert-v0"
            --out "$d/medium-expert-v0" --registry "$reg")
      echo "bidex ${args[*]}" >>"$out/commands-$task.txt"
      "$bidex" "${args[@]}" >>"$out/collect-$task.txt" 2>&1 || echo "FAILED $task medium-expert"
      "$bidex" dataset info "$d/replay-v0" >>"$out/collect-$task.txt" 2>&1
    ) &
  done
  wait
  cat "$out"/collect-*.txt
  python3 - "$root/datasets" "$out/datasets.json" "${BIDEX_COMMIT:-unknown}" "$(machine)" <<'PY'
import json, sys, glob, os, datetime
root, path, commit, machine = sys.argv[1:5]
out = {"what": "the offline datasets: metadata.json of each (checksum, sizes, references)",
       "machine": machine, "commit": commit,
       "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
       "datasets": []}
for m in sorted(glob.glob(f"{root}/*/*/data/metadata.json")):
    d = json.load(open(m))
    d["folder"] = os.path.relpath(os.path.dirname(os.path.dirname(m)), root)
    out["datasets"].append(d)
json.dump(out, open(path, "w"), indent=2)
PY
  done_in datasets
  ;;
offline)
  out=$(realpath -m "${1:?OUTDIR}"); tasks=${2:?TASKS}; algos=${3:?ALGOS}
  qualities=${4:?QUALITIES}; gsteps=${5:?GRADIENT_STEPS}; per=${6:?PER_UPDATE}
  eslots=${7:?SLOTS}; parallel=${8:?PARALLEL}; limit=${9:?SECONDS}
  mkdir -p "$out/runs"
  jobs="$out/jobs.txt"
  : >"$jobs"
  for task in ${tasks//,/ }; do
    for q in ${qualities//,/ }; do
      for algo in ${algos//,/ }; do
        echo "$task $q $algo" >>"$jobs"
      done
    done
  done
  cmdlog="$out/commands.txt"
  export -f offline_run
  export bidex root reg out gsteps per eslots limit cmdlog
  xargs -P "$parallel" -L 1 bash -c '
    task=$0; q=$1; algo=$2; name=$task-$q-$algo
    offline_run "$root/runs/$name" "$root/datasets/$task/$q-v0" "$algo" "$gsteps" "$per" \
      "$eslots" --time-limit "$limit" --registry "$reg" \
      >"$out/runs/$name.txt" 2>"$out/runs/$name.err"
    rc=$?
    # 130: stopped at --time-limit (or Ctrl-C), with a checkpoint and its evaluations
    if ((rc == 130)); then echo "STOPPED $name at its time limit"
    elif ((rc != 0)); then echo "FAILED $name (exit $rc):"; tail -3 "$out/runs/$name.err"; fi
    cp "$root/runs/$name/metrics.csv" "$out/runs/$name-metrics.csv" 2>/dev/null
    tail -3 "$out/runs/$name.txt"' <"$jobs"
  python3 bench/offline_table.py "$reg" "$out" "${BIDEX_COMMIT:-unknown}"
  cp "$reg" "$out/registry.sqlite"
  done_in offline
  ;;
probe)
  out=$(realpath -m "${1:?OUTDIR}"); task=${2:?TASK}; algos=${3:?ALGOS}; gsteps=${4:?GRADIENT_STEPS}
  plist=${5:?PARALLEL_LIST}
  mkdir -p "$out"
  d="$root/datasets/$task/probe-random-v0"
  [[ -d $d ]] || "$bidex" collect --quality random --task "$task" --out "$d" --steps 200000 \
    --slots 4096 --device cuda --no-registry >"$out/probe-collect.txt" 2>&1 || exit 1
  : >"$out/probe.csv"
  for p in ${plist//,/ }; do
    for algo in ${algos//,/ }; do
      for ((k = 0; k < p; ++k)); do
        run="$root/runs/probe-$algo-$p-$k"
        rm -rf "$run"
        offline_run "$run" "$d" "$algo" $((2 * gsteps)) "$gsteps" 64 --no-registry \
          >"$out/probe-$algo-$p-$k.log" 2>&1 &
      done
      wait
      for ((k = 0; k < p; ++k)); do
        # empty where the run failed (its log says why)
        echo "$algo,$p,$(awk -F, 'NR == 2 {a = $3} NR == 3 {print $3 - a}' \
          "$root/runs/probe-$algo-$p-$k/metrics.csv" 2>/dev/null)" >>"$out/probe.csv"
      done
    done
  done
  python3 - "$out" "$gsteps" "${BIDEX_COMMIT:-unknown}" "${*:2}" "$(machine)" <<'PY'
import collections, datetime, json, sys
out, g, commit, args, machine = sys.argv[1], int(sys.argv[2]), *sys.argv[3:6]
runs = collections.defaultdict(list)
failed = collections.Counter()
for line in open(f"{out}/probe.csv"):
    algo, p, sec = line.strip().split(",")
    if sec:
        runs[(algo, int(p))].append(float(sec))
    else:
        failed[(algo, int(p))] += 1
rows = [{"algo": a, "parallel": p, "finished": len(s), "failed": failed[(a, p)],
         "seconds_per_update": max(s), "steps_per_s_per_run": g / max(s),
         "steps_per_s_in_all": len(s) * g / max(s)}
        for (a, p), s in sorted(runs.items())]
for r in rows:
    print(f"{r['algo']} x{r['parallel']}: {r['steps_per_s_per_run']:.0f} gradient steps/s a run, "
          f"{r['steps_per_s_in_all']:.0f} in all ({r['failed']} failed)")
json.dump({"what": "offline learners sharing one GPU: gradient steps/s of the second update "
           "(its gradient steps and one evaluation) per run and in all",
           "machine": machine, "commit": commit,
           "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
           "command": f"bench/gpu_offline_run.sh probe OUTDIR {args}", "results": rows},
          open(f"{out}/probe.json", "w"), indent=2)
PY
  done_in probe
  ;;
*)
  echo "unknown stage $stage (experts, datasets, offline, probe)" >&2
  exit 2
  ;;
esac
