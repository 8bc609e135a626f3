// A hash of voxel coordinates, for unordered containers of voxels.
#pragma once

#include <openvdb/Types.h>

#include <cstddef>

namespace vdbmap::planner {

struct CoordHash {
  std::size_t operator()(const openvdb::Coord& c) const noexcept;
};

}  // namespace vdbmap::planner
