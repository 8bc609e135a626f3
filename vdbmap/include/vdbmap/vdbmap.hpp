// The umbrella header of the mapping engine: every public header of the vdbmap library.
//
//   #include <vdbmap/vdbmap.hpp>   // after find_package(vdbmap) and linking vdbmap::vdbmap
//
// It pulls in OpenVDB's core (through vdbmap/openvdb.hpp) but none of OpenVDB's tools, so it costs
// about as much to compile as one of its headers. Translation units that need only one concept
// compile faster with that header alone (e.g. vdbmap/tsdf_volume.hpp). The planner and the
// simulator have their own headers under vdbmap/planner/ and vdbmap/sim/.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/eval.hpp"
#include "vdbmap/io/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/log_replay.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/set_cover.hpp"
#include "vdbmap/triangle_mesh.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/types.hpp"
#include "vdbmap/version.hpp"
