# Finds every dependency from Debian 12's archive and wraps the ones without imported targets.

# OpenVDB 10.0.1 on Debian ships only a Find module, outside CMake's default module path.
# TBB first, from its own CMake config: OpenVDB's Find module would otherwise define TBB's targets
# itself, and Ceres's config (which loads TBB's config) then fails on the half-defined export set.
find_package(TBB CONFIG REQUIRED)       # TBB::tbb
list(APPEND CMAKE_MODULE_PATH "/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/OpenVDB")
# FindOpenVDB.cmake sets BUILD_SHARED_LIBS ON in the caller's scope (for Boost); keep our own choice.
set(_vdbmap_build_shared_libs ${BUILD_SHARED_LIBS})
find_package(OpenVDB REQUIRED)          # OpenVDB::openvdb (needs Boost iostreams on Debian)
set(BUILD_SHARED_LIBS ${_vdbmap_build_shared_libs})
find_package(Eigen3 3.4 REQUIRED NO_MODULE)  # Eigen3::Eigen
find_package(Threads REQUIRED)
find_package(ZLIB REQUIRED)             # ZLIB::ZLIB, keyframe compression
find_package(PNG REQUIRED)              # PNG::PNG, 16-bit depth images
find_package(nlohmann_json 3 REQUIRED)  # nlohmann_json::nlohmann_json, sensor.json and summaries
find_package(CLI11 REQUIRED)            # CLI11::CLI11, the vdbmap command line

# OMPL 1.5.2 gives variables only: wrap them in an INTERFACE target.
find_package(ompl REQUIRED)
if(NOT TARGET vdbmap_ompl)
  add_library(vdbmap_ompl INTERFACE)
  target_include_directories(vdbmap_ompl SYSTEM INTERFACE ${OMPL_INCLUDE_DIRS})
  target_link_libraries(vdbmap_ompl INTERFACE ${OMPL_LIBRARIES})
endif()

find_package(Ceres REQUIRED)            # Ceres::ceres, the simulator's 4-DOF pose graph (sim/pose_graph.hpp)

if(VDBMAP_BUILD_TESTS)
  find_package(Catch2 2 REQUIRED)       # Catch2::Catch2WithMain
  include(CTest)
  include(Catch)
endif()

find_program(CCACHE_PROGRAM ccache)
if(CCACHE_PROGRAM AND NOT VDBMAP_USE_PCH)
  set(CMAKE_CXX_COMPILER_LAUNCHER ${CCACHE_PROGRAM})
endif()

# The light precompiled header: our OpenVDB header with extern templates, Eigen and TBB.
# Never add openvdb/tools/*.h here: it slows every translation unit down.
function(vdbmap_use_pch target)
  if(VDBMAP_USE_PCH)
    target_precompile_headers(${target} PRIVATE
      "$<$<COMPILE_LANGUAGE:CXX>:${PROJECT_SOURCE_DIR}/vdbmap/include/vdbmap/openvdb.hpp>"
      <Eigen/Core> <Eigen/Geometry> <tbb/parallel_for.h> <vector> <string> <cstdint>)
  endif()
endfunction()
