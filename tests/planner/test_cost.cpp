// Travel costs: FUEL's formula, legs planned on the map, the incremental pair table and the
// open-tour matrix layout.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/cost.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// The 10 x 6 x 3 m room split at x = 5 m with a door, plus a closed box room (x 7-9 m, y 4-5.5 m).
DenseMap costRoom() {
  DenseMap map = test::makeRoom(Eigen::Vector3i(100, 60, 30));
  map.fill(CoordBBox(Coord(50, 1, 1), Coord(50, 58, 28)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(50, 25, 1), Coord(50, 35, 20)), Occupancy::Free);
  map.fill(CoordBBox(Coord(70, 40, 1), Coord(90, 55, 28)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(71, 41, 2), Coord(89, 54, 27)), Occupancy::Free);
  return map;
}
}  // namespace

TEST_CASE("motionCost is FUEL's max of travel time (with the direction term) and turning time", "[planner][cost]") {
  CostConfig p;   // 2 m/s, 0.9 rad/s
  p.w_dir = 1.5;  // FUEL's
  CHECK(motionCost(4.0, 0.0, 0.0, p) == Approx(2.0));
  CHECK(motionCost(4.0, 2.7, 0.0, p) == Approx(3.0));          // turning takes longer
  CHECK(motionCost(4.0, 0.0, M_PI / 2, p) == Approx(2.0 + 1.5 * M_PI / 2));
  CHECK(motionCost(1.0, 2.7, 0.5, p) == Approx(3.0));          // 0.5 + 0.75 < 3
  CHECK(yawDistance(3.0, -3.0) == Approx(2.0 * M_PI - 6.0));
  CHECK(wrapAngle(3.0 * M_PI) == Approx(M_PI));
  CHECK(wrapAngle(-M_PI) == Approx(M_PI));
}

TEST_CASE("CostEvaluator legs: straight, around a wall, moving, unreachable", "[planner][cost]") {
  const DenseMap map = costRoom();
  CostEvaluator eval(map, {}, test::countedPaths());
  const FlatPose a{Vec3d(1, 1, 1), 0.0};
  SECTION("straight") {
    const LegCost leg = eval.cost(a, FlatPose{Vec3d(4, 5, 1), 0.0});
    REQUIRE(leg.reachable);
    CHECK(leg.path.status == PathStatus::Straight);
    CHECK(leg.cost_s == Approx(5.0 / 2.0));
  }
  SECTION("around the wall costs the path's length") {
    const LegCost leg = eval.cost(a, FlatPose{Vec3d(8, 1, 1), 0.0});
    REQUIRE(leg.reachable);
    CHECK(leg.path.status == PathStatus::Planned);
    CHECK(leg.cost_s == Approx(leg.path.length_m / 2.0));
    CHECK(leg.cost_s > 7.0 / 2.0);
  }
  SECTION("the velocity-direction term applies from a moving state") {
    VehicleState moving;
    moving.position_W = a.position_W;
    moving.velocity_W = Vec3d(0, -1.0, 0);  // away from the target at +x
    const LegCost leg = eval.cost(moving, FlatPose{Vec3d(4, 1, 1), 0.0});
    CHECK(leg.cost_s == Approx(3.0 / 2.0 + CostConfig{}.w_dir * M_PI / 2));
  }
  SECTION("a pose inside the closed room is unreachable: a large finite cost") {
    const LegCost leg = eval.cost(a, FlatPose{Vec3d(8, 4.7, 1.5), 0.0});
    CHECK_FALSE(leg.reachable);
    CHECK(leg.cost_s == eval.params().unreachable_cost_s);
    CHECK(leg.path.status == PathStatus::NoPath);
  }
}

TEST_CASE("PairCostTable plans each new pair once and forgets pairs of removed targets", "[planner][cost]") {
  const DenseMap map = costRoom();
  PairCostTable table({}, test::countedPaths());
  std::vector<TourTarget> targets{{1, {Vec3d(1, 1, 1), 0.0}},
                                  {2, {Vec3d(4, 5, 1), 1.0}},
                                  {5, {Vec3d(8, 1, 1), 0.0}},
                                  {9, {Vec3d(8, 4.7, 1.5), 0.0}}};
  CHECK(table.update(map, targets) == 6);
  CHECK(table.pairCount() == 6);
  CHECK(table.update(map, targets) == 0);
  CHECK(table.cost(1, 2) == table.cost(2, 1));
  CHECK(table.cost(1, 2) == Approx(2.5));
  CHECK(table.cost(5, 5) == 0.0);
  CHECK_FALSE(table.reachable(1, 9));
  CHECK(table.cost(9, 2) == table.costParams().unreachable_cost_s);
  // Move target 2: its three pairs are planned again.
  targets[1].pose.position_W = Vec3d(3, 5, 1);
  CHECK(table.update(map, targets) == 3);
  CHECK(table.cost(1, 2) == Approx(std::hypot(2.0, 4.0) / 2.0));
  // Drop target 9.
  targets.pop_back();
  CHECK(table.update(map, targets) == 0);
  CHECK(table.pairCount() == 3);
  CHECK_THROWS_AS(table.cost(1, 9), std::out_of_range);
}

TEST_CASE("PairCostTable with a budget plans the shortest legs first and estimates the rest until later updates",
          "[planner][cost]") {
  const DenseMap map = costRoom();
  const std::vector<TourTarget> targets{{1, {Vec3d(1, 1, 1), 0.0}},
                                        {2, {Vec3d(4, 5, 1), 0.0}},
                                        {5, {Vec3d(8, 1, 1), 0.0}},
                                        {9, {Vec3d(8, 4.7, 1.5), 0.0}}};
  PairCostTable all({}, test::countedPaths());
  REQUIRE(all.update(map, targets) == 6);
  PairCostTable budgeted({}, test::countedPaths());
  // Straight legs, shortest first: 5-9 (3.7 m), 2-9 (4.0 m), 1-2 (5 m), 2-5 (5.7 m), 1-5 (7 m), 1-9 (7.9 m).
  CHECK(budgeted.update(map, targets, 2) == 2);
  CHECK(budgeted.pairCount() == 6);
  CHECK(budgeted.estimatedCount() == 4);
  CHECK_FALSE(budgeted.reachable(5, 9));  // planned: the closed room
  CHECK_FALSE(budgeted.reachable(2, 9));
  // An estimate is the straight leg's cost, a lower bound of the planned one (around the wall).
  CHECK(budgeted.reachable(1, 5));
  CHECK(budgeted.cost(1, 5) == Approx(7.0 / 2.0));
  CHECK(budgeted.cost(1, 5) < all.cost(1, 5));
  CHECK(budgeted.update(map, targets, 2) == 2);
  CHECK(budgeted.estimatedCount() == 2);
  CHECK(budgeted.cost(1, 2) == all.cost(1, 2));
  CHECK(budgeted.update(map, targets, 2) == 2);
  CHECK(budgeted.estimatedCount() == 0);
  CHECK(budgeted.update(map, targets, 2) == 0);
  // Planned late, each pair's cost is the one planned at once (legs are seeded by their ids).
  for (const TourTarget& a : targets)
    for (const TourTarget& b : targets) {
      CHECK(budgeted.cost(a.cluster, b.cluster) == all.cost(a.cluster, b.cluster));
      CHECK(budgeted.reachable(a.cluster, b.cluster) == all.reachable(a.cluster, b.cluster));
    }
}

TEST_CASE("The tour matrix: vehicle row, zero return column, pair costs", "[planner][cost]") {
  const DenseMap map = costRoom();
  PairCostTable table;
  const std::vector<TourTarget> targets{{3, {Vec3d(1, 1, 1), 0.0}}, {4, {Vec3d(4, 5, 1), 0.0}}};
  table.update(map, targets);
  const RealCostMatrix m = buildTourCostMatrix({0.5, 0.7}, targets, table);
  REQUIRE(m.size() == 3);
  CHECK(m(0, 1) == 0.5);
  CHECK(m(0, 2) == 0.7);
  CHECK(m(1, 0) == 0.0);
  CHECK(m(2, 0) == 0.0);
  CHECK(m(1, 2) == Approx(2.5));
  CHECK(m(2, 1) == Approx(2.5));
  CHECK_THROWS_AS(buildTourCostMatrix({0.5}, targets, table), std::invalid_argument);
  // Legs from the vehicle, in parallel, match single evaluations.
  VehicleState v;
  v.position_W = Vec3d(2, 2, 1);
  const std::vector<LegCost> legs = costsFromVehicle(map, v, targets);
  CostEvaluator eval(map);
  CHECK(legs[0].cost_s == Approx(eval.cost(v, targets[0].pose).cost_s));
  CHECK(legs[1].cost_s == Approx(eval.cost(v, targets[1].pose).cost_s));
}
