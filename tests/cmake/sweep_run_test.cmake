# bench/sweep_run.sh as a GPU lease's device calls use it, without a GPU:
# - wait, which a waiting call runs: it returns as soon as the last lane ends, not at its next
#   minute, and at its time limit when lanes still run, saying how many are done;
# - the commit in collect's sweep.json: the BIDEX_COMMIT that start was given, when collect runs
#   in a later call without it, and collect's own when it has one;
# - start refuses lanes when the tree has no bidex build, and a lane whose training fails logs
#   the exit status in lanes.log;
# - wait's report of each run's last update, its columns by name;
# - the extension towards 100M leaves a run of 100M or more that has reached its length alone;
# - the physics' load in collect's sweep.json: sim_fps, efc_rows and solver_iters early and late.
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
# a lane needs this tree's bidex: without it start refuses at once, naming the binary, and starts
# no lane (a lease's start from a tree without the build ran its lane into the missing binary)
run_script(start_nobuild FALSE ${CMAKE_COMMAND} -E env BIDEX_GPU_BUILD=${WORK}/no-build SWEEP_RUNS=${WORK}/runs bash "${sweep}" start "${WORK}/c4" 5 0=hand_over)
expect_text(start_nobuild "start: no bidex binary at ${WORK}/no-build/apps/bidex"
            "build it first (bench/sweep_run.sh build)")
if(EXISTS "${WORK}/c4/lanes" OR EXISTS "${WORK}/c4/deadline")
  message(SEND_ERROR "start without a build wrote ${WORK}/c4/lanes or deadline: it started lanes")
endif()
# a lane whose training fails says so in lanes.log with the exit status, beside "done" (a
# stand-in bidex that fails every command)
file(MAKE_DIRECTORY "${WORK}/fake-build/apps")
file(WRITE "${WORK}/fake-build/apps/bidex" "#!/bin/sh\necho \"stand-in bidex: failing\" >&2\nexit 3\n")
file(CHMOD "${WORK}/fake-build/apps/bidex" PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE)
run_script(start_failing TRUE ${CMAKE_COMMAND} -E env BIDEX_GPU_BUILD=${WORK}/fake-build SWEEP_RUNS=${WORK}/runs-failing SWEEP_RESERVE=10 bash "${sweep}" start "${WORK}/c5" 100 0=hand_over)
run_script(failing_wait TRUE bash "${sweep}" wait "${WORK}/c5" 60)
expect_text(failing_wait "all 1 lanes done")
file(READ "${WORK}/c5/lanes.log" lanes_log)
if(NOT lanes_log MATCHES "hand_over: bidex train exited 3 \\(its progress.log says why\\)")
  message(SEND_ERROR "a failed training is not in lanes.log with its exit status:\n${lanes_log}")
endif()
# the extension resumes a finished run that still rises towards 100M only when it is shorter:
# an m200 run that reached its 200M is neither resumed nor has its length rewritten (the
# twenty-fifth lease resumed one for nothing and wrote 100M into its config.yaml). A stand-in
# bidex whose training writes the run's config.yaml and a rising metrics.csv at once
file(MAKE_DIRECTORY "${WORK}/rising-build/apps")
file(WRITE "${WORK}/rising-build/apps/bidex" [=[#!/bin/bash
# train --run DIR ... -o train.steps=N: config.yaml and metrics.csv, return rising to N
# train --resume DIR: noted in DIR/resumed; eval: nothing
[[ $1 == train ]] || exit 0
dir= steps=
while (($#)); do
  case $1 in
    --run) dir=$2; shift ;;
    --resume) echo "$*" >>"$2/resumed"; exit 0 ;;
    train.steps=*) steps=${1#train.steps=} ;;
  esac
  shift
done
mkdir -p "$dir"
printf 'task: x\ntrain:\n  steps: %s\n  save_interval: 50\n' "$steps" >"$dir/config.yaml"
{ echo update,steps,wall_s,fps,sim_fps,efc_rows,solver_iters,episodes,return,length,success
  for ((u = 1; u <= 40; u++)); do
    echo "$u,$((u * steps / 40)),$u,1,1,1,1,10,$((u * 10)),75,0"
  done; } >"$dir/metrics.csv"
]=])
file(CHMOD "${WORK}/rising-build/apps/bidex" PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE)
run_script(start_rising TRUE ${CMAKE_COMMAND} -E env BIDEX_GPU_BUILD=${WORK}/rising-build SWEEP_RUNS=${WORK}/runs-rising SWEEP_RESERVE=10 bash "${sweep}" start "${WORK}/c6" 200 0=hand_over/m200,catch_underarm)
run_script(rising_wait TRUE ${CMAKE_COMMAND} -E env SWEEP_RUNS=${WORK}/runs-rising bash "${sweep}" wait "${WORK}/c6" 60)
expect_text(rising_wait "all 1 lanes done")
# wait's report of a run's last update names its columns right (return and success are found
# by the header's names: they once showed solver_iters and the return)
if(NOT out_rising_wait MATCHES "catch_underarm +50.0M  return 400  success 0  fps 1\n")
  message(SEND_ERROR "wait's report of catch_underarm's last update (50.0M, return 400, success 0, fps 1):\n${out_rising_wait}")
endif()
file(READ "${WORK}/c6/lanes.log" lanes_log)
if(NOT lanes_log MATCHES "catch_underarm: extend for" OR lanes_log MATCHES "hand_over/m200: extend")
  message(SEND_ERROR "the extension should resume catch_underarm (50M, rising) and not hand_over/m200 (200M reached):\n${lanes_log}")
endif()
foreach(run_steps "hand_over-m200;200000000" "catch_underarm;100000000")
  list(GET run_steps 0 run)
  list(GET run_steps 1 want)
  file(STRINGS "${WORK}/runs-rising/${run}/config.yaml" length REGEX "steps: ")
  if(NOT length MATCHES "^ *steps: ${want}$")
    message(SEND_ERROR "${run}'s config.yaml after the extension: '${length}', expected 'steps: ${want}'")
  endif()
endforeach()
if(EXISTS "${WORK}/runs-rising/hand_over-m200/resumed")
  message(SEND_ERROR "hand_over/m200 was resumed after reaching its 200M")
endif()
file(WRITE "${WORK}/c/lanes" "hand_over\n")
function(collected_commit name expected)
  run_script(${name} TRUE ${ARGN} SWEEP_RUNS=${WORK}/runs bash "${sweep}" collect "${WORK}/c")
  file(READ "${WORK}/c/sweep.json" json)
  string(JSON commit GET "${json}" commit)
  if(NOT commit STREQUAL expected)
    message(SEND_ERROR "${name}: sweep.json names commit '${commit}', expected '${expected}'")
  endif()
endfunction()
# a run's metrics: 30 updates whose simulation slows as its constraint rows grow; collect keeps
# the mean of updates 6-15 and of the last 10 (sim_fps, efc_rows, solver_iters)
set(csv "update,steps,wall_s,fps,sim_fps,efc_rows,solver_iters,episodes,return,length,success\n")
foreach(u RANGE 1 30)
  math(EXPR fps "300000 - ${u} * 1000")
  math(EXPR rows "100 + ${u}")
  math(EXPR steps "${u} * 131072")
  string(APPEND csv "${u},${steps},${u},100000,${fps},${rows},2,10,1.5,75,0.5\n")
endforeach()
file(WRITE "${WORK}/runs/hand_over/metrics.csv" "${csv}")
function(expect_load key first last)
  string(JSON f GET "${load_of_hand_over}" ${key} first)
  string(JSON l GET "${load_of_hand_over}" ${key} last)
  if(NOT f STREQUAL first OR NOT l STREQUAL last)
    message(SEND_ERROR "sweep.json's physics_load.${key}: first ${f} and last ${l}, expected ${first} and ${last}")
  endif()
endfunction()
collected_commit(collect_later abc1234 ${CMAKE_COMMAND} -E env --unset=BIDEX_COMMIT)
file(READ "${WORK}/c/sweep.json" json)
string(JSON load_of_hand_over GET "${json}" runs 0 physics_load)
expect_load(sim_fps 289500.0 274500.0)   # updates 6-15: 294000..285000; 21-30: 279000..270000
expect_load(efc_rows 110.5 125.5)
expect_load(solver_iters 2.0 2.0)
collected_commit(collect_own def5678 ${CMAKE_COMMAND} -E env BIDEX_COMMIT=def5678)
# every training overrides file of a run, in its parts' order (collect once kept the first only,
# and the table labelled a run of gamma99 and value_norm as one of gamma99)
file(WRITE "${WORK}/c/lanes" "hand_over\nhand_over/ogamma99/ovalue_norm\n")
file(MAKE_DIRECTORY "${WORK}/runs/hand_over-ogamma99-ovalue_norm")
file(WRITE "${WORK}/runs/hand_over-ogamma99-ovalue_norm/metrics.csv" "${csv}")
run_script(collect_overrides TRUE ${CMAKE_COMMAND} -E env SWEEP_RUNS=${WORK}/runs bash "${sweep}" collect "${WORK}/c")
file(READ "${WORK}/c/sweep.json" json)
string(JSON one TYPE "${json}" runs 0 overrides)
string(JSON two GET "${json}" runs 1 overrides)
if(NOT one STREQUAL "NULL")
  message(SEND_ERROR "collect: a run without o parts has overrides of type ${one}, expected null")
endif()
if(NOT two STREQUAL [=[[ "bench/sweep/gamma99.overrides", "bench/sweep/value_norm.overrides" ]]=])
  message(SEND_ERROR "collect: overrides '${two}', expected both files of hand_over/ogamma99/ovalue_norm in order")
endif()
