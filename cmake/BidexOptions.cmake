# compiler settings shared by every target of the project
set(CMAKE_CXX_STANDARD 20)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_CXX_EXTENSIONS OFF)
set(CMAKE_EXPORT_COMPILE_COMMANDS ON)
set(CMAKE_POSITION_INDEPENDENT_CODE ON)
if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  set(CMAKE_BUILD_TYPE Release CACHE STRING "Build type" FORCE)
endif()

# ccache when present (clean rebuilds in CI and on the GPU machine)
find_program(BIDEX_CCACHE ccache)
if(BIDEX_CCACHE)
  set(CMAKE_CXX_COMPILER_LAUNCHER ${BIDEX_CCACHE})
  # ccache must hash the precompiled header's timestamps loosely to reuse it
  set(ENV{CCACHE_SLOPPINESS} "pch_defines,time_macros,include_file_mtime,include_file_ctime")
endif()

# warnings for our own targets
function(bidex_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wno-unused-parameter>)
  if(BIDEX_WERROR)
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror>
                                             $<$<COMPILE_LANGUAGE:CUDA>:-Werror=all-warnings>)
  endif()
  if(BIDEX_NAN_FILL)
    target_compile_definitions(${target} PRIVATE BIDEX_NAN_FILL=1)
  endif()
endfunction()

# a library target for one top-level folder, with the alias bidex::<name>
function(bidex_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  add_library(bidex_${name} ${ARG_SOURCES})
  add_library(bidex::${name} ALIAS bidex_${name})
  target_include_directories(bidex_${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(bidex_${name} PUBLIC ${ARG_PUBLIC} PRIVATE ${ARG_PRIVATE})
  bidex_warnings(bidex_${name})
endfunction()

# LibTorch is heavy to parse: a target's sources share one precompiled <torch/torch.h>, except
# those named WITHOUT, which include no LibTorch header (directly or through bidex's headers).
# Both ways a wrong entry costs: loading the PCH adds about 9 s to a light source (rl/
# config_fields.cc: 1.1 s to 10.2 s), and a source that includes LibTorch without it takes 1.5-2x
# its time (rl/td3.cc: 9.6 s to 20.4 s). New sources get the PCH; `g++ -M` on a source's compile
# command (ninja -t commands) shows whether it includes torch/torch.h.
# The header is compiled once for the libraries and once for the executables, the first target of
# each kind making it and the later ones reusing it (REUSE_FROM): GCC takes a PCH only where
# -fPIC/-fPIE match, and the flags are otherwise the same. Compiling it took 61-76 s a target on
# two cores, six times before (bench/results/build-pch-2core/).
function(bidex_torch_pch target)
  cmake_parse_arguments(ARG "" "" "WITHOUT" ${ARGN})
  if(NOT BIDEX_PCH)
    return()
  endif()
  get_target_property(_type ${target} TYPE)
  if(_type STREQUAL "EXECUTABLE")
    set(_kind executable)
  else()
    set(_kind library)
  endif()
  get_property(_donor GLOBAL PROPERTY BIDEX_TORCH_PCH_${_kind})
  if(_donor)
    target_precompile_headers(${target} REUSE_FROM ${_donor})
  else()
    target_precompile_headers(${target} PRIVATE <torch/torch.h>)
    set_property(GLOBAL PROPERTY BIDEX_TORCH_PCH_${_kind} ${target})
  endif()
  get_target_property(_all ${target} SOURCES)
  foreach(_src IN LISTS ARG_WITHOUT)
    if(NOT _src IN_LIST _all)
      message(FATAL_ERROR "bidex_torch_pch(${target}): WITHOUT names ${_src}, not one of its sources")
    endif()
  endforeach()
  foreach(_src IN LISTS _all)
    if(_src IN_LIST ARG_WITHOUT)
      set_source_files_properties(${_src} TARGET_DIRECTORY ${target}
        PROPERTIES SKIP_PRECOMPILE_HEADERS ON)
    endif()
  endforeach()
endfunction()

# CUDA: the GPU path's kernels (task stages over MuJoCo Warp's arrays, sim/warp). AUTO builds
# them when a CUDA compiler is found; the CPU path never needs one. Architecture 90: H100/H200.
set(BIDEX_CUDA AUTO CACHE STRING "Build the CUDA kernels: ON, OFF or AUTO (when nvcc is found)")
set_property(CACHE BIDEX_CUDA PROPERTY STRINGS AUTO ON OFF)
set(BIDEX_HAS_CUDA OFF)
if(NOT BIDEX_CUDA STREQUAL "OFF")
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
      set(CMAKE_CUDA_ARCHITECTURES 90)
    endif()
    enable_language(CUDA)
    set(CMAKE_CUDA_STANDARD 20)
    set(CMAKE_CUDA_STANDARD_REQUIRED ON)
    if(BIDEX_CCACHE)
      set(CMAKE_CUDA_COMPILER_LAUNCHER ${BIDEX_CCACHE})
    endif()
    set(BIDEX_HAS_CUDA ON)
  elseif(BIDEX_CUDA STREQUAL "ON")
    message(FATAL_ERROR "BIDEX_CUDA=ON but no CUDA compiler was found: install the CUDA toolkit "
                        "(nvcc) or configure with -DBIDEX_CUDA=OFF")
  endif()
endif()
message(STATUS "bidex: CUDA kernels ${BIDEX_HAS_CUDA}")
