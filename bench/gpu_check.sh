#!/usr/bin/env bash
# The GPU path's checks, for a GPU machine (the test suite never needs one). For each task:
#   - the CPU and GPU paths agree under a random policy: mean return and episode length within 4
#     standard errors + 2%, success rate within 4 standard errors + 0.01, over >= 1,000
#     episodes a side (bidex bench agree)
#   - no fault in >= 1M fault-checked random-action slot-steps at 16,384 worlds, and the whole
#     task step's rate against raw MuJoCo Warp (bidex bench warp; it also compares two fresh
#     backends for bitwise determinism, reported, not required)
# Writes agree.json and warp.json into OUTDIR; exits 1 when a task disagrees or faults.
#   bench/gpu_check.sh OUTDIR [TASKS]    (BIDEX: the binary, default build/apps/bidex)
set -uo pipefail
cd "$(dirname "$0")/.."
out=$(realpath -m "${1:?OUTDIR}")
# every task (each runs on the GPU: tasks/gpu_families.h)
tasks=${2:-hand_over,catch_underarm,catch_over2underarm,catch_abreast,two_catch_underarm,catch_underarm_raise,hand_over_free,lift_underarm,door_open_outward,door_close_inward,door_open_inward,door_close_outward,bottle_cap,push_block,re_orientation,block_stack,grasp_and_place,swing_cup,scissors,pen,switch,pour_water}
bidex=${BIDEX:-build/apps/bidex}
mkdir -p "$out"
"$bidex" bench agree --task "$tasks" --episodes 1000 --slots 1024 --out "$out/agree.json" || exit 1
"$bidex" bench warp --task "$tasks" --worlds 16384 --seconds 3 --rounds 2 \
  --min-checked 1000000 --out "$out/warp.json" || exit 1
python3 - "$out/agree.json" "$out/warp.json" <<'PY'
import json, sys
agree, warp = (json.load(open(p)) for p in sys.argv[1:3])
bad = []
for r in agree["results"]:
    if not r["agree"]:
        bad.append(f"{r['task']}: CPU and GPU differ: " + ", ".join(
            f"{m['metric']} {m['cpu_mean']:.4g} vs {m['gpu_mean']:.4g} (tolerance {m['tolerance']:.3g})"
            for m in r["metrics"] if not m["agree"]))
for r in warp["results"]:
    if r["checked_slot_steps"] < 1_000_000:
        bad.append(f"{r['task']}: only {r['checked_slot_steps']} checked slot-steps")
    if r["faults"] or r.get("task_faults", 0):
        bad.append(f"{r['task']}: {r['faults']} faults, {r.get('task_faults', 0)} in the task step"
                   + (f" ({r['room_advice']})" if r.get("room_advice") else ""))
for r in warp.get("determinism", []):
    print(f"{r['task']}: two fresh backends bitwise equal after {r['steps']} steps: "
          f"{r['bitwise_identical']}")
print("\n".join(bad) if bad else "gpu_check: every task agrees and ran without a fault")
sys.exit(1 if bad else 0)
PY
