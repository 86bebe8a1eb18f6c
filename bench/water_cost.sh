#!/usr/bin/env bash
# What pour_water's water balls cost: bidex bench task on pour_water with 0, 8 (the default) and
# 30 (the original's) balls, same slots and threads, one after the other; merged into OUT.json.
#   bench/water_cost.sh OUT.json [BIDEX] [SLOTS] [THREADS]
set -euo pipefail
out=$1; bidex=${2:-build/apps/bidex}; slots=${3:-128}; threads=${4:-1}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
for n in 0 8 30; do
  sed "s/^water: {count: 8,/water: {count: $n,/" tasks/pour_water/pour_water.yaml > "$tmp/water$n.yaml"
  "$bidex" bench task --task pour_water --config "$tmp/water$n.yaml" --slots "$slots" \
    --threads "$threads" --seconds 5 --out "$tmp/r$n.json" 2>/dev/null
done
python3 - "$tmp" "$out" "$*" <<'PY'
import json, sys
tmp, out, args = sys.argv[1:4]
runs = {n: json.load(open(f"{tmp}/r{n}.json")) for n in (0, 8, 30)}
res = []
for n, r in runs.items():
    x = r["results"][0]
    res.append({"water_balls": n, "slot_steps_per_s": x["slot_steps_per_s"],
                "ms_per_slot_step_per_thread": 1e3 * x["threads"] / x["slot_steps_per_s"],
                "bytes_per_slot": x["bytes_per_slot"], "faults": x["faults"]})
base = res[0]["slot_steps_per_s"]
for x in res: x["cost_vs_no_water"] = base / x["slot_steps_per_s"]
json.dump({"what": "pour_water with 0, 8 and 30 water balls, one after the other",
           "machine": runs[0]["machine"], "command": "bench/water_cost.sh " + args,
           "bench_commands": [r["command"] for r in runs.values()], "results": res},
          open(out, "w"), indent=2)
print(json.dumps(res, indent=1))
PY
