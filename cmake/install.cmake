# SPDX-License-Identifier: MIT
# Install rules (included by the top-level CMakeLists.txt after every target exists).
# Everything installed is relocatable: nothing below may bake CMAKE_INSTALL_PREFIX into a file,
# because `cmake --install build --prefix P` and CPack pick the prefix after configuration.
# Components, one Debian package each (cmake/packaging.cmake): runtime, dev, tools, lcm, python, dask.
include(CMakePackageConfigHelpers)

# Executables find liblidarflow through a RUNPATH relative to themselves, so an install
# started from any prefix runs without LD_LIBRARY_PATH.
file(RELATIVE_PATH _lf_bin_to_lib ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
# ($ORIGIN-relative paths are also what Debian accepts in packages: lintian's
# custom-library-search-path ignores them.)
set(LIDARFLOW_TOOLS_RUNPATH "$ORIGIN/${_lf_bin_to_lib}")
foreach(_lf_tool lidarflow_cli lidarflow_lcm_bridge)
  if(TARGET ${_lf_tool})
    set_target_properties(${_lf_tool} PROPERTIES INSTALL_RPATH "${LIDARFLOW_TOOLS_RUNPATH}")
  endif()
endforeach()

install(TARGETS lidarflow EXPORT lidarflowTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT dev
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
# lidarflow.hpp: the header-only C++ API over lidarflow.h (nothing of it is in the library).
install(FILES include/lidarflow/lidarflow.h include/lidarflow/lidarflow.hpp
              ${CMAKE_CURRENT_BINARY_DIR}/include/lidarflow/lidarflow_version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lidarflow COMPONENT dev)
install(EXPORT lidarflowTargets NAMESPACE lidarflow::
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lidarflow COMPONENT dev)
# configure_package_config_file computes PACKAGE_PREFIX_DIR from the config file's own
# location, so the package config is relocatable (the generated targets file is too).
configure_package_config_file(cmake/lidarflowConfig.cmake.in
        ${CMAKE_CURRENT_BINARY_DIR}/lidarflowConfig.cmake
        INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lidarflow)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/lidarflowConfigVersion.cmake
        COMPATIBILITY SameMajorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/lidarflowConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/lidarflowConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lidarflow COMPONENT dev)

# pkg-config: prefix from the .pc file's own directory (${pcfiledir} = PREFIX/LIBDIR/pkgconfig),
# one "/.." per component of LIBDIR (lib, or lib/x86_64-linux-gnu under /usr) plus pkgconfig.
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  message(FATAL_ERROR "CMAKE_INSTALL_LIBDIR must be relative to the prefix for a relocatable install")
endif()
set(LIDARFLOW_PC_PREFIX "\${pcfiledir}/..")
string(REPLACE "/" ";" _lf_libdir_parts "${CMAKE_INSTALL_LIBDIR}")
foreach(_lf_part ${_lf_libdir_parts})
  string(APPEND LIDARFLOW_PC_PREFIX "/..")
endforeach()
configure_file(cmake/lidarflow.pc.in ${CMAKE_CURRENT_BINARY_DIR}/lidarflow.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/lidarflow.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)

# Licence and notices for a prefix install. Component `doc` is not packaged: each Debian
# package carries them as /usr/share/doc/PACKAGE/copyright instead (cmake/packaging.cmake).
install(FILES LICENSE THIRD_PARTY_NOTICES.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT doc)

# The Python packages are pure Python (the binding: ctypes + numpy; lidarflow_lcm, the LCM
# messages and logs: numpy): their files are installed as they are. lidarflow_lcm needs no LCM
# at all, so it is installed in every build, with the binding.
set(LIDARFLOW_INSTALL_PYTHONDIR "lib/python3/dist-packages" CACHE STRING
    "Where the Python packages lidarflow and lidarflow_lcm are installed, relative to the prefix")
install(DIRECTORY bindings/python/lidarflow bindings/python/lidarflow_lcm DESTINATION ${LIDARFLOW_INSTALL_PYTHONDIR}
        COMPONENT python FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
# lidarflow_dask (Dask runs of drives and logs through the CLI and the bridge): a package of its
# own, as it needs Dask, which the binding does not.
install(DIRECTORY bindings/python/lidarflow_dask DESTINATION ${LIDARFLOW_INSTALL_PYTHONDIR}
        COMPONENT dask FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
