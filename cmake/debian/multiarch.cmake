# SPDX-License-Identifier: MIT
# CPack post-build script (CPACK_POST_BUILD_SCRIPTS, cmake/packaging.cmake): writes the
# Multi-Arch field into the control file of each package CPACK_LIDARFLOW_MULTIARCH names
# ("PACKAGE=VALUE;..."), as CPack 3.25's DEB generator has no variable for it. Such a .deb is
# unpacked with dpkg-deb -R and built again under its own name with dpkg-deb -b: its files, their
# modes and time stamps, and the other control files (md5sums, shlibs, symbols, triggers,
# maintainer scripts) stay as CPack wrote them, owned by root as CPack's are. With
# SOURCE_DATE_EPOCH set, dpkg-deb takes it for the archive's time stamps, as CPack does.
find_program(_lf_dpkg_deb dpkg-deb)
if(NOT _lf_dpkg_deb)
  message(FATAL_ERROR "multiarch.cmake: dpkg-deb is needed to write the Multi-Arch fields")
endif()
# CPack's compression (its default gzip), if dpkg-deb builds it; otherwise dpkg-deb's default.
set(_lf_compression gzip)
if(CPACK_DEBIAN_COMPRESSION_TYPE)
  set(_lf_compression ${CPACK_DEBIAN_COMPRESSION_TYPE})
endif()
set(_lf_z)
if(_lf_compression MATCHES "^(gzip|xz|zstd|none)$")
  set(_lf_z -Z${_lf_compression})
endif()

foreach(deb IN LISTS CPACK_PACKAGE_FILES)
  if(NOT deb MATCHES "\\.deb$")
    continue()
  endif()
  execute_process(COMMAND ${_lf_dpkg_deb} -f ${deb} Package OUTPUT_VARIABLE package
                  OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "multiarch.cmake: dpkg-deb cannot read ${deb}")
  endif()
  set(value)
  foreach(entry IN LISTS CPACK_LIDARFLOW_MULTIARCH)
    if(entry MATCHES "^${package}=(.+)$")
      set(value ${CMAKE_MATCH_1})
    endif()
  endforeach()
  if(NOT value)
    continue()
  endif()
  set(root ${deb}.multiarch)
  file(REMOVE_RECURSE ${root})
  execute_process(COMMAND ${_lf_dpkg_deb} -R ${deb} ${root} RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "multiarch.cmake: dpkg-deb -R ${deb}: ${err}")
  endif()
  file(READ ${root}/DEBIAN/control control)
  if(control MATCHES "\nMulti-Arch:")
    message(FATAL_ERROR "multiarch.cmake: ${package} has a Multi-Arch field already")
  endif()
  # After Architecture, where dpkg-gencontrol puts it.
  string(REGEX REPLACE "(\nArchitecture: [^\n]*\n)" "\\1Multi-Arch: ${value}\n" control "\n${control}")
  string(SUBSTRING "${control}" 1 -1 control)
  if(NOT control MATCHES "\nMulti-Arch: ${value}\n")
    message(FATAL_ERROR "multiarch.cmake: ${package}'s control file has no Architecture field")
  endif()
  file(WRITE ${root}/DEBIAN/control "${control}")
  execute_process(COMMAND ${_lf_dpkg_deb} --root-owner-group ${_lf_z} -b ${root} ${deb}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  file(REMOVE_RECURSE ${root})
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "multiarch.cmake: dpkg-deb -b ${deb}: ${out}${err}")
  endif()
  message(STATUS "${package}: Multi-Arch: ${value}")
endforeach()
