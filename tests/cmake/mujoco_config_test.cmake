# Configure stops with a clear message when MuJoCo is missing or another version: runs the real
# configure of this source tree (SRC) against fake MuJoCo folders under WORK and checks that it
# fails, naming what it found and what to run. Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P mujoco_config_test.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
set(failures 0)

# expect_failure(NAME MUJOCO_DIR TEXT...): configure fails and its output holds every TEXT
function(expect_failure name dir)
  execute_process(
    COMMAND "${CMAKE_COMMAND}" -S "${SRC}" -B "${WORK}/${name}-build" -G Ninja
            -DBIDEX_MUJOCO_DIR=${dir} -DBIDEX_TESTS=OFF
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(all "${out}${err}")
  if(rc EQUAL 0)
    message(SEND_ERROR "${name}: configure succeeded with MuJoCo folder '${dir}'")
    math(EXPR n "${failures} + 1")
    set(failures ${n} PARENT_SCOPE)
    return()
  endif()
  foreach(text IN LISTS ARGN)
    string(FIND "${all}" "${text}" at)
    if(at EQUAL -1)
      message(SEND_ERROR "${name}: the message lacks '${text}':\n${all}")
      math(EXPR n "${failures} + 1")
      set(failures ${n} PARENT_SCOPE)
    endif()
  endforeach()
  message(STATUS "${name}: configure stopped as expected")
endfunction()

# a fake wheel folder: mujoco.h of the given version, with or without the library
function(fake_mujoco dir version_number with_library)
  file(WRITE "${dir}/include/mujoco/mujoco.h" "#define mjVERSION_HEADER ${version_number}\n")
  if(with_library)
    file(WRITE "${dir}/libmujoco.so.3.17.0" "not a library\n")
  endif()
endfunction()

expect_failure(missing "${WORK}/nothing-here"
  "MuJoCo headers not found" "${WORK}/nothing-here/include/mujoco/mujoco.h" "scripts/setup.sh")
fake_mujoco("${WORK}/old" 3016000 TRUE)
expect_failure(wrong-version "${WORK}/old"
  "MuJoCo 3.17.0 required, found 3.16.0" "${WORK}/old" "scripts/setup.sh")
fake_mujoco("${WORK}/nolib" 3017000 FALSE)
expect_failure(no-library "${WORK}/nolib"
  "MuJoCo library not found" "libmujoco.so.3.17.0" "scripts/setup.sh")

file(REMOVE_RECURSE "${WORK}")
if(failures GREATER 0)
  message(FATAL_ERROR "${failures} check(s) failed")
endif()
