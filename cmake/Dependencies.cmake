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
find_package(ZLIB REQUIRED)             # ZLIB::ZLIB, for OpenVDB and libpng
find_package(PNG REQUIRED)              # PNG::PNG, 16-bit depth images
# libdeflate (keyframe payloads, plain depth PNGs) 1.14 ships a pkg-config file only: wrapped in an
# INTERFACE target, exported with the core library (static libraries need it at the user's link).
find_path(VDBMAP_LIBDEFLATE_INCLUDE_DIR libdeflate.h REQUIRED)
find_library(VDBMAP_LIBDEFLATE_LIBRARY deflate REQUIRED)
if(NOT TARGET vdbmap_libdeflate)
  add_library(vdbmap_libdeflate INTERFACE)
  target_include_directories(vdbmap_libdeflate SYSTEM INTERFACE ${VDBMAP_LIBDEFLATE_INCLUDE_DIR})
  target_link_libraries(vdbmap_libdeflate INTERFACE ${VDBMAP_LIBDEFLATE_LIBRARY})
endif()
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

# ROS1 bags without ROS (io/ros_bag.hpp): Debian's rosbag_storage and message headers. Their
# CMake configs are catkin's and their pkg-config files name a missing package, so the headers
# and libraries are found one by one and wrapped in an INTERFACE target. Without them the io
# library is built without bag support and says so when asked to read a bag.
set(_vdbmap_ros_paths rosbag/bag.h pluginlib/class_loader.hpp class_loader/class_loader.hpp
    rcutils/logging_macros.h rcpputils/shared_library.hpp ament_index_cpp/get_package_prefix.hpp
    sensor_msgs/Image.h nav_msgs/Path.h geometry_msgs/TransformStamped.h)
set(VDBMAP_HAS_ROSBAG ON)
set(_vdbmap_ros_includes "")
foreach(_header IN LISTS _vdbmap_ros_paths)
  string(MAKE_C_IDENTIFIER "VDBMAP_ROS_${_header}" _var)
  get_filename_component(_dir "${_header}" DIRECTORY)
  find_path(${_var} ${_header} PATH_SUFFIXES ${_dir})  # pluginlib/pluginlib/..., class_loader/class_loader/...
  if(${_var})
    list(APPEND _vdbmap_ros_includes ${${_var}})
  else()
    set(VDBMAP_HAS_ROSBAG OFF)
  endif()
endforeach()
set(_vdbmap_ros_libraries "")
foreach(_lib rosbag_storage roscpp_serialization rostime cpp_common console_bridge roslz4)
  find_library(VDBMAP_ROS_LIB_${_lib} ${_lib})
  if(VDBMAP_ROS_LIB_${_lib})
    list(APPEND _vdbmap_ros_libraries ${VDBMAP_ROS_LIB_${_lib}})
  else()
    set(VDBMAP_HAS_ROSBAG OFF)
  endif()
endforeach()
if(VDBMAP_HAS_ROSBAG AND NOT TARGET vdbmap_rosbag_deps)
  list(REMOVE_DUPLICATES _vdbmap_ros_includes)
  add_library(vdbmap_rosbag_deps INTERFACE)
  target_include_directories(vdbmap_rosbag_deps SYSTEM INTERFACE ${_vdbmap_ros_includes})
  target_link_libraries(vdbmap_rosbag_deps INTERFACE ${_vdbmap_ros_libraries})
endif()
message(STATUS "vdbmap: ROS bag support ${VDBMAP_HAS_ROSBAG}")

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
