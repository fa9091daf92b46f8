# SPDX-License-Identifier: MIT
# One precompiled header for the C++ targets compiled like the core: OpenCV's core and imgproc
# headers plus the standard headers most files include. Parsing opencv2/core.hpp alone takes
# ~1.3 s of a 2-3 s gcc compile, in each of ~150 translation units, and CI builds the tree four
# times (gcc Release and ASan, clang TSan and fuzz). gcc falls back to the headers when it
# rejects a PCH (-Winvalid-pch, which CMake adds, says so); clang stops with an error, so both
# need the flags below to match. LIDARFLOW_PCH=OFF turns it off.
option(LIDARFLOW_PCH "Precompile OpenCV and the common standard headers once for the C++ targets" ON)

function(_lidarflow_collect_targets dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub ${subdirs})
    _lidarflow_collect_targets(${sub} sub_targets)
    list(APPEND targets ${sub_targets})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

# gcc also rejects a PCH built with other code-model flags, so there are two: -fPIC for the
# libraries, -fPIE for the executables.
function(_lidarflow_pch_target name type)
  if(type STREQUAL EXECUTABLE)
    add_executable(${name} ${PROJECT_SOURCE_DIR}/cmake/precompiled_headers.cpp)
  else()
    add_library(${name} OBJECT ${PROJECT_SOURCE_DIR}/cmake/precompiled_headers.cpp)
  endif()
  # The same flags as the core (OpenMP defines _REENTRANT, which gcc checks; include paths).
  # gcc does not check visibility, so the libraries' PCH is hidden like the core and the
  # executables' keeps the default, as they do.
  target_link_libraries(${name} PRIVATE ${OpenCV_LIBS} Eigen3::Eigen OpenMP::OpenMP_CXX)
  target_compile_options(${name} PRIVATE -pthread)
  if(NOT type STREQUAL EXECUTABLE)
    set_target_properties(${name} PROPERTIES CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  endif()
  target_precompile_headers(${name} PRIVATE
    <opencv2/core.hpp> <opencv2/imgproc.hpp>
    <algorithm> <chrono> <cmath> <cstdint> <cstdio> <cstdlib> <cstring> <filesystem> <fstream>
    <functional> <limits> <memory> <sstream> <string> <vector>)
endfunction()

if(LIDARFLOW_PCH AND CMAKE_CXX_COMPILER_ID MATCHES "^(GNU|Clang)$")
  _lidarflow_collect_targets(${PROJECT_SOURCE_DIR} all_targets)
  _lidarflow_pch_target(lidarflow_pch_pic OBJECT_LIBRARY)
  _lidarflow_pch_target(lidarflow_pch_pie EXECUTABLE)
  foreach(t ${all_targets})
    get_target_property(type ${t} TYPE)
    if(NOT type MATCHES "^(EXECUTABLE|STATIC_LIBRARY|SHARED_LIBRARY|MODULE_LIBRARY|OBJECT_LIBRARY)$")
      continue()
    endif()
    get_target_property(sources ${t} SOURCES)
    set(cxx FALSE)
    set(c FALSE)
    foreach(s ${sources})
      if(s MATCHES "\\.(cpp|cc|cxx)$")
        set(cxx TRUE)
      elseif(s MATCHES "\\.c$")
        set(c TRUE)
      endif()
    endforeach()
    # Only targets compiled like the core (OpenMP, no debug info of their own), and not mixed
    # C/C++ targets, which would ask for a C PCH the reused target does not have.
    get_target_property(libs ${t} LINK_LIBRARIES)
    get_target_property(options ${t} COMPILE_OPTIONS)
    get_target_property(visibility ${t} CXX_VISIBILITY_PRESET)
    set(core_like FALSE)
    if(t STREQUAL lidarflow_core OR "OpenMP::OpenMP_CXX" IN_LIST libs OR "lidarflow_core" IN_LIST libs)
      set(core_like TRUE)
    endif()
    if(cxx AND NOT c AND core_like AND NOT "-g" IN_LIST options)
      # clang checks -pthread, which some targets get from Threads::Threads: all get it here.
      target_compile_options(${t} PRIVATE -pthread)
      if(type STREQUAL EXECUTABLE AND NOT visibility)
        target_precompile_headers(${t} REUSE_FROM lidarflow_pch_pie)
      elseif(NOT type STREQUAL EXECUTABLE AND visibility STREQUAL hidden)
        target_precompile_headers(${t} REUSE_FROM lidarflow_pch_pic)
      endif()
    endif()
  endforeach()
endif()
