# bench/lease_run.sh then, how a GPU lease's chain waits for its build and logs how each command
# ended, without a GPU: the command's own exit status reaches then.log (not date's, which the log
# line once printed), a build that ended without bidex runs nothing and says so, and a folder
# with no build is refused. Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -P lease_run_test.cmake
include(${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake)
set(lease ${SRC}/bench/lease_run.sh)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/built ${WORK}/failed ${WORK}/none)
# what scripts/offline-build.sh prints when bidex is built, and a build that stopped before
file(WRITE ${WORK}/built/build.log "build: 12s, build-gpu/apps/bidex\n")
file(WRITE ${WORK}/failed/build.log "FAILED: sim/warp_backend.cc.o\n")
file(WRITE ${WORK}/failed/build.end "1\n")

# wait_for(FILE TEXT): up to 30 s for FILE to hold TEXT (the chain runs in the background)
function(wait_for file text)
  foreach(i RANGE 60)
    if(EXISTS ${file})
      file(READ ${file} got)
      string(FIND "${got}" "${text}" at)
      if(NOT at EQUAL -1)
        return()
      endif()
    endif()
    execute_process(COMMAND ${CMAKE_COMMAND} -E sleep 0.5)
  endforeach()
  set(got "")
  if(EXISTS ${file})
    file(READ ${file} got)
  endif()
  message(SEND_ERROR "${file} does not say '${text}' after 30 s:\n${got}")
endfunction()

run_script(then TRUE bash ${lease} then ${WORK}/built
           "echo ran in \$PWD with \$BIDEX_GPU_BUILD && exit 3")
expect_text(then "after the build, in ${WORK}/built")
wait_for(${WORK}/built/then.log "end (exit 3): echo ran")
wait_for(${WORK}/built/then.log "ran in ${WORK}/built with build-gpu")

run_script(then_ok TRUE bash ${lease} then ${WORK}/built "true")
wait_for(${WORK}/built/then.log "end (exit 0): true")

run_script(then_failed TRUE bash ${lease} then ${WORK}/failed "touch ${WORK}/failed/ran")
wait_for(${WORK}/failed/then.log "the build ended without bidex: touch")
if(EXISTS ${WORK}/failed/ran)
  message(SEND_ERROR "then_failed: the command ran after a build without bidex")
endif()

run_script(then_none FALSE bash ${lease} then ${WORK}/none "true")
expect_text(then_none "no build in ${WORK}/none")
