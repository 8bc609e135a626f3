// The umbrella header of vdbmap's file layer (library vdbmap::io): our log format, dataset
// importers, frame sources and replay, PNG depth, PLY/PCD/OBJ/OFF, TUM trajectories.
//
//   #include <vdbmap/io/io.hpp>   // after find_package(vdbmap) and linking vdbmap::io
#pragma once

#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"
#include "vdbmap/io/pose_interpolation.hpp"
#include "vdbmap/io/ros_bag.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
