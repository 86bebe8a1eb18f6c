# scripts/offline-build.sh, the path every GPU lease builds by: `split` and `join` give back the
# bundle's files byte for byte, `join` and `build` stop with a message naming what is missing,
# and `packages` lists the bundle's Debian packages, without the renderer's under
# BIDEX_BUNDLE_RENDER=0.
# Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P offline_build_test.cmake
cmake_policy(VERSION 3.20)  # IN_LIST, and lists that keep empty elements
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
set(script "${SRC}/scripts/offline-build.sh")
include("${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake")
macro(run name expect_ok)
  run_script(${name} ${expect_ok} env BIDEX_PART_SIZE=3K bash "${script}" ${ARGN})
endmacro()

# split into parts of 3 KiB and join: the same files, byte for byte
file(MAKE_DIRECTORY "${WORK}/deps/sub")
string(REPEAT "0123456789abcdef" 700 big)  # 11,200 bytes: four parts with the tar headers
file(WRITE "${WORK}/deps/big.bin" "${big}")
file(WRITE "${WORK}/deps/sub/small.txt" "a small file\n")
run(split TRUE split "${WORK}/deps" "${WORK}/parts")
file(GLOB parts "${WORK}/parts/bidex-deps.tar.part*")
list(LENGTH parts n)
if(n LESS 4)
  message(SEND_ERROR "split: ${n} parts of 3 KiB for more than 11 KiB:\n${out_split}")
endif()
run(join TRUE join "${WORK}/parts" "${WORK}/joined")
expect_same_file(join "${WORK}/deps/big.bin" "${WORK}/joined/big.bin")
expect_same_file(join "${WORK}/deps/sub/small.txt" "${WORK}/joined/sub/small.txt")

file(MAKE_DIRECTORY "${WORK}/noparts")
run(join-empty FALSE join "${WORK}/noparts" "${WORK}/joined2")
expect_text(join-empty "no bidex-deps.tar.part* in" "${WORK}/noparts")

run(build-nodebs FALSE build "${WORK}/noparts" "${WORK}/build1")
expect_text(build-nodebs "no .deb files in" "${WORK}/noparts")

# a real (empty) Debian package but no MuJoCo wheel for this Python: the message names the wheel
# and the bundle's setting (it used to stop silently with exit 2 under set -e and pipefail)
file(MAKE_DIRECTORY "${WORK}/pkg/DEBIAN" "${WORK}/debs")
file(WRITE "${WORK}/pkg/DEBIAN/control"
  "Package: bidex-test-empty\nVersion: 1.0\nArchitecture: all\nMaintainer: bidex tests\nDescription: empty\n")
execute_process(COMMAND dpkg-deb --build "${WORK}/pkg" "${WORK}/debs/bidex-test-empty_1.0_all.deb"
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(SEND_ERROR "dpkg-deb could not build the test package: ${err}")
endif()
run(build-nowheel FALSE build "${WORK}/debs" "${WORK}/build2")
expect_text(build-nowheel "no mujoco-3.17.0-cp" "wheel in ${WORK}/debs" "BIDEX_TARGET_PYTHON=")

# the packages a bundle downloads: the renderer's by default, without them under
# BIDEX_BUNDLE_RENDER=0 (the GPU leases' bundle), the rest the same; another value is refused
run_script(pkgs TRUE bash "${script}" packages)
run_script(pkgs-norender TRUE env BIDEX_BUNDLE_RENDER=0 bash "${script}" packages)
string(REPLACE "\n" ";" all "${out_pkgs}")
string(REPLACE "\n" ";" lean "${out_pkgs-norender}")
list(FILTER all EXCLUDE REGEX "^$")
list(FILTER lean EXCLUDE REGEX "^$")
foreach(p IN ITEMS libosmesa6 libllvm15 libgl-dev libpng-dev)
  if(NOT p IN_LIST all)
    message(SEND_ERROR "packages: ${p} missing from the default bundle:\n${out_pkgs}")
  endif()
  if(p IN_LIST lean)
    message(SEND_ERROR "packages: ${p} in the bundle without the renderer:\n${out_pkgs-norender}")
  endif()
endforeach()
foreach(p IN LISTS lean)
  if(NOT p IN_LIST all)
    message(SEND_ERROR "packages: ${p} only in the bundle without the renderer")
  endif()
endforeach()
foreach(p IN ITEMS libyaml-cpp-dev libhdf5-dev libssl-dev catch2)
  if(NOT p IN_LIST lean)
    message(SEND_ERROR "packages: ${p} missing from the bundle without the renderer:\n${out_pkgs-norender}")
  endif()
endforeach()
list(LENGTH all n_all)
list(LENGTH lean n_lean)
math(EXPR n_render "${n_all} - ${n_lean}")
if(NOT n_render EQUAL 19)
  message(SEND_ERROR "packages: ${n_render} renderer packages left out, expected 19")
endif()
run_script(pkgs-bad FALSE env BIDEX_BUNDLE_RENDER=no bash "${script}" packages)
expect_text(pkgs-bad "BIDEX_BUNDLE_RENDER must be 1" "not 'no'")

file(REMOVE_RECURSE "${WORK}")
