// The lattice search: its clearance test against brute force, its paths checked densely, its
// lengths against a brute-force Dijkstra on the same lattice, quick proofs that a closed pocket
// holds no path, and PathPlanner's modes that use it.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/grid_search.hpp"
#include "vdbmap/planner/path_planner.hpp"

#include <catch2/catch.hpp>

#include <map>
#include <queue>
#include <random>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {

/// A room of 6 x 4 x 2 m with random occupied and unknown voxels (fixed seed).
DenseMap clutteredRoom(unsigned seed, double fraction) {
  DenseMap map = test::makeRoom(Eigen::Vector3i(60, 40, 20));
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(1, 58), y(1, 38), z(1, 18);
  std::bernoulli_distribution unknown(0.3);
  const int n = int(fraction * 58 * 38 * 18);
  for (int i = 0; i < n; ++i)
    map.set(Coord(x(rng), y(rng), z(rng)), unknown(rng) ? Occupancy::Unknown : Occupancy::Occupied);
  return map;
}

Eigen::AlignedBox3d worldBoxOf(const DenseMap& map) { return map.worldBox(map.knownBounds()); }

}  // namespace

TEST_CASE("The lattice's clearance test agrees with brute force at the node radius", "[planner][grid]") {
  const DenseMap map = clutteredRoom(7, 0.01);
  for (const double clearance : {0.0, 0.12, 0.3}) {
    MapProbe probe(map);
    const Eigen::AlignedBox3d bounds(Vec3d(0.35, 0.25, 0.15), Vec3d(5.55, 3.65, 1.75));
    GridSearch search(probe, clearance, bounds);
    CHECK(search.nodeRadius() == Approx(std::sqrt(clearance * clearance + 0.75 * 0.01)));
    int clear = 0, blocked = 0;
    for (int x = -1; x <= 61; x += 1)
      for (int y = -1; y <= 41; y += 2)
        for (int z = -1; z <= 21; z += 1) {
          const Coord v(x, y, z);
          const Vec3d c = map.voxelCenter(v);
          const bool expected = bounds.contains(c) && test::bruteClear(map, c, search.nodeRadius());
          REQUIRE(search.centreClear(v) == expected);
          (expected ? clear : blocked) += 1;
        }
    CHECK(clear > 1000);
    CHECK(blocked > 1000);
  }
}

TEST_CASE("The lattice's clearance test agrees with brute force for radii wider than its bit rows", "[planner][grid]") {
  // 3 m of clearance at 0.1 m voxels pads a block by 31 voxels: the voxel-by-voxel path.
  DenseMap map = test::makeRoom(Eigen::Vector3i(90, 90, 90));
  map.set(Coord(12, 45, 45), Occupancy::Occupied);  // 2.8-3.5 m from the block's voxels below
  MapProbe probe(map);
  GridSearch search(probe, 2.95, worldBoxOf(map));
  int clear = 0;
  for (int x = 40; x <= 47; ++x)  // one block: 512 voxel-by-voxel tests
    for (const int y : {40, 45, 47}) {
      const bool expected = test::bruteClear(map, map.voxelCenter(Coord(x, y, 45)), search.nodeRadius());
      REQUIRE(search.centreClear(Coord(x, y, 45)) == expected);
      clear += expected;
    }
  CHECK(clear > 0);
  CHECK(clear < 24);
}

TEST_CASE("Lattice paths go through the door, clear along their whole length", "[planner][grid]") {
  const DenseMap map = test::wallRoom();
  PathConfig config;
  config.clearance_m = 0.25;
  config.search = PathSearch::Grid;
  config.time_limit_s = 10.0;  // the expansion budget, not the clock, ends the search
  PathPlanner planner(map, config);
  const Vec3d start(2, 1, 1), goal(8, 1.2, 1.4);
  const PathResult r = planner.plan(start, goal);
  REQUIRE(r.status == PathStatus::Planned);
  CHECK(r.waypoints.front() == start);
  CHECK(r.waypoints.back() == goal);
  CHECK(test::denselyClear(map, r.waypoints, config.clearance_m));
  CHECK(r.length_m == Approx(polylineLength(r.waypoints)));
  // The shortest way, through the door's lower corner at (5, 2.75, 1.x): about 7.0 m.
  CHECK(r.length_m > 6.9);
  CHECK(r.length_m < 7.6);
  CHECK(r.iterations > 0);
  // Deterministic: a second planner gives the same path.
  PathPlanner again(map, config);
  CHECK(again.plan(start, goal).waypoints == r.waypoints);
}

TEST_CASE("With weight 1 the lattice path is no longer than brute-force Dijkstra's on the lattice", "[planner][grid]") {
  const DenseMap map = clutteredRoom(3, 0.004);
  const double clearance = 0.2;
  MapProbe probe(map);
  GridSearchConfig config;
  config.heuristic_weight = 1.0;
  config.max_expansions = 1'000'000;
  const Eigen::AlignedBox3d bounds = worldBoxOf(map);
  GridSearch search(probe, clearance, bounds, config);
  // Brute force: nodes at even voxels, clear (with the centres between them) at the node radius.
  auto ok = [&](const Coord& v) {
    return bounds.contains(map.voxelCenter(v)) && test::bruteClear(map, map.voxelCenter(v), search.nodeRadius());
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(0.5, 5.5), uy(0.5, 3.5), uz(0.4, 1.6);
  int compared = 0;
  while (compared < 4) {
    const Vec3d a(ux(rng), uy(rng), uz(rng)), b(ux(rng), uy(rng), uz(rng));
    if (!test::bruteClear(map, a, clearance) || !test::bruteClear(map, b, clearance)) continue;
    if (test::bruteSegmentClear(map, a, b, clearance)) continue;
    const GridSearchResult found = search.search(a, b);
    REQUIRE(found.found);
    CHECK(test::denselyClear(map, found.waypoints, clearance));
    const double length = polylineLength(found.waypoints);
    // Dijkstra from every node joined to a (within two cells, clear segment) to those joined to b.
    auto nodeOf = [&](const Coord& n) { return map.voxelCenter(Coord(2 * n.x(), 2 * n.y(), 2 * n.z())); };
    auto joined = [&](const Vec3d& p) {
      std::vector<Coord> nodes;
      const Coord low(int(std::floor(p.x() / 0.2)), int(std::floor(p.y() / 0.2)), int(std::floor(p.z() / 0.2)));
      for (int dx = -1; dx <= 2; ++dx)
        for (int dy = -1; dy <= 2; ++dy)
          for (int dz = -1; dz <= 2; ++dz) {
            const Coord n = low.offsetBy(dx, dy, dz);
            if (ok(Coord(2 * n.x(), 2 * n.y(), 2 * n.z())) && test::bruteSegmentClear(map, p, nodeOf(n), clearance))
              nodes.push_back(n);
          }
      return nodes;
    };
    std::map<Coord, double> dist;
    using E = std::pair<double, Coord>;
    auto later = [](const E& l, const E& r) { return l.first > r.first; };
    std::priority_queue<E, std::vector<E>, decltype(later)> open(later);
    for (const Coord& n : joined(a)) open.emplace((nodeOf(n) - a).norm(), n);
    std::map<Coord, bool> goal_side;
    for (const Coord& n : joined(b)) goal_side[n] = true;
    double best = std::numeric_limits<double>::infinity();
    while (!open.empty()) {
      const auto [d, n] = open.top();
      open.pop();
      if (dist.count(n)) continue;
      dist[n] = d;
      if (goal_side.count(n)) best = std::min(best, d + (nodeOf(n) - b).norm());
      if (d >= best) break;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            if (!dx && !dy && !dz) continue;
            const Coord m = n.offsetBy(dx, dy, dz);
            if (dist.count(m)) continue;
            const Coord v(2 * n.x(), 2 * n.y(), 2 * n.z());
            if (!ok(v.offsetBy(dx, dy, dz)) || !ok(v.offsetBy(2 * dx, 2 * dy, 2 * dz))) continue;
            open.emplace(d + 0.2 * std::sqrt(double(dx * dx + dy * dy + dz * dz)), m);
          }
    }
    REQUIRE(std::isfinite(best));
    CHECK(length <= best + 1e-9);
    CHECK(length >= (b - a).norm());
    ++compared;
  }
}

TEST_CASE("A closed pocket is proven to hold no path after few expansions", "[planner][grid]") {
  // The goal sits in a 1 m box walled off inside the room: the search from its side runs out of
  // nodes long before the one from the start could.
  DenseMap map = test::makeRoom(Eigen::Vector3i(100, 60, 30));
  map.fill(CoordBBox(Coord(70, 20, 5), Coord(81, 31, 16)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(71, 21, 6), Coord(80, 30, 15)), Occupancy::Free);
  PathConfig config;
  config.clearance_m = 0.2;
  config.search = PathSearch::Grid;
  PathPlanner planner(map, config);
  const Vec3d start(1, 1, 1), goal(7.55, 2.55, 1.05);
  REQUIRE(planner.isClear(goal));
  const PathResult r = planner.plan(start, goal);
  CHECK(r.status == PathStatus::NoPath);
  CHECK(r.iterations > 0);
  CHECK(r.iterations < 200);
}

TEST_CASE("The expansion budget ends a search with NoPath", "[planner][grid]") {
  const DenseMap map = test::wallRoom();
  PathConfig config;
  config.search = PathSearch::Grid;
  config.grid.max_expansions = 10;
  config.time_limit_s = 10.0;  // the budget, not the clock, ends the search
  PathPlanner planner(map, config);
  const PathResult r = planner.plan(Vec3d(2, 1, 1), Vec3d(8, 1.2, 1.4));
  CHECK(r.status == PathStatus::NoPath);
  CHECK(r.iterations == 10);
}

TEST_CASE("Sampling then grid: the lattice finds the door when RRTConnect's budget does not", "[planner][grid]") {
  const DenseMap map = test::wallRoom();
  PathConfig config;
  config.max_iterations = 1;
  PathPlanner sampling(map, config);
  const Vec3d start(2, 1, 1), goal(8, 1.2, 1.4);
  REQUIRE(sampling.plan(start, goal).status == PathStatus::NoPath);
  config.search = PathSearch::SamplingThenGrid;
  config.time_limit_s = 10.0;  // the budgets, not the clock, end the searches
  PathPlanner both(map, config);
  const PathResult r = both.plan(start, goal);
  REQUIRE(r.status == PathStatus::Planned);
  CHECK(test::denselyClear(map, r.waypoints, config.clearance_m));
  CHECK(r.iterations > 1);  // RRTConnect's iteration and the lattice's expansions
}

TEST_CASE("Grid search settings are validated", "[planner][grid]") {
  GridSearchConfig c;
  CHECK_NOTHROW(c.validate());
  c.stride_vox = 0;
  CHECK_THROWS_AS(c.validate(), std::invalid_argument);
  c = {};
  c.max_expansions = 0;
  CHECK_THROWS_AS(c.validate(), std::invalid_argument);
  c = {};
  c.heuristic_weight = 0.5;
  CHECK_THROWS_AS(c.validate(), std::invalid_argument);
  PathConfig p;
  p.grid.stride_vox = 9;
  CHECK_THROWS_AS(p.validate(), std::invalid_argument);
  CHECK(std::string(toString(PathSearch::SamplingThenGrid)) == "sampling_then_grid");
}
