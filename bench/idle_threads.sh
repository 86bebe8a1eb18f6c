#!/usr/bin/env bash
# Idle threads that sleep (core/idle_threads.h) against the libraries' defaults, on the CPU:
# the Quickstart's training, the TD3 learning test, the physics alone (bidex sim), and the cost
# of the second start. "spin" is libgomp's and OpenBLAS's defaults written out (GOMP_SPINCOUNT
# 300000, OPENBLAS_THREAD_TIMEOUT 28; OMP_WAIT_POLICY set so that bidex does not start again);
# "sleep" is what bidex now sets. Each row also gives the run's final metrics row, which must be
# the same in both. Usage: bench/idle_threads.sh OUT.txt [REPS]
set -euo pipefail
out=$1
reps=${2:-2}
bidex=build/apps/bidex
tests=build/tests/bidex_torch_tests
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
spin=(OMP_WAIT_POLICY=passive GOMP_SPINCOUNT=300000 OPENBLAS_THREAD_TIMEOUT=28)
sleep_=(OMP_WAIT_POLICY=passive OPENBLAS_THREAD_TIMEOUT=4)
timed() {  # LABEL ENV... -- COMMAND...: wall, user, sys seconds
  local label=$1; shift; local envs=(); while [ "$1" != -- ]; do envs+=("$1"); shift; done; shift
  env "${envs[@]}" /usr/bin/time -f "$label: %e s wall, %U s user, %S s sys" "$@" 2>&1 >/dev/null |
    grep "^$label:"
}
{
  echo "# idle threads on the CPU: libraries' defaults (spin) against core/idle_threads.h (sleep)"
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "commit: ${BIDEX_COMMIT:-$(git rev-parse --short HEAD)}"
  echo "command: bench/idle_threads.sh $out $reps"
  echo
  echo "## the Quickstart's training: bidex train --task catch_underarm_raise (30 updates)"
  for r in $(seq "$reps"); do
    for mode in spin sleep; do
      if [ $mode = spin ]; then e=("${spin[@]}"); else e=("${sleep_[@]}"); fi
      timed "$mode" "${e[@]}" -- "$bidex" train --task catch_underarm_raise --no-registry \
        --run "$tmp/$mode$r"
      echo "  final row: $(tail -1 "$tmp/$mode$r/metrics.csv" | cut -d, -f1,2,6-9)"
    done
  done
  echo
  echo "## the TD3 learning test (tests/rl/learning_test.cc), alone"
  for mode in spin sleep; do
    if [ $mode = spin ]; then e=("${spin[@]}"); else e=("${sleep_[@]}"); fi
    timed "$mode" "${e[@]}" -- "$tests" "TD3 learns catch_underarm_raise within its CI budget"
  done
  echo
  echo "## physics alone: bidex sim --slots 64 --steps 240 (OpenMP only)"
  for mode in spin sleep; do
    if [ $mode = spin ]; then e=("${spin[@]}"); else e=("${sleep_[@]}"); fi
    timed "$mode" "${e[@]}" -- "$bidex" sim --slots 64 --steps 240
    env "${e[@]}" "$bidex" sim --slots 64 --steps 240 | grep "slot-steps/s" | sed 's/^/  /'
  done
  echo
  echo "## the second start: bidex --help with the variables unset (bidex starts again) or set"
  for r in 1 2 3; do
    timed unset -u OMP_WAIT_POLICY -u OPENBLAS_THREAD_TIMEOUT -- "$bidex" --help
    timed set "${sleep_[@]}" -- "$bidex" --help
  done
} | tee "$out"
