#!/usr/bin/env bash
# Installs whatever Debian 12 packages bidex needs and are missing, then configures and builds
# it (Release, Ninja, ccache when present) into ./build (or $BIDEX_BUILD_DIR).
#   scripts/setup.sh            install missing packages, build everything
#   scripts/setup.sh --no-apt   only build (for machines without package access)
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake ninja-build ccache git pkg-config
          libmujoco-dev libmujoco-samples libtorch-dev libyaml-cpp-dev libsqlite3-dev catch2
          libeigen3-dev libcli11-dev nlohmann-json3-dev
          libosmesa6-dev libpng-dev)  # headless rendering (sim/render): OSMesa and libpng
build_dir=${BIDEX_BUILD_DIR:-build}

if [[ "${1:-}" != "--no-apt" ]]; then
  missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]})); then
    echo "setup: installing ${missing[*]}"
    if [[ $(id -u) -ne 0 ]]; then
      echo "setup: run as root (or: sudo apt-get install -y ${missing[*]})" >&2
      exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
fi

cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release ${BIDEX_CMAKE_ARGS:-} >/dev/null
cmake --build "$build_dir"
echo "setup: built $build_dir/apps/bidex"
