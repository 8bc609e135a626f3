// The umbrella header of the mapping engine: every public header of the vdbmap library.
//
//   #include <vdbmap/vdbmap.hpp>   // after find_package(vdbmap) and linking vdbmap::vdbmap
//
// It pulls in OpenVDB's core (through vdbmap/openvdb.hpp) but none of OpenVDB's tools, so it costs
// about as much to compile as one of its headers. Translation units that need only one concept
// compile faster with that header alone (e.g. vdbmap/tsdf_volume.hpp). The file formats and frame
// sources (library vdbmap::io) have their umbrella vdbmap/io/io.hpp; the planner and the simulator
// have their own headers under vdbmap/planner/ and vdbmap/sim/.
#pragma once

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/eval.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/sensor_frame.hpp"
#include "vdbmap/set_cover.hpp"
#include "vdbmap/triangle_mesh.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/types.hpp"
#include "vdbmap/version.hpp"
