#!/usr/bin/env bash
# Times a cold build (no ccache) and the test suite on this machine; writes JSON with machine,
# date, commit and command.   bench/build_time.sh [OUT.json]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/dev/stdout}
dir=$(mktemp -d)
export CCACHE_DISABLE=1
t0=$(date +%s.%N)
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$dir" >/dev/null
t1=$(date +%s.%N)
ctest --test-dir "$dir" >"$dir/ctest.log"
t2=$(date +%s.%N)
summary=$(grep -E "tests passed" "$dir/ctest.log")
rm -rf "$dir"
cat >"$out" <<JSON
{
  "machine": {"cpu": "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')",
              "cores": $(nproc), "memory_gb": $(free -g | awk '/Mem:/{print $2}'),
              "date": "$(date -u +%Y-%m-%dT%H:%M:%SZ)", "commit": "$(git rev-parse --short HEAD)",
              "compiler": "$(c++ --version | head -1)"},
  "command": "bench/build_time.sh",
  "clean_build_seconds": $(echo "$t1 - $t0" | bc),
  "ctest_seconds": $(echo "$t2 - $t1" | bc),
  "ctest": "$summary"
}
JSON
