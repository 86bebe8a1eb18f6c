#!/usr/bin/env bash
# The multi-agent runs of the GPU machine, all at once on its one GPU (2,048 slots each, as the
# original), each for SECONDS more (a later call resumes them):
#   MAPPO and HAPPO with per-hand agents on hand_over, catch_over2underarm and pen, and HAPPO with
#   per-finger agents on hand_over.
#   bench/gpu_marl_run.sh OUTDIR SECONDS [RUNS]
# RUNS (optional) keeps only the runs whose "task-algo-agents" contains one of its comma-separated
# words, e.g. hand_over-mappo-hand,hand_over-happo-hand.
# Then bench/marl_table.py OUTDIR writes the table and the curves beside the original's and HARL's
# figures. Needs a build (bench/gpu_learn_run.sh build PARTS).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:?OUTDIR}; budget=${2:?SECONDS}; only=${3:-}
all=(
  "hand_over mappo hand" "hand_over happo hand" "hand_over happo finger"
  "catch_over2underarm mappo hand" "catch_over2underarm happo hand"
  "pen mappo hand" "pen happo hand"
  "hand_over ppo -"   # the single-agent baseline beside them (only when RUNS asks for it)
)
runs=()
for r in "${all[@]}"; do
  read -r task algo agents <<<"$r"
  keep=${only:+no}
  for w in ${only//,/ }; do [[ $task-$algo-$agents == *"$w"* ]] && keep=; done
  [[ -z $keep && ( -n $only || $algo != ppo ) ]] && runs+=("$r")
done
mkdir -p "$out"
for r in "${runs[@]}"; do
  read -r task algo agents <<<"$r"
  agent_args=(--agents "$agents")
  [[ $agents == - ]] && agent_args=()
  bench/gpu_learn_run.sh train "$out" "$task" 2048 "$budget" 1e9 --algo "$algo" \
    "${agent_args[@]}" >"$out/$task-$algo-$agents.call.log" 2>&1 &
done
wait
for r in "${runs[@]}"; do
  read -r task algo agents <<<"$r"
  tail -3 "$out/$task-$algo-$agents.call.log"
done
