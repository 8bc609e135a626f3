// A set of voxels as one bit per voxel of a dense box, kept up to date one voxel at a time, with
// the set's exact bounding box.
//
// The safety layer's flight map (recent_obstacle_map.hpp) asks whether a voxel holds a recent
// surface for every voxel its checks read, so the answer must cost a few nanoseconds; and the set
// changes by a few hundred voxels a frame out of some 60,000. RecentFrames keeps this index as it
// counts its frames, so that the map is made without copying the set every frame.
//
// The box grows (with a margin) to hold the voxels inserted; it is fitted to the set again when
// it would exceed kMaxVoxels, and beyond that the voxels outside it are kept in a hash set.
#pragma once

#include "vdbmap/planner/coord_hash.hpp"
#include "vdbmap/planner/map_query.hpp"  // boxIndex

#include <openvdb/Types.h>

#include <cstddef>
#include <cstdint>
#include <unordered_set>
#include <vector>

namespace vdbmap::planner {

class SurfaceIndex {
 public:
  /// Adds ijk (no effect when it is in the set).
  void insert(const openvdb::Coord& ijk);
  /// Removes ijk (no effect when it is not in the set).
  void erase(const openvdb::Coord& ijk);
  void clear();

  bool contains(const openvdb::Coord& ijk) const { return view().contains(ijk); }

  /// The index's state as plain values, for readers that look up many voxels (the flight map
  /// keeps one, so that a lookup reads no more than the bits): valid until the next change.
  struct View {
    openvdb::CoordBBox bounds, box;
    openvdb::Coord dim;
    const std::uint64_t* bits = nullptr;
    const std::unordered_set<openvdb::Coord, CoordHash>* outside = nullptr;

    bool contains(const openvdb::Coord& ijk) const {
      if (!bounds.isInside(ijk)) return false;
      if (!box.isInside(ijk)) return outside->count(ijk) > 0;
      const std::size_t i = boxIndex(box.min(), dim, ijk);
      return (bits[i / 64] >> (i % 64)) & 1u;
    }
  };
  View view() const { return {bounds_, box_, dim_, bits_.data(), &outside_}; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// The bounding box of the set's voxels (empty when the set is).
  const openvdb::CoordBBox& bounds() const { return bounds_; }

  /// Largest box held as bits (16 MB).
  static constexpr std::size_t kMaxVoxels = std::size_t(1) << 27;

 private:
  /// Makes the bit box hold ijk (grown by a margin), or refits it to the set and ijk when that
  /// would be too large; false when ijk stays outside it.
  bool reserve(const openvdb::Coord& ijk);
  /// Moves the set into the bit box `box` (those of its voxels beyond it into outside_).
  void rebox(const openvdb::CoordBBox& box);
  void setBit(const openvdb::Coord& ijk, bool on);
  /// Counts ijk in (change 1) or out of (-1) each axis's histogram and keeps bounds_ exact.
  void count(const openvdb::Coord& ijk, int change);

  openvdb::CoordBBox box_;  ///< the voxels held as bits
  openvdb::Coord dim_;
  std::vector<std::uint64_t> bits_;
  std::unordered_set<openvdb::Coord, CoordHash> outside_;  ///< voxels of the set beyond box_
  std::size_t size_ = 0;
  /// Per axis, how many of the set's voxels have each coordinate (from histogram_min_); the
  /// bounds are the first and last non-zero entries.
  openvdb::Coord histogram_min_;
  std::vector<std::int32_t> histogram_[3];
  openvdb::CoordBBox bounds_;
};

}  // namespace vdbmap::planner
