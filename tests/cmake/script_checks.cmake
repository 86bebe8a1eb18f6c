# Checks shared by the script tests run with cmake -P (the *_test.cmake beside this file).
# A failed check is a SEND_ERROR: the test goes on with its other checks and exits non-zero.

# run_script(NAME EXPECT_OK COMMAND...): runs COMMAND; out_<NAME> holds what it printed, and
# its exit status must be 0 (EXPECT_OK true) or not (a refusal)
function(run_script name expect_ok)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(out_${name} "${out}${err}" PARENT_SCOPE)
  if(expect_ok AND NOT rc EQUAL 0)
    message(SEND_ERROR "${name}: exit ${rc}, expected 0:\n${out}${err}")
  elseif(NOT expect_ok AND rc EQUAL 0)
    message(SEND_ERROR "${name}: succeeded, expected a refusal:\n${out}${err}")
  endif()
endfunction()

# expect_text(NAME TEXT...): what run_script(NAME ...) printed holds every TEXT
function(expect_text name)
  foreach(text IN LISTS ARGN)
    string(FIND "${out_${name}}" "${text}" at)
    if(at EQUAL -1)
      message(SEND_ERROR "${name}: the message lacks '${text}':\n${out_${name}}")
    endif()
  endforeach()
endfunction()

# expect_same_file(WHAT A B): B exists and has A's bytes
function(expect_same_file what a b)
  if(NOT EXISTS "${b}")
    message(SEND_ERROR "${what}: ${b} missing")
    return()
  endif()
  file(SHA256 "${a}" ha)
  file(SHA256 "${b}" hb)
  if(NOT ha STREQUAL hb)
    message(SEND_ERROR "${what}: ${b} differs from ${a}")
  endif()
endfunction()

# require_python_yaml(): PYTHON is set and imports yaml (the bench scripts read YAML), else the
# test stops naming what to install
function(require_python_yaml)
  if(NOT PYTHON)
    message(FATAL_ERROR "no python3 found (Debian: python3 with python3-yaml, which scripts/setup.sh installs)")
  endif()
  execute_process(COMMAND "${PYTHON}" -c "import yaml" RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${PYTHON} cannot import yaml (Debian: python3-yaml, which scripts/setup.sh "
                        "installs): ${err}")
  endif()
endfunction()
