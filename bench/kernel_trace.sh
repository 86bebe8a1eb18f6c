#!/usr/bin/env bash
# Every kernel a CUDA program runs, with its GPU times and stream, on a machine where nsys cannot
# make a report (the GPU machines: /work/.library/device/KINDS.md), through CUPTI's injection
# (bench/kernel_trace.cc; bench/kernel_trace.py summarises the file):
#   bench/kernel_trace.sh build LIB
#       LIB (a shared library) built from bench/kernel_trace.cc against the CUPTI that the
#       machine has (CUDA's own include/ and lib64/, its extras/CUPTI, or the nvidia-cuda-cupti
#       wheel of the python3 that holds PyTorch; CUPTI_ROOT names another folder with
#       include/cupti.h), the newest record types of its header named at build time; prints
#       what it used
#   bench/kernel_trace.sh run LIB TRACE -- COMMAND [ARG...]
#       COMMAND with LIB injected (CUDA_INJECTION64_PATH: the driver loads it at the first
#       cuInit), its kernels, copies and memsets written to TRACE (KTRACE_OUT); exits with
#       COMMAND's status. KTRACE_DEVICE_GRAPHS=0 leaves device-launched graphs untraced.
#       For diagnosis only: on an H200 (2026-12-02) a traced `bidex bench pack` and `bench warp`
#       failed with an illegal memory access partway through, where the same commands untraced
#       passed (bench/results/pack-trace-h200/README.md)
set -uo pipefail
stage=${1:-}
if [[ -z "$stage" || "$stage" == -h || "$stage" == --help ]]; then
  sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
here=$(cd "$(dirname "$0")" && pwd)

# cupti_root: a folder whose include/ holds cupti.h and whose lib64/ or lib/ holds libcupti
cupti_root() {
  local c
  local -a roots=()
  [[ -n "${CUPTI_ROOT:-}" ]] && roots+=("$CUPTI_ROOT")
  local cuda
  for cuda in ${CUDA_HOME:-} /usr/local/cuda; do
    roots+=("$cuda" "$cuda/targets/$(uname -m)-linux" "$cuda/extras/CUPTI")
  done
  local site
  site=$(python3 -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])' 2>/dev/null)
  if [[ -n "$site" && -d "$site/nvidia" ]]; then
    while IFS= read -r c; do roots+=("$(dirname "$(dirname "$c")")"); done \
      < <(find "$site/nvidia" -name cupti.h -path '*/include/*' 2>/dev/null | sort)
  fi
  for c in "${roots[@]}"; do
    if [[ -f "$c/include/cupti.h" ]] &&
       { compgen -G "$c/lib64/libcupti.so*" || compgen -G "$c/lib/libcupti.so*"; } >/dev/null; then
      echo "$c"
      return 0
    fi
  done
  echo "kernel_trace: no CUPTI found (looked for include/cupti.h with lib/libcupti.so in:" \
       "${roots[*]}); set CUPTI_ROOT" >&2
  return 1
}

# newest NAME: the highest-numbered CUPTI record type NAME<N> that the headers define
newest() {
  local name=$1 inc=$2 found
  found=$(grep -ho "}[[:space:]]*$name[0-9]*;" "$inc"/cupti*.h "$inc"/generated_cupti*.h \
            2>/dev/null | grep -o "$name[0-9]*" | sort -V | tail -1)
  [[ -n "$found" ]] || { echo "kernel_trace: no $name record type in $inc" >&2; return 1; }
  echo "$found"
}

case "$stage" in
build)
  lib=${2:?LIB}
  root=$(cupti_root) || exit 1
  libdir=$root/lib64
  compgen -G "$libdir/libcupti.so*" >/dev/null || libdir=$root/lib
  kernel=$(newest CUpti_ActivityKernel "$root/include") || exit 1
  memcpy=$(newest CUpti_ActivityMemcpy "$root/include") || exit 1
  memset=$(newest CUpti_ActivityMemset "$root/include") || exit 1
  # the wheel ships libcupti.so.N without the unversioned link
  so=$(ls "$libdir"/libcupti.so "$libdir"/libcupti.so.* 2>/dev/null | head -1)
  cuda_inc=""
  for d in "${CUDA_HOME:-/usr/local/cuda}/include" /usr/local/cuda/include; do
    [[ -f "$d/cuda.h" ]] && { cuda_inc=$d; break; }
  done
  [[ -n "$cuda_inc" ]] ||
    cuda_inc=$(dirname "$(find "$root/.." -name cuda.h 2>/dev/null | head -1)")
  echo "kernel_trace: CUPTI $root ($so), records $kernel, $memcpy, $memset, cuda.h in $cuda_inc"
  ${CXX:-g++} -std=c++17 -O2 -shared -fPIC -Wall -Wextra -o "$lib" "$here/kernel_trace.cc" \
    -I"$root/include" -I"$cuda_inc" -DKTRACE_KERNEL="$kernel" -DKTRACE_MEMCPY="$memcpy" \
    -DKTRACE_MEMSET="$memset" "$so" -Wl,-rpath,"$libdir" -ldl || exit 1
  echo "kernel_trace: built $lib"
  ;;
run)
  lib=$(realpath "${2:?LIB}"); trace=$(realpath -m "${3:?TRACE}")
  [[ "${4:-}" == "--" ]] || { echo "kernel_trace: expected -- before the command" >&2; exit 2; }
  shift 4
  [[ -f "$lib" ]] ||
    { echo "kernel_trace: no library $lib (bench/kernel_trace.sh build)" >&2; exit 1; }
  CUDA_INJECTION64_PATH=$lib KTRACE_OUT=$trace "$@"
  ;;
*)
  echo "kernel_trace: unknown stage '$stage' (build or run; --help)" >&2
  exit 2
  ;;
esac
