# every dependency but MuJoCo (cmake/BidexMuJoCo.cmake: the official wheel) is a Debian 12 package
# (see README); LibTorch may instead come from an
# installed PyTorch through CMAKE_PREFIX_PATH (python3 -c "import torch;print(torch.utils.cmake_prefix_path)")
include(${CMAKE_CURRENT_LIST_DIR}/BidexMuJoCo.cmake)
find_package(yaml-cpp REQUIRED)
find_package(SQLite3 REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(OpenMP REQUIRED COMPONENTS CXX)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(Torch REQUIRED)
if(BIDEX_TESTS)
  find_package(Catch2 2 REQUIRED)
endif()

# yaml-cpp 0.7 in Debian exports the plain target name
if(TARGET yaml-cpp::yaml-cpp)
  set(BIDEX_YAML yaml-cpp::yaml-cpp)
else()
  set(BIDEX_YAML yaml-cpp)
endif()

# Torch's config hands back flags and libraries as variables: wrap them in one target
add_library(bidex_torch INTERFACE)
target_link_libraries(bidex_torch INTERFACE ${TORCH_LIBRARIES})
target_include_directories(bidex_torch SYSTEM INTERFACE ${TORCH_INCLUDE_DIRS})
set(BIDEX_TORCH_CUDA OFF)
if(TORCH_CUDA_LIBRARIES OR CAFFE2_USE_CUDA)
  set(BIDEX_TORCH_CUDA ON)
endif()
message(STATUS "bidex: MuJoCo ${mujoco_VERSION}, Torch ${Torch_VERSION}, Torch CUDA: ${BIDEX_TORCH_CUDA}")

# headless rendering (sim/render.cc): one offscreen OpenGL backend and libpng, both optional (the
# render library then throws a clear error). The backend's headers are compiled in and its library
# is opened at the first render (dlopen), so binaries start where it is missing. Found with plain
# find_path/find_library, not pkg-config, so that the unpacked .debs of scripts/offline-build.sh
# are found through CMAKE_PREFIX_PATH. AUTO prefers OSMesa: software, the same on every machine.
set(BIDEX_RENDER_GL AUTO CACHE STRING "Offscreen OpenGL for sim/render: AUTO, OSMESA, EGL or NONE")
set_property(CACHE BIDEX_RENDER_GL PROPERTY STRINGS AUTO OSMESA EGL NONE)
find_path(BIDEX_GL_INCLUDE_DIR GL/gl.h)  # render.cc includes it with either backend
find_path(BIDEX_OSMESA_INCLUDE_DIR GL/osmesa.h)
find_library(BIDEX_OSMESA_LIBRARY OSMesa)
find_path(BIDEX_EGL_INCLUDE_DIR EGL/egl.h)
find_library(BIDEX_EGL_LIBRARY EGL)
find_path(BIDEX_PNG_INCLUDE_DIR png.h PATH_SUFFIXES libpng16)
find_library(BIDEX_PNG_LIBRARY NAMES png16 png)
add_library(bidex_render_deps INTERFACE)
target_link_libraries(bidex_render_deps INTERFACE ${CMAKE_DL_LIBS})
set(_gl ${BIDEX_RENDER_GL})
if(_gl STREQUAL "AUTO")
  if(BIDEX_GL_INCLUDE_DIR AND BIDEX_OSMESA_INCLUDE_DIR AND BIDEX_OSMESA_LIBRARY)
    set(_gl OSMESA)
  elseif(BIDEX_GL_INCLUDE_DIR AND BIDEX_EGL_INCLUDE_DIR AND BIDEX_EGL_LIBRARY)
    set(_gl EGL)
  else()
    set(_gl NONE)
    message(WARNING "bidex: no OpenGL headers (GL/gl.h) with OSMesa or EGL found: `render` will "
                    "throw (install libosmesa6-dev, or run scripts/setup.sh)")
  endif()
endif()
if(_gl STREQUAL "OSMESA")
  if(NOT (BIDEX_OSMESA_INCLUDE_DIR AND BIDEX_OSMESA_LIBRARY))
    message(FATAL_ERROR "BIDEX_RENDER_GL=OSMESA but GL/osmesa.h or libOSMesa was not found "
                        "(Debian: libosmesa6-dev)")
  endif()
  target_include_directories(bidex_render_deps SYSTEM INTERFACE ${BIDEX_OSMESA_INCLUDE_DIR}
                             ${BIDEX_GL_INCLUDE_DIR})
  target_compile_definitions(bidex_render_deps INTERFACE BIDEX_GL_OSMESA=1)
elseif(_gl STREQUAL "EGL")
  if(NOT (BIDEX_EGL_INCLUDE_DIR AND BIDEX_EGL_LIBRARY))
    message(FATAL_ERROR "BIDEX_RENDER_GL=EGL but EGL/egl.h or libEGL was not found (Debian: "
                        "libegl-dev, and at run time a vendor library such as libegl-mesa0)")
  endif()
  target_include_directories(bidex_render_deps SYSTEM INTERFACE ${BIDEX_EGL_INCLUDE_DIR}
                             ${BIDEX_GL_INCLUDE_DIR})
  target_compile_definitions(bidex_render_deps INTERFACE BIDEX_GL_EGL=1)
elseif(NOT _gl STREQUAL "NONE")
  message(FATAL_ERROR "BIDEX_RENDER_GL must be AUTO, OSMESA, EGL or NONE, not '${_gl}'")
endif()
set(BIDEX_HAVE_PNG OFF)
if(BIDEX_PNG_INCLUDE_DIR AND BIDEX_PNG_LIBRARY)
  set(BIDEX_HAVE_PNG ON)
  target_include_directories(bidex_render_deps SYSTEM INTERFACE ${BIDEX_PNG_INCLUDE_DIR})
  target_link_libraries(bidex_render_deps INTERFACE ${BIDEX_PNG_LIBRARY})
  target_compile_definitions(bidex_render_deps INTERFACE BIDEX_HAVE_PNG=1)
else()
  message(WARNING "bidex: libpng not found: `write_png` will throw (install libpng-dev)")
endif()
message(STATUS "bidex: render GL backend: ${_gl}, PNG: ${BIDEX_HAVE_PNG}")
