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
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  if(BIDEX_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
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

# LibTorch is heavy to parse: every target that includes it reuses one precompiled header
function(bidex_torch_pch target)
  if(BIDEX_PCH)
    if(TARGET bidex_torch_pch_anchor)
      target_precompile_headers(${target} REUSE_FROM bidex_torch_pch_anchor)
    else()
      target_precompile_headers(${target} PRIVATE <torch/torch.h>)
    endif()
  endif()
endfunction()
