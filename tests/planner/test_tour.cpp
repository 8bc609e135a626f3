// The global tour: the open-tour cost equals the solver's result recomputed from the matrix, the
// order is a permutation, and small tours are optimal (brute force).
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/tour.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <numeric>
#include <random>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// An open-tour matrix over random points: travel time at 2 m/s, zero return column.
RealCostMatrix randomTourMatrix(std::size_t targets, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 20.0);
  std::vector<Vec3d> p(targets + 1);
  for (Vec3d& x : p) x = Vec3d(u(rng), u(rng), 0.0);
  RealCostMatrix m(targets + 1, 0.0);
  for (std::size_t i = 0; i <= targets; ++i)
    for (std::size_t j = 1; j <= targets; ++j)
      if (i != j) m(i, j) = (p[i] - p[j]).norm() / 2.0 + (i == 0 ? 0.3 * double(j % 3) : 0.0);  // asymmetric row 0
  return m;
}

double bruteForceOpenTour(const RealCostMatrix& m) {
  std::vector<std::size_t> order(m.size() - 1);
  std::iota(order.begin(), order.end(), 0);
  double best = 1e300;
  do best = std::min(best, openTourCost(m, order));
  while (std::next_permutation(order.begin(), order.end()));
  return best;
}
}  // namespace

TEST_CASE("openTourCost sums the legs from the vehicle and rejects non-permutations", "[planner][tour]") {
  RealCostMatrix m(3, 0.0);
  m(0, 1) = 1.0, m(0, 2) = 5.0, m(1, 2) = 2.0, m(2, 1) = 7.0;
  CHECK(openTourCost(m, {0, 1}) == 3.0);
  CHECK(openTourCost(m, {1, 0}) == 12.0);
  CHECK_THROWS_AS(openTourCost(m, {0, 0}), std::invalid_argument);
  CHECK_THROWS_AS(openTourCost(m, {0}), std::invalid_argument);
}

TEST_CASE("A tour of tens of clusters stops once it has settled, long before a generous limit", "[planner][tour]") {
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    const RealCostMatrix m = randomTourMatrix(30, seed);
    TourConfig settling;
    settling.time_limit_s = 60.0;  // never reached: the default stale-round rule ends the search
    const TourResult settled = solveOpenTour(m, settling);
    INFO("seed " << seed);
    REQUIRE((settled.status == AtspStatus::kSettled || settled.status == AtspStatus::kOptimal));
    // The same rounds without the rule, capped well beyond where it stopped: no shorter tour.
    TourConfig capped = settling;
    capped.max_stale_iterations = 0;
    capped.max_iterations = 20000;
    CHECK(solveOpenTour(m, capped).cost_s >= settled.cost_s - 1e-9);
  }
}

TEST_CASE("Small open tours are optimal and their cost is the matrix's", "[planner][tour]") {
  for (std::uint32_t seed = 1; seed <= 5; ++seed) {
    const RealCostMatrix m = randomTourMatrix(7, seed);
    TourConfig p;
    p.time_limit_s = 10.0;  // the exact search's proof ends it
    const TourResult t = solveOpenTour(m, p);
    std::vector<std::size_t> sorted = t.order;
    std::sort(sorted.begin(), sorted.end());
    REQUIRE(sorted == (std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6}));
    CHECK(t.cost_s == openTourCost(m, t.order));
    CHECK(t.optimal_proven);
    CHECK(t.cost_s == Approx(bruteForceOpenTour(m)).epsilon(1e-9));
  }
}

TEST_CASE("Large open tours: a permutation whose cost is the matrix's", "[planner][tour]") {
  const RealCostMatrix m = randomTourMatrix(40, 3);
  TourConfig p;
  p.time_limit_s = 0.2;
  const TourResult t = solveOpenTour(m, p);
  std::vector<std::size_t> sorted = t.order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::size_t> all(40);
  std::iota(all.begin(), all.end(), 0);
  REQUIRE(sorted == all);
  CHECK(t.cost_s == openTourCost(m, t.order));
  // Better than visiting in index order.
  CHECK(t.cost_s <= openTourCost(m, all));
}

TEST_CASE("Tours of zero and one target need no solver", "[planner][tour]") {
  CHECK(solveOpenTour(RealCostMatrix(1, 0.0)).order.empty());
  RealCostMatrix one(2, 0.0);
  one(0, 1) = 4.0;
  const TourResult t = solveOpenTour(one);
  CHECK(t.order == std::vector<std::size_t>{0});
  CHECK(t.cost_s == 4.0);
}

TEST_CASE("planGlobalTour over clusters of a map: the open-tour cost equals the matrix's", "[planner][tour]") {
  // A room with free space known everywhere but a few unknown pockets: each pocket is a cluster.
  DenseMap map = test::makeRoom(Eigen::Vector3i(120, 80, 30));
  const Coord pockets[] = {Coord(20, 20, 8), Coord(90, 15, 8), Coord(60, 60, 8), Coord(15, 65, 8), Coord(100, 60, 8)};
  for (const Coord& c : pockets) map.fill(CoordBBox(c, c + Coord(5, 5, 6)), Occupancy::Unknown);
  FrontierConfig fp;
  fp.min_cluster_size = 50;
  FrontierMap frontiers(fp);
  frontiers.rebuild(map);
  REQUIRE(frontiers.clusters().size() == 5);
  std::vector<TourTarget> targets;
  for (const FrontierCluster& c : frontiers.clusters()) {
    const std::vector<Viewpoint> views = computeViewpoints(c, map);
    REQUIRE_FALSE(views.empty());
    targets.push_back({c.id, {views.front().position_W, views.front().yaw_rad}});
  }
  VehicleState vehicle;
  vehicle.position_W = Vec3d(6, 4, 1.2);
  PairCostTable table;
  const GlobalTour g = planGlobalTour(map, vehicle, targets, table);
  REQUIRE(g.tour.order.size() == 5);
  CHECK(g.tour.cost_s == openTourCost(g.costs, g.tour.order));
  CHECK(g.tour.optimal_proven);
  CHECK(g.tour.cost_s == Approx(bruteForceOpenTour(g.costs)));
  for (std::size_t i = 0; i < targets.size(); ++i) {
    CHECK(g.costs(0, i + 1) == g.from_vehicle[i].cost_s);
    CHECK(g.costs(i + 1, 0) == 0.0);
  }
}
