# `cmake --install`: headers, libraries, the CLI and a CMake package, so that another project does
#
#   find_package(vdbmap 0.1 REQUIRED)            # optionally COMPONENTS io testing planner sim
#   target_link_libraries(app PRIVATE vdbmap::vdbmap)   # and vdbmap::io, vdbmap::testing,
#                                                       # vdbmap::planner, vdbmap::sim
#
# The libraries are shared by default (BUILD_SHARED_LIBS); when static, their private dependencies
# (libpng, libdeflate, zlib, nlohmann_json, OMPL, Ceres) become part of the link interface, so
# vdbmapConfig.cmake finds those again in the user's project either way. Each library has its own
# export set, so a component whose dependencies are missing on the user's machine does not stop
# the others from loading. Installed binaries find the libraries by a relative RPATH, so the prefix
# can move. The Python module installs from bindings/python/CMakeLists.txt.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(VDBMAP_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/vdbmap" CACHE STRING
    "Where `cmake --install` puts vdbmapConfig.cmake, relative to the prefix")

# vdbmap_install_library(<target> <export name> <export set> [<extra target>...]): the library (and
# helper INTERFACE targets in its link interface) into its own export set, as vdbmap::<export name>.
function(vdbmap_install_library target export_name export_set)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
  install(TARGETS ${target} ${ARGN} EXPORT ${export_set}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT devel
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
  install(EXPORT ${export_set} NAMESPACE vdbmap:: DESTINATION ${VDBMAP_INSTALL_CMAKEDIR} COMPONENT devel)
endfunction()

# Headers: every module's include/ tree, merged (all live under include/vdbmap/).
foreach(module vdbmap vdbmap/io testing planner sim)
  if(IS_DIRECTORY ${PROJECT_SOURCE_DIR}/${module}/include)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/${module}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
            COMPONENT devel FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
  endif()
endforeach()

# libdeflate through an INTERFACE wrapper, exported with the core (the io library links it too).
set_target_properties(vdbmap_libdeflate PROPERTIES EXPORT_NAME libdeflate)
vdbmap_install_library(vdbmap vdbmap vdbmapTargets vdbmap_libdeflate)
vdbmap_install_library(vdbmap_io io vdbmapIoTargets)
vdbmap_install_library(vdbmap_testing testing vdbmapTestingTargets)
set(VDBMAP_EXPORTED_COMPONENTS io testing)
set(VDBMAP_SIM_USES_CERES OFF)
set(VDBMAP_SIM_USES_PLANNER OFF)
if(TARGET vdbmap_planner)
  # The planner links OMPL privately through this INTERFACE wrapper, which a static planner needs
  # at the user's link too, so it is exported with OMPL's absolute paths as found here.
  set_target_properties(vdbmap_ompl PROPERTIES EXPORT_NAME ompl)
  vdbmap_install_library(vdbmap_planner planner vdbmapPlannerTargets vdbmap_ompl)
  list(APPEND VDBMAP_EXPORTED_COMPONENTS planner)
endif()
if(TARGET vdbmap_sim)
  vdbmap_install_library(vdbmap_sim sim vdbmapSimTargets)
  list(APPEND VDBMAP_EXPORTED_COMPONENTS sim)
  if(Ceres_FOUND)
    set(VDBMAP_SIM_USES_CERES ON)
  endif()
  if(TARGET vdbmap_planner)
    set(VDBMAP_SIM_USES_PLANNER ON)
  endif()
endif()

file(RELATIVE_PATH _vdbmap_lib_from_bin /${CMAKE_INSTALL_BINDIR} /${CMAKE_INSTALL_LIBDIR})
set_target_properties(vdbmap_cli PROPERTIES INSTALL_RPATH "$ORIGIN/${_vdbmap_lib_from_bin}")
foreach(library vdbmap vdbmap_io vdbmap_testing vdbmap_planner vdbmap_sim)
  if(TARGET ${library})
    set_target_properties(${library} PROPERTIES INSTALL_RPATH "$ORIGIN")
  endif()
endforeach()
install(TARGETS vdbmap_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT cli)
# The embedded default world, where the installed CLI looks for it (tools/world_option.cpp).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/worlds DESTINATION ${CMAKE_INSTALL_DATADIR}/vdbmap COMPONENT cli)

# Where Debian's FindOpenVDB.cmake is (it ships no CMake config), for the user's project.
find_file(VDBMAP_FIND_OPENVDB_MODULE FindOpenVDB.cmake PATHS ${CMAKE_MODULE_PATH} NO_DEFAULT_PATH)
get_filename_component(VDBMAP_OPENVDB_MODULE_DIR "${VDBMAP_FIND_OPENVDB_MODULE}" DIRECTORY)

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/vdbmapConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/cmake/vdbmapConfig.cmake
                              INSTALL_DESTINATION ${VDBMAP_INSTALL_CMAKEDIR})
# 0.x: a minor release may break the API, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cmake/vdbmapConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/cmake/vdbmapConfig.cmake ${PROJECT_BINARY_DIR}/cmake/vdbmapConfigVersion.cmake
        DESTINATION ${VDBMAP_INSTALL_CMAKEDIR} COMPONENT devel)
