# bench/carry.sh, how run folders and Warp's kernel cache go from one GPU lease to the next: a
# folder split into parts and unpacked again is the same byte for byte, parts can be taken a few
# at a time, and a missing or changed part is refused with a message. Run by ctest
# (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P carry_test.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/from/run/checkpoints")
set(carry "${SRC}/bench/carry.sh")

include("${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake")
macro(carry name expect_ok)
  run_script(${name} ${expect_ok} env CARRY_PART_SIZE=4K bash "${carry}" ${ARGN})
endmacro()

string(REPEAT "checkpoint bytes " 1000 ckpt)  # 17,000 bytes: five parts of 4 KiB with tar's headers
file(WRITE "${WORK}/from/run/checkpoints/update_2.ckpt" "${ckpt}")
file(WRITE "${WORK}/from/run/checkpoints/update_1.ckpt" "an older checkpoint\n")
file(WRITE "${WORK}/from/run/config.yaml" "seed: 0\n")

# only the named paths, two parts in the first call and the rest in the second
carry(out1 TRUE out run "${WORK}/from" "${WORK}/work" "${WORK}/dest" 0 2
      -- run/config.yaml run/checkpoints/update_2.ckpt)
file(GLOB got "${WORK}/dest/run.tar.part*")
list(LENGTH got n)
if(NOT n EQUAL 2)
  message(SEND_ERROR "out 0 2: ${n} parts in DEST, expected 2:\n${out_out1}")
endif()
carry(in-short FALSE in run "${WORK}/dest" "${WORK}/to")
expect_text(in-short "do not match run.sha256")
carry(out2 TRUE out run "${WORK}/from" "${WORK}/work" "${WORK}/dest" 2)
carry(in TRUE in run "${WORK}/dest" "${WORK}/to")
foreach(f config.yaml checkpoints/update_2.ckpt)
  expect_same_file(in "${WORK}/from/run/${f}" "${WORK}/to/run/${f}")
endforeach()
if(EXISTS "${WORK}/to/run/checkpoints/update_1.ckpt")
  message(SEND_ERROR "in: update_1.ckpt came along though it was not named")
endif()

# recut: the same bytes in fewer, larger parts, with a checksum file of their own
carry(recut TRUE recut run "${WORK}/dest" 8K)
file(GLOB got "${WORK}/dest/run.tar.part*")
list(LENGTH got n)
if(NOT n EQUAL 3)
  message(SEND_ERROR "recut 8K: ${n} parts, expected 3 (from five of 4 KiB):\n${out_recut}")
endif()
expect_text(recut "run in 3 parts of at most 8K")
file(GLOB aside "${WORK}/dest/.recut-run" "${WORK}/dest/.old-run")
if(aside)
  message(SEND_ERROR "recut left ${aside} behind")
endif()
carry(in-recut TRUE in run "${WORK}/dest" "${WORK}/to-recut")
foreach(f config.yaml checkpoints/update_2.ckpt)
  expect_same_file(in-recut "${WORK}/from/run/${f}" "${WORK}/to-recut/run/${f}")
endforeach()

# a changed part is refused, and nothing is unpacked
file(APPEND "${WORK}/dest/run.tar.part01" "x")
carry(in-changed FALSE in run "${WORK}/dest" "${WORK}/to2")
expect_text(in-changed "do not match run.sha256")
if(EXISTS "${WORK}/to2/run")
  message(SEND_ERROR "in-changed: unpacked from a changed part")
endif()
# recut refuses a changed part and leaves the parts as they were
file(GLOB before "${WORK}/dest/run.tar.part*")
carry(recut-changed FALSE recut run "${WORK}/dest" 16K)
expect_text(recut-changed "do not match run.sha256")
file(GLOB after "${WORK}/dest/run.tar.part*")
if(NOT before STREQUAL after)
  message(SEND_ERROR "recut of a changed part changed the parts: ${before} -> ${after}")
endif()
carry(in-none FALSE in other "${WORK}/dest" "${WORK}/to3")
expect_text(in-none "no other.sha256 in")
carry(out-none FALSE out x "${WORK}/nothing" "${WORK}/work" "${WORK}/dest")
expect_text(out-none "no folder")

file(REMOVE_RECURSE "${WORK}")
