#!/usr/bin/env bash
# The margin of the CI learning test (tests/rl/learning_test.cc): PPO on catch_underarm_raise
# with its per-task defaults for several seeds, each evaluated (mean action, 64 episodes) against
# the random policy. Usage: [BIDEX_ALGO=trpo] bench/learning_seeds.sh OUT.json [BIDEX] [SEEDS...]
# BIDEX_LEARN_ARGS adds arguments to every training, after the seed (issue 39's graphed update
# against the eager one on a GPU: "--device cuda -o sac.cuda_graph=true"); each seed's training
# log is kept in OUT.logs/sSEED.txt (a graphed update says "replayed as a CUDA graph" there).
# Nothing is recorded in a registry.
set -euo pipefail
out=$1; shift
bidex=${1:-build/apps/bidex}; shift || true
seeds=("$@"); [ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2 3)
algo=${BIDEX_ALGO:-ppo}
# shellcheck disable=SC2206  # word-split on purpose: several arguments in one variable
extra=(${BIDEX_LEARN_ARGS:-})
logs=${out%.json}.logs
mkdir -p "$logs"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
rand=$("$bidex" play --task catch_underarm_raise --policy random --slots 64 --steps 40 --seed 777 --json "$tmp/random.json" >/dev/null && python3 -c "import json;print(json.load(open('$tmp/random.json'))['episodes']['mean_return'])")
rows=""
for s in "${seeds[@]}"; do
  start=$(date +%s.%N)
  "$bidex" train --task catch_underarm_raise --algo "$algo" --no-registry -o seed="$s" "${extra[@]}" \
    --run "$tmp/s$s" >"$logs/s$s.txt" 2>&1 ||
    { echo "learning_seeds: seed $s's training failed (exit $?): $logs/s$s.txt" >&2; exit 1; }
  end=$(date +%s.%N)
  "$bidex" eval --run "$tmp/s$s" --episodes 64 --seed 777 --no-registry --json "$tmp/e$s.json" >/dev/null
  ret=$(python3 -c "import json;print(json.load(open('$tmp/e$s.json'))['mean_return'])")
  rows="$rows{\"seed\": $s, \"trained_return\": $ret, \"train_seconds\": $(python3 -c "print(round($end-$start,1))")},"
done
args=${BIDEX_LEARN_ARGS:+BIDEX_LEARN_ARGS=\\\"$BIDEX_LEARN_ARGS\\\" }
cat > "$out" <<JSON
{
  "what": "CI learning test margin: $algo on catch_underarm_raise (configs/train/$algo.yaml per_task${BIDEX_LEARN_ARGS:+, then $BIDEX_LEARN_ARGS}), eval of the mean action over 64 episodes (seed 777) vs random actions",
  "machine": "$(nproc) cores, $(uname -m), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)",
  "date": "$(date -u +%Y-%m-%dT%H:%M:%SZ)",
  "commit": "${BIDEX_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}",
  "command": "${args}BIDEX_ALGO=$algo bench/learning_seeds.sh $out $bidex ${seeds[*]}",
  "train_logs": "$logs",
  "random_return": $rand,
  "seeds": [${rows%,}]
}
JSON
cat "$out"
