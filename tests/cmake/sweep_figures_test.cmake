# The PPO sweep's committed figures are what its scripts make from the committed run folders:
# - bench/sweep_time_to_goal.py, given the folders its output's header names, writes
#   configs/registry/time_to_goal.yaml (which the registry loads) byte for byte; it counts a run
#   as its task's default however its training YAML's path is spelt, and a folder of one task
#   gives an undefined rank correlation, said so;
# - `bidex registry report age` from a new registry (the shipped references and that file) draws
#   bench/results/sweep-h100x4/age-time-to-goal.svg and .txt byte for byte;
# - bench/sweep_table.py, given the folders of the command in bench/results/sweep-h100x4/README.md,
#   prints that README's table "All leases" and draws its figure sweep-curves.svg byte for byte;
#   the folders include suites' folders, whose suite runs the table leaves out (is_suite in
#   bench/sweep_collect.py; sweep_time_to_goal.py once stopped at them).
# - bench/lane_rates.py, given the command in the header of a lease's lane-rates.txt, prints its
#   table (the lines below its comments) byte for byte; so does bench/sweep_terms.py for a run's
#   success-by-10M.txt.
# A lease's new folder, a changed reference or a changed script that was not drawn again fails here.
# Run by ctest (tests/CMakeLists.txt), with python3 and its yaml module (python3-yaml):
#   cmake -DSRC=<source> -DWORK=<scratch folder> -DBIDEX=<bidex binary> -DPYTHON=<python3>
#         -P sweep_figures_test.cmake
cmake_policy(VERSION 3.20)
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
include("${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake")
require_python_yaml()

# time to the goal: the folders from the header's command line
set(ttg "${SRC}/configs/registry/time_to_goal.yaml")
file(STRINGS "${ttg}" command REGEX "^# Command: bench/sweep_time_to_goal.py ")
list(LENGTH command n)
if(NOT n EQUAL 1)
  message(FATAL_ERROR "${ttg}: expected one '# Command: bench/sweep_time_to_goal.py DIR...' line, found ${n}")
endif()
string(REGEX REPLACE "^# Command: bench/sweep_time_to_goal.py " "" dirs "${command}")
separate_arguments(dirs UNIX_COMMAND "${dirs}")
execute_process(COMMAND "${PYTHON}" bench/sweep_time_to_goal.py ${dirs} --bidex "${BIDEX}"
                        --out "${WORK}/time_to_goal.yaml"
                WORKING_DIRECTORY "${SRC}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(SEND_ERROR "sweep_time_to_goal.py: exit ${rc}:\n${out}${err}")
endif()
expect_same_file("sweep_time_to_goal.py's output, against the shipped file" "${ttg}"
                 "${WORK}/time_to_goal.yaml")

# a run counts as its task's default whatever the spelling of its training YAML's path: './x',
# an absolute path ending in it (a run started from another checkout) as the plain 'x'; another
# file does not count (re_orientation's run of the twenty-third lease, its config.yaml edited)
set(reorient "re_orientation-creorient_progress100-ogamma99-ovalue_norm-e-m200")
foreach(case dot abs other)
  set(d "${WORK}/spelling-${case}")
  file(MAKE_DIRECTORY "${d}")
  file(COPY "${SRC}/bench/results/sweep-h200x2/lease23/sweep.json"
            "${SRC}/bench/results/sweep-h200x2/lease23/${reorient}" DESTINATION "${d}")
  file(READ "${d}/${reorient}/config.yaml" cfg)
  set(path "bench/sweep/reorient_progress100.yaml")
  if(case STREQUAL "dot")
    set(spelt "./${path}")
  elseif(case STREQUAL "abs")
    set(spelt "/elsewhere/checkout/${path}")
  else()
    set(spelt "/elsewhere/checkout/bench/sweep/reorient_progress.yaml")
  endif()
  string(REPLACE "task_config: ${path}" "task_config: ${spelt}" edited "${cfg}")
  if(edited STREQUAL cfg)
    message(FATAL_ERROR "${d}/${reorient}/config.yaml: no 'task_config: ${path}' to respell")
  endif()
  file(WRITE "${d}/${reorient}/config.yaml" "${edited}")
  execute_process(COMMAND "${PYTHON}" bench/sweep_time_to_goal.py "${d}" --bidex "${BIDEX}"
                          --out "${d}/time_to_goal.yaml"
                  WORKING_DIRECTORY "${SRC}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(SEND_ERROR "sweep_time_to_goal.py on ${d}: exit ${rc}:\n${out}${err}")
  endif()
  # one task or none: the rank correlation is undefined, and said so (it divided by zero)
  string(FIND "${out}" "undefined (it needs two tasks or more" undefined)
  if(undefined EQUAL -1)
    message(SEND_ERROR "sweep_time_to_goal.py on one folder of one task: no 'undefined' rank "
                       "correlation in:\n${out}")
  endif()
  string(FIND "${out}" "${d}/${reorient}" counted)
  if(case STREQUAL "other" AND NOT counted EQUAL -1)
    message(SEND_ERROR "a run trained under ${spelt} counted as re_orientation's default:\n${out}")
  elseif(NOT case STREQUAL "other" AND counted EQUAL -1)
    message(SEND_ERROR "a run trained under ${spelt} did not count as re_orientation's default:\n${out}")
  endif()
endforeach()

# the age report's figure and table, as the sweep README says they were drawn: from a new registry
execute_process(COMMAND "${BIDEX}" registry report age --registry "${WORK}/age/r.sqlite"
                        --out "${WORK}/age/age.svg"
                WORKING_DIRECTORY "${SRC}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(SEND_ERROR "bidex registry report age: exit ${rc}:\n${out}${err}")
endif()
foreach(ext svg txt)
  expect_same_file("the age report's ${ext}, against the committed one"
                   "${SRC}/bench/results/sweep-h100x4/age-time-to-goal.${ext}" "${WORK}/age/age.${ext}")
endforeach()

# the table and the figure: the folders of the README's command (a block of lines ending in
# backslashes, from `bench/sweep_table.py` to `--out bench/results/sweep-h100x4`)
set(readme "${SRC}/bench/results/sweep-h100x4/README.md")
file(READ "${readme}" text)
string(FIND "${text}" "    bench/sweep_table.py " at)
if(at EQUAL -1)
  message(FATAL_ERROR "${readme}: no indented 'bench/sweep_table.py' command")
endif()
string(SUBSTRING "${text}" ${at} -1 rest)
string(FIND "${rest}" "--out bench/results/sweep-h100x4" end)
if(end EQUAL -1)
  message(FATAL_ERROR "${readme}: the sweep_table.py command lacks '--out bench/results/sweep-h100x4'")
endif()
string(SUBSTRING "${rest}" 0 ${end} cmd)
string(REPLACE "\\\n" " " cmd "${cmd}")
string(REGEX REPLACE "^ *bench/sweep_table.py " "" cmd "${cmd}")
separate_arguments(dirs UNIX_COMMAND "${cmd}")
execute_process(COMMAND "${PYTHON}" bench/sweep_table.py ${dirs} --out "${WORK}/figure"
                WORKING_DIRECTORY "${SRC}" RESULT_VARIABLE rc OUTPUT_VARIABLE table ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(SEND_ERROR "sweep_table.py: exit ${rc}:\n${err}")
endif()
expect_same_file("sweep_table.py's figure, against the committed one"
                 "${SRC}/bench/results/sweep-h100x4/sweep-curves.svg" "${WORK}/figure/sweep-curves.svg")
# the README's table: the first block of lines starting with '|' after "## All leases"
string(FIND "${text}" "\n## All leases\n" sec)
string(SUBSTRING "${text}" ${sec} -1 sec_text)
string(FIND "${sec_text}" "\n|" first)
string(SUBSTRING "${sec_text}" ${first} -1 sec_text)
string(REGEX MATCH "^(\n\\|[^\n]*)+" block "${sec_text}")
string(SUBSTRING "${block}" 1 -1 block)  # without the leading newline
string(STRIP "${table}" table)
if(NOT block STREQUAL table)
  file(WRITE "${WORK}/readme-table.md" "${block}\n")
  file(WRITE "${WORK}/printed-table.md" "${table}\n")
  message(SEND_ERROR "the README's table 'All leases' differs from what sweep_table.py prints: "
                     "diff ${WORK}/readme-table.md ${WORK}/printed-table.md")
endif()
string(FIND "${table}" "| MT20" mt20)
if(NOT mt20 EQUAL -1)
  message(SEND_ERROR "sweep_table.py printed a suite's run (MT20) from the suites' folders")
endif()

# text without its comment lines (#...), stripped: a lane_rates.py table below its header
function(strip_comments var)
  string(REGEX REPLACE "(^|\n)#[^\n]*" "" t "${${var}}")
  string(STRIP "${t}" t)
  set(${var} "${t}" PARENT_SCOPE)
endfunction()

# every lane-rates.txt under bench/results made by bench/lane_rates.py, and every
# success-by-10M.txt made by bench/sweep_terms.py --every: its table (the lines below the
# header's comments) is what the command in its header prints from the committed run folders
# (the header's machine, date and commit lines are the only ones allowed to differ)
file(GLOB_RECURSE rates_files RELATIVE "${SRC}" "${SRC}/bench/results/*/lane-rates.txt"
     "${SRC}/bench/results/*/success-by-10M.txt")
set(checked 0)
set(checked_terms 0)
foreach(f IN LISTS rates_files)
  file(STRINGS "${SRC}/${f}" cmd REGEX "^# command: bench/(lane_rates|sweep_terms).py ")
  if(NOT cmd)
    continue()
  endif()
  string(REGEX MATCH "bench/[a-z_]+.py" script "${cmd}")
  string(REGEX REPLACE "^# command: bench/[a-z_]+.py " "" cmd "${cmd}")
  separate_arguments(args UNIX_COMMAND "${cmd}")
  execute_process(COMMAND "${PYTHON}" ${script} ${args}
                  WORKING_DIRECTORY "${SRC}" RESULT_VARIABLE rc OUTPUT_VARIABLE printed ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(SEND_ERROR "${script} for ${f}: exit ${rc}:\n${err}")
    continue()
  endif()
  file(READ "${SRC}/${f}" committed)
  strip_comments(committed)
  strip_comments(printed)
  if(NOT committed STREQUAL printed)
    string(REPLACE "/" "_" name "${f}")
    file(WRITE "${WORK}/${name}.committed" "${committed}\n")
    file(WRITE "${WORK}/${name}.printed" "${printed}\n")
    message(SEND_ERROR "${f}: its table differs from what its command prints: "
                       "diff ${WORK}/${name}.committed ${WORK}/${name}.printed")
  endif()
  if(script STREQUAL "bench/sweep_terms.py")
    math(EXPR checked_terms "${checked_terms} + 1")
  else()
    math(EXPR checked "${checked} + 1")
  endif()
endforeach()
if(checked LESS 2 OR checked_terms LESS 1)
  message(SEND_ERROR "expected at least 2 lane-rates.txt files made by bench/lane_rates.py and 1 "
                     "success-by-10M.txt made by bench/sweep_terms.py under bench/results, found "
                     "${checked} and ${checked_terms}")
endif()

# bench/results keeps run metrics compressed (bench/metrics_io.py compress): no plain metrics.csv
file(GLOB_RECURSE plain RELATIVE "${SRC}" "${SRC}/bench/results/*/metrics.csv")
if(plain)
  list(LENGTH plain n)
  list(GET plain 0 first)
  message(SEND_ERROR "${n} plain metrics.csv under bench/results (${first} first): compress them "
                     "with bench/metrics_io.py compress bench/results")
endif()
# compress turns a plain metrics.csv into metrics.csv.xz, and a reader gives the same figures
set(m "${WORK}/metrics_io")
file(MAKE_DIRECTORY "${m}/plain/run" "${m}/packed/run")
foreach(d plain packed)
  file(WRITE "${m}/${d}/run/metrics.csv" "update,steps,wall_s,return\n1,1000,1.0,\n2,3000,2.0,5\n3,7000,3.5,6\n")
endforeach()
execute_process(COMMAND "${PYTHON}" "${SRC}/bench/metrics_io.py" compress "${m}/packed"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS "${m}/packed/run/metrics.csv.xz" OR EXISTS "${m}/packed/run/metrics.csv")
  message(SEND_ERROR "metrics_io.py compress: exit ${rc}, expected run/metrics.csv.xz in place of "
                     "run/metrics.csv:\n${out}${err}")
endif()
foreach(d plain packed)
  execute_process(COMMAND "${PYTHON}" "${SRC}/bench/lane_rates.py" "${m}/${d}" run --window 2
                  RESULT_VARIABLE rc OUTPUT_VARIABLE rates_${d} ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(SEND_ERROR "lane_rates.py on the ${d} metrics: exit ${rc}:\n${err}")
  endif()
  strip_comments(rates_${d})
endforeach()
if(NOT rates_plain STREQUAL rates_packed OR NOT rates_plain MATCHES "2,000")
  message(SEND_ERROR "lane_rates.py read the compressed metrics otherwise than the plain ones:\n"
                     "plain:${rates_plain}\ncompressed:${rates_packed}")
endif()
# read_metrics also takes the compressed file's own name
execute_process(COMMAND "${PYTHON}" -c "import sys; sys.path.insert(0, sys.argv[1]); \
from metrics_io import read_metrics as r; a = r(sys.argv[2]); b = r(sys.argv[3]); \
sys.exit(0 if a == b and len(a) == 3 else 1)"
                        "${SRC}/bench" "${m}/plain/run/metrics.csv" "${m}/packed/run/metrics.csv.xz"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(SEND_ERROR "read_metrics of run/metrics.csv.xz by its own name: exit ${rc}, expected the "
                     "plain file's 3 rows:\n${out}${err}")
endif()
