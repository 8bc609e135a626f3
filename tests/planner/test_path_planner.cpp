// Paths: straight when clear, RRTConnect + simplification otherwise; every path is checked
// densely against the map by brute force; failures are statuses; results repeat for a seed.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/cached_map.hpp"
#include "vdbmap/planner/path_planner.hpp"

#include <catch2/catch.hpp>

#include <random>
#include <vector>

using namespace vdbmap;
using namespace vdbmap::planner;

TEST_CASE("A clear straight segment is the path", "[planner][path]") {
  const DenseMap map = test::wallRoom(true);
  PathPlanner planner(map);
  const PathResult r = planner.plan(Vec3d(1, 1, 1), Vec3d(4, 4, 1.5));
  REQUIRE(r.status == PathStatus::Straight);
  CHECK(r.waypoints == (std::vector<Vec3d>{Vec3d(1, 1, 1), Vec3d(4, 4, 1.5)}));
  CHECK(r.length_m == Approx((Vec3d(3, 3, 0.5)).norm()));
}

TEST_CASE("Through the door: RRTConnect paths are collision-free against the map", "[planner][path]") {
  const DenseMap map = test::wallRoom(true);
  PathConfig params = test::countedPaths(5000);
  params.clearance_m = 0.25;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    params.seed = seed;
    PathPlanner planner(map, params);
    const Vec3d start(2, 1, 1), goal(8, 1.2, 1.4);
    const PathResult r = planner.plan(start, goal);
    REQUIRE(r.status == PathStatus::Planned);
    REQUIRE(r.waypoints.size() >= 3);
    CHECK(r.waypoints.front() == start);
    CHECK(r.waypoints.back() == goal);
    CHECK(test::denselyClear(map, r.waypoints, params.clearance_m));
    CHECK(r.length_m == Approx(polylineLength(r.waypoints)));
    // It goes through the door: the shortest way is about 2 x hypot(3, 2) = 7.2 m.
    CHECK(r.length_m > 7.0);
    CHECK(r.length_m < 9.5);
    bool through_door = false;
    for (std::size_t i = 1; i < r.waypoints.size(); ++i) {
      const Vec3d a = r.waypoints[i - 1], b = r.waypoints[i];
      if ((a.x() - 5.0) * (b.x() - 5.0) <= 0.0) {
        const Vec3d c = a + (b - a) * ((5.0 - a.x()) / (b.x() - a.x()));
        through_door = c.y() > 2.5 && c.y() < 3.5 && c.z() < 2.05;
      }
    }
    CHECK(through_door);
  }
}

TEST_CASE("A closed one-voxel wall gives the status NoPath within the time limit", "[planner][path]") {
  const DenseMap map = test::wallRoom(false);
  PathConfig params;
  params.time_limit_s = 0.05;
  PathPlanner planner(map, params);
  // The search runs on the calling thread; its CPU time after the limit passes shows whether it
  // stopped there, whatever time slices a loaded machine took from it.
  const double cpu_start_s = test::threadCpuSeconds();
  const PathResult r = planner.plan(Vec3d(2, 1, 1), Vec3d(8, 1, 1));
  const double cpu_s = test::threadCpuSeconds() - cpu_start_s;
  CHECK(r.status == PathStatus::NoPath);
  CHECK_FALSE(r.ok());
  CHECK(r.waypoints.empty());
  CHECK(r.time_s >= params.time_limit_s);
  CHECK(cpu_s < 1.0);  // the limit (0.05 s) plus set-up, with a generous margin
}

TEST_CASE("An iteration cap ends a hopeless search after exactly that many iterations", "[planner][path]") {
  const DenseMap map = test::wallRoom(false);
  PathConfig params;
  params.time_limit_s = 60.0;  // the cap, not the clock, must end it
  params.max_iterations = 200;
  PathPlanner planner(map, params);
  const PathResult r = planner.plan(Vec3d(2, 1, 1), Vec3d(8, 1, 1));
  CHECK(r.status == PathStatus::NoPath);
  CHECK(r.iterations == params.max_iterations);
  // A search that succeeds reports the iterations it used, within the cap.
  const DenseMap open = test::wallRoom(true);
  PathPlanner through(open, params);
  const PathResult found = through.plan(Vec3d(2, 1, 1), Vec3d(8, 1.2, 1.4));
  REQUIRE(found.status == PathStatus::Planned);
  CHECK(found.iterations >= 1);
  CHECK(found.iterations <= params.max_iterations);
  // A straight segment needs no search.
  CHECK(through.plan(Vec3d(1, 1, 1), Vec3d(4, 4, 1.5)).iterations == 0);
}

TEST_CASE("Starts and goals near obstacles or in unknown space are statuses", "[planner][path]") {
  const DenseMap map = test::wallRoom(true);
  PathPlanner planner(map);
  CHECK(planner.plan(Vec3d(4.9, 1, 1), Vec3d(2, 2, 1)).status == PathStatus::StartInvalid);  // 0.1 m from the wall
  CHECK(planner.plan(Vec3d(2, 2, 1), Vec3d(20, 2, 1)).status == PathStatus::GoalInvalid);    // outside the map
  CHECK(planner.plan(Vec3d(2, 2, 1), Vec3d(2, 2, 0.15)).status == PathStatus::GoalInvalid);  // near the floor
}

TEST_CASE("Paths repeat for a seed, whatever ran before", "[planner][path]") {
  const DenseMap map = test::wallRoom(true);
  PathConfig params = test::countedPaths(5000);
  params.seed = 17;
  PathPlanner a(map, params), b(map, params);
  const PathResult first = a.plan(Vec3d(2, 1, 1), Vec3d(8, 1, 1.5), 3);
  b.plan(Vec3d(8, 1, 1), Vec3d(2, 1.5, 1.5), 99);  // an unrelated query first
  const PathResult second = b.plan(Vec3d(2, 1, 1), Vec3d(8, 1, 1.5), 3);
  const PathResult again = a.plan(Vec3d(2, 1, 1), Vec3d(8, 1, 1.5), 3);
  REQUIRE(first.status == PathStatus::Planned);
  CHECK(first.waypoints == second.waypoints);
  CHECK(first.waypoints == again.waypoints);
}

TEST_CASE("The search space is the map's known bounds cut by the optional box", "[planner][path]") {
  const DenseMap map = test::wallRoom(true);
  PathConfig params = test::countedPaths(5000);  // the passage left is narrow (about 50 iterations)
  params.bounds_W = Eigen::AlignedBox3d(Vec3d(-1, -1, -1), Vec3d(6, 3, 4));  // cuts the door at y = 3 m
  PathPlanner planner(map, params);
  CHECK(planner.searchBounds().max().isApprox(Vec3d(6, 3, 2.95)));
  CHECK(planner.searchBounds().min().isApprox(Vec3d(-0.05, -0.05, -0.05)));
  const PathResult r = planner.plan(Vec3d(2, 1, 1), Vec3d(5.5, 1, 1));
  REQUIRE(r.ok());
  for (const Vec3d& p : r.waypoints) CHECK(p.y() <= 3.0);
  CHECK(planner.plan(Vec3d(2, 1, 1), Vec3d(8, 1, 1)).status == PathStatus::GoalInvalid);
}

TEST_CASE("PathConfig::validate names the field", "[planner][path]") {
  PathConfig p;
  p.time_limit_s = 0.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("time_limit_s"));
  p = PathConfig{};
  p.clearance_m = -1.0;
  const DenseMap map = test::wallRoom(true);
  CHECK_THROWS_WITH(PathPlanner(map, p), Catch::Contains("clearance_m"));
  p = PathConfig{};
  p.max_iterations = 2'000'000'000u;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("max_iterations"));
}

TEST_CASE("A path search on a CachedMap finds the same path as on its base", "[planner][path]") {
  const DenseMap map = test::wallRoom(true);
  PathConfig params;
  params.time_limit_s = 10.0;  // the iteration cap ends every search: no dependence on speed
  params.max_iterations = 5000;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    params.seed = seed;
    const CachedMap cached(map);
    PathPlanner on_base(map, params), on_cache(cached, params);
    const PathResult want = on_base.plan(Vec3d(2, 1, 1), Vec3d(8, 1.2, 1.4), seed);
    const PathResult got = on_cache.plan(Vec3d(2, 1, 1), Vec3d(8, 1.2, 1.4), seed);
    REQUIRE(want.status == PathStatus::Planned);
    CHECK(got.status == want.status);
    CHECK(got.waypoints == want.waypoints);
    CHECK(got.iterations == want.iterations);
    CHECK(cached.blocksRead() > 0);
  }
}

TEST_CASE("The planner's checks answer as a fresh probe after it remembered the clear points", "[planner][path]") {
  // PathPlanner keeps the points it found clear and reads their balls once; every later answer,
  // of segments between them and of the points themselves, must still be the probe's.
  const DenseMap map = test::wallRoom(true);
  PathConfig params;
  params.clearance_m = 0.25;
  PathPlanner planner(map, params);
  MapProbe fresh(map);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> x(0.2, 9.8), y(0.2, 5.8), z(0.2, 2.8);
  std::vector<Vec3d> points;
  for (int i = 0; i < 200; ++i) points.emplace_back(x(rng), y(rng), z(rng));
  int clear_segments = 0, blocked_segments = 0;
  for (int round = 0; round < 2; ++round)  // the second round answers from what the first kept
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Vec3d &a = points[i], &b = points[(i * 7 + 3) % points.size()];
      const bool inside = planner.searchBounds().contains(a) && planner.searchBounds().contains(b);
      REQUIRE(planner.isClear(a) == (planner.searchBounds().contains(a) && fresh.isClear(a, params.clearance_m)));
      const bool want = inside && fresh.isSegmentClear(a, b, params.clearance_m);
      REQUIRE(planner.isSegmentClear(a, b) == want);
      (want ? clear_segments : blocked_segments) += 1;
    }
  CHECK(clear_segments > 20);
  CHECK(blocked_segments > 20);
}
