#!/usr/bin/env bash
# A GPU lease's build and work in the background, so that device calls only carry files and wait
# (the device tool lays the working tree down again on every call, and in the fourteenth lease a
# background build in the call's working folder failed on a tracked header that was missing
# meanwhile: bench/results/suites-h200/lease14/lease.txt):
#   bench/lease_run.sh build PARTS [SRC]
#       copies this working tree to SRC (default /root/src; an existing SRC is replaced, its
#       build-gpu kept), joins the bundle's PARTS (scripts/offline-build.sh split) and starts
#       the build of bidex there in the background (SRC/build-gpu, no renderer; log
#       SRC/build.log); returns at once
#   bench/lease_run.sh then SRC COMMAND
#       in the background: waits for SRC's build, then runs COMMAND (one bash command line) in
#       SRC with BIDEX_GPU_BUILD=build-gpu (log SRC/then.log, each line timed); returns at once;
#       several `then` calls run their commands side by side
#   bench/lease_run.sh status SRC
#       the build's state and the tail of then.log
#   bench/lease_run.sh keep-cache DEST [FIRST [COUNT]]
#       Warp's kernel cache (~/.cache/warp; a fresh machine spends minutes compiling the scenes'
#       kernels before the first step) as warp-cache.tar.partNN of 15 MiB in DEST (bench/carry.sh
#       out, split once a machine; at most four parts a call come back); `build` unpacks those
#       parts into ~/.cache before it starts when PARTS holds them beside the bundle's
# BIDEX_COMMIT (the commit of the results) is passed on to COMMAND.
# A machine goes back after 30 s without a call (idle_release_s), with everything on it: while
# COMMAND runs, send the next waiting call as soon as the last returns (local work beside it only
# if it ends first), and let every waiting call pack the runs finished so far into $OUT, so that a
# lost machine loses only the run in progress (bench/results/learner-equiv-h200/lease29/lease.txt).
# A call packs only when it ends, so keep waiting calls to about one run's length: a machine taken
# back during a 545 s call lost the runs finished since the last pack (three, by the chain's
# timing: bench/results/learner-equiv-h200/lease34/lease.txt).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
stage=${1:-}
if [[ -z "$stage" || "$stage" == -h || "$stage" == --help ]]; then
  sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
built='^build: .*apps/bidex'
cache_parent=${XDG_CACHE_HOME:-$HOME/.cache}  # Warp's kernel cache is its folder warp/
case "$stage" in
build)
  parts=$(realpath -e "${2:?PARTS}") || exit 2
  compgen -G "$parts/bidex-deps.tar.part*" >/dev/null ||
    { echo "lease_run: no bidex-deps.tar.part* in $parts" >&2; exit 2; }
  src=$(realpath -m "${3:-/root/src}")
  [[ "$src" != "$here" ]] || { echo "lease_run: SRC is this working tree itself" >&2; exit 2; }
  # only a folder this script made is emptied (it holds the marker .lease-src)
  if [[ -d $src && -n $(ls -A "$src") && ! -f $src/.lease-src ]]; then
    echo "lease_run: $src exists and is not a copy made by lease_run.sh build; not replaced" >&2
    exit 2
  fi
  mkdir -p "$src"
  find "$src" -mindepth 1 -maxdepth 1 ! -name build-gpu -exec rm -rf {} +
  touch "$src/.lease-src"
  tar -C "$here" --exclude=./build-gpu --exclude=./build --exclude=./.venv --exclude=./.whl -cf - . |
    tar -C "$src" -xf - || { echo "lease_run: copying the tree to $src failed" >&2; exit 1; }
  cd "$src" || exit 1
  scripts/offline-build.sh join "$parts" /tmp/bidex-deps || exit 1
  if [[ -f $parts/warp-cache.sha256 ]]; then
    bench/carry.sh in warp-cache "$parts" "$cache_parent" || exit 1
  fi
  rm -f build.end
  BIDEX_CMAKE_ARGS="${BIDEX_CMAKE_ARGS:--DBIDEX_RENDER_GL=NONE}" BIDEX_BUILD_TARGETS=bidex \
    setsid nohup bash -c 'scripts/offline-build.sh build /tmp/bidex-deps build-gpu; echo $? >build.end' \
    >"$src/build.log" 2>&1 </dev/null &
  echo "lease_run: building in $src (log $src/build.log)"
  ;;
then)
  src=$(realpath -e "${2:?SRC}") || exit 2
  cmd=${3:?COMMAND}
  [[ -f "$src/build.log" ]] || { echo "lease_run: no build in $src (run build first)" >&2; exit 2; }
  # shellcheck disable=SC2016
  setsid nohup bash -c '
    cd "$0" || exit 1
    until grep -q "$2" build.log; do
      [[ -f build.end ]] && ! grep -q "$2" build.log &&
        { echo "$(date -u +%T) the build ended without bidex: $1 not run"; exit 1; }
      sleep 5
    done
    echo "$(date -u +%T) start: $1"
    BIDEX_GPU_BUILD=build-gpu bash -c "$1"
    rc=$?  # before $(date ...) below, which sets $? itself
    echo "$(date -u +%T) end (exit $rc): $1"' "$src" "$cmd" "$built" \
    >>"$src/then.log" 2>&1 </dev/null &
  echo "lease_run: after the build, in $src: $cmd (log $src/then.log)"
  ;;
status)
  src=$(realpath -e "${2:?SRC}") || exit 2
  if grep -q "$built" "$src/build.log" 2>/dev/null; then echo "build: done"
  elif [[ ! -f "$src/build.end" ]]; then echo "build: running, $(tail -n1 "$src/build.log" 2>/dev/null)"
  else
    echo "build: failed (exit $(cat "$src/build.end"))"
    grep -m3 -A8 '^FAILED' "$src/build.log" || tail -n 20 "$src/build.log"
  fi
  tail -n 20 "$src/then.log" 2>/dev/null
  ;;
keep-cache)
  [[ -d $cache_parent/warp ]] || { echo "lease_run: no Warp kernel cache in $cache_parent/warp" >&2; exit 1; }
  du -sh "$cache_parent/warp"
  "$here/bench/carry.sh" out warp-cache "$cache_parent" /tmp/bidex-carry "${2:?DEST}" \
    "${3:-0}" "${4:-1000000}" -- warp
  ;;
*)
  echo "lease_run: unknown stage $stage (build, then, status or keep-cache)" >&2
  exit 2
  ;;
esac
