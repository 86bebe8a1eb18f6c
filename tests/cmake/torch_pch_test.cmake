# LibTorch's precompiled header is compiled twice, once for the libraries (-fPIC) and once for the
# executables (-fPIE), and every source that takes a precompiled header takes one of those two
# (bidex_torch_pch in cmake/BidexOptions.cmake; six were compiled before, 61-76 s each on two
# cores: bench/results/build-pch-2core/). Reads this build's Ninja graph and compile commands:
#   cmake -DBUILD=<build folder> -DNINJA=<ninja> -P torch_pch_test.cmake
execute_process(COMMAND "${NINJA}" -C "${BUILD}" -t targets all
                OUTPUT_VARIABLE targets RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "ninja -t targets all in ${BUILD} failed (exit ${rc})")
endif()
string(REGEX MATCHALL "[^\n]*cmake_pch\\.hxx\\.gch:" headers "${targets}")
list(LENGTH headers n)
if(NOT n EQUAL 2)
  message(FATAL_ERROR "expected 2 precompiled headers (libraries, executables) in ${BUILD}, "
                      "found ${n}:\n${headers}")
endif()
file(READ "${BUILD}/compile_commands.json" commands)
string(REGEX MATCHALL "-include [^ \"]*cmake_pch\\.hxx" includes "${commands}")
list(LENGTH includes uses)
list(REMOVE_DUPLICATES includes)
list(LENGTH includes distinct)
if(NOT distinct EQUAL 2 OR uses LESS 20)
  message(FATAL_ERROR "expected the compile commands to include 2 precompiled headers, found "
                      "${distinct} in ${uses} commands: ${includes}")
endif()
message(STATUS "2 precompiled headers, taken by ${uses} compile commands")
