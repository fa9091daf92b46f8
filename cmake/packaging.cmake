# SPDX-License-Identifier: MIT
# Debian packages (CPack DEB), one per install component (cmake/install.cmake):
#   liblidarflow0          runtime   the C ABI library (named for its SONAME, Debian policy 8.1)
#   liblidarflow-dev       dev       headers (C, header-only C++), liblidarflow.so, CMake package, pkg-config file
#   lidarflow-tools        tools     lidarflow, lidarflow-lcm-bridge
#   lidarflow-lcm-types    lcm       .lcm definitions, generated C and C++ types
#   python3-lidarflow      python    the pure-Python binding and lidarflow_lcm in /usr/lib/python3/dist-packages
#   python3-lidarflow-dask dask      lidarflow_dask: drives and LCM logs in chunks over a Dask cluster
# The library, CMake package and pkg-config files are in the multiarch libdir with /usr paths
# (the deb layout of cmake/install.cmake); Python packages byte-compile in postinst and clean up
# in prerm, as Debian's own do.
# Multi-Arch (written by cmake/debian/multiarch.cmake after CPack): liblidarflow0 and
# liblidarflow-dev `same` (co-installable for several architectures: their files are in the
# multiarch libdir or the same on every architecture), lidarflow-tools `foreign` (programs: any
# architecture's serve a user of another). The arch-all packages have none: the Python ones load
# liblidarflow.so.0 into the interpreter of their own architecture, and the LCM types come with
# liblcm-dev of the architecture they are built for.
# `tools/dev.sh package` (or `cpack -G DEB` in the build tree) writes them to build/packages/.
# Run-time dependencies on system libraries come from dpkg-shlibdeps; the ones it cannot see
# (between our own packages, Python, LCM headers) are declared below.

set(LIDARFLOW_DEB_MAINTAINER "lidarflow maintainers <maintainers@lidarflow.invalid>" CACHE STRING
    "Maintainer field of the Debian packages (the default is a placeholder: set a real address to publish)")
set(LIDARFLOW_DEB_RELEASE 1 CACHE STRING "Debian revision of the packages")

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME lidarflow)
set(CPACK_PACKAGE_VENDOR "The lidarflow authors")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${LIDARFLOW_DEB_MAINTAINER}")
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/packages)
set(CPACK_PACKAGING_INSTALL_PREFIX ${LIDARFLOW_DEB_PREFIX})  # the layout cmake/install.cmake installs for
set(CPACK_STRIP_FILES ON)

set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev tools python dask)
if(LIDARFLOW_WITH_LCM)
  list(APPEND CPACK_COMPONENTS_ALL lcm)
endif()
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE ${LIDARFLOW_DEB_RELEASE})
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "")
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# liblidarflow0's own shlibs file (and the ldconfig trigger CPack adds with it), so that
# dpkg-shlibdeps can resolve the tools' dependency on it.
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
# ldconfig through dpkg's trigger, not CPack's default maintainer scripts that call it
# directly (lintian: lacks-ldconfig-trigger, maintscript-calls-ldconfig). Providing postinst
# and postrm stops CPack from generating its own.
# A symbols file (capi/lidarflow.symbols, each function with the version that added it): a
# program that uses a newer function depends on the liblidarflow0 that has it, not on any.
file(MAKE_DIRECTORY ${PROJECT_BINARY_DIR}/debian)
execute_process(COMMAND bash ${PROJECT_SOURCE_DIR}/capi/symbols.sh debian ${PROJECT_BINARY_DIR}/debian/symbols
                        ${LIDARFLOW_ABI_MAJOR} RESULT_VARIABLE _lf_symbols_rc)
if(NOT _lf_symbols_rc EQUAL 0)
  message(FATAL_ERROR "capi/symbols.sh could not write the Debian symbols file")
endif()
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/capi/lidarflow.symbols)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/cmake/debian/triggers
    ${PROJECT_SOURCE_DIR}/cmake/debian/postinst
    ${PROJECT_SOURCE_DIR}/cmake/debian/postrm
    ${PROJECT_BINARY_DIR}/debian/symbols)
# The tools need liblidarflow.so.0, which is in another package of the same build: let
# dpkg-shlibdeps find it in the build tree (it has no shlibs information there, so CPack's
# --ignore-missing-info applies); the dependency on liblidarflow0 is declared below.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${PROJECT_BINARY_DIR}/capi)

set(_lf_deb_version "${PROJECT_VERSION}-${LIDARFLOW_DEB_RELEASE}")
set(_lf_description_tail
"lidarflow computes dense scene flow (optical flow and disparity at two times\nfor every pixel) from a rectified stereo camera and a sparse LiDAR, an\nimplementation of LiDAR-Flow (IROS 2019) behind a stable C ABI.")

macro(_lf_deb_component comp package section architecture summary)
  string(TOUPPER ${comp} _C)
  set(CPACK_DEBIAN_${_C}_PACKAGE_NAME ${package})
  set(CPACK_DEBIAN_${_C}_PACKAGE_SECTION ${section})
  if(${architecture} STREQUAL all)  # else CPack asks dpkg for the build machine's
    set(CPACK_DEBIAN_${_C}_PACKAGE_ARCHITECTURE all)
  endif()
  # First line: the synopsis; CPack indents the rest and turns empty lines into " .".
  set(CPACK_DEBIAN_${_C}_DESCRIPTION "${summary}\n${_lf_description_tail}\n\n${ARGN}")
  # Debian policy 12.5/12.7: every package carries the licence and a changelog in its doc dir.
  # EXCLUDE_FROM_ALL: only component installs (CPack) get these, not `cmake --install`.
  install(FILES ${_lf_deb_dir}/copyright ${_lf_deb_dir}/changelog.Debian.gz
          DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/${package} COMPONENT ${comp} EXCLUDE_FROM_ALL)
  # Every Python package: byte-compiled in postinst, cleaned in prerm (cmake/debian/python-*.in),
  # so that a purge leaves no __pycache__ behind.
  if(${section} STREQUAL python)
    set(LF_DEB_PACKAGE ${package})
    configure_file(${PROJECT_SOURCE_DIR}/cmake/debian/python-postinst.in ${_lf_deb_dir}/${package}/postinst @ONLY)
    configure_file(${PROJECT_SOURCE_DIR}/cmake/debian/python-prerm.in ${_lf_deb_dir}/${package}/prerm @ONLY)
    set(CPACK_DEBIAN_${_C}_PACKAGE_CONTROL_EXTRA ${_lf_deb_dir}/${package}/postinst ${_lf_deb_dir}/${package}/prerm)
  endif()
endmacro()

# copyright (machine-readable format) and changelog.Debian.gz, generated once per configuration.
set(_lf_deb_dir ${PROJECT_BINARY_DIR}/debian)
file(READ ${PROJECT_SOURCE_DIR}/LICENSE _lf_license)
string(REGEX REPLACE "^MIT License\n\n[^\n]*\n\n" "" _lf_license "${_lf_license}")
string(REGEX REPLACE "\n\n" "\n.\n" _lf_license "${_lf_license}")
string(REGEX REPLACE "\n([^\n])" "\n \\1" _lf_license " ${_lf_license}")
string(REGEX REPLACE "\n$" "" _lf_license "${_lf_license}")
file(WRITE ${_lf_deb_dir}/copyright
"Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/
Upstream-Name: lidarflow
Upstream-Contact: ${LIDARFLOW_DEB_MAINTAINER}
Comment: The binaries link OpenCV (Apache-2.0), libgomp (GPL-3+ with the GCC
 Runtime Library Exception), LCM and GLib (LGPL-2.1) dynamically and contain
 template code of Eigen 3.4 (MPL-2.0, unmodified; see
 /usr/share/common-licenses/MPL-2.0). See THIRD_PARTY_NOTICES.md in the source.

Files: *
Copyright: 2026 The lidarflow authors
License: Expat
${_lf_license}
")
# Its date is this version's release date in CHANGELOG.md, not the build's: liblidarflow0 and
# liblidarflow-dev of every architecture ship the file, which dpkg co-installs (Multi-Arch: same)
# only when it is the same bytes.
string(REPLACE "." "\\." _lf_version_re "${PROJECT_VERSION}")
file(STRINGS ${PROJECT_SOURCE_DIR}/CHANGELOG.md _lf_release REGEX "^## \\[${_lf_version_re}\\] - [0-9]+-[0-9]+-[0-9]+$")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/CHANGELOG.md)
if(_lf_release MATCHES "([0-9]+)-([0-9]+)-([0-9]+)$")
  # Days since 1970-01-01 of the civil date (H. Hinnant's days_from_civil), at 00:00 UTC.
  set(_y ${CMAKE_MATCH_1})
  set(_m ${CMAKE_MATCH_2})
  set(_d ${CMAKE_MATCH_3})
  if(_m LESS_EQUAL 2)
    math(EXPR _y "${_y} - 1")
    math(EXPR _mp "${_m} + 9")
  else()
    math(EXPR _mp "${_m} - 3")
  endif()
  math(EXPR _era "${_y} / 400")
  math(EXPR _yoe "${_y} - ${_era} * 400")
  math(EXPR _doe "${_yoe} * 365 + ${_yoe} / 4 - ${_yoe} / 100 + (153 * ${_mp} + 2) / 5 + ${_d} - 1")
  math(EXPR _lf_release_epoch "(${_era} * 146097 + ${_doe} - 719468) * 86400")
  # string(TIMESTAMP) formats SOURCE_DATE_EPOCH when it is set: the release date, then the
  # caller's value back.
  set(_lf_sde_was_set FALSE)
  if(DEFINED ENV{SOURCE_DATE_EPOCH})
    set(_lf_sde_was_set TRUE)
    set(_lf_sde "$ENV{SOURCE_DATE_EPOCH}")
  endif()
  set(ENV{SOURCE_DATE_EPOCH} ${_lf_release_epoch})
  string(TIMESTAMP _lf_deb_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
  if(_lf_sde_was_set)
    set(ENV{SOURCE_DATE_EPOCH} "${_lf_sde}")
  else()
    unset(ENV{SOURCE_DATE_EPOCH})
  endif()
else()
  message(WARNING "CHANGELOG.md has no '## [${PROJECT_VERSION}] - YYYY-MM-DD' heading: changelog.Debian is "
                  "dated by the build, and liblidarflow0 / liblidarflow-dev of two builds are not co-installable")
  string(TIMESTAMP _lf_deb_date "%a, %d %b %Y %H:%M:%S +0000" UTC)
endif()
file(WRITE ${_lf_deb_dir}/changelog.Debian
"lidarflow (${_lf_deb_version}) unstable; urgency=medium

  * Binary packages built from the lidarflow source tree with CPack.

 -- ${LIDARFLOW_DEB_MAINTAINER}  ${_lf_deb_date}
")
execute_process(COMMAND gzip -9nf ${_lf_deb_dir}/changelog.Debian RESULT_VARIABLE _lf_gzip_rc)
if(NOT _lf_gzip_rc EQUAL 0)
  message(FATAL_ERROR "gzip failed on ${_lf_deb_dir}/changelog.Debian")
endif()

_lf_deb_component(runtime liblidarflow0 libs any "dense scene flow from stereo and sparse LiDAR - library"
  "This package holds the shared library with the C ABI.")
_lf_deb_component(dev liblidarflow-dev libdevel any "dense scene flow from stereo and sparse LiDAR - development files"
  "This package holds the C header, the header-only C++17 API (lidarflow.hpp,\nwith optional OpenCV cv::Mat support), the CMake package\n(find_package(lidarflow)) and the pkg-config file.")
_lf_deb_component(tools lidarflow-tools science any "dense scene flow from stereo and sparse LiDAR - tools"
  "This package holds the command-line program lidarflow and the LCM bridge\nlidarflow-lcm-bridge.")
_lf_deb_component(python python3-lidarflow python all "dense scene flow from stereo and sparse LiDAR - Python 3"
  "This package holds the Python 3 binding (ctypes and NumPy) and lidarflow_lcm,\nthe LCM messages and log reader/writer in pure Python.")
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "liblidarflow0 (= ${_lf_deb_version})")
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "python3, python3-numpy, liblidarflow0 (= ${_lf_deb_version})")
_lf_deb_component(dask python3-lidarflow-dask python all "dense scene flow from stereo and sparse LiDAR - Dask runs"
  "This package holds lidarflow_dask (python3 -m lidarflow_dask): recorded drives\nand LCM logs in chunks of frames over a Dask cluster, each chunk computed by\nlidarflow sequence or lidarflow-lcm-bridge --replay.")
# Its chunks run the tools of the same build; lidarflow_lcm (python3-lidarflow) reads the logs.
set(CPACK_DEBIAN_DASK_PACKAGE_DEPENDS
    "python3, python3-distributed, python3-lidarflow (= ${_lf_deb_version}), lidarflow-tools (= ${_lf_deb_version})")
# The tools are built from the same tree as the library: the exact version, not just >=.
set(CPACK_DEBIAN_TOOLS_PACKAGE_DEPENDS "liblidarflow0 (= ${_lf_deb_version})")
if(LIDARFLOW_WITH_LCM)
  _lf_deb_component(lcm lidarflow-lcm-types libdevel all "dense scene flow from stereo and sparse LiDAR - LCM types"
    "This package holds the LCM message definitions of the lidarflow channels and\nthe C and C++ code lcm-gen generates from them.")
  set(CPACK_DEBIAN_LCM_PACKAGE_DEPENDS "liblcm-dev")
endif()

set(CPACK_LIDARFLOW_MULTIARCH liblidarflow0=same liblidarflow-dev=same lidarflow-tools=foreign)
set(CPACK_POST_BUILD_SCRIPTS ${PROJECT_SOURCE_DIR}/cmake/debian/multiarch.cmake)

include(CPack)
