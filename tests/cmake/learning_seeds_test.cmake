# bench/learning_seeds.sh with the real bidex (SAC on catch_underarm_raise, one short seed):
# - BIDEX_LEARN_ARGS reaches the training (3 updates, 1,536 slot-steps, in place of the per-task
#   30,720) and the JSON's command names it;
# - each seed's training log is kept in OUT.logs/sSEED.txt;
# - a training that fails on a bad key stops the script, naming the log, which names the key.
# Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -DBIDEX=<bidex> -P learning_seeds_test.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
include("${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake")
set(script "${SRC}/bench/learning_seeds.sh")
set(args "-o train.steps=1280 -o sac.replay_size=640")

run_script(short TRUE ${CMAKE_COMMAND} -E env BIDEX_ALGO=sac "BIDEX_LEARN_ARGS=${args}"
           bash "${script}" "${WORK}/short.json" "${BIDEX}" 3)
file(READ "${WORK}/short.json" json)
string(JSON command GET "${json}" command)
string(JSON seed GET "${json}" seeds 0 seed)
string(JSON ret GET "${json}" seeds 0 trained_return)
if(NOT command MATCHES "^BIDEX_LEARN_ARGS=\"${args}\" BIDEX_ALGO=sac bench/learning_seeds.sh ")
  message(SEND_ERROR "short.json's command does not name BIDEX_LEARN_ARGS: ${command}")
endif()
if(NOT seed EQUAL 3 OR NOT ret MATCHES "^-?[0-9]")
  message(SEND_ERROR "short.json's seed row: seed ${seed}, trained_return ${ret}")
endif()
if(NOT EXISTS "${WORK}/short.logs/s3.txt")
  message(SEND_ERROR "no training log ${WORK}/short.logs/s3.txt")
else()
  file(READ "${WORK}/short.logs/s3.txt" log)
  if(NOT log MATCHES "3 updates, 1536 slot-steps")
    message(SEND_ERROR "the training did not take BIDEX_LEARN_ARGS (expected 3 updates, 1536 slot-steps):\n${log}")
  endif()
endif()

run_script(bad FALSE ${CMAKE_COMMAND} -E env BIDEX_ALGO=sac "BIDEX_LEARN_ARGS=-o sac.no_such_key=1"
           bash "${script}" "${WORK}/bad.json" "${BIDEX}" 0)
expect_text(bad "learning_seeds: seed 0's training failed" "${WORK}/bad.logs/s0.txt")
file(READ "${WORK}/bad.logs/s0.txt" log)
if(NOT log MATCHES "no_such_key")
  message(SEND_ERROR "the failed training's log does not name the bad key:\n${log}")
endif()
if(EXISTS "${WORK}/bad.json")
  message(SEND_ERROR "a failed training still wrote ${WORK}/bad.json")
endif()
