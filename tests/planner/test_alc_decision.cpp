// Active loop closure, the tour decision (Algorithm 2 with the text's rule) on hand-made cost
// matrices: the detour is taken at exactly (1 + epsilon) C_frt and not above, epsilon = 0 only when
// the detour is free; c* is the cheapest cluster from the vehicle; M_loop equals a matrix built
// from scratch on a map; a timed-out cluster is not chosen again until the suspension ends; no
// ALC in a flight's first seconds nor right after a loop closure; the loop before finishing.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/active_loop_closure.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <map>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {

constexpr LoopClusterId kA = 0, kB = 1;  // the two loop clusters flyPlaces() creates

/// ALC parameters for the hand-made histories: every pose recorded, clusters after 1 s.
AlcConfig testParams() {
  AlcConfig p;
  p.history.record_spacing_m = 0.0;
  p.clusters.min_age_s = 1.0;
  p.clusters.link_distance_m = 0.5;
  return p;
}

/// Two places flown in the first 3.5 s: cluster A around (0.125, 0, 1) (centre yaw 0) and cluster
/// B around (5.125, 0, 1) (yaw pi/2); a far last pose ends B's run.
void flyPlaces(ActiveLoopClosure& alc) {
  double t = 0.0;
  for (const double x : {0.0, 0.125, 0.25}) alc.addFlownPose(Vec3d(x, 0, 1), 0.0, t += 0.5);
  for (const double x : {5.0, 5.125, 5.25}) alc.addFlownPose(Vec3d(x, 0, 1), M_PI / 2, t += 0.5);
  alc.addFlownPose(Vec3d(50, 50, 1), 0.0, t += 0.5);
}

/// The vehicle: 0.875 m from A's centre, 4.125 m from B's.
VehicleState vehicleAt(const Vec3d& p = Vec3d(1, 0, 1)) {
  VehicleState v;
  v.position_W = p;
  v.velocity_W = Vec3d(0.5, 0, 0);
  return v;
}

/// Three frontier targets. M_frt: from the vehicle 2, 4, 6; between them d(1,2) = d(2,3) = 3,
/// d(1,3) = 6. The best open tour is 1, 2, 3 at C_frt = 2 + 3 + 3 = 8.
const std::vector<TourTarget> kTargets{
    {100, {Vec3d(3, 0, 1), 0.0}}, {101, {Vec3d(3, 3, 1), 0.0}}, {102, {Vec3d(0, 3, 1), 0.0}}};

RealCostMatrix frontierMatrix() {
  RealCostMatrix m(4, 0.0);
  m(0, 1) = 2, m(0, 2) = 4, m(0, 3) = 6;
  m(1, 2) = m(2, 1) = 3;
  m(2, 3) = m(3, 2) = 3;
  m(1, 3) = m(3, 1) = 6;
  return m;
}

/// Hand-made legs: from the vehicle to each cluster centre (by cluster id), and from any cluster
/// centre to the three targets ({1, 4, 6}: the tour from there is 1, 2, 3 at 1 + 3 + 3 = 7).
struct FakeLegs {
  Vec3d vehicle_W = vehicleAt().position_W;
  std::map<LoopClusterId, double> to_cluster{{kA, 1.0}, {kB, 1.5}};
  std::map<LoopClusterId, bool> reachable{{kA, true}, {kB, true}};
  std::vector<double> from_cluster{1.0, 4.0, 6.0};
  std::vector<std::size_t> row_sizes;  ///< every row asked for

  LegCostFunction function() {
    return [this](const VehicleState& from, const std::vector<TourTarget>& to) {
      row_sizes.push_back(to.size());
      std::vector<LegCost> legs(to.size());
      for (std::size_t k = 0; k < to.size(); ++k) {
        if (from.position_W == vehicle_W) {
          legs[k].reachable = reachable.at(to[k].cluster);
          legs[k].cost_s = legs[k].reachable ? to_cluster.at(to[k].cluster) : 1000.0;
        } else {
          REQUIRE(from.velocity_W.isZero());  // legs from a loop cluster start at rest
          legs[k].reachable = true;
          legs[k].cost_s = from_cluster.at(k);
        }
      }
      return legs;
    };
  }
};

AlcDecision decideAt(ActiveLoopClosure& alc, FakeLegs& legs, double now_s, bool loop_closed = false,
                     const VehicleState& vehicle = vehicleAt()) {
  return alc.decide(vehicle, now_s, loop_closed, kTargets, frontierMatrix(), legs.function());
}

}  // namespace

TEST_CASE("ALC takes the loop tour at exactly (1 + epsilon) C_frt and not above it", "[planner][alc]") {
  CHECK(AlcConfig{}.epsilon == 0.2);
  for (const double epsilon : {0.25, 0.5, 1.0}) {
    AlcConfig p = testParams();
    p.epsilon = epsilon;
    const double threshold = (1.0 + epsilon) * 8.0;  // exact in binary for these epsilons
    for (const double above : {0.0, 1e-9}) {
      ActiveLoopClosure alc(p);
      flyPlaces(alc);
      FakeLegs legs;
      legs.to_cluster[kA] = threshold - 7.0 + above;  // C_loop = to c* + 7
      const AlcDecision d = decideAt(alc, legs, 30.0);
      CAPTURE(epsilon, above);
      CHECK(d.frontier_cost_s == 8.0);
      CHECK(d.frontier_tour.order == std::vector<std::size_t>{0, 1, 2});
      REQUIRE(d.cluster == std::optional<LoopClusterId>(kA));
      CHECK(d.loop_cost_s == legs.to_cluster[kA] + 7.0);
      CHECK(d.loop_tour.order == std::vector<std::size_t>{0, 1, 2});
      CHECK(d.status == (above == 0.0 ? AlcStatus::kDetour : AlcStatus::kFrontierCheaper));
      CHECK(alc.stats(30.0).detours == (above == 0.0 ? 1u : 0u));
      CHECK(d.order() == std::vector<std::size_t>{0, 1, 2});
    }
  }
  SECTION("the default epsilon: 0.2") {
    for (const auto& [to_a, expected] :
         {std::pair{2.5, AlcStatus::kDetour}, std::pair{2.7, AlcStatus::kFrontierCheaper}}) {
      ActiveLoopClosure alc(testParams());
      flyPlaces(alc);
      FakeLegs legs;
      legs.to_cluster[kA] = to_a;  // C_loop 9.5 or 9.7 against 1.2 x 8 = 9.6
      CHECK(decideAt(alc, legs, 30.0).status == expected);
    }
  }
}

TEST_CASE("With epsilon = 0 ALC detours only when the detour is free", "[planner][alc]") {
  AlcConfig p = testParams();
  p.epsilon = 0.0;
  for (const double extra : {0.0, 1e-9, 0.5}) {
    ActiveLoopClosure alc(p);
    flyPlaces(alc);
    FakeLegs legs;
    legs.to_cluster[kA] = 1.0 + extra;  // 1 + 7 = C_frt: the cluster lies on the way
    const AlcDecision d = decideAt(alc, legs, 30.0);
    CAPTURE(extra);
    CHECK(d.loop_cost_s == legs.to_cluster[kA] + 7.0);
    CHECK(d.status == (extra == 0.0 ? AlcStatus::kDetour : AlcStatus::kFrontierCheaper));
  }
}

TEST_CASE("c* is the cluster cheapest to reach from the current state; only two cost rows are asked for",
          "[planner][alc]") {
  AlcConfig p = testParams();
  p.search_radius_m = 10.0;  // both clusters are candidates
  ActiveLoopClosure alc(p);
  flyPlaces(alc);
  FakeLegs legs;
  legs.to_cluster = {{kA, 4.0}, {kB, 2.0}};
  AlcDecision d = decideAt(alc, legs, 30.0);
  CHECK(d.cluster == std::optional<LoopClusterId>(kB));
  CHECK(d.to_cluster.cost_s == 2.0);
  CHECK(d.loop_cost_s == 9.0);
  CHECK(d.status == AlcStatus::kDetour);
  // The legs asked for: vehicle -> the two centres, then c* -> the three targets. M_loop reuses
  // every other entry of M_frt.
  CHECK(legs.row_sizes == std::vector<std::size_t>{2, 3});
  const RealCostMatrix m = frontierMatrix();
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t j = 0; j < 4; ++j)
      CHECK(d.loop_costs(i, j) == (i == 0 && j > 0 ? legs.from_cluster[j - 1] : m(i, j)));
  // The decision carries c*'s viewpoints for local refinement: its centre first.
  REQUIRE(d.cluster_viewpoints.size() == 3);
  CHECK(d.cluster_viewpoints[0].position_W == Vec3d(5.125, 0, 1));
  CHECK(d.cluster_viewpoints[0].yaw_rad == Approx(M_PI / 2));

  SECTION("ties go to the older cluster; unreachable clusters are skipped") {
    ActiveLoopClosure tie(p);
    flyPlaces(tie);
    FakeLegs same;
    same.to_cluster = {{kA, 2.0}, {kB, 2.0}};
    CHECK(decideAt(tie, same, 30.0).cluster == std::optional<LoopClusterId>(kA));
    ActiveLoopClosure blocked(p);
    flyPlaces(blocked);
    FakeLegs no_a;
    no_a.to_cluster = {{kA, 0.5}, {kB, 2.0}};
    no_a.reachable[kA] = false;
    CHECK(decideAt(blocked, no_a, 30.0).cluster == std::optional<LoopClusterId>(kB));
  }
}

TEST_CASE("M_loop, M_frt with row 0 from c*, equals the matrix built from scratch on a map", "[planner][alc]") {
  const DenseMap map = test::makeRoom(Eigen::Vector3i(100, 60, 30));  // 10 x 6 x 3 m, free inside
  PairCostTable table;
  const std::vector<TourTarget> targets{{7, {Vec3d(8, 1, 1.5), 0.3}},
                                        {8, {Vec3d(8, 5, 1.5), 2.0}},
                                        {9, {Vec3d(2, 5, 1.5), -1.0}},
                                        {10, {Vec3d(5, 3, 2.0), 3.0}}};
  VehicleState vehicle;
  vehicle.position_W = Vec3d(3, 1.5, 1.5);
  vehicle.velocity_W = Vec3d(0.5, 0.2, 0.0);  // the direction term makes row 0 of M_frt differ
  vehicle.yaw_rad = 0.2;

  ActiveLoopClosure alc(testParams());
  for (const double x : {2.0, 2.125, 2.25}) alc.addFlownPose(Vec3d(x, 1, 1.5), 1.0, x);
  alc.addFlownPose(Vec3d(9, 5, 1.5), 0.0, 3.0);

  table.update(map, targets);
  std::vector<double> row;
  for (const LegCost& leg : costsFromVehicle(map, vehicle, targets, table.costParams(), table.pathParams()))
    row.push_back(leg.cost_s);
  const RealCostMatrix frontier = buildTourCostMatrix(row, targets, table);
  const AlcDecision d = alc.decide(vehicle, 30.0, false, targets, frontier, mapLegCosts(map, table));
  REQUIRE(d.cluster == std::optional<LoopClusterId>(0));

  // From scratch: every entry by a fresh CostEvaluator, c* (its centre, at rest) as node 0.
  const FlownViewpoint& c = alc.history()[alc.clusters()[0].centre];
  const FlatPose centre{c.position_W, c.yaw_rad};
  CHECK(centre.position_W == Vec3d(2.125, 1, 1.5));
  CostEvaluator eval(map, table.costParams(), table.pathParams());
  const std::size_t n = targets.size() + 1;
  RealCostMatrix scratch(n, 0.0);
  for (std::size_t j = 1; j < n; ++j) scratch(0, j) = eval.cost(centre, targets[j - 1].pose).cost_s;
  for (std::size_t i = 1; i < n; ++i)
    for (std::size_t j = 1; j < n; ++j)
      if (i != j) scratch(i, j) = eval.cost(targets[i - 1].pose, targets[j - 1].pose).cost_s;
  REQUIRE(d.loop_costs.size() == n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) {
      CAPTURE(i, j);
      CHECK(d.loop_costs(i, j) == scratch(i, j));
    }
  CHECK(d.loop_costs(0, 1) != frontier(0, 1));
  CHECK(d.to_cluster.cost_s == eval.cost(vehicle, centre).cost_s);
  CHECK(d.loop_cost_s == Approx(d.to_cluster.cost_s + openTourCost(scratch, d.loop_tour.order)).epsilon(1e-12));
  CHECK(d.frontier_cost_s == Approx(openTourCost(frontier, d.frontier_tour.order)).epsilon(1e-12));
}

TEST_CASE("A timed-out cluster is not chosen again until the suspension ends", "[planner][alc]") {
  AlcConfig p = testParams();  // give up after 15 s, suspend 10 s, retire a cluster after 2 failures
  p.search_radius_m = 10.0;
  ActiveLoopClosure alc(p);
  flyPlaces(alc);
  FakeLegs legs;  // A costs 1 (C_loop 8), B 1.5 (C_loop 8.5): A first, both worth a detour

  CHECK(decideAt(alc, legs, 30.0).status == AlcStatus::kDetour);
  REQUIRE(alc.detour());
  CHECK(alc.detour()->cluster == kA);
  // The detour is kept at later replans even if B became cheaper, until the timeout.
  legs.to_cluster[kB] = 0.5;
  AlcDecision d = decideAt(alc, legs, 40.0);
  CHECK(d.status == AlcStatus::kDetour);
  CHECK(d.cluster == std::optional<LoopClusterId>(kA));
  CHECK_FALSE(alc.detourTimedOut(44.9));
  CHECK(alc.detourTimedOut(45.0));

  CHECK(decideAt(alc, legs, 45.0).status == AlcStatus::kGaveUp);
  CHECK_FALSE(alc.detour());
  CHECK(alc.failures(kA) == 1);
  CHECK(alc.suspendedUntil() == std::optional<double>(55.0));
  for (const double t : {45.5, 50.0, 54.999}) {
    d = decideAt(alc, legs, t);
    CHECK(d.status == AlcStatus::kSuspended);
    CHECK_FALSE(d.cluster);
    CHECK(d.order() == std::vector<std::size_t>{0, 1, 2});  // the frontier tour
  }
  // After the suspension A may be chosen again (one failure is below the limit of 2): make it
  // the cheapest again.
  legs.to_cluster[kB] = 1.5;
  d = decideAt(alc, legs, 55.0);
  CHECK(d.status == AlcStatus::kDetour);
  CHECK(d.cluster == std::optional<LoopClusterId>(kA));
  CHECK(decideAt(alc, legs, 70.0).status == AlcStatus::kGaveUp);
  CHECK(alc.failures(kA) == 2);
  CHECK(decideAt(alc, legs, 79.0).status == AlcStatus::kSuspended);
  // A is retired now: B is chosen, though A is cheaper.
  d = decideAt(alc, legs, 80.0);
  CHECK(d.status == AlcStatus::kDetour);
  CHECK(d.cluster == std::optional<LoopClusterId>(kB));

  const AlcStats s = alc.stats(85.0);
  CHECK(s.detours == 3);
  CHECK(s.give_ups == 2);
  CHECK(s.loops_on_detour == 0);
  CHECK(s.detour_time_s == Approx(15.0 + 15.0 + 5.0));

  SECTION("with max_failures_per_cluster = 1 and only A in range, ALC finds no cluster after the suspension") {
    AlcConfig once = testParams();
    once.max_failures_per_cluster = 1;
    ActiveLoopClosure one(once);
    flyPlaces(one);
    FakeLegs l;
    CHECK(decideAt(one, l, 30.0).status == AlcStatus::kDetour);
    CHECK(decideAt(one, l, 45.0).status == AlcStatus::kGaveUp);
    CHECK(decideAt(one, l, 54.0).status == AlcStatus::kSuspended);
    CHECK(decideAt(one, l, 55.0).status == AlcStatus::kNoCluster);
  }
  SECTION("a detour whose cluster can no longer be reached is given up at once") {
    ActiveLoopClosure lost(testParams());
    flyPlaces(lost);
    FakeLegs l;
    CHECK(decideAt(lost, l, 30.0).status == AlcStatus::kDetour);
    l.reachable[kA] = false;
    CHECK(decideAt(lost, l, 31.0).status == AlcStatus::kNoReachableCluster);
    CHECK_FALSE(lost.detour());
    CHECK(lost.failures(kA) == 1);
    CHECK(decideAt(lost, l, 32.0).status == AlcStatus::kSuspended);
  }
}

TEST_CASE("A loop closure ends a detour and quiets ALC for loop_quiet_s", "[planner][alc]") {
  ActiveLoopClosure alc(testParams());  // quiet 30 s
  flyPlaces(alc);
  FakeLegs legs;
  CHECK(decideAt(alc, legs, 30.0).status == AlcStatus::kDetour);
  CHECK(decideAt(alc, legs, 34.0, true).status == AlcStatus::kQuietAfterLoop);
  CHECK_FALSE(alc.detour());
  CHECK(alc.failures(kA) == 0);
  AlcStats s = alc.stats(34.0);
  CHECK(s.loops_on_detour == 1);
  CHECK(s.detour_time_s == Approx(4.0));
  CHECK(decideAt(alc, legs, 63.9).status == AlcStatus::kQuietAfterLoop);
  CHECK(decideAt(alc, legs, 64.0).status == AlcStatus::kDetour);

  SECTION("a loop closed without a detour quiets ALC too") {
    ActiveLoopClosure natural(testParams());
    flyPlaces(natural);
    CHECK(decideAt(natural, legs, 25.0, true).status == AlcStatus::kQuietAfterLoop);
    CHECK(decideAt(natural, legs, 54.9).status == AlcStatus::kQuietAfterLoop);
    CHECK(decideAt(natural, legs, 55.0).status == AlcStatus::kDetour);
    CHECK(natural.stats(55.0).loops_on_detour == 0);
  }
}

TEST_CASE("No ALC during the first initial_period_s of a flight", "[planner][alc]") {
  ActiveLoopClosure alc(testParams(), 5.0);  // the flight starts at 5 s; initial period 20 s
  flyPlaces(alc);
  FakeLegs legs;
  const AlcDecision d = decideAt(alc, legs, 24.9);
  CHECK(d.status == AlcStatus::kInitialPeriod);
  CHECK(alc.clusters().size() == 2);  // clusters exist: only the period holds ALC back
  CHECK(legs.row_sizes.empty());      // and nothing was costed
  CHECK(d.frontier_cost_s == 8.0);
  CHECK(decideAt(alc, legs, 25.0).status == AlcStatus::kDetour);
}

TEST_CASE("Before finishing, ALC closes a loop when the last one is older than finish_loop_age_s", "[planner][alc]") {
  AlcConfig p = testParams();  // a loop before finishing after 10 s without one, within 10 m
  ActiveLoopClosure alc(p);
  flyPlaces(alc);
  FakeLegs legs;  // A costs 1, B 1.5
  const auto finishAt = [&](double now_s, bool loop_closed = false) {
    return alc.decideFinish(vehicleAt(), now_s, loop_closed, legs.function());
  };
  CHECK(decideAt(alc, legs, 25.0, true).status == AlcStatus::kQuietAfterLoop);  // a loop at 25 s
  legs.row_sizes.clear();
  CHECK(finishAt(34.9).status == AlcStatus::kNoFrontier);  // 9.9 s since the loop: finish
  CHECK_FALSE(alc.detour());
  CHECK(legs.row_sizes.empty());  // nothing was costed

  AlcDecision d = finishAt(35.0);
  CHECK(d.status == AlcStatus::kDetour);
  CHECK(d.cluster == std::optional<LoopClusterId>(kA));  // the cheapest
  CHECK(d.to_cluster.cost_s == 1.0);
  REQUIRE_FALSE(d.cluster_viewpoints.empty());
  CHECK(d.cluster_viewpoints.front().position_W.isApprox(Vec3d(0.125, 0, 1)));  // the centre first
  CHECK(d.order().empty());
  CHECK(legs.row_sizes == std::vector<std::size_t>{2});  // only the legs to the two centres
  REQUIRE(alc.detour());
  CHECK(alc.detour()->before_finish);

  SECTION("each detour goes on until its timeout; at most max_finish_detours, then exploration finishes") {
    legs.to_cluster[kB] = 0.5;
    d = finishAt(45.0);
    CHECK(d.status == AlcStatus::kDetour);
    CHECK(d.cluster == std::optional<LoopClusterId>(kA));
    CHECK(alc.detourTimedOut(50.0));
    d = finishAt(50.0);  // given up, and the next one starts at once
    CHECK(d.status == AlcStatus::kDetour);
    CHECK(d.cluster == std::optional<LoopClusterId>(kB));  // now the cheapest
    CHECK(alc.failures(kA) == 1);
    CHECK(alc.stats(50.0).give_ups == 1);
    CHECK(finishAt(65.0).cluster == std::optional<LoopClusterId>(kB));  // one failure is below the limit
    CHECK(alc.failures(kB) == 1);
    CHECK(p.max_finish_detours == 3);
    CHECK(finishAt(80.0).status == AlcStatus::kGaveUp);  // the third given up: finish
    CHECK_FALSE(alc.detour());
    CHECK(finishAt(81.0).status == AlcStatus::kNoFrontier);
    const AlcStats s = alc.stats(81.0);
    CHECK(s.detours == 3);
    CHECK(s.finish_detours == 3);
    CHECK(s.give_ups == 3);
  }
  SECTION("a loop closure ends it: exploration finishes") {
    CHECK(finishAt(38.0, true).status == AlcStatus::kNoFrontier);
    CHECK_FALSE(alc.detour());
    CHECK(alc.stats(38.0).loops_on_detour == 1);
    CHECK(alc.failures(kA) == 0);
  }
  SECTION("frontiers that appear during it do not end it") {
    d = decideAt(alc, legs, 36.0);
    CHECK(d.status == AlcStatus::kDetour);
    CHECK(d.cluster == std::optional<LoopClusterId>(kA));
    CHECK(alc.detour()->before_finish);
  }
}

TEST_CASE("ALC's loop before finishing: off, out of range, unreachable; an exploring detour ends", "[planner][alc]") {
  FakeLegs legs;
  SECTION("finish_loop_age_s = 0 finishes at once, ending an exploring detour") {
    AlcConfig p = testParams();
    p.finish_loop_age_s = 0.0;
    ActiveLoopClosure alc(p);
    flyPlaces(alc);
    CHECK(decideAt(alc, legs, 30.0).status == AlcStatus::kDetour);
    CHECK(alc.decideFinish(vehicleAt(), 31.0, false, legs.function()).status == AlcStatus::kNoFrontier);
    CHECK_FALSE(alc.detour());
    CHECK(alc.stats(31.0).detour_time_s == Approx(1.0));
  }
  SECTION("an exploring detour in progress gives way to the one before finishing") {
    ActiveLoopClosure alc(testParams());
    flyPlaces(alc);
    CHECK(decideAt(alc, legs, 30.0).status == AlcStatus::kDetour);
    CHECK_FALSE(alc.detour()->before_finish);
    CHECK(alc.decideFinish(vehicleAt(), 31.0, false, legs.function()).status == AlcStatus::kDetour);
    REQUIRE(alc.detour());
    CHECK(alc.detour()->before_finish);
    CHECK(alc.detour()->since_s == 31.0);
    CHECK(alc.stats(31.0).detours == 2);
  }
  SECTION("no cluster within finish_search_radius_m") {
    AlcConfig p = testParams();
    p.finish_search_radius_m = 0.5;  // A's viewpoints lie 0.75 m and more from the vehicle
    ActiveLoopClosure alc(p);
    flyPlaces(alc);
    CHECK(alc.decideFinish(vehicleAt(), 30.0, false, legs.function()).status == AlcStatus::kNoCluster);
    CHECK(alc.stats(30.0).finish_detours == 0);
  }
  SECTION("no reachable cluster: nothing tried, nothing given up") {
    ActiveLoopClosure alc(testParams());
    flyPlaces(alc);
    legs.reachable[kA] = legs.reachable[kB] = false;
    CHECK(alc.decideFinish(vehicleAt(), 30.0, false, legs.function()).status == AlcStatus::kNoReachableCluster);
    CHECK(alc.failures(kA) == 0);
    legs.reachable[kB] = true;
    CHECK(alc.decideFinish(vehicleAt(), 31.0, false, legs.function()).cluster == std::optional<LoopClusterId>(kB));
  }
  SECTION("misuse") {
    ActiveLoopClosure alc(testParams());
    alc.decideFinish(vehicleAt(), 30.0, false, legs.function());
    CHECK_THROWS_AS(alc.decideFinish(vehicleAt(), 29.0, false, legs.function()), std::invalid_argument);
    AlcConfig bad;
    bad.finish_loop_age_s = -1.0;
    CHECK_THROWS_WITH(ActiveLoopClosure(bad), Catch::Contains("finish_loop_age_s"));
    bad = AlcConfig{};
    bad.finish_search_radius_m = 0.0;
    CHECK_THROWS_WITH(ActiveLoopClosure(bad), Catch::Contains("finish_search_radius_m"));
    bad = AlcConfig{};
    bad.max_finish_detours = 0;
    CHECK_THROWS_WITH(ActiveLoopClosure(bad), Catch::Contains("max_finish_detours"));
  }
}

TEST_CASE("ALC's other outcomes and misuse", "[planner][alc]") {
  ActiveLoopClosure alc(testParams());
  flyPlaces(alc);
  FakeLegs legs;
  SECTION("no cluster within the search radius") {
    legs.vehicle_W = Vec3d(20, 20, 1);
    CHECK(decideAt(alc, legs, 30.0, false, vehicleAt(legs.vehicle_W)).status == AlcStatus::kNoCluster);
  }
  SECTION("no reachable cluster") {
    legs.reachable[kA] = false;
    CHECK(decideAt(alc, legs, 30.0).status == AlcStatus::kNoReachableCluster);
    CHECK(alc.failures(kA) == 0);  // not a detour: nothing to give up
  }
  SECTION("no frontier target left") {
    const AlcDecision d = alc.decide(vehicleAt(), 30.0, false, {}, RealCostMatrix(1, 0.0), legs.function());
    CHECK(d.status == AlcStatus::kNoFrontier);
    CHECK(d.order().empty());
  }
  SECTION("the frontier tour passed in is used as it is") {
    TourResult given;
    given.order = {2, 1, 0};  // not the best: 6 + 3 + 3 = 12
    const AlcDecision d = alc.decide(vehicleAt(), 30.0, false, kTargets, frontierMatrix(), legs.function(), &given);
    CHECK(d.frontier_tour.order == given.order);
    CHECK(d.frontier_cost_s == 12.0);
  }
  SECTION("misuse throws") {
    CHECK_THROWS_AS(alc.decide(vehicleAt(), 30.0, false, kTargets, RealCostMatrix(3, 0.0), legs.function()),
                    std::invalid_argument);
    decideAt(alc, legs, 30.0);
    CHECK_THROWS_AS(decideAt(alc, legs, 29.0), std::invalid_argument);  // time goes back
    AlcConfig bad;
    bad.epsilon = -0.1;
    CHECK_THROWS_WITH(ActiveLoopClosure(bad), Catch::Contains("epsilon"));
    bad = AlcConfig{};
    bad.clusters.max_viewpoints = 0;
    CHECK_THROWS_WITH(ActiveLoopClosure(bad), Catch::Contains("max_viewpoints"));
    CHECK_THROWS_AS(alc.addFlownPose(Vec3d::Zero(), 0.0, 1.0), std::invalid_argument);  // before the last pose
  }
  CHECK(toString(AlcStatus::kGaveUp) == "gave_up");
}

TEST_CASE("Unreachable legs do not inflate the epsilon allowance", "[planner][alc]") {
  // A fourth target without a path (1000 s legs into it): both tours end there. Counted, it
  // would let a detour of C_loop = 10 pass against 1.2 x 1008; left out, 10 > 1.2 x 8.
  RealCostMatrix m(5, 0.0);
  const RealCostMatrix base = frontierMatrix();
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t j = 0; j < 4; ++j) m(i, j) = base(i, j);
  for (std::size_t i = 0; i < 4; ++i) m(i, 4) = 1000.0;
  for (std::size_t j = 1; j < 4; ++j) m(4, j) = 1000.0;
  CHECK(reachableTourCost(m, {0, 1, 2, 3}, 1000.0) == 8.0);
  CHECK(openTourCost(m, {0, 1, 2, 3}) == 1008.0);

  ActiveLoopClosure alc(testParams());
  flyPlaces(alc);
  FakeLegs legs;
  legs.to_cluster[kA] = 3.0;
  legs.from_cluster = {1.0, 4.0, 6.0, 1000.0};
  std::vector<TourTarget> targets = kTargets;
  targets.push_back({103, {Vec3d(9, 9, 1), 0.0}});
  const AlcDecision d = alc.decide(vehicleAt(), 30.0, false, targets, m, legs.function());
  CHECK(d.frontier_cost_s == 8.0);
  CHECK(d.loop_cost_s == 10.0);
  CHECK(d.status == AlcStatus::kFrontierCheaper);
}

TEST_CASE("Refinement layers put the loop cluster's viewpoints first on a detour", "[planner][alc]") {
  ActiveLoopClosure alc(testParams());
  flyPlaces(alc);
  FakeLegs legs;
  const AlcDecision d = decideAt(alc, legs, 30.0);
  REQUIRE(d.detour());
  // Two viewpoints per frontier target, within 5 m of the vehicle (refinement's radius).
  std::vector<std::vector<Viewpoint>> views;
  for (const TourTarget& t : kTargets)
    views.push_back({Viewpoint{t.pose.position_W, 0.0, 40}, Viewpoint{t.pose.position_W + Vec3d(0, 0.5, 0), 0.0, 35}});
  const auto layers = alcRefinementLayers(vehicleAt(), d, views);
  REQUIRE(layers.size() == 4);
  // The cluster's three viewpoints (all 0.75 m or more from the vehicle), its centre first.
  REQUIRE(layers[0].size() == 3);
  CHECK(layers[0][0].position_W == Vec3d(0.125, 0, 1));
  CHECK(layers[0][1].position_W == Vec3d(0.0, 0, 1));
  CHECK(layers[0][2].position_W == Vec3d(0.25, 0, 1));
  CHECK(layers[1].size() == 2);
  CHECK(layers[1][0].position_W == kTargets[d.order()[0]].pose.position_W);
  CHECK(layers[3].size() == 1);  // the anchor
  // Without a detour the layers follow the frontier tour.
  ActiveLoopClosure early(testParams());
  flyPlaces(early);
  const AlcDecision e = decideAt(early, legs, 10.0);  // the initial period
  const auto plain = alcRefinementLayers(vehicleAt(), e, views);
  REQUIRE(plain.size() == 3);
  CHECK(plain[0][0].position_W == kTargets[e.order()[0]].pose.position_W);
  CHECK_THROWS_AS(alcRefinementLayers(vehicleAt(), e, {}), std::invalid_argument);
}
