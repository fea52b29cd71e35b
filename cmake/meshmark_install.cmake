# SPDX-License-Identifier: MIT
# Installation and the CMake package: `find_package(meshmark CONFIG REQUIRED)` gives
# meshmark::meshmark (every module) and meshmark::<module> (one module and what it needs).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(MESHMARK_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/meshmark" CACHE STRING
    "Where the meshmark CMake package is installed, relative to the prefix")

# The packages the exported targets name: a static library carries its PRIVATE dependencies
# to the consumer's link line as $<LINK_ONLY:pkg::target>, so the consumer must find them too.
# Each namespace becomes one find_dependency() call; the arguments below are the ones the
# project itself uses, any other namespace is looked up as a package of the same name.
function(meshmark_package_dependencies targets out_var)
  set(namespaces "")
  # Imported targets a module defines itself, without a namespace (e.g. meshmark_lib3mf for a
  # library with no CMake package): re-created in the package with their found paths.
  set(imported "")
  foreach(target IN LISTS targets)
    get_target_property(libraries ${target} INTERFACE_LINK_LIBRARIES)
    if(NOT libraries)
      continue()
    endif()
    # Build-only dependencies (header-only libraries used in sources) are not the consumer's.
    string(REGEX REPLACE "\\$<BUILD_INTERFACE:[^>]*>" "" used "${libraries}")
    string(REGEX MATCHALL "[A-Za-z0-9_]+::" found "${used}")
    list(APPEND namespaces ${found})
    foreach(item IN LISTS libraries)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" item "${item}")
      if(NOT item MATCHES "::" AND TARGET ${item})
        get_target_property(is_imported ${item} IMPORTED)
        if(is_imported)
          list(APPEND imported ${item})
        endif()
      endif()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES namespaces)
  list(REMOVE_DUPLICATES imported)
  list(SORT namespaces)
  set(calls "")
  foreach(namespace IN LISTS namespaces)
    string(REPLACE "::" "" package "${namespace}")
    if(package STREQUAL "meshmark")
      continue()
    elseif(package STREQUAL "Eigen3")
      set(call "find_dependency(Eigen3 3.4 NO_MODULE)")
    elseif(package STREQUAL "OpenMP")
      set(call "find_dependency(OpenMP COMPONENTS CXX)")
    elseif(package STREQUAL "nlohmann_json")
      set(call "find_dependency(nlohmann_json 3.10)")
    elseif(package STREQUAL "meshoptimizer")
      set(call "find_dependency(meshoptimizer CONFIG)")
    else()
      set(call "find_dependency(${package})")
    endif()
    string(APPEND calls "${call}\n")
  endforeach()
  foreach(target IN LISTS imported)
    # SQLiteCpp's package names its target without a namespace: found again, not re-created.
    if(target STREQUAL "SQLiteCpp")
      string(APPEND calls "find_dependency(SQLiteCpp)\n")
      continue()
    endif()
    string(APPEND calls "if(NOT TARGET ${target})\n  add_library(${target} INTERFACE IMPORTED)\n")
    foreach(property INTERFACE_LINK_LIBRARIES INTERFACE_INCLUDE_DIRECTORIES
                     INTERFACE_COMPILE_DEFINITIONS)
      get_target_property(value ${target} ${property})
      if(value)
        string(APPEND calls "  set_property(TARGET ${target} PROPERTY ${property} \"${value}\")\n")
      endif()
    endforeach()
    string(APPEND calls "endif()\n")
  endforeach()
  set(${out_var} "${calls}" PARENT_SCOPE)
endfunction()

# Install the headers, the module libraries, the umbrella target and the package files.
# \p modules: the module names built in this tree (targets meshmark_<module>).
function(meshmark_install modules)
  set(targets meshmark)
  set(built "")
  foreach(module IN LISTS modules)
    if(TARGET meshmark_${module})
      list(APPEND targets meshmark_${module})
      list(APPEND built ${module})
      set_target_properties(meshmark_${module} PROPERTIES EXPORT_NAME ${module})
    endif()
  endforeach()

  install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/meshmark
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
          COMPONENT meshmark_development
          FILES_MATCHING PATTERN "*.h")
  install(TARGETS ${targets}
          EXPORT meshmarkTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT meshmark_development
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT meshmark_development)
  install(EXPORT meshmarkTargets
          NAMESPACE meshmark::
          DESTINATION ${MESHMARK_INSTALL_CMAKEDIR}
          COMPONENT meshmark_development)

  meshmark_package_dependencies("${targets}" MESHMARK_FIND_DEPENDENCIES)
  set(MESHMARK_EXPORTED_MODULES "${built}")
  configure_package_config_file(
    ${PROJECT_SOURCE_DIR}/cmake/meshmarkConfig.cmake.in
    ${PROJECT_BINARY_DIR}/meshmarkConfig.cmake
    INSTALL_DESTINATION ${MESHMARK_INSTALL_CMAKEDIR})
  # 0.x: a minor release may break the API, so only the same major.minor is compatible.
  write_basic_package_version_file(
    ${PROJECT_BINARY_DIR}/meshmarkConfigVersion.cmake
    VERSION ${PROJECT_VERSION}
    COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/meshmarkConfig.cmake
                ${PROJECT_BINARY_DIR}/meshmarkConfigVersion.cmake
                ${PROJECT_SOURCE_DIR}/cmake/FindCHOLMOD.cmake
          DESTINATION ${MESHMARK_INSTALL_CMAKEDIR}
          COMPONENT meshmark_development)

  # The program, when it is built.
  if(TARGET meshmark_cli)
    install(TARGETS meshmark_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT meshmark_runtime)
  endif()
  # The voxel remeshing's OpenVDB plugin, where the loader looks from <prefix>/bin and from the
  # configured prefix (src/attacks/voxel_plugin_loader.cpp); every user of the attacks needs it.
  if(TARGET meshmark_voxel)
    install(TARGETS meshmark_voxel LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/meshmark
            COMPONENT meshmark_runtime)
  endif()
endfunction()
