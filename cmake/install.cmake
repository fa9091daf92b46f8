# SPDX-License-Identifier: MIT
# Install rules (included by the top-level CMakeLists.txt after every target exists).
# A prefix install is relocatable: nothing below may bake CMAKE_INSTALL_PREFIX into a file,
# because `cmake --install build --prefix P` picks the prefix after configuration. Only the
# Debian layout (below) names its fixed prefix, LIDARFLOW_DEB_PREFIX.
# Components, one Debian package each (cmake/packaging.cmake): runtime, dev, tools, lcm, python, dask.
include(CMakePackageConfigHelpers)

# The packages' library folder: the multiarch libdir (lib/<triplet>, Debian policy 9.1.1).
set(LIDARFLOW_DEB_LIBDIR lib)
if(CMAKE_LIBRARY_ARCHITECTURE)
  set(LIDARFLOW_DEB_LIBDIR lib/${CMAKE_LIBRARY_ARCHITECTURE})
endif()
set(LIDARFLOW_DEB_PREFIX /usr)  # CPACK_PACKAGING_INSTALL_PREFIX (cmake/packaging.cmake)

# Executables find liblidarflow through a RUNPATH relative to themselves, so an install
# started from any prefix runs without LD_LIBRARY_PATH. The same files go into both layouts
# below, so the RUNPATH names both library folders (one entry when they are the same).
file(RELATIVE_PATH _lf_bin_to_lib ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
file(RELATIVE_PATH _lf_bin_to_deb_lib /${CMAKE_INSTALL_BINDIR} /${LIDARFLOW_DEB_LIBDIR})
# ($ORIGIN-relative paths are also what Debian accepts in packages: lintian's
# custom-library-search-path ignores them.)
set(LIDARFLOW_TOOLS_RUNPATH "$ORIGIN/${_lf_bin_to_lib}")
if(NOT _lf_bin_to_deb_lib STREQUAL _lf_bin_to_lib)
  list(APPEND LIDARFLOW_TOOLS_RUNPATH "$ORIGIN/${_lf_bin_to_deb_lib}")
endif()
foreach(_lf_tool lidarflow_cli lidarflow_lcm_bridge)
  if(TARGET ${_lf_tool})
    set_target_properties(${_lf_tool} PROPERTIES INSTALL_RPATH "${LIDARFLOW_TOOLS_RUNPATH}")
  endif()
endforeach()
# Their man pages (share/man/man1, component tools), when help2man is installed.
include(${CMAKE_CURRENT_LIST_DIR}/manpages.cmake)

# The C header and the header-only C++ API (lidarflow.hpp: nothing of it is in the library) are
# the same in both layouts below.
install(FILES include/lidarflow/lidarflow.h include/lidarflow/lidarflow.hpp
              ${CMAKE_CURRENT_BINARY_DIR}/include/lidarflow/lidarflow_version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lidarflow COMPONENT dev)

# Two layouts of what depends on the library folder (the library, the CMake package, the
# pkg-config files), from the same build tree:
#   prefix  `cmake --install BUILD --prefix P`: CMAKE_INSTALL_LIBDIR (lib/ unless configured
#           for /usr), everything relative to its own location, so the tree can be moved;
#           component `prefix`, which no package takes.
#   deb     the Debian packages (CPack installs the packaged components one by one, and only
#           component installs reach EXCLUDE_FROM_ALL rules): the multiarch libdir
#           (lib/<triplet>, Debian policy 9.1.1) and pkg-config files with plain /usr paths.
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  message(FATAL_ERROR "CMAKE_INSTALL_LIBDIR must be relative to the prefix for a relocatable install")
endif()
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/lidarflowConfigVersion.cmake
        COMPATIBILITY SameMajorVersion)

# _lf_install_layout(prefix|deb LIBDIR): the layout-dependent install rules.
function(_lf_install_layout layout libdir)
  set(out ${CMAKE_CURRENT_BINARY_DIR}/install-${layout})
  if(layout STREQUAL deb)
    set(runtime runtime)
    set(dev dev)
    set(lcm lcm)
    set(exclude EXCLUDE_FROM_ALL)
    set(export lidarflowDebTargets)
    set(pc_prefix "${LIDARFLOW_DEB_PREFIX}")
    set(lcm_pc_prefix "${LIDARFLOW_DEB_PREFIX}")
    # lidarflow-lcm-types is Architecture: all, so its .pc is in the arch-independent folder.
    set(lcm_pc_dir ${CMAKE_INSTALL_DATADIR}/pkgconfig)
  else()
    set(runtime prefix)
    set(dev prefix)
    set(lcm prefix)
    set(exclude "")
    set(export lidarflowTargets)
    # ${pcfiledir} = PREFIX/LIBDIR/pkgconfig: one "/.." per component of LIBDIR, plus pkgconfig.
    set(pc_prefix "\${pcfiledir}/..")
    string(REPLACE "/" ";" parts "${libdir}")
    foreach(part ${parts})
      string(APPEND pc_prefix "/..")
    endforeach()
    set(lcm_pc_prefix "${pc_prefix}")
    # Beside lidarflow.pc, so that one PKG_CONFIG_PATH finds both.
    set(lcm_pc_dir ${libdir}/pkgconfig)
  endif()

  install(TARGETS lidarflow EXPORT ${export}
          LIBRARY DESTINATION ${libdir} COMPONENT ${runtime} NAMELINK_COMPONENT ${dev} ${exclude}
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT ${runtime} ${exclude}
          INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(EXPORT ${export} NAMESPACE lidarflow:: FILE lidarflowTargets.cmake
          DESTINATION ${libdir}/cmake/lidarflow COMPONENT ${dev} ${exclude})
  # configure_package_config_file computes PACKAGE_PREFIX_DIR from the config file's own
  # location, so the package config is relocatable (the generated targets file is too).
  set(LIDARFLOW_LCM_C_SOURCES_DIR ${CMAKE_INSTALL_DATADIR}/lidarflow/lcm/c)
  set(LIDARFLOW_LCM_INCLUDE_DIR ${CMAKE_INSTALL_INCLUDEDIR}/lidarflow/lcm)
  configure_package_config_file(cmake/lidarflowConfig.cmake.in ${out}/lidarflowConfig.cmake
          INSTALL_DESTINATION ${libdir}/cmake/lidarflow
          PATH_VARS CMAKE_INSTALL_INCLUDEDIR LIDARFLOW_LCM_INCLUDE_DIR LIDARFLOW_LCM_C_SOURCES_DIR)
  install(FILES ${out}/lidarflowConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/lidarflowConfigVersion.cmake
          DESTINATION ${libdir}/cmake/lidarflow COMPONENT ${dev} ${exclude})

  set(LIDARFLOW_PC_PREFIX "${pc_prefix}")
  set(LIDARFLOW_PC_LIBDIR "${libdir}")
  configure_file(cmake/lidarflow.pc.in ${out}/lidarflow.pc @ONLY)
  install(FILES ${out}/lidarflow.pc DESTINATION ${libdir}/pkgconfig COMPONENT ${dev} ${exclude})
  if(LIDARFLOW_WITH_LCM)
    set(LIDARFLOW_PC_PREFIX "${lcm_pc_prefix}")
    configure_file(cmake/lidarflow-lcm-types.pc.in ${out}/lidarflow-lcm-types.pc @ONLY)
    install(FILES ${out}/lidarflow-lcm-types.pc DESTINATION ${lcm_pc_dir} COMPONENT ${lcm} ${exclude})
  endif()
endfunction()
_lf_install_layout(prefix ${CMAKE_INSTALL_LIBDIR})
_lf_install_layout(deb ${LIDARFLOW_DEB_LIBDIR})

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
