// A map with boxes where unknown space is read as free: how the vehicle gets going.
//
// At take-off the vehicle sits in space its camera has never seen (behind it, below it, closer
// than the minimum range), so every clearance check around it fails and it could neither turn on
// the spot nor move. FUEL marks a box around the start position as free; this does the same
// without touching the map: inside the boxes an *unknown* voxel reads as free (occupied stays
// occupied). Wrap the map once and hand the wrapper to every planner piece (frontiers,
// viewpoints, paths, trajectories), so unknown space is treated the same way everywhere.
#pragma once

#include "vdbmap/planner/map_query.hpp"

#include <Eigen/Geometry>

#include <memory>
#include <vector>

namespace vdbmap::planner {

class AssumeFreeMap : public MapQuery {
 public:
  /// `base` must outlive this wrapper. A voxel is inside a box when its centre is. With
  /// `occupied_too`, occupied voxels inside the boxes read free as well: only for a manoeuvre that
  /// was checked otherwise (the exploration manager's escape from a blocked start).
  AssumeFreeMap(const MapQuery& base, std::vector<Eigen::AlignedBox3d> free_boxes_W, bool occupied_too = false);

  double voxelSize() const override { return base_->voxelSize(); }
  /// The base map's bounds grown by the boxes.
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;
  /// The same boxes over the base's sightMap() (this map when the base is its own).
  const MapQuery& sightMap() const override;
  /// As the base's: a box read here is the base's box read.
  bool boxReadsPay() const override { return base_->boxReadsPay(); }

  const std::vector<openvdb::CoordBBox>& freeBoxes() const { return boxes_; }

 private:
  const MapQuery* base_;
  std::vector<openvdb::CoordBBox> boxes_;  ///< index-space boxes of the voxels assumed free
  bool occupied_too_ = false;
  std::shared_ptr<const AssumeFreeMap> sight_;  ///< null: sightMap() is this map
};

/// A box of half-extents `half_size_m` centred at `centre_W`: the usual start box.
Eigen::AlignedBox3d boxAround(const Vec3d& centre_W, const Vec3d& half_size_m);

}  // namespace vdbmap::planner
