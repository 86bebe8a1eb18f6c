#!/usr/bin/env bash
# bidex from Python on a GPU machine without package access (python/README.md), in slices that
# fit one device call each:
#   bench/python_gpu_run.sh build PARTS WHEELS
#       the Python wheels in WHEELS (nanobind, gymnasium and its dependencies, for the machine's
#       python3) into that python3, then the bundle's parts joined and bidex and its Python
#       module built against it (scripts/offline-build.sh). WHEELS, where pip works (numpy is
#       installed from it only where missing; the GPU machine has it):
#         pip download --only-binary=:all: --python-version 3.12 --platform manylinux_2_28_x86_64 \
#           --platform any -d .whl/py312 nanobind==3.1.0 gymnasium==1.4.0
#   bench/python_gpu_run.sh speed OUTDIR TASK WORLDS
#       `bidex bench warp`'s task step, the Python loop (bench/python_speed.py), then bench warp
#       again, on TASK at WORLDS worlds: OUTDIR/speed.json with the ratio of the Python loop to
#       the faster of the two bench warp rates
#   bench/python_gpu_run.sh ppo OUTDIR TASK STEPS TARGET [ARGS...]
#       examples/ppo_torch.py on the GPU (16,384 worlds, 16 minibatches, seed 0) in its own
#       process session, into OUTDIR/ppo (it outlives the call; `wait` follows it)
#   bench/python_gpu_run.sh wait OUTDIR SECONDS
#       waits up to SECONDS for the PPO run
# BIDEX_COMMIT names the commit in the results; BIDEX_GPU_BUILD is the build (default build-gpu).
set -uo pipefail
cd "$(dirname "$0")/.."
stage=${1:-}
if [[ -z "$stage" || "$stage" == -h || "$stage" == --help ]]; then
  sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'
  exit 0
fi
build=${BIDEX_GPU_BUILD:-build-gpu}
export PYTHONPATH=$PWD/$build/python${PYTHONPATH:+:$PYTHONPATH}
case "$stage" in
build)
  parts=${2:?PARTS}; wheels=${3:?WHEELS}
  python3 -c 'import numpy' 2>/dev/null || python3 -m pip install -q --no-index --no-deps "$wheels"/numpy-*.whl
  python3 -m pip install -q --disable-pip-version-check --no-index --no-deps \
    $(ls "$wheels"/*.whl | grep -v /numpy-) || exit 1
  deps=${BIDEX_GPU_DEPS:-/tmp/bidex-deps}
  scripts/offline-build.sh join "$parts" "$deps" >/tmp/join.log 2>&1 || { cat /tmp/join.log; exit 1; }
  BIDEX_CMAKE_ARGS="-DBIDEX_RENDER_GL=NONE -DBIDEX_TESTS=OFF -DPython_EXECUTABLE=$(command -v python3)" \
  BIDEX_BUILD_TARGETS="bidex _bidex bidex_python_sources" \
    scripts/offline-build.sh build "$deps" "$build" >/tmp/build.log 2>&1 || { tail -40 /tmp/build.log; exit 1; }
  python3 -c 'import bidex; print("bidex imports:", bidex.__file__)' || exit 1
  echo "build: ${SECONDS}s"
  ;;
speed)
  out=$(realpath -m "${2:?OUTDIR}"); task=${3:?TASK}; worlds=${4:?WORLDS}
  mkdir -p "$out"
  bench() {
    "$build/apps/bidex" bench warp --task "$task" --worlds "$worlds" --seconds 5 --rounds 2 \
      --determinism-steps 0 --out "$out/bench-warp-$1.json" >"$out/bench-warp-$1.log" 2>&1 \
      || { tail "$out/bench-warp-$1.log"; exit 1; }
  }
  bench 1
  python3 bench/python_speed.py --task "$task" --num-envs "$worlds" --out "$out/python-loop.json" \
    >"$out/python-loop.log" 2>&1 || { tail -30 "$out/python-loop.log"; exit 1; }
  bench 2
  python3 - "$out" "${BIDEX_COMMIT:-unknown}" <<'PY'
import json, os, sys, datetime
out, commit = sys.argv[1], sys.argv[2]
py = json.load(open(f"{out}/python-loop.json"))
warp = [json.load(open(f"{out}/bench-warp-{k}.json"))["results"][0] for k in (1, 2)]
best = max(w["task_slot_steps_per_s"] for w in warp)
res = {"commit": commit, "date": datetime.datetime.now(datetime.timezone.utc).isoformat(),
       "machine": py["device"], "task": py["task"], "worlds": py["worlds"],
       "python_loop_slot_steps_per_s": py["slot_steps_per_s"], "python_rounds": py["rounds"],
       "bench_warp_task_slot_steps_per_s": [w["task_slot_steps_per_s"] for w in warp],
       "bench_warp_raw_slot_steps_per_s": [w["raw_slot_steps_per_s"] for w in warp],
       "ratio_python_to_bench_warp": py["slot_steps_per_s"] / best,
       "commands": ["bidex bench warp --task %s --worlds %d --seconds 5 --rounds 2 "
                    "--determinism-steps 0 (twice)" % (py["task"], py["worlds"]), py["command"]]}
json.dump(res, open(f"{out}/speed.json", "w"), indent=2)
print(json.dumps({k: res[k] for k in ("python_loop_slot_steps_per_s",
      "bench_warp_task_slot_steps_per_s", "ratio_python_to_bench_warp")}))
PY
  ;;
ppo)
  out=$(realpath -m "${2:?OUTDIR}"); task=${3:?TASK}; steps=${4:?STEPS}; target=${5:?TARGET}
  shift 5
  mkdir -p "$out/ppo"
  cmd=(python3 examples/ppo_torch.py --task "$task" --num-envs 16384 --minibatches 16
       --device cuda --seed 0 --steps "$steps" --target "$target" --out "$out/ppo" --plot "$@")
  echo "${cmd[*]}" >"$out/ppo/command.txt"
  setsid nohup bash -c "$(printf '%q ' "${cmd[@]}") >'$out/ppo/train.log' 2>&1; echo \$? >'$out/ppo/rc'" \
    >/dev/null 2>&1 < /dev/null &
  echo "ppo: started ($out/ppo)"
  ;;
wait)
  out=$(realpath -m "${2:?OUTDIR}"); secs=${3:?SECONDS}
  end=$((SECONDS + secs))
  while [[ ! -f "$out/ppo/rc" ]] && (( SECONDS < end )); do sleep 20; tail -1 "$out/ppo/train.log"; done
  [[ -f "$out/ppo/rc" ]] && echo "ppo: exit $(cat "$out/ppo/rc")"
  tail -3 "$out/ppo/train.log"
  ;;
*)
  echo "python_gpu_run.sh: unknown stage '$stage' (expected build, speed, ppo or wait; --help)" >&2
  exit 2
  ;;
esac
