// What the camera has seen of a world: the voxels its depth returns fell in, placed at the true
// sensor poses. ObservableSurface::coverage measures the map, which drift bends; this measures the
// exploration, whatever the map made of it. A run that saw nearly all of the observable surface
// but mapped a fraction of it where it is failed at mapping (drift the loop closures left), not at
// exploring; one that never saw it failed at exploring (a finish that believed the world done).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/types.hpp"

#include <openvdb/openvdb.h>

#include <memory>

namespace vdbmap::sim {

/// A map of the voxels (of the planner's convention, map_query.hpp) that a depth return fell in.
/// As a MapQuery those voxels read occupied and every other voxel unknown, so that
/// ObservableSurface::coverage(seen) is the fraction of the observable surface the camera saw.
class SeenSurface : public planner::MapQuery {
 public:
  /// Throws std::invalid_argument unless voxel_size_m is finite and > 0.
  explicit SeenSurface(double voxel_size_m);

  /// Marks the voxels of the returns of `depth` (metres, 0 or NaN: none) within max_range_m, taken
  /// by a camera `K` at T_W_S. Only every n-th pixel in each direction is used, n as large as
  /// keeps the returns at most half a voxel apart at max_range_m: each voxel a skipped pixel's
  /// return fell in lies within a voxel of a marked one (ObservableSurface's known radius), at a
  /// sixteenth of the cost for the simulator's camera at 0.1 m. Throws std::invalid_argument when
  /// the image does not match K (checkDepthImageSize) or max_range_m is not finite and > 0.
  void addFrame(const DepthImage& depth, const CameraIntrinsics& K, const Pose3d& T_W_S, double max_range_m);

  double voxelSize() const override { return voxel_size_m_; }
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<planner::MapReader> reader() const override;
  std::size_t seenVoxels() const { return grid_->activeVoxelCount(); }

 private:
  double voxel_size_m_;
  openvdb::BoolGrid::Ptr grid_;
};

}  // namespace vdbmap::sim
