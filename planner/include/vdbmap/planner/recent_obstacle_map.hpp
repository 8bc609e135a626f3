// A map for flight near the vehicle: another map with the voxels where the recent frames saw a
// surface (recent_frames.hpp) read as occupied. Under drift the global map may hold a wall half a
// metre from where the vehicle now sees it; paths, trajectories and their collision checks read
// through this wrapper so that what is seen now is an obstacle whatever the global map says.
//
// Optionally the other way round too (`seen_free`): a voxel without a recent surface whose centre
// a recent frame saw free (RecentFrames::seesFree) reads free, whatever the global map says
// (within the map's known bounds: the frames were integrated into it). Under drift the global map
// also holds walls where the vehicle now sees space: the wall beside a door, seen from the
// corridor and again, displaced, from the room, narrows or closes the door in the map, and the
// vehicle inside the room finds no way out. Free space seen now reopens it.
//
// Optionally surfaces above and below grow toward the vehicle (`vertical_margin_voxels`): a free
// voxel with one of the base map's obstacles (as read through the seen free space) within that
// many voxels straight above or below reads occupied. The camera sees neither straight up nor
// straight down, so under drift a beam overhead or the floor below may sit closer than the map
// holds, and no look brings it into view. A recent frame's free space does not undo this: a ray
// that passed through the voxel says nothing about what lies just above or below it.
//
// Lines of sight (sightMap) and frontiers read the base map: a recent surface voxel changes what
// the vehicle may fly through, not what the map knows.
#pragma once

#include "vdbmap/planner/map_query.hpp"
#include "vdbmap/planner/recent_frames.hpp"
#include "vdbmap/planner/surface_index.hpp"

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace vdbmap::planner {

class RecentObstacleMap : public MapQuery {
 public:
  /// `base` and `surface` (RecentFrames::surfaceIndex(base.voxelSize()),
  /// unchanged while the wrapper is used) must outlive the wrapper. The index answers a lookup in
  /// a few nanoseconds (paths check many voxels).
  /// With `seen_free` (it must outlive the wrapper too), the voxels it saw free read free (above);
  /// each voxel's answer is computed once per wrapper, when first read.
  /// `vertical_margin_voxels` in [0, 100]: how far the base map's obstacles grow up and down (above).
  RecentObstacleMap(const MapQuery& base, const SurfaceIndex& surface, const RecentFrames* seen_free = nullptr,
                    int vertical_margin_voxels = 0);
  /// As above, over a set of surface voxels (copied into an index of the wrapper's own).
  RecentObstacleMap(const MapQuery& base, const SurfaceVoxels& surface, const RecentFrames* seen_free = nullptr,
                    int vertical_margin_voxels = 0);
  RecentObstacleMap(const RecentObstacleMap&) = delete;
  RecentObstacleMap& operator=(const RecentObstacleMap&) = delete;

  double voxelSize() const override { return base_->voxelSize(); }
  /// The base map's bounds grown by the surface voxels.
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;
  const MapQuery& sightMap() const override { return base_->sightMap(); }
  /// False with `seen_free`: each of its voxels costs a projection into every recent frame.
  bool boxReadsPay() const override { return !seen_free_ && base_->boxReadsPay(); }

  /// The voxel holds a recent surface.
  bool isRecentSurface(const openvdb::Coord& ijk) const { return surface_.contains(ijk); }
  /// A recent frame saw the voxel's centre free (false without `seen_free`).
  bool isSeenFree(const openvdb::Coord& ijk) const;
  /// The voxels isSeenFree() may be true for (empty without `seen_free`).
  const openvdb::CoordBBox& seenFreeBounds() const { return free_bounds_; }
  /// Some recent surface voxel's centre lies within radius_m of p_W.
  bool nearSurface(const Vec3d& p_W, double radius_m) const;
  /// The distance from p_W to the nearest recent surface voxel's centre, or max_m when none lies
  /// within max_m.
  double surfaceDistance(const Vec3d& p_W, double max_m) const;
  /// The bounding box of the recent surface voxels (empty when there are none).
  const openvdb::CoordBBox& surfaceBounds() const { return surface_.bounds; }
  int verticalMarginVoxels() const { return vertical_margin_; }

 private:
  static constexpr std::size_t kMaxCachedVoxels = std::size_t(1) << 25;  ///< 32 MB of answers

  /// The surface is `owned` when given, else `surface`.
  RecentObstacleMap(const MapQuery& base, std::unique_ptr<const SurfaceIndex> owned, const SurfaceIndex* surface,
                    const RecentFrames* seen_free, int vertical_margin_voxels);

  const MapQuery* base_;
  std::unique_ptr<const SurfaceIndex> owned_surface_;  ///< when made from a set
  SurfaceIndex::View surface_;

  const RecentFrames* seen_free_ = nullptr;
  int vertical_margin_ = 0;
  openvdb::CoordBBox free_bounds_;
  openvdb::Coord free_dim_;
  /// isSeenFree() per voxel of free_bounds_, z fastest: 0 not asked yet, 1 free, 2 not (empty: ask
  /// every time). Readers on several threads fill it; every writer writes the same answer.
  mutable std::unique_ptr<std::atomic<std::uint8_t>[]> free_cache_;
  mutable std::once_flag free_cache_once_;
};

}  // namespace vdbmap::planner
