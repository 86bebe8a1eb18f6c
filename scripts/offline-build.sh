#!/usr/bin/env bash
# Builds bidex on a machine that has PyTorch but no package access (a GPU node, a cluster
# without root), from Debian 12 packages and the MuJoCo wheel bundled beforehand on a machine
# that has apt and pip.
#
#   scripts/offline-build.sh bundle [DEPS]          # where apt works: the .debs and the wheel (default .deps/)
#   scripts/offline-build.sh build  [DEPS] [BUILD]  # on the target: unpack, configure, build
#
# `bundle` downloads the mujoco wheel for the target's Python: $BIDEX_TARGET_PYTHON (default 3.11,
# Debian 12's; 3.12 on the GPU machine). `build` unpacks every .deb into a private prefix
# (BUILD/deps, never /) and the wheel matching the local python3 beside it, finds LibTorch
# through the local PyTorch (python3 -c 'import torch; print(torch.utils.cmake_prefix_path)', or
# $BIDEX_TORCH_PREFIX) so tensors go to its GPU, and links with an old-style rpath so that the
# bundled libraries are found at run time without LD_LIBRARY_PATH.
set -euo pipefail
cd "$(dirname "$0")/.."

mujoco_version=3.17.0  # as cmake/BidexMuJoCo.cmake
debs=(libyaml-cpp0.7 libyaml-cpp-dev libsqlite3-0 libsqlite3-dev catch2 libeigen3-dev
      libcli11-dev nlohmann-json3-dev librandom123-dev
      # headless rendering (sim/render): OpenGL headers, OSMesa (software llvmpipe, opened at the first render)
      # with what Ubuntu 24.04 lacks of its LLVM's dependencies, and libpng (~44 MB of .debs)
      libgl-dev libglx-dev libopengl-dev libgl1 libglx0 libopengl0 libglvnd0
      libosmesa6 libosmesa6-dev libglapi-mesa libllvm15 libz3-4 libedit2 libbsd0 libmd0
      libxml2 libicu72 libpng16-16 libpng-dev)

mode=${1:-}
deps=$(realpath -m "${2:-.deps}")
case "$mode" in
  bundle)
    mkdir -p "$deps"
    (cd "$deps" && apt-get download "${debs[@]}")
    py=${BIDEX_TARGET_PYTHON:-3.11}
    python3 -m pip download -q --disable-pip-version-check --no-deps --only-binary=:all: \
      --implementation cp --python-version "$py" --platform manylinux_2_28_x86_64 \
      --platform manylinux_2_27_x86_64 -d "$deps" "mujoco==$mujoco_version"
    du -sh "$deps"
    echo "bundle: ${#debs[@]} packages and the mujoco wheel for Python $py in $deps; take that folder to the target machine"
    ;;
  build)
    build=$(realpath -m "${3:-build}")
    prefix="$build/deps"
    ls "$deps"/*.deb >/dev/null 2>&1 || { echo "build: no .deb files in $deps (run 'bundle' first)" >&2; exit 1; }
    mkdir -p "$prefix"
    for f in "$deps"/*.deb; do dpkg -x "$f" "$prefix"; done
    # the mujoco wheel for this machine's python3 (a wheel is a zip archive)
    tag=$(python3 -c 'import sys; print("cp%d%d" % sys.version_info[:2])')
    wheel=$(ls "$deps"/mujoco-"$mujoco_version"-"$tag"-*.whl 2>/dev/null | head -1)
    [[ -n "$wheel" ]] || { echo "build: no mujoco-$mujoco_version-$tag wheel in $deps (bundle with BIDEX_TARGET_PYTHON=$(python3 -c 'import sys; print("%d.%d" % sys.version_info[:2])'))" >&2; exit 1; }
    python3 -m zipfile -e "$wheel" "$prefix/python"
    torch_prefix=${BIDEX_TORCH_PREFIX:-$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')}
    lib="$prefix/usr/lib/x86_64-linux-gnu"
    link="-Wl,-rpath-link,$lib -Wl,--disable-new-dtags -Wl,-rpath,$lib"
    cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$torch_prefix;$prefix/usr;$lib/cmake;$prefix/usr/share/cmake;$prefix/usr/lib/cmake" \
      -DBIDEX_MUJOCO_DIR="$prefix/python/mujoco" \
      -DCMAKE_EXE_LINKER_FLAGS="$link" -DCMAKE_SHARED_LINKER_FLAGS="$link" ${BIDEX_CMAKE_ARGS:-}
    cmake --build "$build" ${BIDEX_BUILD_TARGETS:+--target $BIDEX_BUILD_TARGETS}
    echo "build: $build/apps/bidex (data: BIDEX_DATA_DIR=$(pwd) if the tree moves)"
    ;;
  *)
    sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
