// The planner's view of the TSDF map: voxel states read straight from TsdfVolume's exact
// fixed-point grids through OpenVDB accessors, with the map's own known/free/occupied rule
// (docs/conventions.md): known when W > tau_w, occupied when known and tsdf below the occupancy
// threshold, else free.
//
// Lifetime and threads: the adapter refers to the volume; it must not outlive it, and the volume
// must not change while planner threads read it (run the planner between integration cycles).
// Readers hold the grids they were created on, so a reader outlives a map that is replaced.
#pragma once

#include "vdbmap/planner/map_query.hpp"

namespace vdbmap {
class TsdfVolume;
}

namespace vdbmap::planner {

class TsdfMapQuery : public MapQuery {
 public:
  explicit TsdfMapQuery(const TsdfVolume& volume);

  double voxelSize() const override;
  /// The box around every voxel with any weight (a superset of the known voxels).
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;

 private:
  const TsdfVolume* volume_;
};

}  // namespace vdbmap::planner
