# cpack-options.cmake -- read by cpack when it runs (CPACK_PROJECT_CONFIG_FILE): adds the shared
# libraries' packages that packaging/shlibdeps.sh found ($INDUROP_DEB_SHLIBDEPS, set by deb.sh) to
# the .deb's Depends.
if(DEFINED ENV{INDUROP_DEB_SHLIBDEPS} AND NOT "$ENV{INDUROP_DEB_SHLIBDEPS}" STREQUAL "")
  set(CPACK_DEBIAN_PACKAGE_DEPENDS "$ENV{INDUROP_DEB_SHLIBDEPS}, ${CPACK_DEBIAN_PACKAGE_DEPENDS}")
endif()
