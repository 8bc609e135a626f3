// A synthetic map set by hand: a dense box of voxel states, unknown everywhere else. For tests
// and benchmarks of the planner without integrating depth frames.
#pragma once

#include "vdbmap/planner/map_query.hpp"

#include <Eigen/Geometry>

#include <vector>

namespace vdbmap::planner {

class DenseMap : public MapQuery {
 public:
  /// A map over the index-space box `extent` (voxels outside it are always unknown), every voxel
  /// unknown at first. Throws std::invalid_argument for a non-positive voxel size or an empty box.
  DenseMap(double voxel_size_m, const openvdb::CoordBBox& extent);

  double voxelSize() const override { return voxel_size_m_; }
  /// The box around every voxel ever set to free or occupied.
  openvdb::CoordBBox knownBounds() const override { return known_; }
  std::unique_ptr<MapReader> reader() const override;

  const openvdb::CoordBBox& extent() const { return extent_; }
  Occupancy get(const openvdb::Coord& ijk) const;
  /// Sets one voxel; throws std::out_of_range outside the extent.
  void set(const openvdb::Coord& ijk, Occupancy state);
  /// Sets every voxel of `box` (clipped to the extent).
  void fill(const openvdb::CoordBBox& box, Occupancy state);
  /// Sets every voxel whose centre lies in the world box (clipped to the extent).
  void fillWorld(const Eigen::AlignedBox3d& box_W, Occupancy state);

 private:
  std::size_t index(const openvdb::Coord& ijk) const;

  double voxel_size_m_;
  openvdb::CoordBBox extent_;
  openvdb::CoordBBox known_;
  std::vector<Occupancy> cells_;
};

}  // namespace vdbmap::planner
