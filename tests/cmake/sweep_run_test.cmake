# bench/sweep_run.sh as a GPU lease's device calls use it, without a GPU:
# - wait, which a waiting call runs: it returns as soon as the last lane ends, not at its next
#   minute, and at its time limit when lanes still run, saying how many are done;
# - the commit in collect's sweep.json: the BIDEX_COMMIT that start was given, when collect runs
#   in a later call without it, and collect's own when it has one.
# Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P sweep_run_test.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/out")
file(WRITE "${WORK}/out/lanes" "0=hand_over\n0=catch_underarm\n")
set(sweep "${SRC}/bench/sweep_run.sh")
include("${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake")

# wait_for(NAME LIMIT MAX_SECONDS SHELL): runs SHELL and then `wait OUT LIMIT` in one bash; it
# must exit 0 within MAX_SECONDS
function(wait_for name limit max_seconds shell)
  string(TIMESTAMP t0 "%s")
  run_script(${name} TRUE bash -c "${shell} exec bash '${sweep}' wait '${WORK}/out' ${limit}")
  string(TIMESTAMP t1 "%s")
  math(EXPR took "${t1} - ${t0}")
  if(took GREATER max_seconds)
    message(SEND_ERROR "${name}: wait took ${took} s, expected at most ${max_seconds}:\n${out_${name}}")
  endif()
  set(out_${name} "${out_${name}}" PARENT_SCOPE)
endfunction()

# one lane of two done: a wait of 2 s ends at its limit and says so
file(WRITE "${WORK}/out/lanes.done" "0=hand_over\n")
wait_for(limit 2 20 "")
expect_text(limit "1 of 2 lanes done")

# the second lane ends 2 s into a wait of 100 s: it returns then (it slept out a whole minute
# before the fifteenth lease; bench/results/suites-h200/lease15/lease.txt)
wait_for(ends 100 30 "(sleep 2 && echo 0=catch_underarm >> '${WORK}/out/lanes.done') &")
expect_text(ends "all 2 lanes done")

# the commit: start (no lanes) is given it, collect in a later shell is not
file(REMOVE_RECURSE "${WORK}/c")
run_script(start TRUE ${CMAKE_COMMAND} -E env BIDEX_COMMIT=abc1234 SWEEP_RUNS=${WORK}/runs bash "${sweep}" start "${WORK}/c" 5)
# start says when training ends, 240 s before the deadline, and when evaluations end, at it (it
# named the deadline as the time every run stops: bench/results/sweep-h200x2/README.md)
function(clock_s var hms)
  string(REPLACE ":" ";" parts "${hms}")
  list(GET parts 0 h)
  list(GET parts 1 m)
  list(GET parts 2 s)
  math(EXPR t "${h} * 3600 + ${m} * 60 + ${s}")
  set(${var} ${t} PARENT_SCOPE)
endfunction()
if(out_start MATCHES "every run trains until ([0-9:]+) UTC at the latest \\(a suite's until ([0-9:]+)\\) and is evaluated by ([0-9:]+) UTC")
  clock_s(train "${CMAKE_MATCH_1}")
  clock_s(suite "${CMAKE_MATCH_2}")
  clock_s(deadline "${CMAKE_MATCH_3}")
  math(EXPR gap "(${deadline} - ${train} + 86400) % 86400")
  math(EXPR suite_gap "(${deadline} - ${suite} + 86400) % 86400")
  if(NOT gap EQUAL 240 OR NOT suite_gap EQUAL 600)
    message(SEND_ERROR "start: training ends ${gap} s and a suite's ${suite_gap} s before the deadline, expected 240 and 600:\n${out_start}")
  endif()
else()
  message(SEND_ERROR "start: no training and evaluation times in:\n${out_start}")
endif()
# SWEEP_RESERVE sets the first gap; a value that is no whole number of seconds >= 10 is refused
run_script(start_reserve TRUE ${CMAKE_COMMAND} -E env SWEEP_RESERVE=90 SWEEP_RUNS=${WORK}/runs bash "${sweep}" start "${WORK}/c2" 5)
if(out_start_reserve MATCHES "trains until ([0-9:]+) UTC.* evaluated by ([0-9:]+) UTC")
  clock_s(train "${CMAKE_MATCH_1}")
  clock_s(deadline "${CMAKE_MATCH_2}")
  math(EXPR gap "(${deadline} - ${train} + 86400) % 86400")
  if(NOT gap EQUAL 90)
    message(SEND_ERROR "start with SWEEP_RESERVE=90: training ends ${gap} s before the deadline:\n${out_start_reserve}")
  endif()
else()
  message(SEND_ERROR "start with SWEEP_RESERVE=90: no times in:\n${out_start_reserve}")
endif()
foreach(bad 5 1.5 x)
  run_script(reserve_${bad} FALSE ${CMAKE_COMMAND} -E env SWEEP_RESERVE=${bad} SWEEP_RUNS=${WORK}/runs bash "${sweep}" start "${WORK}/c3" 5)
  expect_text(reserve_${bad} "SWEEP_RESERVE must be a whole number of seconds, at least 10, not '${bad}'")
endforeach()
file(WRITE "${WORK}/c/lanes" "hand_over\n")
function(collected_commit name expected)
  run_script(${name} TRUE ${ARGN} SWEEP_RUNS=${WORK}/runs bash "${sweep}" collect "${WORK}/c")
  file(READ "${WORK}/c/sweep.json" json)
  string(JSON commit GET "${json}" commit)
  if(NOT commit STREQUAL expected)
    message(SEND_ERROR "${name}: sweep.json names commit '${commit}', expected '${expected}'")
  endif()
endfunction()
collected_commit(collect_later abc1234 ${CMAKE_COMMAND} -E env --unset=BIDEX_COMMIT)
collected_commit(collect_own def5678 ${CMAKE_COMMAND} -E env BIDEX_COMMIT=def5678)
