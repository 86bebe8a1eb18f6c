# MuJoCo, the C library and headers of the official `mujoco` wheel, pinned to one version.
# scripts/setup.sh installs the wheel into the git-ignored virtual environment .venv/;
# scripts/offline-build.sh unpacks it into the build folder. This module finds the wheel's
# package folder (mujoco/, holding libmujoco.so.<version> and include/mujoco/) and makes the
# imported target mujoco::mujoco. CMake writes the library's folder into the binaries' run path,
# so they find it at run time without LD_LIBRARY_PATH.
#   -DBIDEX_MUJOCO_DIR=PATH   the package folder, when it is not in .venv/
set(BIDEX_MUJOCO_VERSION 3.17.0)
set(BIDEX_MUJOCO_DIR "" CACHE PATH
    "The mujoco wheel's package folder (libmujoco.so.${BIDEX_MUJOCO_VERSION}, include/mujoco/)")

set(_mj_fix "run scripts/setup.sh, which installs mujoco==${BIDEX_MUJOCO_VERSION} into .venv/, or pass -DBIDEX_MUJOCO_DIR=<site-packages>/mujoco")
set(_mj_dir "${BIDEX_MUJOCO_DIR}")
if(NOT _mj_dir)
  file(GLOB _mj_found "${PROJECT_SOURCE_DIR}/.venv/lib/python3*/site-packages/mujoco")
  list(LENGTH _mj_found _mj_n)
  if(_mj_n EQUAL 0)
    message(FATAL_ERROR "bidex: MuJoCo ${BIDEX_MUJOCO_VERSION} not found: expected the mujoco "
                        "wheel in ${PROJECT_SOURCE_DIR}/.venv/lib/python3*/site-packages/mujoco, "
                        "found no such folder; ${_mj_fix}")
  endif()
  list(GET _mj_found 0 _mj_dir)
endif()

set(_mj_header "${_mj_dir}/include/mujoco/mujoco.h")
if(NOT EXISTS "${_mj_header}")
  message(FATAL_ERROR "bidex: MuJoCo headers not found: expected ${_mj_header}; ${_mj_fix}")
endif()
file(STRINGS "${_mj_header}" _mj_line REGEX "^#define mjVERSION_HEADER [0-9]+")
string(REGEX REPLACE ".* ([0-9]+)$" "\\1" _mj_num "${_mj_line}")
math(EXPR _mj_major "${_mj_num} / 1000000")
math(EXPR _mj_minor "(${_mj_num} / 1000) % 1000")
math(EXPR _mj_patch "${_mj_num} % 1000")
set(mujoco_VERSION "${_mj_major}.${_mj_minor}.${_mj_patch}")
if(NOT mujoco_VERSION VERSION_EQUAL BIDEX_MUJOCO_VERSION)
  message(FATAL_ERROR "bidex: MuJoCo ${BIDEX_MUJOCO_VERSION} required, found ${mujoco_VERSION} "
                      "in ${_mj_dir}; ${_mj_fix}")
endif()
set(_mj_lib "${_mj_dir}/libmujoco.so.${BIDEX_MUJOCO_VERSION}")
if(NOT EXISTS "${_mj_lib}")
  message(FATAL_ERROR "bidex: MuJoCo library not found: expected ${_mj_lib}; ${_mj_fix}")
endif()

add_library(mujoco::mujoco SHARED IMPORTED)
set_target_properties(mujoco::mujoco PROPERTIES
  IMPORTED_LOCATION "${_mj_lib}"
  IMPORTED_SONAME "libmujoco.so.${BIDEX_MUJOCO_VERSION}"
  INTERFACE_INCLUDE_DIRECTORIES "${_mj_dir}/include")
set(BIDEX_MUJOCO_PACKAGE_DIR "${_mj_dir}")
message(STATUS "bidex: MuJoCo ${mujoco_VERSION} from ${_mj_dir}")
