# meshmark_imported_library(<target> PREFIX <var> HEADER <file> [PATH_SUFFIXES <dir>...]
#                           NAMES <name>...)
# An INTERFACE IMPORTED GLOBAL target for a library whose package ships no usable CMake
# package: found by one of its headers (cache variable <var>_INCLUDE_DIR) and its library
# (<var>_LIBRARY), both required. Defined once; later calls only look the paths up again.
include_guard(GLOBAL)

function(meshmark_imported_library target)
  cmake_parse_arguments(ARG "" "PREFIX;HEADER" "PATH_SUFFIXES;NAMES" ${ARGN})
  find_path(${ARG_PREFIX}_INCLUDE_DIR ${ARG_HEADER} PATH_SUFFIXES ${ARG_PATH_SUFFIXES} REQUIRED)
  find_library(${ARG_PREFIX}_LIBRARY NAMES ${ARG_NAMES} REQUIRED)
  if(NOT TARGET ${target})
    add_library(${target} INTERFACE IMPORTED GLOBAL)
    target_include_directories(${target} SYSTEM INTERFACE ${${ARG_PREFIX}_INCLUDE_DIR})
    target_link_libraries(${target} INTERFACE ${${ARG_PREFIX}_LIBRARY})
  endif()
endfunction()
