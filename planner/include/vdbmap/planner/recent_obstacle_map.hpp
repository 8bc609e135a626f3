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

namespace vdbmap::planner {

class RecentObstacleMap : public MapQuery {
 public:
  /// `base` and `surface` (RecentFrames::surfaceVoxels at base.voxelSize()) must outlive the wrapper.
  RecentObstacleMap(const MapQuery& base, const SurfaceVoxels& surface);

  double voxelSize() const override { return base_->voxelSize(); }
  /// The base map's bounds grown by the surface voxels.
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;
  const MapQuery& sightMap() const override { return base_->sightMap(); }

 private:
  const MapQuery* base_;
  const SurfaceVoxels* surface_;
  openvdb::CoordBBox surface_bounds_;
};

}  // namespace vdbmap::planner
