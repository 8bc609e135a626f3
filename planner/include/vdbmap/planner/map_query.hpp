// The small query interface through which the planner reads a map.
//
// A map answers three things: the state of a voxel (unknown, free, occupied), its voxel size, and
// an index-space box that holds every known voxel. Everything else the planner needs (clearance
// around a point, clear segments, ray visibility) is built on those answers by MapProbe, so the
// planner runs unchanged on the TSDF map (tsdf_map_query.hpp), on synthetic maps set by hand
// (dense_map.hpp), and on either with boxes assumed free (assume_free_map.hpp).
//
// Unknown space is an obstacle everywhere in the planner: clearance, segment and ray checks all
// ask for *known-free* voxels, and frontiers are free voxels next to unknown ones.
//
// Voxels follow OpenVDB's convention (docs/conventions.md): voxel (i, j, k) is centred at
// (i, j, k) * voxel_size_m and a world point p lies in voxel floor(p / voxel_size_m + 0.5).
//
// Threads: a MapQuery is shared and const; every thread reads it through its own MapReader (or
// MapProbe), which caches tree accessors and is cheap to create (one allocation).
#pragma once

#include "vdbmap/types.hpp"
#include "vdbmap/voxel_codec.hpp"  // VoxelState

#include <openvdb/Types.h>  // openvdb::Coord, CoordBBox (no trees)

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

namespace vdbmap::planner {

/// What the planner knows about one voxel: the map's own three states (vdbmap::toString names
/// them), read through the planner's rules (hits, assumed-free space) by each MapQuery.
using Occupancy = VoxelState;

/// The voxel that holds p_W, for voxels of voxel_size_m (the convention above).
openvdb::Coord voxelOf(const Vec3d& p_W, double voxel_size_m);
/// The centre of voxel ijk, for voxels of voxel_size_m (MapQuery::voxelCenter with the size at hand).
inline Vec3d voxelCenterOf(const openvdb::Coord& ijk, double voxel_size_m) {
  return Vec3d(ijk.x(), ijk.y(), ijk.z()) * voxel_size_m;
}

/// Where voxel ijk goes in a z-fastest array over the box with corner `min` and sides `dim`
/// (MapReader::readBox's order): ((x - min.x) * dim.y + (y - min.y)) * dim.z + (z - min.z).
inline std::size_t boxIndex(const openvdb::Coord& min, const openvdb::Coord& dim, const openvdb::Coord& ijk) {
  const openvdb::Coord d = ijk - min;
  return (std::size_t(d.x()) * std::size_t(dim.y()) + std::size_t(d.y())) * std::size_t(dim.z()) + std::size_t(d.z());
}

/// Per-thread reader of a map. Not thread-safe: one per thread.
class MapReader {
 public:
  virtual ~MapReader() = default;
  virtual Occupancy at(const openvdb::Coord& ijk) = 0;
  /// The states of every voxel of a non-empty `box`, z fastest: voxel (x, y, z) goes to
  /// out[boxIndex(box.min(), box.dim(), (x, y, z))]. The default calls at() per
  /// voxel; maps override it to read whole blocks at once (frontier scans read boxes).
  virtual void readBox(const openvdb::CoordBBox& box, Occupancy* out);
};

/// A map as the planner sees it. Implementations are read-only and safe to share between threads.
class MapQuery {
 public:
  virtual ~MapQuery() = default;
  virtual double voxelSize() const = 0;
  /// An index-space box that holds every known voxel (it may be larger); empty when nothing is known.
  virtual openvdb::CoordBBox knownBounds() const = 0;
  /// A new reader for the calling thread.
  virtual std::unique_ptr<MapReader> reader() const = 0;
  /// The map as lines of sight read it (viewpoint scoring, what a view sees): by default this map.
  /// A map whose rules read some free voxels as obstacles for flight only (structure thinner than
  /// a voxel, tsdf_map_query.hpp) returns the map without those rules: a 2.5 cm post keeps the
  /// vehicle 0.3 m away, but hides only a sliver of its 0.1 m voxel from a camera.
  virtual const MapQuery& sightMap() const { return *this; }
  /// Whether reading a whole box at once (MapReader::readBox, MapProbe::cacheBox) pays before
  /// checks that read only part of it: true for maps whose voxels are looked up; false for one
  /// that computes some voxels' states at a cost (RecentObstacleMap's seen free space projects
  /// each into every recent frame), where a box read computes states that no check reads.
  virtual bool boxReadsPay() const { return true; }

  /// The voxel that contains p_W.
  openvdb::Coord worldToVoxel(const Vec3d& p_W) const;
  Vec3d voxelCenter(const openvdb::Coord& ijk) const;
  /// The index box of the voxels whose centres lie in box_W (empty when there are none).
  openvdb::CoordBBox voxelsIn(const Eigen::AlignedBox3d& box_W) const;
  /// The world box covered by the voxels of an index box (their outer faces).
  Eigen::AlignedBox3d worldBox(const openvdb::CoordBBox& box) const;
};

/// Geometric checks on a map for one thread: clearance, clear segments and ray visibility, all
/// treating unknown voxels like occupied ones. Holds a reader and caches the voxel offsets of
/// each clearance radius it is asked for.
class MapProbe {
 public:
  explicit MapProbe(const MapQuery& map);

  const MapQuery& map() const { return *map_; }
  double voxelSize() const { return voxel_size_m_; }

  Occupancy at(const openvdb::Coord& ijk) {
    if (!cache_box_.isInside(ijk)) return reader_->at(ijk);
    return cache_[boxIndex(cache_box_.min(), cache_dim_, ijk)];
  }
  Occupancy atWorld(const Vec3d& p_W) { return at(map_->worldToVoxel(p_W)); }

  /// Reads `box` into a dense block at once (MapReader::readBox) and answers from it from now on;
  /// voxels outside it are still read one by one. Worth it before many checks in one region
  /// (viewpoint scoring does this per cluster). The block is a snapshot: call again (or with an
  /// empty box, to drop it) after the map changed.
  void cacheBox(const openvdb::CoordBBox& box);
  bool isFree(const Vec3d& p_W) { return atWorld(p_W) == Occupancy::Free; }

  /// True when the voxel containing p_W and every voxel whose centre lies within radius_m of p_W
  /// are known-free. radius_m in [0, 100 voxels].
  bool isClear(const Vec3d& p_W, double radius_m);

  /// Distance from p_W to the nearest voxel centre that is not known-free, searched up to max_m
  /// (max_m when there is none that close); 0 when the voxel containing p_W is not free.
  double clearance(const Vec3d& p_W, double max_m);

  /// True when every voxel the segment a-b passes through (exact 3D DDA traversal, both end
  /// voxels included) is known-free: the ray a-b is not blocked by occupied or unknown space.
  bool isVisible(const Vec3d& a_W, const Vec3d& b_W);

  /// The first voxel along the segment a-b (from a's, as isVisible traverses) that is not
  /// known-free; none when isVisible(a_W, b_W).
  std::optional<openvdb::Coord> firstNotFree(const Vec3d& a_W, const Vec3d& b_W);

  /// True when every voxel whose centre lies within radius_m of any point of the segment a-b (the
  /// capsule around it), and every voxel the segment passes through, is known-free. Exact: the
  /// capsule's voxels are enumerated layer by layer along the segment's main axis, each once.
  /// For a = b it is isClear(a, radius_m).
  bool isSegmentClear(const Vec3d& a_W, const Vec3d& b_W, double radius_m);
  /// isSegmentClear for ends already known clear (isClear(a_W, radius_m) and isClear(b_W,
  /// radius_m) were true on this map): the same answer, without reading the ends' balls again.
  bool isSegmentClearFromClearEnds(const Vec3d& a_W, const Vec3d& b_W, double radius_m);

 private:
  /// Calls on_voxel(ijk) for the voxels the segment a-b passes through, in order from a's (exact
  /// 3D DDA), until it returns false; returns false then, true when b's voxel was accepted.
  template <typename OnVoxel>
  bool traverse(const Vec3d& a_W, const Vec3d& b_W, OnVoxel&& on_voxel) const;

  struct Offset {
    openvdb::Coord d;
    double dist_vox;  ///< |d| in voxels, for ordering
  };
  /// Offsets of every voxel whose centre can lie within radius_m of a point of the centre voxel,
  /// nearest first (so a blocked neighbour is found early).
  const std::vector<Offset>& offsetsFor(double radius_m);
  /// The states of the n > 0 voxels from `first` along `axis` (0, 1, 2), valid until the next call.
  const Occupancy* readRun(const openvdb::Coord& first, int axis, int n);

  const MapQuery* map_;
  std::unique_ptr<MapReader> reader_;
  double voxel_size_m_;
  std::map<std::int64_t, std::vector<Offset>> offsets_;  ///< by radius in micro-voxels
  openvdb::CoordBBox cache_box_;  ///< empty: no block
  openvdb::Coord cache_dim_;
  std::vector<Occupancy> cache_;
  std::vector<Occupancy> run_;  ///< readRun's buffer
};

}  // namespace vdbmap::planner
