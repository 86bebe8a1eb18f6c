# bench/kernel_trace.py (issue 39: where a GPU pack's step goes) on a kernel trace written here
# in bench/kernel_trace.cc's format: the per-step span, busy time, kernels side by side and a
# stream's gaps come out as computed by hand; phases are cut at pauses and named; malformed or
# unusable traces are refused naming the file, line or option, with nothing written; and
# bench/kernel_trace.sh's help and refusals (the injection itself needs a GPU: its measurement is
# bench/results/pack-trace-h200/). Run with -DSRC=... -DWORK=... -DPYTHON=...
include(${CMAKE_CURRENT_LIST_DIR}/script_checks.cmake)
set(script ${SRC}/bench/kernel_trace.py)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

# Two phases two seconds apart, four draws each (three steps with --skip 0). In each step of the
# first ("packed"), from the end of its draw: stream 11 runs [0, 100) and [150, 250) us, stream 12
# runs [50, 200) us: span 250 us, busy 250 us, 350 us of kernels (1.40 side by side), stream 11's
# gaps 50 us. In the second ("alone") one kernel of 200 us on stream 11 per step. One kernel
# without a time (start 0) is counted and left out.
set(trace "N\t0\t_random_fill_0123abcd_cuda_kernel_forward\n")
string(APPEND trace "N\t1\tsolve_deadbeef12_cuda_kernel_forward\n")
string(APPEND trace "N\t2\tcollide\nK\t0\t0\t11\t0\t128\t128\t1\n")
foreach(phase 0 1)
  math(EXPR base "1000000000 + ${phase} * 2000000000")
  foreach(i 0 1 2 3)
    math(EXPR d0 "${base} + ${i} * 1000000")
    math(EXPR d1 "${d0} + 1000")
    string(APPEND trace "K\t${d0}\t${d1}\t7\t0\t1024\t128\t0\n")
    if(i LESS 3)
      if(phase EQUAL 0)
        foreach(k "0;100;11;1" "150;250;11;2" "50;200;12;1")
          list(GET k 0 s)
          list(GET k 1 e)
          list(GET k 2 stream)
          list(GET k 3 name)
          math(EXPR s "${d1} + ${s} * 1000")
          math(EXPR e "${d1} + ${e} * 1000")
          string(APPEND trace "K\t${s}\t${e}\t${stream}\t3\t4096\t128\t${name}\n")
        endforeach()
      else()
        math(EXPR s "${d1}")
        math(EXPR e "${d1} + 200000")
        string(APPEND trace "K\t${s}\t${e}\t11\t0\t4096\t128\t1\n")
      endif()
    endif()
  endforeach()
endforeach()
file(WRITE ${WORK}/trace.txt "${trace}")

run_script(help TRUE ${PYTHON} ${script} --help)
expect_text(help "kernel-trace.json" "--step-kernel" "--labels" "--compare" "side by side"
            "--long-stream")

run_script(summary TRUE ${PYTHON} ${script} ${WORK}/trace.txt --out ${WORK}/out --skip 0
           --labels packed,alone --compare --long-stream 2)
# (with --long-stream 2, stream 11 is long in the packed phase and stream 12 short)
expect_text(summary "== packed: 3 steps"
  "span 0.25 ms, busy 0.25 ms, idle 0.00 ms, kernels 3 (0.35 ms added up: 1.40 side by side)"
  "streams of 2+ kernels a step: 1 streams, 2 kernels, 0.20 ms added up, busy 0.20 ms"
  "the other streams: 1 streams, 1 kernels, 0.15 ms added up, busy 0.15 ms"
  "== alone: 3 steps" "span 0.20 ms, busy 0.20 ms, idle 0.00 ms, kernels 1"
  "packed against the mean of the 1 tasks alone")
file(READ ${WORK}/out/kernel-trace.json json)
foreach(check "phases;0;side_by_side;1.4" "phases;0;idle_ms;0" "phases;1;span_ms;0.2"
              "unstamped_kernels;1" "dropped_records;0")
  string(REPLACE ";" "|" shown "${check}")
  list(POP_BACK check want)
  string(JSON got GET "${json}" ${check})
  if(NOT got MATCHES "^[0-9.e+-]+$")
    message(SEND_ERROR "summary: ${shown}: not a number: ${got}")
  endif()
  execute_process(COMMAND ${PYTHON} -c "import sys; sys.exit(abs(float('${got}') - ${want}) > 1e-9)"
                  RESULT_VARIABLE differs)
  if(differs)
    message(SEND_ERROR "summary: ${shown}: got ${got}")
  endif()
endforeach()
# stream 11 of the packed phase: two kernels, 0.20 ms of them, 0.05 ms of gaps
string(JSON rows GET "${json}" phases 0 stream_rows)
string(JSON n LENGTH "${rows}")
set(found FALSE)
math(EXPR last "${n} - 1")
foreach(r RANGE ${last})
  string(JSON sid GET "${rows}" ${r} stream)
  if(sid EQUAL 11)
    string(JSON gaps GET "${rows}" ${r} gaps_ms)
    string(JSON kernels GET "${rows}" ${r} kernels)
    execute_process(COMMAND ${PYTHON} -c
      "import sys; sys.exit(abs(${gaps} - 0.05) > 1e-9 or ${kernels} != 2)" RESULT_VARIABLE bad)
    if(bad)
      message(SEND_ERROR "summary: stream 11: gaps ${gaps} ms, ${kernels} kernels; want 0.05, 2")
    endif()
    set(found TRUE)
  endif()
endforeach()
if(NOT found)
  message(SEND_ERROR "summary: no row for stream 11 in ${rows}")
endif()
# the shortened names: the module hash and _cuda_kernel_forward cut
string(JSON solve GET "${json}" phases 0 names solve per_step)
if(NOT solve EQUAL 2)
  message(SEND_ERROR "summary: 'solve' runs ${solve} times a step, expected 2")
endif()

# the same trace xz-compressed (traces come back from a lease that way) gives the same summary
execute_process(COMMAND ${PYTHON} -c
  "import lzma, sys; lzma.open(sys.argv[2], 'wb').write(open(sys.argv[1], 'rb').read())"
  ${WORK}/trace.txt ${WORK}/trace.txt.xz)
run_script(xz TRUE ${PYTHON} ${script} ${WORK}/trace.txt.xz --out ${WORK}/out-xz --skip 0
           --labels packed,alone --compare --long-stream 2)
file(READ ${WORK}/out/kernel-trace.txt plain_text)
file(READ ${WORK}/out-xz/kernel-trace.txt xz_text)
if(NOT plain_text STREQUAL xz_text)
  message(SEND_ERROR "xz: the compressed trace's summary differs:\n${xz_text}")
endif()

# the phases named from bidex bench pack's JSON (the pack, then each task alone)
file(WRITE ${WORK}/bench.json
     "{\"packed\": {}, \"single\": [{\"task\": \"t\", \"label\": \"one\"}]}")
run_script(bench TRUE ${PYTHON} ${script} ${WORK}/trace.txt --out ${WORK}/out-bench --skip 0
           --bench ${WORK}/bench.json --compare)
expect_text(bench "== packed: 3 steps" "== one: 3 steps" "packed against the mean of the 1 tasks")

# refusals, each with nothing written
file(WRITE ${WORK}/bench3.json
     "{\"packed\": {}, \"packed_one_backend_per_scene\": {}, \"single\": [{\"label\": \"a\"}]}")
run_script(bench3 FALSE ${PYTHON} ${script} ${WORK}/trace.txt --out ${WORK}/bad --skip 0
           --bench ${WORK}/bench3.json)
expect_text(bench3 "bench3.json names 3 measurements, the trace holds 2 phases")
execute_process(COMMAND ${PYTHON} -c
  "import sys; b = open(sys.argv[1], 'rb').read(); open(sys.argv[2], 'wb').write(b[:len(b) // 2])"
  ${WORK}/trace.txt.xz ${WORK}/cut.txt.xz)
run_script(cut FALSE ${PYTHON} ${script} ${WORK}/cut.txt.xz --out ${WORK}/bad)
expect_text(cut "cut.txt.xz: cannot read past line")
file(WRITE ${WORK}/bad.txt "N\t0\t_random_fill\nK\t10\t20\t7\n")
run_script(bad_record FALSE ${PYTHON} ${script} ${WORK}/bad.txt --out ${WORK}/bad)
expect_text(bad_record "bad.txt:2" "expected a K, N, C, S or D record")
run_script(no_draws FALSE ${PYTHON} ${script} ${WORK}/trace.txt --out ${WORK}/bad
           --step-kernel no_such_kernel)
expect_text(no_draws "no kernel's name holds 'no_such_kernel'" "--step-kernel")
run_script(labels FALSE ${PYTHON} ${script} ${WORK}/trace.txt --out ${WORK}/bad --skip 0
           --labels one,two,three)
expect_text(labels "--labels names 3 phases, the trace holds 2")
run_script(compare FALSE ${PYTHON} ${script} ${WORK}/trace.txt --out ${WORK}/bad --skip 0
           --compare)
expect_text(compare "--compare needs a phase labelled packed")
run_script(missing FALSE ${PYTHON} ${script} ${WORK}/none.txt --out ${WORK}/bad)
expect_text(missing "cannot read ${WORK}/none.txt")
if(EXISTS ${WORK}/bad)
  message(SEND_ERROR "a refused run wrote ${WORK}/bad")
endif()

# the shell side: its help, and run's refusals
set(sh ${SRC}/bench/kernel_trace.sh)
run_script(sh_help TRUE bash ${sh} --help)
expect_text(sh_help "CUDA_INJECTION64_PATH" "build LIB" "run LIB TRACE -- COMMAND")
run_script(sh_no_lib FALSE bash ${sh} run ${WORK}/none.so ${WORK}/t.txt -- true)
expect_text(sh_no_lib "no library" "bench/kernel_trace.sh build")
run_script(sh_no_dashes FALSE bash ${sh} run ${WORK}/trace.txt ${WORK}/t.txt true)
expect_text(sh_no_dashes "expected -- before the command")
run_script(sh_stage FALSE bash ${sh} trace)
expect_text(sh_stage "unknown stage 'trace'")
