# cbfgen @CBFGEN_VERSION@: compatible with a request of the same major version, no newer than it
# (before 1.0, of the same minor version too).
set(PACKAGE_VERSION "@CBFGEN_VERSION@")
set(PACKAGE_VERSION_COMPATIBLE FALSE)
if(PACKAGE_FIND_VERSION)
  string(REPLACE "." ";" _cbfgen_have "${PACKAGE_VERSION}")
  list(GET _cbfgen_have 0 _cbfgen_major)
  list(GET _cbfgen_have 1 _cbfgen_minor)
  if(NOT PACKAGE_FIND_VERSION VERSION_GREATER PACKAGE_VERSION
     AND PACKAGE_FIND_VERSION_MAJOR EQUAL _cbfgen_major
     AND (_cbfgen_major GREATER 0 OR PACKAGE_FIND_VERSION_MINOR EQUAL _cbfgen_minor))
    set(PACKAGE_VERSION_COMPATIBLE TRUE)
  endif()
  if(PACKAGE_FIND_VERSION VERSION_EQUAL PACKAGE_VERSION)
    set(PACKAGE_VERSION_EXACT TRUE)
  endif()
else()
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
endif()
