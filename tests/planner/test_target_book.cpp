// The target book: failures per frontier voxel, a cluster's count as the median over its voxels,
// the blacklist, revisit forgiveness, visits judged by what the viewpoint saw, and finding the
// target again after its cluster was re-made.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/target_book.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
FrontierCluster clusterOf(ClusterId id, std::vector<Coord> voxels) {
  FrontierCluster c;
  c.id = id;
  c.voxels = std::move(voxels);
  return c;
}

/// Two frontier slabs (free boxes beside unknown space): x = 0..4 and x = 20..24, y = z = 0.
FrontierMap twoSlabs(DenseMap& map) {
  map.fill(CoordBBox(Coord(0, 0, 0), Coord(4, 0, 0)), Occupancy::Free);
  map.fill(CoordBBox(Coord(20, 0, 0), Coord(24, 0, 0)), Occupancy::Free);
  FrontierConfig p;
  p.min_cluster_size = 1;
  FrontierMap f(p);
  f.rebuild(map);
  return f;
}
}  // namespace

TEST_CASE("TargetBook counts a cluster's failures as the median over its voxels and blacklists at max_failures",
          "[planner][target_book]") {
  TargetBook book(2);
  const FrontierCluster a = clusterOf(1, {Coord(0, 0, 0), Coord(1, 0, 0), Coord(2, 0, 0)});
  CHECK(book.failures(a) == 0);
  book.addFailure(a);
  CHECK(book.failures(a) == 1);
  CHECK_FALSE(book.isBlacklisted(a));
  // A cluster re-made from two of a's voxels and one new one inherits the median: 1.
  const FrontierCluster b = clusterOf(2, {Coord(1, 0, 0), Coord(2, 0, 0), Coord(9, 0, 0)});
  CHECK(book.failures(b) == 1);
  // Mostly new voxels: the median is 0.
  const FrontierCluster c = clusterOf(3, {Coord(2, 0, 0), Coord(8, 0, 0), Coord(9, 0, 0)});
  CHECK(book.failures(c) == 0);
  book.addFailure(b);
  CHECK(book.failures(b) == 2);
  CHECK(book.isBlacklisted(b));
  CHECK(book.failuresAdded() == 2);
  // A revisit round: one more try each.
  book.forgiveBlacklisted();
  CHECK(book.failures(b) == 1);
  CHECK_FALSE(book.isBlacklisted(b));
  CHECK_THROWS_WITH(TargetBook(0), Catch::Contains("TargetBook.max_failures"));
}

TEST_CASE("TargetBook judges a visit by what its viewpoint saw, and finds its target again after a re-make",
          "[planner][target_book]") {
  DenseMap map(0.1, CoordBBox(Coord(-5), Coord(30, 5, 5)));
  FrontierMap frontiers = twoSlabs(map);
  REQUIRE(frontiers.clusters().size() == 2);
  const FrontierCluster left =
      frontiers.clusters()[0].voxels.front().x() < 10 ? frontiers.clusters()[0] : frontiers.clusters()[1];
  const FrontierCluster right =
      left.id == frontiers.clusters()[0].id ? frontiers.clusters()[1] : frontiers.clusters()[0];
  TargetBook book(3);

  SECTION("a visit that saw none of its promised frontier go is a failure against the target") {
    book.setTarget(left, {left.voxels.front()});
    const VisitJudgement v = book.judgeVisit(frontiers, 0.5);
    CHECK(v.failed);
    CHECK(v.judged_voxels == 1);  // judged by what the viewpoint saw
    CHECK(v.gone_fraction == 0.0);
    CHECK(book.failures(left) == 1);
  }
  SECTION("a visit after which the promised frontier is gone is not") {
    book.setTarget(left, {Coord(0, 3, 3)});  // no longer frontier (never was)
    const VisitJudgement v = book.judgeVisit(frontiers, 0.5);
    CHECK_FALSE(v.failed);
    CHECK(v.gone_fraction == 1.0);
    CHECK(book.failures(left) == 0);
  }
  SECTION("a visit whose viewpoint saw none of its samples is judged by the whole target") {
    book.setTarget(left, {});
    const VisitJudgement v = book.judgeVisit(frontiers, 0.5);
    CHECK(v.failed);
    CHECK(v.judged_voxels == left.voxels.size());
  }
  SECTION("no target: nothing is judged") {
    CHECK_FALSE(book.judgeVisit(frontiers, 0.5).failed);
    book.addTargetFailure();
    CHECK(book.failuresAdded() == 0);
  }
  SECTION("the target is found by its id, or by most of its voxels once re-made") {
    book.setTarget(left, {});
    CHECK(book.findTarget({right.id, left.id}, frontiers) == 1);
    CHECK(book.findTarget({right.id, 999}, frontiers) == 2);  // cluster 999 does not exist: none holds its voxels
    // The map grows beside the left slab: its cluster is re-made under a new id.
    map.set(Coord(5, 0, 0), Occupancy::Free);
    frontiers.update(map, CoordBBox(Coord(4, -1, -1), Coord(6, 1, 1)));
    std::vector<ClusterId> ids;
    for (const FrontierCluster& c : frontiers.clusters()) ids.push_back(c.id);
    REQUIRE(std::find(ids.begin(), ids.end(), left.id) == ids.end());
    const std::size_t found = book.findTarget(ids, frontiers);
    REQUIRE(found < ids.size());
    CHECK(frontiers.find(ids[found])->voxels.front().x() < 10);
    book.clearTarget();
    CHECK(book.target() == 0);
  }
}
