# The suites' committed result tables are what their scripts make with today's references
# (configs/registry/references.yaml): a ground truth raised by a lease and not drawn again into
# them fails here (ML20's table was once a ground truth behind).
# - bench/meta_table.py: the meta-RL tables and summaries of ML20 (suites-h200x4, the results
#   page's; suites-h200/lease16, RL² to 97M) and of ML1 and ML4 (gpu-meta-h100/ml1-ml4-today;
#   MAML's, sweep-h200x2/lease21/meta), each drawn into WORK and compared byte for byte; and its refusals of a bad --suites and a
#   missing folder, naming them;
# - bench/suite_train_table.py: MT20's table at 300M (suites-h200/lease15), from its run folder,
#   run from another folder than the source root.
# Run by ctest (tests/CMakeLists.txt):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -DPYTHON=<python3 with yaml> -P results_tables_test.cmake
cmake_policy(VERSION 3.20)
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
include("${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake")
require_python_yaml()
set(r "${SRC}/bench/results")
set(meta "${SRC}/bench/meta_table.py")

# meta_table.py DIR [ARGS...] --out WORK/NAME, then both files against DIR_COMMITTED's
function(check_meta name committed)
  run_script(meta_${name} TRUE "${PYTHON}" "${meta}" ${ARGN} --out "${WORK}/${name}")
  foreach(f table.md summary.json)
    expect_same_file("meta_table.py's ${f} for ${name}, against the committed one"
                     "${committed}/${f}" "${WORK}/${name}/${f}")
  endforeach()
endfunction()
check_meta(ml20 "${r}/suites-h200x4" "${r}/suites-h200x4" --baselines "${r}/suites-h100x4/meta")
check_meta(rl2_97m "${r}/suites-h200/lease16" "${r}/suites-h200/lease16"
           --baselines "${r}/suites-h100x4/meta")
check_meta(ml1_ml4 "${r}/gpu-meta-h100/ml1-ml4-today" "${r}/gpu-meta-h100" --suites ML1,ML4)
check_meta(maml_ml1_ml4 "${r}/sweep-h200x2/lease21/meta" "${r}/sweep-h200x2/lease21" --suites ML1,ML4
           --baselines "${r}/gpu-meta-h100")

run_script(meta_bad_suite FALSE "${PYTHON}" "${meta}" "${r}/gpu-meta-h100" --suites ML1,ML5 --out "${WORK}/bad")
expect_text(meta_bad_suite "--suites" "ML1,ML4,ML20" "ML1,ML5")
run_script(meta_no_folder FALSE "${PYTHON}" "${meta}" "${WORK}/absent" --out "${WORK}/bad")
expect_text(meta_no_folder "DIR" "${WORK}/absent" "not a folder")
if(EXISTS "${WORK}/bad")
  message(SEND_ERROR "meta_table.py wrote ${WORK}/bad although it refused")
endif()

# MT20 at 300M: suite_train_table.py, run from another folder than the source root, prints the
# run's train-table.md (whose header names the run from the root, as it was made)
set(mt20_rel "bench/results/suites-h200/lease15/MT20-osuite16k-otaskadv-ovaluetask-m300")
set(mt20 "${SRC}/${mt20_rel}")
execute_process(COMMAND "${PYTHON}" "${SRC}/bench/suite_train_table.py" "${mt20}" --curve
                WORKING_DIRECTORY "${WORK}" OUTPUT_VARIABLE printed RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ "${mt20}/train-table.md" committed)
string(REPLACE "${mt20}:" "${mt20_rel}:" printed "${printed}")
if(NOT rc EQUAL 0 OR NOT printed STREQUAL committed)
  file(WRITE "${WORK}/mt20-train-table.md" "${printed}")
  message(SEND_ERROR "suite_train_table.py ${mt20} --curve run from ${WORK} (exit ${rc}): its "
                     "table differs from the committed one: diff ${mt20}/train-table.md "
                     "${WORK}/mt20-train-table.md\n${err}")
endif()
