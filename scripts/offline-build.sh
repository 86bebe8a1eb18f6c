#!/usr/bin/env bash
# Builds bidex on a machine that has PyTorch but no package access (a GPU node, a cluster
# without root), from Debian 12 packages bundled beforehand on a machine that has apt.
#
#   scripts/offline-build.sh bundle [DEPS]          # where apt works: download the .debs (default .deps/)
#   scripts/offline-build.sh build  [DEPS] [BUILD]  # on the target: unpack, configure, build
#
# `build` unpacks every .deb into a private prefix (BUILD/deps, never /), finds LibTorch through
# the local PyTorch (python3 -c 'import torch; print(torch.utils.cmake_prefix_path)', or
# $BIDEX_TORCH_PREFIX) so tensors go to its GPU, and links with an old-style rpath so that
# MuJoCo's own dependencies are found at run time without LD_LIBRARY_PATH.
set -euo pipefail
cd "$(dirname "$0")/.."

debs=(libmujoco2.2.2 libmujoco-dev libccd2 liblodepng0 libqhull-r8.0 libtinyxml2-9
      libyaml-cpp0.7 libyaml-cpp-dev libsqlite3-0 libsqlite3-dev catch2 libeigen3-dev
      libcli11-dev nlohmann-json3-dev
      libgl-dev libglx-dev libopengl-dev libgl1 libglx0 libopengl0 libglvnd0  # OpenGL: named by mujocoConfig.cmake
      # headless rendering (sim/render): OSMesa (software llvmpipe, opened at the first render)
      # with what Ubuntu 24.04 lacks of its LLVM's dependencies, and libpng (~44 MB of .debs)
      libosmesa6 libosmesa6-dev libglapi-mesa libllvm15 libz3-4 libedit2 libbsd0 libmd0
      libxml2 libicu72 libpng16-16 libpng-dev)

mode=${1:-}
deps=$(realpath -m "${2:-.deps}")
case "$mode" in
  bundle)
    mkdir -p "$deps"
    (cd "$deps" && apt-get download "${debs[@]}")
    du -sh "$deps"
    echo "bundle: ${#debs[@]} packages in $deps; take that folder to the target machine"
    ;;
  build)
    build=$(realpath -m "${3:-build}")
    prefix="$build/deps"
    ls "$deps"/*.deb >/dev/null 2>&1 || { echo "build: no .deb files in $deps (run 'bundle' first)" >&2; exit 1; }
    mkdir -p "$prefix"
    for f in "$deps"/*.deb; do dpkg -x "$f" "$prefix"; done
    torch_prefix=${BIDEX_TORCH_PREFIX:-$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')}
    lib="$prefix/usr/lib/x86_64-linux-gnu"
    link="-Wl,-rpath-link,$lib -Wl,--disable-new-dtags -Wl,-rpath,$lib"
    cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$torch_prefix;$prefix/usr;$lib/cmake;$prefix/usr/share/cmake;$prefix/usr/lib/cmake" \
      -DCMAKE_EXE_LINKER_FLAGS="$link" -DCMAKE_SHARED_LINKER_FLAGS="$link" ${BIDEX_CMAKE_ARGS:-}
    cmake --build "$build"
    echo "build: $build/apps/bidex (data: BIDEX_DATA_DIR=$(pwd) if the tree moves)"
    ;;
  *)
    sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
