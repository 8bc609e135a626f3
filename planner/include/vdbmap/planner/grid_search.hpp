// A* over a lattice of voxel centres: a path search that is complete at the lattice's resolution,
// for legs that a sampling search would give up on (narrow passages, long ways round).
//
// The lattice holds every `stride_vox`-th voxel centre along each axis; a node may step to its 26
// neighbours. A node and the voxel centres on the edge between two nodes must be clear at
//   r_node = sqrt(clearance^2 + (half a voxel diagonal)^2),
// which makes every lattice edge clear at `clearance` exactly as MapProbe::isSegmentClear tests it
// (a point within `clearance` of the edge is within r_node of one of those centres, which lie at
// most a voxel diagonal apart). So a lattice path never needs re-checking, and the search fails
// only where the lattice is too coarse for the passage: a passage must be about r_node - clearance
// (1.2 cm at 0.1 m voxels and 0.3 m clearance) wider than a capsule needs, plus the lattice's
// alignment. The start and the goal join the lattice through clear segments to nearby nodes.
// Clearance is computed for a whole 8^3 block of voxels at once: the non-free voxels of the block
// and its margin as bit rows along z, dilated by the sphere's half-height over each (dx, dy).
//
// Weighted A* (heuristic_weight > 1) runs from both ends in turn, each toward the other end. Either
// one arriving gives the path; either one running out of nodes proves that no lattice path exists,
// which is quick when an end sits in a small closed pocket (a viewpoint walled off by unknown
// space), where a sampling search would spend its whole budget.
//
// The path returned is shortened (collinear steps merged, then a greedy pass that jumps to the
// farthest point it can see clear), each segment clear at `clearance`. The search is
// deterministic: no sampling, ties broken by node index; `max_expansions` bounds its work.
//
// Clearance answers are kept for the searcher's life: the map must not change while it lives.
// Not thread-safe: one searcher per thread, like MapProbe.
#pragma once

#include "vdbmap/planner/map_query.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace vdbmap::planner {

struct GridSearchConfig {
  /// Lattice spacing in voxels; [1, 8]. 2 at 0.1 m voxels: nodes every 0.2 m.
  int stride_vox = 2;
  /// Nodes expanded before the search gives up; [1, 1e8]
  std::uint64_t max_expansions = 10000;
  /// The heuristic's weight: 1 is A*, shortest on the lattice; w > 1 expands far fewer nodes for
  /// paths at most w times that long (before shortening); [1, 1e4]
  double heuristic_weight = 2.0;
  void validate() const;
};

struct GridSearchResult {
  bool found = false;
  std::vector<Vec3d> waypoints;  ///< start ... goal, shortened (empty unless found)
  std::uint64_t expansions = 0;
  std::uint64_t clear_blocks = 0;  ///< 8^3 voxel blocks whose clearance this search computed
};

class GridSearch {
 public:
  /// `probe` and its map must outlive the searcher; nodes outside `bounds_W` are blocked.
  GridSearch(MapProbe& probe, double clearance_m, const Eigen::AlignedBox3d& bounds_W,
             const GridSearchConfig& config = {});
  ~GridSearch();

  /// A path from start to goal, both assumed clear at clearance_m (PathPlanner checks them).
  /// `stop` is asked once per expansion; true ends the search (a time limit).
  GridSearchResult search(const Vec3d& start_W, const Vec3d& goal_W, const std::function<bool()>& stop = {});

  /// The node radius above.
  double nodeRadius() const { return node_radius_m_; }
  /// Whether voxel centre `voxel` is clear at nodeRadius() (inside the bounds); the lattice's test.
  bool centreClear(const openvdb::Coord& voxel);

 private:
  struct ClearBlock;
  struct NodeBlock;
  struct NodeRef {
    NodeBlock* block;
    int index;
  };
  bool edgeClear(const openvdb::Coord& from_node, const openvdb::Coord& step);
  /// Clear bits of the 8^3 voxels of block `block_ijk` (voxel >> 3), computed at once.
  void fillClearBlock(const openvdb::Coord& block_ijk, ClearBlock& out);
  /// The search's record of a node (fresh for each search); nullptr outside the lattice.
  NodeRef node(const openvdb::Coord& n);
  /// Nodes near p (the lattice cells around it) that are clear and joined to p by a clear
  /// segment, nearest first, at most `max_nodes`.
  std::vector<openvdb::Coord> attachNodes(const Vec3d& p_W, std::size_t max_nodes);
  std::vector<Vec3d> shorten(std::vector<Vec3d> points);
  Vec3d nodeCentre(const openvdb::Coord& node) const;

  MapProbe* probe_;
  std::unique_ptr<MapReader> reader_;  ///< reads the padded boxes of clear blocks
  double clearance_m_;
  double node_radius_m_;
  GridSearchConfig config_;
  openvdb::CoordBBox voxels_;  ///< voxel centres inside the bounds
  // Clear blocks: a table over the blocks of voxels_, each computed on first use.
  openvdb::Coord clear_origin_, clear_dim_;  ///< in blocks
  std::vector<std::int32_t> clear_index_;    ///< -1: not computed
  std::vector<ClearBlock> clear_blocks_;
  // Node blocks (8^3 nodes): a table over the lattice, records reset lazily by generation.
  openvdb::Coord node_origin_, node_dim_;  ///< in node blocks
  std::vector<std::int32_t> node_index_;   ///< -1: none yet
  std::vector<std::unique_ptr<NodeBlock>> node_blocks_;
  std::uint32_t generation_ = 0;
  std::uint64_t blocks_computed_ = 0;
};

}  // namespace vdbmap::planner
