#!/usr/bin/env bash
# The bars of the offline CI learning test (tests/offline/learning_test.cc): its whole procedure
# (SAC expert, expert and random datasets, their mix, BC on expert, TD3+BC, IQL and BCQ on the
# mix, each evaluated over 64 episodes, seed 777) for several seeds, through the test binary's
# hidden case. Usage: bench/offline_learning_seeds.sh OUT.json [bidex_torch_tests] [SEEDS...]
set -euo pipefail
out=$1; shift
bin=${1:-build/tests/bidex_torch_tests}; shift || true
seeds=("$@"); [ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2 3)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
BIDEX_OFFLINE_SEEDS="${seeds[*]}" BIDEX_OFFLINE_OUT="$tmp/rows.jsonl" \
  "$bin" "[offline-seeds]" >/dev/null
rows=$(paste -sd, "$tmp/rows.jsonl")
cat > "$out" <<JSON
{
  "what": "offline CI learning test bars: SAC expert (configs/train/sac.yaml per_task) on catch_underarm_raise, offline::collect of 20,000 expert and 20,000 random steps (32 slots), mixed = random + expert episodes; BC on expert, TD3+BC, IQL and BCQ on mixed (configs/train/<algo>.yaml per_task); returns of the mean action over 64 episodes (seed 777); normalised = 100 (return - random) / (expert - random)",
  "machine": "$(nproc) cores, $(uname -m), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)",
  "date": "$(date -u +%Y-%m-%dT%H:%M:%SZ)",
  "commit": "${BIDEX_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}",
  "command": "bench/offline_learning_seeds.sh $out $bin ${seeds[*]}",
  "seeds": [$rows]
}
JSON
cat "$out"
