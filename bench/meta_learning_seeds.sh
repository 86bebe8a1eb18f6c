#!/usr/bin/env bash
# The margin of the CI meta-learning test (tests/metarl/meta_train_test.cc): ALGO meta-trained on
# ML1-raise-goals with its per-suite defaults for several seeds, then evaluated on the held-out
# test goals (bidex eval --split test: 16 slots per goal, 1 adaptation episode, 1 step), beside
# the same protocol after a single update (before meta-training has done anything).
# Usage: [BIDEX_ALGO=promp] bench/meta_learning_seeds.sh OUT.json [BIDEX] [SEEDS...]
set -euo pipefail
out=$1; shift
bidex=${1:-build/apps/bidex}; shift || true
seeds=("$@"); [ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2 3)
algo=${BIDEX_ALGO:-promp}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
field() { python3 -c "import json;d=json.load(open('$1'));print(d['return_before'], d['return_after'])"; }
rows=""
for s in "${seeds[@]}"; do
  start=$(date +%s.%N)
  "$bidex" train --suite ML1-raise-goals --algo "$algo" -o seed=$s --run "$tmp/s$s" --no-registry >/dev/null 2>&1
  end=$(date +%s.%N)
  "$bidex" eval --run "$tmp/s$s" --split test --episodes 16 --no-registry --json "$tmp/e$s.json" >/dev/null
  "$bidex" train --suite ML1-raise-goals --algo "$algo" -o seed=$s -o train.steps=1 --run "$tmp/u$s" --no-registry >/dev/null 2>&1
  "$bidex" eval --run "$tmp/u$s" --split test --episodes 16 --no-registry --json "$tmp/u$s.json" >/dev/null
  read -r b a < <(field "$tmp/e$s.json")
  read -r ub ua < <(field "$tmp/u$s.json")
  rows="$rows{\"seed\": $s, \"before\": $b, \"after\": $a, \"one_update_before\": $ub, \"one_update_after\": $ua, \"train_seconds\": $(python3 -c "print(round($end-$start,1))")},"
done
cat > "$out" <<JSON
{
  "what": "CI meta-learning test margin: $algo on ML1-raise-goals (configs/train/$algo.yaml per_task), held-out goals' return before and after adaptation (bidex eval --split test --episodes 16, seed 12345), and the same after one update",
  "machine": "$(nproc) cores, $(uname -m), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)",
  "date": "$(date -u +%Y-%m-%dT%H:%M:%SZ)",
  "commit": "${BIDEX_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}",
  "command": "BIDEX_ALGO=$algo bench/meta_learning_seeds.sh $out $bidex ${seeds[*]}",
  "seeds": [${rows%,}]
}
JSON
cat "$out"
