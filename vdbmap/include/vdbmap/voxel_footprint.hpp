// The voxels one integration of a frame updates: what the set cover counts as the frame's view,
// recorded by the integration pass itself so that no frame is projected twice.
#pragma once

#include "vdbmap/openvdb.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace vdbmap {

/// The updated voxels of one leaf (8^3, origin its voxel (0, 0, 0)): bit n of the 512 is the voxel
/// at offset n = 64 i + 8 j + k, as in OpenVDB's leaf nodes.
struct LeafFootprint {
  openvdb::Coord origin;
  std::array<std::uint64_t, 8> voxels{};
  bool empty() const {
    for (const std::uint64_t w : voxels)
      if (w) return false;
    return true;
  }
};

/// A frame's footprint: its non-empty leaves, each once, in no particular order.
using VoxelFootprint = std::vector<LeafFootprint>;

}  // namespace vdbmap
