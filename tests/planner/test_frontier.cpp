// Frontier detection, clustering, splitting, and incremental updates on synthetic maps with
// hand-counted answers, and incremental == from scratch on random edit sequences.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/frontier.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <set>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
DenseMap unknownMap() { return DenseMap(0.1, CoordBBox(Coord(-40), Coord(140, 60, 40))); }

FrontierConfig everyCluster() {
  FrontierConfig p;
  p.min_cluster_size = 1;
  return p;
}

std::vector<std::size_t> clusterSizes(const FrontierMap& f) {
  std::vector<std::size_t> sizes;
  for (const FrontierCluster& c : f.clusters()) sizes.push_back(c.voxels.size());
  std::sort(sizes.begin(), sizes.end());
  return sizes;
}

/// Clusters as a canonical set of voxel sets (ids aside).
std::set<std::vector<Coord>> clusterSets(const FrontierMap& f) {
  std::set<std::vector<Coord>> sets;
  for (const FrontierCluster& c : f.clusters()) sets.insert(c.voxels);
  return sets;
}

/// The frontier voxels by brute force over a box.
std::set<Coord> bruteFrontier(const DenseMap& map, const CoordBBox& box) {
  std::set<Coord> out;
  auto reader = map.reader();
  for (auto it = box.begin(); it; ++it) {
    if (map.get(*it) != Occupancy::Free) continue;
    for (const Coord d : {Coord(1, 0, 0), Coord(-1, 0, 0), Coord(0, 1, 0), Coord(0, -1, 0), Coord(0, 0, 1), Coord(0, 0, -1)})
      if (map.get(*it + d) == Occupancy::Unknown) {
        out.insert(*it);
        break;
      }
  }
  return out;
}
}  // namespace

TEST_CASE("A free box in unknown space: its whole surface is one frontier cluster", "[planner][frontier]") {
  DenseMap map = unknownMap();
  map.fill(CoordBBox(Coord(0), Coord(4, 3, 2)), Occupancy::Free);  // 5 x 4 x 3
  FrontierMap f(everyCluster());
  const FrontierUpdate u = f.rebuild(map);
  // 5*4*3 = 60 voxels, 3*2*1 = 6 inside: 54 on the surface.
  CHECK(f.frontierVoxelCount() == 54);
  REQUIRE(f.clusters().size() == 1);
  CHECK(f.clusters()[0].voxels.size() == 54);
  CHECK(u.added == std::vector<ClusterId>{f.clusters()[0].id});
  CHECK(f.clusters()[0].centroid_W.isApprox(Vec3d(0.2, 0.15, 0.1), 1e-12));
  CHECK(f.clusters()[0].bbox == CoordBBox(Coord(0), Coord(4, 3, 2)));
  CHECK_FALSE(f.isFrontier(Coord(2, 1, 1)));  // the inside
  CHECK(f.isFrontier(Coord(0, 0, 0)));
}

TEST_CASE("Occupied walls are not unknown: only the open face of a walled box is frontier", "[planner][frontier]") {
  DenseMap map = unknownMap();
  // Free 10 x 10 x 5 box with occupied walls on every side but +x.
  map.fill(CoordBBox(Coord(-1), Coord(10, 10, 5)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(0), Coord(10, 9, 4)), Occupancy::Free);  // x = 10 opens the wall
  FrontierMap f(everyCluster());
  f.rebuild(map);
  // Frontier voxels: x = 10, y in [0, 9], z in [0, 4].
  CHECK(f.frontierVoxelCount() == 50);
  REQUIRE(f.clusters().size() == 1);
  for (const Coord& c : f.clusters()[0].voxels) CHECK(c.x() == 10);
}

TEST_CASE("Clusters are 26-connected: boxes touching at a corner merge, boxes a voxel apart do not",
          "[planner][frontier]") {
  FrontierMap f(everyCluster());
  {
    DenseMap map = unknownMap();
    map.fill(CoordBBox(Coord(0), Coord(2)), Occupancy::Free);
    map.fill(CoordBBox(Coord(3), Coord(5)), Occupancy::Free);  // corner (2,2,2)-(3,3,3)
    f.rebuild(map);
    CHECK(clusterSizes(f) == std::vector<std::size_t>{52});  // 26 + 26 surface voxels
  }
  {
    DenseMap map = unknownMap();
    map.fill(CoordBBox(Coord(0), Coord(2)), Occupancy::Free);
    map.fill(CoordBBox(Coord(4), Coord(6)), Occupancy::Free);
    f.rebuild(map);
    CHECK(clusterSizes(f) == std::vector<std::size_t>{26, 26});
  }
  {
    // Edge-adjacent (two coordinates differ by one): still 26-connected.
    DenseMap map = unknownMap();
    map.fill(CoordBBox(Coord(0), Coord(2)), Occupancy::Free);
    map.fill(CoordBBox(Coord(3, 3, 0), Coord(5, 5, 2)), Occupancy::Free);
    f.rebuild(map);
    CHECK(clusterSizes(f) == std::vector<std::size_t>{52});
  }
}

TEST_CASE("Components below min_cluster_size are dropped but kept for later growth", "[planner][frontier]") {
  DenseMap map = unknownMap();
  map.fill(CoordBBox(Coord(0), Coord(4, 3, 2)), Occupancy::Free);     // 54 frontier voxels
  map.fill(CoordBBox(Coord(20), Coord(22)), Occupancy::Free);         // 26
  FrontierConfig p;
  p.min_cluster_size = 30;
  FrontierMap f(p);
  f.rebuild(map);
  CHECK(clusterSizes(f) == std::vector<std::size_t>{54});
  CHECK(f.componentCount() == 2);
  CHECK(f.frontierVoxelCount() == 80);
  // Growing the small box to 4 x 4 x 4 (56 surface voxels) makes it a cluster.
  map.fill(CoordBBox(Coord(20), Coord(23)), Occupancy::Free);
  const FrontierUpdate u = f.update(map, CoordBBox(Coord(20), Coord(23)));
  CHECK(clusterSizes(f) == (std::vector<std::size_t>{54, 56}));
  CHECK(u.added.size() == 1);
  CHECK(u.removed.empty());
}

TEST_CASE("Wide clusters are split along their principal horizontal axis", "[planner][frontier]") {
  FrontierConfig p = everyCluster();
  p.split_radius_xy_m = 2.0;
  SECTION("6 m line: halves of 30") {
    DenseMap map = unknownMap();
    map.fill(CoordBBox(Coord(0), Coord(59, 0, 0)), Occupancy::Free);  // every voxel is frontier
    FrontierMap f(p);
    f.rebuild(map);
    // The ends are 2.95 m from the centroid: split at x = 2.95 m; each half is 3 m long (1.45 m < 2).
    REQUIRE(clusterSizes(f) == (std::vector<std::size_t>{30, 30}));
    for (const FrontierCluster& c : f.clusters())
      CHECK((c.bbox == CoordBBox(Coord(0), Coord(29, 0, 0)) || c.bbox == CoordBBox(Coord(30, 0, 0), Coord(59, 0, 0))));
  }
  SECTION("11 m slanted line: quarters of 25") {
    DenseMap map = unknownMap();
    // A staircase along (2, 1): 100 voxels, 26-connected, 11 m long.
    for (int i = 0; i < 100; ++i) map.set(Coord(i, i / 2, 0), Occupancy::Free);
    FrontierMap f(p);
    f.rebuild(map);
    CHECK(f.frontierVoxelCount() == 100);
    // 100 -> 50 + 50 (each 5.5 m long: ends 2.7 m out) -> 4 x 25 (each 2.7 m: ends 1.3 m out).
    CHECK(clusterSizes(f) == (std::vector<std::size_t>{25, 25, 25, 25}));
    for (const FrontierCluster& c : f.clusters()) CHECK(c.component_voxels == 100);  // the whole staircase
  }
  SECTION("A vertical strip is not split: only horizontal spread counts") {
    DenseMap map = unknownMap();
    map.fill(CoordBBox(Coord(0), Coord(0, 0, 39)), Occupancy::Free);  // 4 m tall
    FrontierMap f(p);
    f.rebuild(map);
    CHECK(clusterSizes(f) == std::vector<std::size_t>{40});
  }
}

TEST_CASE("The exploration box limits frontier voxels and the unknown that makes them", "[planner][frontier]") {
  DenseMap map = unknownMap();
  map.fill(CoordBBox(Coord(0), Coord(9)), Occupancy::Free);
  FrontierConfig p = everyCluster();
  // Box over voxel centres x in [0, 0.5] (voxels 0..5), y, z in [-1, 2].
  p.bounds_W = Eigen::AlignedBox3d(Vec3d(-0.04, -1.0, -1.0), Vec3d(0.54, 2.0, 2.0));
  FrontierMap f(p);
  f.rebuild(map);
  // Inside the box: x in [0, 5]; frontier where an unknown face neighbour inside the box exists:
  // x = 0 face (-x neighbour at x = -1 is outside the box: no!), so only the y/z faces:
  // voxels with y in {0, 9} or z in {0, 9}, x in [0, 5]: 6 * (100 - 64) = 216.
  CHECK(f.frontierVoxelCount() == 216);
  for (const FrontierCluster& c : f.clusters())
    for (const Coord& v : c.voxels) CHECK((v.x() >= 0 && v.x() <= 5));
}

TEST_CASE("setMinClusterSize gives the clusters a rebuild with that size gives, keeping untouched ids",
          "[planner][frontier]") {
  DenseMap map = unknownMap();
  map.fill(CoordBBox(Coord(0), Coord(4, 3, 2)), Occupancy::Free);  // 54 frontier voxels
  map.fill(CoordBBox(Coord(20), Coord(22)), Occupancy::Free);      // 26
  map.fill(CoordBBox(Coord(40, 40, 20), Coord(41, 41, 21)), Occupancy::Free);  // 8
  FrontierConfig p;
  p.min_cluster_size = 30;
  FrontierMap f(p);
  f.rebuild(map);
  REQUIRE(clusterSizes(f) == std::vector<std::size_t>{54});
  const ClusterId big = f.clusters().front().id;

  const auto sameAsRebuild = [&](int size) {
    FrontierConfig q = p;
    q.min_cluster_size = size;
    FrontierMap scratch(q);
    scratch.rebuild(map);
    return clusterSets(f) == clusterSets(scratch);
  };
  // Lowering to 10 adds the 26-voxel component only; the 54-voxel cluster keeps its id.
  FrontierUpdate u = f.setMinClusterSize(map, 10);
  CHECK(f.params().min_cluster_size == 10);
  CHECK(clusterSizes(f) == (std::vector<std::size_t>{26, 54}));
  CHECK(sameAsRebuild(10));
  CHECK(u.added.size() == 1);
  CHECK(u.removed.empty());
  CHECK(f.find(big) != nullptr);
  const ClusterId mid = u.added.front();
  CHECK(f.find(mid)->voxels.size() == 26);

  // Lowering again adds the 8-voxel one.
  u = f.setMinClusterSize(map, 1);
  CHECK(clusterSizes(f) == (std::vector<std::size_t>{8, 26, 54}));
  CHECK(sameAsRebuild(1));
  CHECK(u.added.size() == 1);

  // Raising drops the clusters of components now too small, and reports them.
  u = f.setMinClusterSize(map, 27);
  CHECK(clusterSizes(f) == std::vector<std::size_t>{54});
  CHECK(sameAsRebuild(27));
  CHECK(u.added.empty());
  CHECK(u.removed.size() == 2);
  CHECK(std::find(u.removed.begin(), u.removed.end(), mid) != u.removed.end());
  CHECK(f.find(big) != nullptr);

  // Updates afterwards use the new size: growing the 8-voxel box to 3 x 3 x 3 (26 surface voxels)
  // keeps it out, growing it to 4 x 4 x 4 (56) brings it in.
  map.fill(CoordBBox(Coord(40, 40, 20), Coord(42, 42, 22)), Occupancy::Free);
  f.update(map, CoordBBox(Coord(40, 40, 20), Coord(42, 42, 22)));
  CHECK(clusterSizes(f) == std::vector<std::size_t>{54});
  map.fill(CoordBBox(Coord(40, 40, 20), Coord(43, 43, 23)), Occupancy::Free);
  f.update(map, CoordBBox(Coord(40, 40, 20), Coord(43, 43, 23)));
  CHECK(clusterSizes(f) == (std::vector<std::size_t>{54, 56}));
  CHECK(sameAsRebuild(27));

  CHECK_THROWS_WITH(f.setMinClusterSize(map, 0), Catch::Contains("min_cluster_size"));
  CHECK(f.params().min_cluster_size == 27);  // a refused size changes nothing
}

TEST_CASE("Detection from scratch equals brute force on a cluttered map", "[planner][frontier]") {
  DenseMap map(0.1, CoordBBox(Coord(0), Coord(39, 39, 14)));
  std::mt19937 rng(2);
  std::uniform_int_distribution<int> x(0, 35), z(0, 11), sz(1, 6);
  for (int i = 0; i < 60; ++i) {
    const Coord lo(x(rng), x(rng), z(rng));
    const Occupancy s = i % 3 == 0 ? Occupancy::Occupied : Occupancy::Free;
    map.fill(CoordBBox(lo, lo + Coord(sz(rng), sz(rng), sz(rng))), s);
  }
  FrontierMap f(everyCluster());
  f.rebuild(map);
  const std::set<Coord> brute = bruteFrontier(map, map.extent());
  std::set<Coord> got;
  for (const FrontierCluster& c : f.clusters()) got.insert(c.voxels.begin(), c.voxels.end());
  CHECK(got == brute);
  CHECK(f.frontierVoxelCount() == brute.size());
  CHECK(brute.size() > 500);
}

TEST_CASE("Incremental updates equal detection from scratch and report id changes exactly", "[planner][frontier]") {
  // A sequence of edits like exploration and re-integration make: carve free space, add
  // obstacles, and forget voxels (unknown again, as de-integration does).
  DenseMap map(0.1, CoordBBox(Coord(-5), Coord(70, 50, 25)));
  FrontierConfig p;
  p.min_cluster_size = 8;
  p.split_radius_xy_m = 1.0;
  FrontierMap incremental(p);
  incremental.rebuild(map);
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> x(0, 60), y(0, 42), z(0, 18), sz(1, 9), kind(0, 9);
  int kept_far = 0;
  for (int step = 0; step < 80; ++step) {
    const Coord lo(x(rng), y(rng), z(rng));
    const CoordBBox box(lo, lo + Coord(sz(rng), sz(rng), sz(rng) / 2));
    const int k = kind(rng);
    const Occupancy s = k < 6 ? Occupancy::Free : k < 8 ? Occupancy::Occupied : Occupancy::Unknown;
    map.fill(box, s);
    const std::vector<FrontierCluster> before = incremental.clusters();
    const FrontierUpdate u = incremental.update(map, box);

    FrontierMap scratch(p);
    scratch.rebuild(map);
    REQUIRE(clusterSets(incremental) == clusterSets(scratch));
    REQUIRE(incremental.frontierVoxelCount() == scratch.frontierVoxelCount());
    for (const FrontierCluster& c : scratch.clusters())
      for (const Coord& v : c.voxels) REQUIRE(incremental.isFrontier(v));
    // A cluster is immutable under its id; ids change exactly as reported.
    std::set<ClusterId> expected_ids;
    for (const FrontierCluster& c : before) {
      const FrontierCluster* now = incremental.find(c.id);
      if (now) {
        REQUIRE(now->voxels == c.voxels);
        kept_far += !c.bbox.hasOverlap(box.expandBy(2));
        expected_ids.insert(c.id);
      } else {
        REQUIRE(std::find(u.removed.begin(), u.removed.end(), c.id) != u.removed.end());
      }
    }
    for (const ClusterId id : u.added) expected_ids.insert(id);
    std::set<ClusterId> ids;
    for (const FrontierCluster& c : incremental.clusters()) ids.insert(c.id);
    REQUIRE(ids == expected_ids);
  }
  CHECK(kept_far > 50);  // clusters away from an edit survive it
  CHECK(incremental.clusters().size() > 3);
}

TEST_CASE("An update with an empty dirty region changes nothing", "[planner][frontier]") {
  DenseMap map = unknownMap();
  map.fill(CoordBBox(Coord(0), Coord(4)), Occupancy::Free);
  FrontierMap f(everyCluster());
  f.rebuild(map);
  const auto ids = f.clusters();
  const FrontierUpdate u = f.update(map, CoordBBox());
  CHECK(u.added.empty());
  CHECK(u.removed.empty());
  CHECK(f.clusters().size() == ids.size());
}

TEST_CASE("Cluster samples keep one voxel per stride cube", "[planner][frontier]") {
  DenseMap map = unknownMap();
  map.fill(CoordBBox(Coord(0), Coord(5, 5, 0)), Occupancy::Free);  // a 6 x 6 sheet: all frontier
  FrontierConfig p = everyCluster();
  p.sample_stride_vox = 3;
  FrontierMap f(p);
  f.rebuild(map);
  REQUIRE(f.clusters().size() == 1);
  // Four 3 x 3 cubes; in each the voxel nearest the cube's mean is its middle one.
  CHECK(f.clusters()[0].samples == (std::vector<Coord>{Coord(1, 1, 0), Coord(1, 4, 0), Coord(4, 1, 0), Coord(4, 4, 0)}));
}

TEST_CASE("FrontierConfig::validate names the field", "[planner][frontier]") {
  FrontierConfig p;
  p.min_cluster_size = 0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("min_cluster_size"));
  p = FrontierConfig{};
  p.split_radius_xy_m = 0.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("split_radius_xy_m"));
  p = FrontierConfig{};
  p.sample_stride_vox = 0;
  CHECK_THROWS_WITH(FrontierMap{p}, Catch::Contains("sample_stride_vox"));
}
