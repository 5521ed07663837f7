# Records the version and the git commit in a generated header, refreshed at every build.
set(MESOROCK_VERSION_IN ${CMAKE_CURRENT_LIST_DIR}/version.h.in)
set(MESOROCK_VERSION_OUT ${CMAKE_BINARY_DIR}/generated/mesorock/version.h)
add_custom_target(mesorock_version_header ALL
  COMMAND ${CMAKE_COMMAND} -DIN=${MESOROCK_VERSION_IN} -DOUT=${MESOROCK_VERSION_OUT}
          -DSRC=${CMAKE_SOURCE_DIR} -DVERSION=${PROJECT_VERSION}
          -P ${CMAKE_CURRENT_LIST_DIR}/WriteVersion.cmake
  BYPRODUCTS ${MESOROCK_VERSION_OUT}
  COMMENT "mesorock version header")
