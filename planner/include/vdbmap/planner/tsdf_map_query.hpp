// The planner's view of the TSDF map: voxel states read straight from TsdfVolume's exact
// fixed-point grids through OpenVDB accessors, with the map's own known/free/occupied rule
// (docs/conventions.md): known when W > tau_w, occupied when known and tsdf below the occupancy
// threshold, else free.
//
// Thin structure (TsdfMapQueryConfig::thin_obstacles, on by default): a post or a board edge
// narrower than a voxel is often missing from those states. Rays passing beside it carve its
// voxel, whose mean tsdf stays positive (a 4 cm shelf post in 0.1 m voxels reads 0.09-0.17 m,
// free), and the vehicle flies into it. What is left of it is a valley of the tsdf: a known voxel
// whose tsdf is small and lower, by a margin, than both of its neighbours along some axis. Near a
// wall the tsdf falls toward the wall and is flat along it, so walls make no valleys. With the
// option on, such voxels read occupied: the planner keeps its clearance from them. The map's own
// states (TsdfVolume::sample) are unchanged.
//
// A post seen only from the side, with rays passing close beside it, may not even leave a valley
// (a 2.5 cm warehouse upright read 0.14-0.16 m, as high as its neighbours). Its depth end points
// still land in its voxel: TsdfVolume counts them (VoxelSample::hits). With `hit_obstacles` on (the
// default), a free voxel holding at least `min_hits` of them reads occupied when its six face
// neighbours are all known and free, as around a post in mapped space. A voxel beside an occupied
// one is a surface the map already has (the voxel in front of a wall holds that wall's end points),
// and reading it occupied would only thicken the wall; a voxel beside unknown space is a surface
// being discovered, and reading it occupied would hide the frontier there.
//
// Lifetime and threads: the adapter refers to the volume; it must not outlive it, and the volume
// must not change while planner threads read it (run the planner between integration cycles).
// Readers hold the grids they were created on, so a reader outlives a map that is replaced.
#pragma once

#include "vdbmap/planner/map_query.hpp"

#include <memory>

namespace vdbmap {
class TsdfVolume;
}

namespace vdbmap::planner {

struct TsdfMapQueryConfig {
  /// Read tsdf valleys (thin structure) as occupied.
  bool thin_obstacles = true;
  /// A valley's tsdf is below this many voxels; (0, 100]
  double thin_below_vox = 1.5;
  /// Both neighbours along the valley's axis are known and at least this many voxels higher; (0, 100]
  double thin_margin_vox = 0.5;
  /// Read free voxels holding surface end points, with only free face neighbours, as occupied.
  bool hit_obstacles = true;
  /// End points a voxel needs for that; [1, 1e9]
  std::int64_t min_hits = 2;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};
using TsdfMapQueryParams [[deprecated("renamed TsdfMapQueryConfig")]] = TsdfMapQueryConfig;

class TsdfMapQuery : public MapQuery {
 public:
  explicit TsdfMapQuery(const TsdfVolume& volume, const TsdfMapQueryConfig& params = {});

  double voxelSize() const override;
  /// The box around every voxel with any weight (a superset of the known voxels).
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;
  /// Without the thin-structure rules (the map's own states) when either is on, else this map.
  const MapQuery& sightMap() const override;

 private:
  const TsdfVolume* volume_;
  TsdfMapQueryConfig params_;
  std::shared_ptr<const TsdfMapQuery> sight_;  ///< null: sightMap() is this map
};

}  // namespace vdbmap::planner
