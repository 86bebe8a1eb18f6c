#!/usr/bin/env bash
# Two builds' PPO learners side by side on one GPU machine (issue 39): the same command, the
# same machine, one lease. Built first with bench/gpu_learn_run.sh build (or python_gpu_run.sh
# build) into two folders, OLD and NEW. (Commit 5d78e24, issue 39's starting learner, builds
# from a bundle without the renderer's packages only with today's sim/render.cc in its tree:
# bench/results/learner-equiv-h200x2/lease27/lease.txt.)
#   bench/learner_compare.sh start OUTDIR OLD NEW
#       runs, in its own process session (it outlives the call; `wait` follows it):
#       1. profile: `bidex train --profile` of 24 updates (3.1M slot-steps;
#          $BIDEX_COMPARE_PROFILE_STEPS slot-steps where set) of catch_abreast and of hand_over
#          with each build, one at a time: OUTDIR/profile-TASK-{old,new}/
#       2. solo: catch_abreast, seed 0, to 25M slot-steps with each build, one at a time (the
#          training rate over a whole run, and the slot-steps at which it reached 43.4):
#          OUTDIR/solo-{old,new}-s0/catch_abreast-ppo/
#       3. together: NEW's catch_abreast seed 1 and hand_over seeds 0 and 1, to 20M slot-steps,
#          three trainings sharing the GPU (curves only): OUTDIR/new-sS/TASK-ppo/
#       4. offpolicy: `bidex train --profile` of SAC and of TD3 ($BIDEX_COMPARE_ALGOS, default
#          "sac td3") at their own YAML's settings (the paper's, 2,048 slots: SAC 4 gradient
#          steps of 32 transitions an update, TD3 20 of 100), 64 updates (1M slot-steps) of
#          catch_abreast with each build: OUTDIR/offpolicy-ALGO-{old,new}/
#       Every PPO run: 16,384 slots, 16 minibatches of 8,192 (the settings that reach the
#       original's returns). OUTDIR/done when all ended; OUTDIR/compare.log tells the stages.
#   bench/learner_compare.sh wait OUTDIR SECONDS
#       waits up to SECONDS for OUTDIR/done, printing the newest progress line
# BIDEX_COMMIT_OLD and BIDEX_COMMIT_NEW name the builds' commits in the results. OLD and NEW may
# be one build: BIDEX_OLD_ARGS and BIDEX_NEW_ARGS add settings to each side's commands, every
# stage's (e.g. "-o ppo.bf16=true"; "-o td3.cuda_graph=true" with BIDEX_COMPARE_ALGOS=td3). BIDEX_COMPARE_STAGES (default "profile solo together";
# offpolicy runs only when named) picks stages,
# BIDEX_COMPARE_TASKS (default "catch_abreast hand_over") the profiles' tasks, BIDEX_COMPARE_TMP
# (default /tmp) the folder of the runs themselves.
set -uo pipefail
cd "$(dirname "$0")/.."
stage=${1:-}
if [[ -z "$stage" || "$stage" == -h || "$stage" == --help ]]; then
  sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
case "$stage" in
start)
  out=$(realpath -m "${2:?OUTDIR}"); old=$(realpath "${3:?OLD}"); new=$(realpath "${4:?NEW}")
  mkdir -p "$out"
  setsid nohup "$0" run "$out" "$old" "$new" >"$out/compare.log" 2>&1 </dev/null &
  echo "learner_compare: started ($out/compare.log)"
  ;;
run)  # the sequence itself (start runs it in the background)
  out=$2; old=$3; new=$4
  tmp=${BIDEX_COMPARE_TMP:-/tmp}  # the runs' own folders (two comparisons at once: one each)
  common=(-o env.slots=16384 -o ppo.minibatches=16)
  build_of() { [[ $1 == old ]] && echo "$old" || echo "$new"; }
  # shellcheck disable=SC2206
  extra_of() { [[ $1 == old ]] && extra=(${BIDEX_OLD_ARGS:-}) || extra=(${BIDEX_NEW_ARGS:-}); }
  stages=" ${BIDEX_COMPARE_STAGES:-profile solo together} "
  commit_of() { [[ $1 == old ]] && echo "${BIDEX_COMMIT_OLD:-unknown}" || echo "${BIDEX_COMMIT_NEW:-unknown}"; }
  for task in ${BIDEX_COMPARE_TASKS:-catch_abreast hand_over}; do
    [[ $stages == *" profile "* ]] || break
    for b in old new; do
      extra_of "$b"
      echo "$(date -u +%T) profile $task $b"
      d=$out/profile-$task-$b
      mkdir -p "$d"
      cmd=(train --task "$task" --device cuda --profile --run "$tmp/compare-profile-$task-$b"
           --no-registry "${common[@]}" -o train.steps="${BIDEX_COMPARE_PROFILE_STEPS:-3145728}"
           "${extra[@]}")
      "$(build_of $b)/apps/bidex" "${cmd[@]}" >"$d/profile.log" 2>&1
      cp "$tmp/compare-profile-$task-$b"/{profile.json,metrics.csv} "$d/" 2>/dev/null
      echo "commit $(commit_of $b): bidex ${cmd[*]}" >"$d/command.txt"
    done
  done
  train() {  # BUILD_NAME OUT_SUBDIR TASK SEED SLOT_STEPS
    extra_of "$1"
    BIDEX_GPU_BUILD=$(build_of "$1") BIDEX_COMMIT=$(commit_of "$1") \
      BIDEX_GPU_RUNS=$tmp/compare-runs-$2 \
      bench/gpu_learn_run.sh train "$out/$2" "$3" 16384 3000 43.4 "${common[@]:2}" \
      -o seed="$4" -o train.steps="$5" "${extra[@]}" >"$out/$2-$3.log" 2>&1
  }
  for b in old new; do
    [[ $stages == *" solo "* ]] || break
    echo "$(date -u +%T) solo catch_abreast $b"
    train "$b" "solo-$b-s0" catch_abreast 0 25e6
  done
  if [[ $stages == *" together "* ]]; then
    echo "$(date -u +%T) together: new catch_abreast s1, hand_over s0 and s1"
    train new new-s1 catch_abreast 1 20e6 &
    train new new-s0 hand_over 0 20e6 &
    train new new-s1 hand_over 1 20e6 &
    wait
  fi
  for algo in ${BIDEX_COMPARE_ALGOS:-sac td3}; do
    [[ $stages == *" offpolicy "* ]] || break
    for b in old new; do
      extra_of "$b"
      echo "$(date -u +%T) offpolicy $algo $b"
      d=$out/offpolicy-$algo-$b
      mkdir -p "$d"
      cmd=(train --task catch_abreast --algo "$algo" --device cuda --profile
           --run "$tmp/compare-offpolicy-$algo-$b" --no-registry -o train.steps=1048576
           "${extra[@]}")
      "$(build_of $b)/apps/bidex" "${cmd[@]}" >"$d/profile.log" 2>&1
      cp "$tmp/compare-offpolicy-$algo-$b"/{profile.json,metrics.csv} "$d/" 2>/dev/null
      echo "commit $(commit_of $b): bidex ${cmd[*]}" >"$d/command.txt"
    done
  done
  echo "$(date -u +%T) done"
  touch "$out/done"
  ;;
wait)
  out=$(realpath -m "${2:?OUTDIR}"); secs=${3:?SECONDS}
  end=$((SECONDS + secs))
  while [[ ! -f "$out/done" ]] && (( SECONDS < end )); do
    sleep 20
    tail -1 "$out/compare.log"
    for f in "$out"/*/*/progress.log; do
      [[ -f $f ]] && echo "  $f: $(tail -c 300 "$f" | tr '\r' '\n' | grep . | tail -1)"
    done
  done
  [[ -f "$out/done" ]] && echo "learner_compare: done"
  tail -3 "$out/compare.log"
  ;;
*)
  echo "learner_compare.sh: unknown stage '$stage' (expected start, wait; --help)" >&2
  exit 2
  ;;
esac
