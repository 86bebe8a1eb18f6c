#!/usr/bin/env bash
# Builds bidex on a machine that has PyTorch but no package access (a GPU node, a cluster
# without root), from Debian 12 packages and the MuJoCo wheel bundled beforehand on a machine
# that has apt and pip.
#
#   scripts/offline-build.sh bundle [DEPS]          # where apt works: the .debs and the wheel (default .deps/)
#   scripts/offline-build.sh bundle-gpu [DEPS]      # the same plus the GPU backend's wheels
#   scripts/offline-build.sh packages               # the Debian packages a bundle downloads
#   scripts/offline-build.sh split [DEPS] [PARTS]   # DEPS as parts that fit beside the tree (default .parts/)
#   scripts/offline-build.sh join  [PARTS] [DEPS]   # on the target: the parts back into DEPS
#   scripts/offline-build.sh build  [DEPS] [BUILD]  # on the target: unpack, configure, build
#
# `bundle` downloads the mujoco wheel for the target's Python: $BIDEX_TARGET_PYTHON (default 3.11,
# Debian 12's; 3.12 on the GPU machine); `bundle-gpu` adds the pinned warp-lang and mujoco-warp,
# pybind11 (Python's embedding) and their dependencies (about 200 MB: warp-lang alone is 149 MB,
# hence `split` for transfers limited in size). `build` unpacks every .deb into a private prefix
# (BUILD/deps, never /) and installs the wheels for the local python3 beside it, finds LibTorch
# through the local PyTorch (python3 -c 'import torch; print(torch.utils.cmake_prefix_path)', or
# $BIDEX_TORCH_PREFIX) so tensors go to its GPU, and links with an old-style rpath so that the
# bundled libraries are found at run time without LD_LIBRARY_PATH.
# BIDEX_BUNDLE_RENDER=0: a bundle without the renderer's packages (OpenGL, OSMesa and the LLVM it
# pulls in, libpng: 44.6 MB of the GPU bundle's 255.6, bench/results/tree-and-bundle-size-2core.txt);
# `build` then configures without `bidex render` (BIDEX_RENDER_GL AUTO finds no OpenGL), as the
# GPU leases build anyway (-DBIDEX_RENDER_GL=NONE), which carry the bundle in parts a call.
set -euo pipefail
cd "$(dirname "$0")/.."

mujoco_version=3.17.0  # as cmake/BidexMuJoCo.cmake
debs=(libyaml-cpp0.7 libyaml-cpp-dev libsqlite3-0 libsqlite3-dev catch2 libeigen3-dev
      libcli11-dev nlohmann-json3-dev librandom123-dev
      # offline datasets (offline/): HDF5 (serial) with its compression libraries, and OpenSSL's
      # libcrypto (SHA-256 checksums; libhdf5 links it too)
      libhdf5-dev libhdf5-103-1 libsz2 libaec0 libssl-dev libssl3)
# headless rendering (sim/render): OpenGL headers, OSMesa (software llvmpipe, opened at the first
# render) with what Ubuntu 24.04 lacks of its LLVM's dependencies, and libpng (~44 MB of .debs)
render_debs=(libgl-dev libglx-dev libopengl-dev libgl1 libglx0 libopengl0 libglvnd0
             libosmesa6 libosmesa6-dev libglapi-mesa libllvm15 libz3-4 libedit2 libbsd0 libmd0
             libxml2 libicu72 libpng16-16 libpng-dev)
case "${BIDEX_BUNDLE_RENDER:-1}" in
  1) debs+=("${render_debs[@]}") ;;
  0) ;;
  *) echo "offline-build: BIDEX_BUNDLE_RENDER must be 1 (the default: the renderer's packages) or 0 (without them), not '${BIDEX_BUNDLE_RENDER}'" >&2
     exit 2 ;;
esac

gpu_wheels=("mujoco==$mujoco_version" warp-lang==1.19.0 mujoco-warp==4.0.0 pybind11==2.13.6)
# A part's size: $BIDEX_PART_SIZE, else what fits beside the tracked tree in a transfer of 64 MiB
# with 6 MiB to spare (the device tool refused a 27 MiB part beside a tree of 35.5 MiB, and took
# 27 MiB beside 33.7 MiB: it counts more than the files' bytes), at least 4 MiB.
default_part_size() {
  local tree
  tree=$(git ls-files -z 2>/dev/null | du -cb --files0-from=- 2>/dev/null | tail -n 1 | cut -f1)
  [[ -n $tree ]] || { echo 38M; return; }  # not a git checkout
  local mib=$(( (64 * 1048576 - tree) / 1048576 - 6 ))
  (( mib >= 4 )) || mib=4
  echo "${mib}M"
}

mode=${1:-}
deps=$(realpath -m "${2:-.deps}")
case "$mode" in
  packages)
    printf '%s\n' "${debs[@]}"
    ;;
  bundle|bundle-gpu)
    mkdir -p "$deps"
    (cd "$deps" && apt-get download "${debs[@]}")
    py=${BIDEX_TARGET_PYTHON:-3.11}
    wheel_args=(--disable-pip-version-check --only-binary=:all: --implementation cp
                --python-version "$py" --platform manylinux_2_28_x86_64
                --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64
                --platform manylinux2014_x86_64 --platform any -d "$deps")
    if [[ "$mode" == bundle-gpu ]]; then
      python3 -m pip download -q "${wheel_args[@]}" "${gpu_wheels[@]}"
    else
      python3 -m pip download -q --no-deps "${wheel_args[@]}" "mujoco==$mujoco_version"
    fi
    du -sh "$deps"
    echo "$mode: ${#debs[@]} packages and the wheels for Python $py in $deps; take that folder to the target machine"
    ;;
  split)
    part_size=${BIDEX_PART_SIZE:-$(default_part_size)}
    parts=$(realpath -m "${3:-.parts}")
    mkdir -p "$parts"
    rm -f "$parts"/bidex-deps.tar.part*
    tar -C "$deps" -cf - . | split -b "$part_size" -d - "$parts/bidex-deps.tar.part"
    ls -l "$parts"
    echo "split: $(ls "$parts" | wc -l) parts of at most $part_size in $parts; 'join' puts them back"
    ;;
  join)
    parts=$(realpath -m "${2:-.parts}")
    deps=$(realpath -m "${3:-.deps}")
    ls "$parts"/bidex-deps.tar.part* >/dev/null 2>&1 || { echo "join: no bidex-deps.tar.part* in $parts" >&2; exit 1; }
    mkdir -p "$deps"
    cat "$parts"/bidex-deps.tar.part* | tar -C "$deps" -xf -
    echo "join: $(ls "$deps" | wc -l) files in $deps"
    ;;
  build)
    build=$(realpath -m "${3:-build}")
    prefix="$build/deps"
    ls "$deps"/*.deb >/dev/null 2>&1 || { echo "build: no .deb files in $deps (run 'bundle' first)" >&2; exit 1; }
    mkdir -p "$prefix"
    for f in "$deps"/*.deb; do dpkg -x "$f" "$prefix"; done
    # the mujoco wheel for this machine's python3 (a wheel is a zip archive)
    tag=$(python3 -c 'import sys; print("cp%d%d" % sys.version_info[:2])')
    ver=$(python3 -c 'import sys; print("%d.%d" % sys.version_info[:2])')
    # (no match must reach the message below, not stop the script under set -e and pipefail)
    wheel=$(compgen -G "$deps/mujoco-$mujoco_version-$tag-*.whl" | head -1 || true)
    [[ -n "$wheel" ]] || { echo "build: no mujoco-$mujoco_version-$tag wheel in $deps (bundle with BIDEX_TARGET_PYTHON=$ver)" >&2; exit 1; }
    # the wheels, for this python3, into a private folder (the GPU backend's embedded Python
    # imports them from there; its path names the Python version that CMake looks for)
    site="$prefix/python$ver/site-packages"
    wheels=("$wheel")
    for w in "$deps"/*.whl; do [[ "$(basename "$w")" == mujoco-"$mujoco_version"-* ]] || wheels+=("$w"); done
    python3 -m pip install -q --disable-pip-version-check --no-index --no-deps --upgrade \
      --target "$site" "${wheels[@]}"
    torch_prefix=${BIDEX_TORCH_PREFIX:-$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')}
    lib="$prefix/usr/lib/x86_64-linux-gnu"
    link="-Wl,-rpath-link,$lib -Wl,--disable-new-dtags -Wl,-rpath,$lib"
    cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$torch_prefix;$prefix/usr;$lib/cmake;$prefix/usr/share/cmake;$prefix/usr/lib/cmake;$site/pybind11" \
      -DBIDEX_MUJOCO_DIR="$site/mujoco" \
      -DCMAKE_EXE_LINKER_FLAGS="$link" -DCMAKE_SHARED_LINKER_FLAGS="$link" ${BIDEX_CMAKE_ARGS:-}
    cmake --build "$build" ${BIDEX_BUILD_TARGETS:+--target $BIDEX_BUILD_TARGETS}
    echo "build: $build/apps/bidex (data: BIDEX_DATA_DIR=$(pwd) if the tree moves)"
    ;;
  *)
    sed -n '2,24p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
