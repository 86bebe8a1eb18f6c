#!/usr/bin/env bash
# MuJoCo 2.2.2 against this tree's MuJoCo in one job on one machine: builds bidex twice (an older
# commit on Debian's MuJoCo 2.2.2, and this tree), then measures `bidex bench task` for every task
# at SLOTS on both, alternating old and new per task, and `bidex bench sim` on this tree. Each
# result file records machine, date, commit and command; compare.json holds the ratios.
#   bench/mujoco_compare.sh OUTDIR OLD_SRC OLD_DEPS NEW_DEPS
# OLD_SRC: the older commit's source (git archive OLD | tar -x -C OLD_SRC); OLD_DEPS, NEW_DEPS:
# each tree's `scripts/offline-build.sh bundle` folder. BIDEX_SLOTS (2048), BIDEX_SECONDS (3),
# BIDEX_TASKS (all twenty) change what is measured; BIDEX_OLD_COMMIT and BIDEX_COMMIT name the two
# commits in the result files when the trees have no .git.
set -uo pipefail
cd "$(dirname "$0")/.."
out=$(realpath -m "${1:?OUTDIR}")
old_src=$(realpath "${2:?OLD_SRC}")
old_deps=$(realpath "${3:?OLD_DEPS}")
new_deps=$(realpath "${4:?NEW_DEPS}")
slots=${BIDEX_SLOTS:-2048}
secs=${BIDEX_SECONDS:-3}
old_build=/tmp/bidex-old-build
new_build=/tmp/bidex-new-build
mkdir -p "$out"

SECONDS=0
export BIDEX_CMAKE_ARGS="-DBIDEX_TESTS=OFF ${BIDEX_CMAKE_ARGS:-}"
(cd "$old_src" && scripts/offline-build.sh build "$old_deps" "$old_build") >"$out/build_old.log" 2>&1 ||
  { tail -30 "$out/build_old.log"; exit 1; }
echo "build old: ${SECONDS}s"
scripts/offline-build.sh build "$new_deps" "$new_build" >"$out/build_new.log" 2>&1 ||
  { tail -30 "$out/build_new.log"; exit 1; }
echo "build new: ${SECONDS}s"

tasks=${BIDEX_TASKS:-"hand_over catch_underarm catch_over2underarm catch_abreast two_catch_underarm lift_underarm door_open_outward door_close_inward door_open_inward door_close_outward bottle_cap push_block swing_cup scissors re_orientation pen switch block_stack pour_water grasp_and_place"}
for t in $tasks; do
  for v in old new; do
    build=${v}_build
    commit=$([ $v = old ] && echo "${BIDEX_OLD_COMMIT:-old}" || echo "${BIDEX_COMMIT:-new}")
    (cd "$([ $v = old ] && echo "$old_src" || pwd)" &&
      BIDEX_COMMIT=$commit BIDEX_DATA_DIR="$PWD" "${!build}/apps/bidex" bench task --task "$t" --slots "$slots" \
        --seconds "$secs" --no-profile --out "$out/task_${v}_$t.json") >/dev/null 2>&1 ||
      echo "bench task $v $t failed"
  done
  echo "$t: ${SECONDS}s"
done

"$new_build/apps/bidex" bench sim --threads 16 --slots 2048,8192 --seconds 1 --rounds 2 \
  --memory-slots 8192 --out "$out/bench_sim.json" >/dev/null 2>&1 || echo "bench sim failed"
echo "bench sim: ${SECONDS}s"

python3 - "$out" $tasks <<'PY'
import json, sys, os
out, tasks = sys.argv[1], sys.argv[2:]
rows = []
for t in tasks:
    r = {"task": t}
    for v in ("old", "new"):
        try:
            j = json.load(open(os.path.join(out, f"task_{v}_{t}.json")))
            res = j["results"][0]
            r[v] = res["slot_steps_per_s"]
            r[v + "_faults"] = res.get("faults")
            r[v + "_commit"] = j.get("commit")
            if v == "new":
                for k in ("memory", "maxuse_arena", "maxuse_con", "maxuse_efc"):
                    r[k] = res.get(k)
        except Exception as e:
            r[v] = None
            r[v + "_error"] = str(e)
    r["ratio"] = r["new"] / r["old"] if r.get("new") and r.get("old") else None
    rows.append(r)
json.dump({"what": "bidex bench task slot-steps/s, MuJoCo 2.2.2 (old) and this tree (new), "
                   "alternating per task in one job", "rows": rows},
          open(os.path.join(out, "compare.json"), "w"), indent=1)
for r in rows:
    print(f"{r['task']:22s} {r.get('old') or 0:9.0f} {r.get('new') or 0:9.0f} {r.get('ratio') or 0:5.2f}x  arena {r.get('maxuse_arena')}/{r.get('memory')}")
PY
echo "total: ${SECONDS}s"
