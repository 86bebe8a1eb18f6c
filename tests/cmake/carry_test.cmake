# bench/carry.sh, how run folders and Warp's kernel cache go from one GPU lease to the next: a
# folder split into parts and unpacked again is the same byte for byte, parts can be taken a few
# at a time, and a missing or changed part is refused with a message. Run by ctest
# (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P carry_test.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/from/run/checkpoints")
set(carry "${SRC}/bench/carry.sh")

# carry(NAME EXPECT_OK ARGS...): out_<NAME> holds what it printed
function(carry name expect_ok)
  execute_process(COMMAND env CARRY_PART_SIZE=4K bash "${carry}" ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(out_${name} "${out}${err}" PARENT_SCOPE)
  if(expect_ok AND NOT rc EQUAL 0)
    message(SEND_ERROR "${name}: exit ${rc}, expected 0:\n${out}${err}")
  elseif(NOT expect_ok AND rc EQUAL 0)
    message(SEND_ERROR "${name}: succeeded, expected a refusal:\n${out}${err}")
  endif()
endfunction()

function(expect_text name)
  foreach(text IN LISTS ARGN)
    string(FIND "${out_${name}}" "${text}" at)
    if(at EQUAL -1)
      message(SEND_ERROR "${name}: the message lacks '${text}':\n${out_${name}}")
    endif()
  endforeach()
endfunction()

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
  file(SHA256 "${WORK}/from/run/${f}" a)
  if(NOT EXISTS "${WORK}/to/run/${f}")
    message(SEND_ERROR "in: run/${f} missing:\n${out_in}")
    continue()
  endif()
  file(SHA256 "${WORK}/to/run/${f}" b)
  if(NOT a STREQUAL b)
    message(SEND_ERROR "in: run/${f} differs from the carried file")
  endif()
endforeach()
if(EXISTS "${WORK}/to/run/checkpoints/update_1.ckpt")
  message(SEND_ERROR "in: update_1.ckpt came along though it was not named")
endif()

# a changed part is refused, and nothing is unpacked
file(APPEND "${WORK}/dest/run.tar.part01" "x")
carry(in-changed FALSE in run "${WORK}/dest" "${WORK}/to2")
expect_text(in-changed "do not match run.sha256")
if(EXISTS "${WORK}/to2/run")
  message(SEND_ERROR "in-changed: unpacked from a changed part")
endif()
carry(in-none FALSE in other "${WORK}/dest" "${WORK}/to3")
expect_text(in-none "no other.sha256 in")
carry(out-none FALSE out x "${WORK}/nothing" "${WORK}/work" "${WORK}/dest")
expect_text(out-none "no folder")

file(REMOVE_RECURSE "${WORK}")
