# scripts/offline-build.sh, the path every GPU lease builds by: `split` and `join` give back the
# bundle's files byte for byte, and `join` and `build` stop with a message naming what is missing.
# Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P offline_build_test.cmake
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

file(REMOVE_RECURSE "${WORK}")
