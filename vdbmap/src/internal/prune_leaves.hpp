// Pruning of the branches where voxels were switched off (private to the library).
#pragma once

#include <openvdb/openvdb.h>

#include <algorithm>
#include <vector>

namespace vdbmap::internal {

namespace detail {

/// Replaces with background tiles the nodes of type NodeT containing `origins` that are inactive;
/// leaves in `origins` the parents of those removed (each once).
template <typename NodeT, typename TreeT>
void pruneInactiveNodes(TreeT& tree, openvdb::Index level, std::vector<openvdb::Coord>& origins) {
  for (openvdb::Coord& c : origins) c = c & ~(openvdb::Int32(NodeT::DIM) - 1);
  std::sort(origins.begin(), origins.end());
  origins.erase(std::unique(origins.begin(), origins.end()), origins.end());
  std::size_t removed = 0;
  for (const openvdb::Coord& c : origins) {
    const NodeT* node = tree.template probeConstNode<NodeT>(c);
    if (!node || !node->isInactive()) continue;
    tree.addTile(level, c, tree.background(), false);  // deletes the node
    origins[removed++] = c;
  }
  origins.resize(removed);
}

}  // namespace detail

/// Replaces with inactive background tiles the leaves containing `voxels` that hold no active
/// voxel, then each internal node above them left with no child and no active tile, and erases
/// the root's background tiles: what openvdb::tools::pruneInactive does, visiting only those
/// branches instead of the whole tree. The two agree when no other node of the tree was inactive
/// before, which every tree of the library keeps true (a loaded map is pruned once). `voxels`
/// may repeat a leaf or name absent ones. Serial: it changes topology.
template <typename TreeT>
void pruneEmptiedLeaves(TreeT& tree, std::vector<openvdb::Coord> voxels) {
  using RootT = typename TreeT::RootNodeType;
  using UpperT = typename RootT::ChildNodeType;   // level 2
  using LowerT = typename UpperT::ChildNodeType;  // level 1
  static_assert(RootT::LEVEL == 3, "a tree of leaves, two internal levels and the root");
  if (voxels.empty()) return;
  tree.clearAllAccessors();  // they may cache the nodes removed here
  detail::pruneInactiveNodes<typename TreeT::LeafNodeType>(tree, 1, voxels);
  detail::pruneInactiveNodes<LowerT>(tree, 2, voxels);
  detail::pruneInactiveNodes<UpperT>(tree, 3, voxels);
  if (!voxels.empty()) tree.root().eraseBackgroundTiles();
}

}  // namespace vdbmap::internal
