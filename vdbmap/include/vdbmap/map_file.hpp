// Reading a saved map's float grids and metadata without rebuilding a TsdfVolume (for tools that
// only look: mesh, info, eval).
#pragma once

#include "vdbmap/openvdb.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace vdbmap {

/// The "tsdf" grid of a map file. Throws std::runtime_error naming the file when it is missing,
/// unreadable or has no float grid "tsdf".
openvdb::FloatGrid::Ptr readTsdfGrid(const std::filesystem::path& path);

struct MapFileGrid {
  std::string name, type, grid_class;
  std::size_t active_voxels = 0;
  std::size_t leaf_nodes = 0;
  std::size_t memory_bytes = 0;
  double voxel_size_m = 0.0;
  openvdb::CoordBBox bbox_index;           ///< active voxels, index space
  openvdb::Vec3d bbox_min_m, bbox_max_m;   ///< the same box in metres (voxel centres)
};

struct MapFileInfo {
  std::filesystem::path path;
  std::size_t file_bytes = 0;
  std::vector<MapFileGrid> grids;
  std::vector<std::pair<std::string, std::string>> metadata;  ///< file metadata, as text
  bool has_exact_state = false;     ///< the .exact.vdb companion exists and belongs to this map
  std::string exact_state_problem;  ///< why a companion that exists is not usable ("" when it is)
  std::int64_t weight_scale = 0;    ///< the exact state's units per ray weight (0 without a usable companion)
  std::string unit_id;              ///< the save's unit id ("" for maps of format 3 and older)
};

/// Lists a .vdb file's grids (fully read, so counts are exact) and metadata.
MapFileInfo inspectMapFile(const std::filesystem::path& path);

}  // namespace vdbmap
