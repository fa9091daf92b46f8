# SPDX-License-Identifier: MIT
# Man pages of the programs, generated at build time from their --help and --version by
# Debian's help2man, gzipped (Debian policy 12.1) and installed with the programs (component
# tools: `cmake --install` and the lidarflow-tools package). Without help2man the build goes
# on without them.
# Sanitizer builds are for tests, not for installing: their programs stay out of the build step.
if(LIDARFLOW_SANITIZE OR LIDARFLOW_SANITIZE_THREAD OR LIDARFLOW_FUZZ)
  return()
endif()
find_program(LIDARFLOW_HELP2MAN help2man)
if(NOT LIDARFLOW_HELP2MAN)
  message(STATUS "help2man not found: no man pages (Debian: apt-get install help2man)")
  return()
endif()

set(_lf_man_dir ${PROJECT_BINARY_DIR}/man)
set(_lf_man_pages)
# _lf_man_page(TARGET NAME "one-line description")
function(_lf_man_page target name description)
  if(NOT TARGET ${target})
    return()
  endif()
  set(page ${_lf_man_dir}/${name}.1)
  # -N: no pointer to a Texinfo manual; --version-string: the footer names the version alone (the
  # bridge's --version adds its ABI); gzip -n: no name or time stamp, so the page is reproducible.
  add_custom_command(OUTPUT ${page}.gz
    COMMAND ${CMAKE_COMMAND} -E make_directory ${_lf_man_dir}
    COMMAND ${LIDARFLOW_HELP2MAN} -N --name=${description} --section=1 --version-string=${PROJECT_VERSION}
            --output=${page} $<TARGET_FILE:${target}>
    COMMAND gzip -9nf ${page}
    DEPENDS ${target}
    COMMENT "help2man: ${name}.1"
    VERBATIM)
  set(_lf_man_pages ${_lf_man_pages} ${page}.gz PARENT_SCOPE)
  install(FILES ${page}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT tools)
endfunction()

_lf_man_page(lidarflow_cli lidarflow "dense scene flow from stereo images and sparse LiDAR")
_lf_man_page(lidarflow_lcm_bridge lidarflow-lcm-bridge "scene flow of LCM stereo and LiDAR streams")
add_custom_target(lidarflow_man_pages ALL DEPENDS ${_lf_man_pages})

# man renders them without warnings, and they say what the --help texts say.
if(LIDARFLOW_BUILD_TESTS AND TARGET lidarflow_cli)
  set(_lf_bridge "")
  if(TARGET lidarflow_lcm_bridge)
    set(_lf_bridge $<TARGET_FILE:lidarflow_lcm_bridge>)
  endif()
  add_test(NAME man_pages COMMAND bash ${PROJECT_SOURCE_DIR}/tests/man_pages.sh ${_lf_man_dir}
                                  $<TARGET_FILE:lidarflow_cli> ${_lf_bridge})
endif()
