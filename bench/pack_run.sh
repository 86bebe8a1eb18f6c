#!/usr/bin/env bash
# Packed-suite throughput and the random-policy reference scores on a GPU machine without package
# access (16 cores): build from the bundled Debian packages, measure MT20 packed against each of
# its twenty tasks alone at the same slot count (bidex bench pack), then each task's random-policy
# return (bidex eval --random, one task at a time); results go to OUTDIR.
#   bench/pack_run.sh OUTDIR DEPS [SLOTS] [EPISODES]   (EPISODES 0: no references;
#   BIDEX_SKIP_PACK=1: references only, with the build left by an earlier call)
set -uo pipefail
cd "$(dirname "$0")/.."
out=$(realpath -m "$1"); deps=$2; slots=${3:-2048}; episodes=${4:-256}
build=${BIDEX_GPU_BUILD:-/tmp/bidex-gpu-build}
mkdir -p "$out"
SECONDS=0
if [ ! -x "$build/apps/bidex" ] || [ -n "${BIDEX_REBUILD:-}" ]; then
  scripts/offline-build.sh build "$deps" "$build" >"$out/build.log" 2>&1 || { tail -30 "$out/build.log"; exit 1; }
  echo "build: ${SECONDS}s"
fi
bidex="$build/apps/bidex"
if [ -z "${BIDEX_SKIP_PACK:-}" ]; then
"$bidex" bench pack --suite MT20 --slots "$slots" --seconds 3 --rounds 2 \
  --out "$out/pack-mt20.json" 2>"$out/pack-mt20.log"
echo "bench pack: ${SECONDS}s"
python3 - "$out/pack-mt20.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print(f"MT20 packed {j['packed']['slot_steps_per_s']:.0f}/s, mean single {j['mean_single_slot_steps_per_s']:.0f}/s, ratio {j['packed_over_mean_single']:.3f}")
PY
fi
if [ "$episodes" -gt 0 ]; then
  # one task at a time (a pack would step every slot until the longest episode, 600 steps, ends)
  export BIDEX_REGISTRY="$out/references.sqlite"
  for t in hand_over catch_underarm catch_over2underarm catch_abreast two_catch_underarm \
           lift_underarm door_open_outward door_close_inward door_open_inward door_close_outward \
           bottle_cap push_block swing_cup scissors re_orientation pen switch block_stack \
           pour_water grasp_and_place; do
    "$bidex" eval --random --task "$t" --episodes "$episodes" --seed 2026 --set-reference \
      --json "$out/random-$t.json" >>"$out/random.txt" 2>&1
  done
  grep "random policy" "$out/random.txt"
  echo "random references: ${SECONDS}s"
fi
echo "total: ${SECONDS}s"
