// The built-in coverage flight (sim/coverage.hpp).
#include <catch2/catch.hpp>

#include "sim/sim_test_helpers.hpp"
#include "vdbmap/sim/coverage.hpp"

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// The smallest distance to the world over every sample of the trajectory.
double minClearance(const World& world, const SampledTrajectory& t) {
  double worst = std::numeric_limits<double>::infinity();
  for (const VehicleState& s : t.states()) worst = std::min(worst, world.distance(s.position_W, 1.0));
  return worst;
}
}  // namespace

TEST_CASE("the house coverage flight is collision-free, within the limits, and returns to its start",
          "[sim][coverage]") {
  const World world = World::load(test::houseMesh());
  const CoverageConfig config;
  const CoveragePlan plan = planCoverage(world, config);
  const SampledTrajectory& t = plan.trajectory;
  REQUIRE_FALSE(t.empty());
  // Every 5 ms sample keeps the clearance (conservative line-of-sight checks allow 5 % less
  // between their samples); a sample 5 ms apart moves at most 1 cm.
  CHECK(minClearance(world, t) >= 0.95 * config.clearance_m);
  CHECK(t.maxima().within(config.limits));
  CHECK((t.states().back().position_W - plan.start_W).norm() < 1e-9);
  CHECK((t.states().front().position_W - plan.start_W).norm() < 1e-9);
  CHECK(plan.returns >= 1);  // passes back through the start during the flight, not only at its end
  // In the ballpark of the paper's house run (1468 frames at 15 Hz).
  CHECK(t.duration() * 15.0 > 1000);
  CHECK(t.duration() * 15.0 < 2500);
  // It covers the house: the vehicle flies through every quarter of the floor, well away from the middle.
  const Eigen::AlignedBox3d& b = world.bounds();
  for (int q = 0; q < 4; ++q) {
    const double sx = q & 1 ? 1 : -1, sy = q & 2 ? 1 : -1;
    bool visited = false;
    for (const VehicleState& s : t.states())
      visited = visited || ((s.position_W.x() - b.center().x()) * sx > 0.25 * b.sizes().x() &&
                            (s.position_W.y() - b.center().y()) * sy > 0.1 * b.sizes().y());
    CAPTURE(q);
    CHECK(visited);
  }
}

TEST_CASE("coverage of two rooms joined by a door goes through the door and back", "[sim][coverage]") {
  // Two 5 x 4 m rooms side by side; the wall between them at x = 0 has a 1.2 m door.
  TriangleMesh m;
  test::addBox(m, {-5, -2, 0}, {5, 2, 2.5});
  test::addBox(m, {-0.05, -2, 0}, {0.05, -0.6, 2.5});
  test::addBox(m, {-0.05, 0.6, 0}, {0.05, 2, 2.5});
  const World world(m);
  CoverageConfig config;
  config.start_xy = Eigen::Vector2d(-3.0, 0.0);
  const CoveragePlan plan = planCoverage(world, config);
  const SampledTrajectory& t = plan.trajectory;
  bool east = false;
  for (const VehicleState& s : t.states()) {
    east = east || s.position_W.x() > 2.0;
    if (std::abs(s.position_W.x()) < 0.05) CHECK(std::abs(s.position_W.y()) < 0.6 - config.clearance_m * 0.95 + 1e-9);
  }
  CHECK(east);
  CHECK(minClearance(world, t) >= 0.95 * config.clearance_m);
  CHECK((t.states().back().position_W.head<2>() - Eigen::Vector2d(-3.0, 0.0)).norm() < 0.05);
  // A start inside the wall is refused.
  config.start_xy = Eigen::Vector2d(0.0, -1.5);
  CHECK_THROWS_WITH(planCoverage(world, config), Catch::Contains("start"));
}
