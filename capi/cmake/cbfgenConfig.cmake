# cbfgen's CMake package, installed by `python -m cbfgen.embed install --prefix <prefix> SYSTEM...`.
#
#   find_package(cbfgen REQUIRED COMPONENTS double_integrator)
#   target_link_libraries(my_controller PRIVATE cbfgen::cpp cbfgen::double_integrator)
#
# Targets: cbfgen::c (the C headers), cbfgen::cpp (the C++17 wrapper, with Eigen 3), and per
# installed system cbfgen::<name> (its shared library) and cbfgen::<name>_static (its static
# library, carrying the core and Rust's standard library: static libraries of one install
# link together; shared ones mix freely whatever built them). A component is a system's name.
cmake_policy(PUSH)  # this file's policies, not the caller's
cmake_policy(VERSION 3.16...3.31)
get_filename_component(_cbfgen_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)

if(NOT TARGET cbfgen::c)
  add_library(cbfgen::c INTERFACE IMPORTED)
  set_target_properties(cbfgen::c PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_cbfgen_prefix}/include")
endif()

if(NOT TARGET cbfgen::cpp)
  find_package(Eigen3 3.3 QUIET NO_MODULE)
  if(TARGET Eigen3::Eigen)
    add_library(cbfgen::cpp INTERFACE IMPORTED)
    set_target_properties(cbfgen::cpp PROPERTIES
      INTERFACE_LINK_LIBRARIES "cbfgen::c;Eigen3::Eigen"
      INTERFACE_COMPILE_FEATURES cxx_std_17)
  endif()
endif()

file(GLOB _cbfgen_system_files "${CMAKE_CURRENT_LIST_DIR}/cbfgen_system_*.cmake")
foreach(_cbfgen_file IN LISTS _cbfgen_system_files)
  include("${_cbfgen_file}")
endforeach()

set(cbfgen_FOUND TRUE)
foreach(_cbfgen_component IN LISTS cbfgen_FIND_COMPONENTS)
  if(_cbfgen_component STREQUAL "cpp")
    set(_cbfgen_target cbfgen::cpp)
    set(_cbfgen_hint "cbfgen::cpp needs Eigen 3 (find_package(Eigen3) failed; Debian: libeigen3-dev)")
  else()
    set(_cbfgen_target cbfgen::${_cbfgen_component})
    set(_cbfgen_hint "no system ${_cbfgen_component} is installed in ${_cbfgen_prefix}: python -m cbfgen.embed install --prefix ${_cbfgen_prefix} ${_cbfgen_component}")
  endif()
  if(TARGET ${_cbfgen_target})
    set(cbfgen_${_cbfgen_component}_FOUND TRUE)
  else()
    set(cbfgen_${_cbfgen_component}_FOUND FALSE)
    if(cbfgen_FIND_REQUIRED_${_cbfgen_component})
      set(cbfgen_FOUND FALSE)
      string(APPEND cbfgen_NOT_FOUND_MESSAGE "${_cbfgen_hint}\n")
    endif()
  endif()
endforeach()
cmake_policy(POP)
