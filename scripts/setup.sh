#!/usr/bin/env bash
# Installs whatever Debian 12 packages bidex needs and are missing, makes the virtual environment
# .venv/ with the pinned MuJoCo wheel (its C library and headers; Debian's MuJoCo is 2.2.2), then
# configures and builds bidex (Release, Ninja, ccache when present) into ./build (or
# $BIDEX_BUILD_DIR).
#   scripts/setup.sh            install what is missing, build everything
#   scripts/setup.sh --no-apt   no Debian packages (machines without apt); the venv as above
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake ninja-build ccache git pkg-config
          python3-venv libtorch-dev libyaml-cpp-dev libsqlite3-dev catch2
          libeigen3-dev libcli11-dev nlohmann-json3-dev librandom123-dev
          libosmesa6-dev libpng-dev   # headless rendering (sim/render): OSMesa and libpng
          python3-dev pybind11-dev    # the GPU backend embeds Python (sim/warp_backend)
          libhdf5-dev libssl-dev      # offline datasets: HDF5 files, SHA-256 checksums
          libopenblas0-pthread        # LibTorch's CPU matrix products: 2-4.5x faster updates than
                                      # the reference BLAS (bench/results/blas-2core.txt)
          librsvg2-bin                # rsvg-convert: PNG copies of SVG plots (registry report age)
          python3-yaml)               # the bench scripts' YAML (bench/sweep_*.py and their test)
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

# MuJoCo from its official wheel, pinned (cmake/BidexMuJoCo.cmake finds it there), the GPU
# backend's MuJoCo Warp, pinned (its tests run it on Warp's CPU device where there is no GPU), and
# h5py, with which the dataset tests read the HDF5 files as Minari's users do; nanobind, which
# builds the Python module, and gymnasium and pytest, which it is used and tested with (python/)
wheels=(mujoco==3.17.0 warp-lang==1.19.0 mujoco-warp==4.0.0 h5py==3.12.1
        nanobind==3.1.0 gymnasium==1.4.0 pytest==9.2.0)
venv=.venv
if ! "$venv/bin/python" - "${wheels[@]}" 2>/dev/null <<'PY'
import importlib.metadata as m, sys
sys.exit(any(m.version(n) != v for n, v in (w.split("==") for w in sys.argv[1:])))
PY
then
  echo "setup: installing ${wheels[*]} into $venv/"
  [[ -x "$venv/bin/python" ]] || python3 -m venv "$venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check "${wheels[@]}"
fi

cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release ${BIDEX_CMAKE_ARGS:-} >/dev/null
cmake --build "$build_dir"
# the Python package of the build tree, importable in the venv (.venv/bin/python -c 'import bidex');
# pip install . builds and installs it into another environment (python/README.md)
site=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$(realpath "$build_dir")/python" > "$site/bidex.pth.tmp" && mv "$site/bidex.pth.tmp" "$site/bidex.pth"
echo "setup: built $build_dir/apps/bidex and the Python package (.venv/bin/python -c 'import bidex')"
