// A map for flight near the vehicle: another map with the voxels where the recent frames saw a
// surface (recent_frames.hpp) read as occupied. Under drift the global map may hold a wall half a
// metre from where the vehicle now sees it; paths, trajectories and their collision checks read
// through this wrapper so that what is seen now is an obstacle whatever the global map says.
//
// Lines of sight (sightMap) and frontiers read the base map: a recent surface voxel changes what
// the vehicle may fly through, not what the map knows.
#pragma once

#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/recent_frames.hpp"

#include <cstdint>
#include <vector>

namespace vdbmap::planner {

class RecentObstacleMap : public MapQuery {
 public:
  /// `base` and `surface` (RecentFrames::surfaceVoxels at base.voxelSize()) must outlive the
  /// wrapper. The surface is copied into a bit per voxel of its bounding box, so that a lookup
  /// costs a few nanoseconds (paths check many voxels), unless that box holds more than
  /// kMaxDenseVoxels (then the set is looked up).
  RecentObstacleMap(const MapQuery& base, const SurfaceVoxels& surface);

  double voxelSize() const override { return base_->voxelSize(); }
  /// The base map's bounds grown by the surface voxels.
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;
  const MapQuery& sightMap() const override { return base_->sightMap(); }

  /// The voxel holds a recent surface.
  bool isRecentSurface(const openvdb::Coord& ijk) const {
    if (!bounds_.isInside(ijk)) return false;
    if (bits_.empty()) return surface_->count(ijk) > 0;
    const std::size_t i = boxIndex(bounds_.min(), dim_, ijk);
    return (bits_[i / 64] >> (i % 64)) & 1u;
  }
  /// Some recent surface voxel's centre lies within radius_m of p_W.
  bool nearSurface(const Vec3d& p_W, double radius_m) const;
  /// The bounding box of the recent surface voxels (empty when there are none).
  const openvdb::CoordBBox& surfaceBounds() const { return bounds_; }

 private:
  static constexpr std::size_t kMaxDenseVoxels = std::size_t(1) << 27;  ///< 16 MB of bits

  const MapQuery* base_;
  const SurfaceVoxels* surface_;
  openvdb::CoordBBox bounds_;
  openvdb::Coord dim_;
  std::vector<std::uint64_t> bits_;  ///< one per voxel of bounds_, z fastest (empty: look up surface_)
};

}  // namespace vdbmap::planner
