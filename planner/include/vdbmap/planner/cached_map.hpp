// A map that reads each 8^3 block of voxel states once and keeps it: for the many queries of one
// planning cycle on a map that does not change meanwhile.
//
// Path searches, tour costs and trajectory checks test the same voxels again and again (an
// RRTConnect search and its simplifier cross the same corridor hundreds of times). Read one by
// one, each test descends the tree and, on the TSDF map, reads up to six neighbours for its
// thin-structure and hit rules. A CachedMap reads a whole block through the base's readBox the
// first time any of its voxels is asked for, and answers from it afterwards: the states are the
// base's, bit for bit (readBox reads what at() reads). Its own readBox copies from the blocks
// too (viewpoint regions and frontier scans share them with the path searches); only the parts
// of a box beyond the cached blocks are read from the base.
//
// Threads: the blocks are shared by every reader of the map (each filled by whichever reader
// first needs it; two readers missing the same block at the same moment both read it, and one
// copy is kept). Readers are per thread, as always. The base must not change while the
// CachedMap is in use: make one per cycle.
#pragma once

#include "vdbmap/planner/map_query.hpp"

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>

namespace vdbmap::planner {

class CachedMap : public MapQuery {
 public:
  /// Blocks are kept for the base's knownBounds() as it is at the first read, when that spans at
  /// most `max_blocks` blocks (8 MB of pointers at the default); outside it, or for larger
  /// bounds, voxels are read from the base one by one. Nothing is read or allocated until then.
  /// `base` must outlive this map.
  explicit CachedMap(const MapQuery& base, std::size_t max_blocks = std::size_t{1} << 20);
  ~CachedMap() override;
  CachedMap(const CachedMap&) = delete;
  CachedMap& operator=(const CachedMap&) = delete;

  double voxelSize() const override { return voxel_size_m_; }
  /// The base's bounds, read once.
  openvdb::CoordBBox knownBounds() const override;
  std::unique_ptr<MapReader> reader() const override;
  /// This map when the base is its own sight map; else a cached map of the base's.
  const MapQuery& sightMap() const override;

  /// Blocks kept so far.
  std::size_t blocksRead() const { return blocks_read_.load(std::memory_order_relaxed); }

 private:
  class Reader;
  struct Block;
  /// Reads the base's bounds and allocates the table of blocks, once.
  void init() const;
  /// The slot of the block holding ijk, or nullptr when ijk is outside the cached blocks.
  std::atomic<const Block*>* slot(const openvdb::Coord& ijk) const;

  const MapQuery* base_;
  double voxel_size_m_;
  std::size_t max_blocks_;
  mutable std::once_flag init_once_;
  mutable openvdb::CoordBBox bounds_;
  mutable openvdb::Coord first_block_;  ///< block coordinates (voxel >> 3) of the table's corner
  mutable openvdb::Coord blocks_dim_;   ///< the table's size in blocks; zero when nothing is cached
  mutable std::unique_ptr<std::atomic<const Block*>[]> table_;
  mutable std::atomic<std::size_t> blocks_read_{0};
  mutable std::once_flag sight_once_;
  mutable std::unique_ptr<const CachedMap> sight_;  ///< null: sightMap() is this map
};

}  // namespace vdbmap::planner
