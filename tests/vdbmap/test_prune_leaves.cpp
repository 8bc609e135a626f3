// Pruning only the branches where voxels were removed, against OpenVDB's whole-tree pruneInactive.
#include "internal/prune_leaves.hpp"

#include <catch2/catch.hpp>

#include <openvdb/tools/Prune.h>

#include <random>
#include <vector>

using vdbmap::internal::pruneEmptiedLeaves;

namespace {

/// The nodes of every level, the root's table entries and the topology agree.
void requireSameTree(const openvdb::Int64Tree& a, const openvdb::Int64Tree& b) {
  REQUIRE(a.hasSameTopology(b));
  REQUIRE(a.nodeCount() == b.nodeCount());
  REQUIRE(a.root().getTableSize() == b.root().getTableSize());
  REQUIRE(a.activeVoxelCount() == b.activeVoxelCount());
}

}  // namespace

TEST_CASE("pruning the emptied branches leaves the tree pruneInactive leaves", "[prune]") {
  openvdb::initialize();
  std::mt19937 rng(17);
  // Voxels in a few root children (4096 voxels wide), each with a few lower internal nodes (128)
  // and leaves (8), so that removals empty whole leaves, lower nodes and root children.
  const auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  for (int trial = 0; trial < 60; ++trial) {
    openvdb::Int64Tree tree(0);
    std::vector<openvdb::Coord> voxels;
    for (int i = 0; i < 400; ++i) {
      const openvdb::Coord c((pick(3) - 1) * 4096 + pick(2) * 128 + pick(3) * 8 + pick(8),
                             pick(2) * 4096 + pick(2) * 128 + pick(2) * 8 + pick(8), pick(8) - 4);
      tree.setValueOn(c, 1 + pick(1000));
      voxels.push_back(c);
    }
    // Remove all voxels of some regions (a root child, a lower node or a leaf, by trial) and a
    // random share of the rest.
    const openvdb::Int32 region = std::array<openvdb::Int32, 3>{4096, 128, 8}[std::size_t(trial % 3)];
    const openvdb::Coord cleared = voxels[std::size_t(pick(int(voxels.size())))] & ~(region - 1);
    const double share = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    std::vector<openvdb::Coord> removed;
    for (const openvdb::Coord& c : voxels) {
      if ((c & ~(region - 1)) == cleared || std::uniform_real_distribution<double>(0.0, 1.0)(rng) < share) {
        tree.setValueOff(c, 0);
        removed.push_back(c);
      }
    }
    openvdb::Int64Tree reference(tree);
    openvdb::tools::pruneInactive(reference);
    pruneEmptiedLeaves(tree, removed);
    requireSameTree(tree, reference);
  }
}

TEST_CASE("pruning emptied branches ignores leaves that still hold active voxels or are absent", "[prune]") {
  openvdb::initialize();
  openvdb::Int64Tree tree(0);
  tree.setValueOn(openvdb::Coord(1, 2, 3), 5);
  tree.setValueOn(openvdb::Coord(9, 2, 3), 6);
  tree.setValueOff(openvdb::Coord(2, 2, 3), 0);  // same leaf as (1, 2, 3): it stays
  const openvdb::Int64Tree before(tree);
  pruneEmptiedLeaves(tree, {openvdb::Coord(2, 2, 3), openvdb::Coord(9000, 0, 0), openvdb::Coord(2, 2, 3)});
  requireSameTree(tree, before);
  REQUIRE(tree.leafCount() == 2);

  tree.setValueOff(openvdb::Coord(9, 2, 3), 0);
  pruneEmptiedLeaves(tree, {openvdb::Coord(9, 2, 3)});
  REQUIRE(tree.leafCount() == 1);
  tree.setValueOff(openvdb::Coord(1, 2, 3), 0);
  pruneEmptiedLeaves(tree, {openvdb::Coord(1, 2, 3)});
  REQUIRE(tree.empty());  // the root keeps no entry
}
