// Local refinement: the layered shortest path matches brute force; layers follow FUEL's rules.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/local_refinement.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace vdbmap;
using namespace vdbmap::planner;

namespace {
Viewpoint vp(double x, double y, int seen) { return Viewpoint{Vec3d(x, y, 1.0), 0.0, seen}; }

/// A 10 x 6 x 3 m room of 0.1 m voxels split at x = 5 m by a wall with a door at its far end
/// (y 4.5-5.5 m, up to 2 m high): legs across it are OMPL searches, far dearer than their
/// straight-leg bound.
DenseMap roomWithWall() {
  DenseMap map = test::makeRoom(Eigen::Vector3i(100, 60, 30));
  map.fill(openvdb::CoordBBox(openvdb::Coord(50, 1, 1), openvdb::Coord(50, 58, 28)), Occupancy::Occupied);
  map.fill(openvdb::CoordBBox(openvdb::Coord(50, 45, 1), openvdb::Coord(50, 55, 20)), Occupancy::Free);
  return map;
}

/// `count` layers of 1-5 viewpoints each, anywhere in that room.
std::vector<std::vector<Viewpoint>> randomLayers(std::mt19937& rng, std::size_t count) {
  std::uniform_real_distribution<double> x(0.5, 9.5), y(0.5, 5.5), z(0.6, 2.4), yaw(-M_PI, M_PI);
  std::uniform_int_distribution<int> size(1, 5);
  std::vector<std::vector<Viewpoint>> layers(count);
  for (auto& layer : layers)
    for (int n = size(rng); n > 0; --n) layer.push_back(Viewpoint{Vec3d(x(rng), y(rng), z(rng)), yaw(rng), 20});
  return layers;
}

/// A vehicle at rest at (1, y_m, 1) in that room, facing a random way.
VehicleState vehicleAt(double y_m, std::mt19937& rng) {
  VehicleState vehicle;
  vehicle.position_W = Vec3d(1.0, y_m, 1.0);
  vehicle.yaw_rad = std::uniform_real_distribution<double>(-M_PI, M_PI)(rng);
  return vehicle;
}
}  // namespace

TEST_CASE("The layered shortest path equals brute-force enumeration", "[planner][refinement]") {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  std::uniform_int_distribution<int> size(1, 5);
  for (int trial = 0; trial < 50; ++trial) {
    const int layers = 1 + trial % 5;
    std::vector<int> sizes(layers);
    for (int& s : sizes) s = size(rng);
    LayeredCosts c;
    for (int j = 0; j < sizes[0]; ++j) c.first.push_back(u(rng));
    for (int l = 1; l < layers; ++l) {
      Eigen::MatrixXd m(sizes[l - 1], sizes[l]);
      for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = u(rng);
      c.between.push_back(m);
    }
    const RefinementResult r = shortestLayeredPath(c);
    REQUIRE(r.choice.size() == std::size_t(layers));
    // Brute force over every combination.
    double best = 1e300;
    std::vector<int> pick(layers, 0);
    while (true) {
      double cost = c.first[pick[0]];
      for (int l = 1; l < layers; ++l) cost += c.between[l - 1](pick[l - 1], pick[l]);
      best = std::min(best, cost);
      int l = layers - 1;
      while (l >= 0 && ++pick[l] == sizes[l]) pick[l--] = 0;
      if (l < 0) break;
    }
    double chosen = c.first[r.choice[0]];
    for (int l = 1; l < layers; ++l) chosen += c.between[l - 1](r.choice[l - 1], r.choice[l]);
    REQUIRE(chosen == Approx(r.cost_s));
    REQUIRE(r.cost_s == Approx(best));
  }
  LayeredCosts bad;
  bad.first = {1.0, 2.0};
  bad.between.push_back(Eigen::MatrixXd::Zero(3, 1));
  CHECK_THROWS_AS(shortestLayeredPath(bad), std::invalid_argument);
  CHECK(shortestLayeredPath(LayeredCosts{}).choice.empty());
}

TEST_CASE("refinementLayers follows FUEL: top viewpoints, decay, distance, radius, anchor", "[planner][refinement]") {
  VehicleState vehicle;
  vehicle.position_W = Vec3d(0, 0, 1);
  RefinementConfig p;
  p.max_clusters = 3;
  p.radius_m = 5.0;
  p.top_viewpoints = 2;
  p.max_decay = 0.8;
  p.min_distance_m = 0.75;
  const std::vector<std::vector<Viewpoint>> tour{
      {vp(0.5, 0, 100), vp(2, 0, 90), vp(3, 0, 85), vp(4, 0, 70)},  // the first is too close
      {vp(4, 0, 50), vp(4, 1, 45), vp(4, 2, 30)},                     // the third decays below 0.8
      {vp(4.5, 0, 30), vp(4.5, 1, 29)},
      {vp(3, 0, 30)}};                                                // beyond max_clusters
  const auto layers = refinementLayers(vehicle, tour, p);
  REQUIRE(layers.size() == 3);
  CHECK(layers[0].size() == 2);  // (2,0) and (3,0): top 2 after skipping the close one
  CHECK(layers[0][0].position_W.x() == 2.0);
  CHECK(layers[0][1].position_W.x() == 3.0);
  CHECK(layers[1].size() == 2);
  CHECK(layers[2].size() == 1);  // the anchor keeps its best only
  CHECK(layers[2][0].position_W.x() == 4.5);

  // Beyond the radius after two layers: stop there.
  p.max_clusters = 7;
  const std::vector<std::vector<Viewpoint>> far{{vp(2, 0, 10)}, {vp(3, 0, 10)}, {vp(20, 0, 10)}, {vp(3, 1, 10)}};
  CHECK(refinementLayers(vehicle, far, p).size() == 2);
  // Only close viewpoints: the best is kept anyway.
  const std::vector<std::vector<Viewpoint>> close{{vp(0.2, 0, 10), vp(0.3, 0, 9)}};
  const auto l2 = refinementLayers(vehicle, close, p);
  REQUIRE(l2.size() == 1);
  CHECK(l2[0].size() == 1);
  CHECK(l2[0][0].position_W.x() == 0.2);
}

TEST_CASE("refineLocalTour on a map picks the cheapest chain of viewpoints", "[planner][refinement]") {
  const DenseMap map = test::makeRoom(Eigen::Vector3i(100, 60, 30));
  VehicleState vehicle;
  vehicle.position_W = Vec3d(1, 3, 1.0);
  // Layer 0: a near and a far viewpoint; layer 1: a single anchor. The near one is on the way.
  const std::vector<std::vector<Viewpoint>> layers{{vp(5, 5.5, 20), vp(3, 3, 20)}, {vp(6, 3, 20)}};
  const RefinementResult r = refineLocalTour(map, vehicle, layers);
  REQUIRE(r.choice.size() == 2);
  CHECK(r.choice[0] == 1);
  CHECK(r.cost_s == Approx((2.0 + 3.0) / 2.0));  // straight legs of 2 m and 3 m at 2 m/s
}

TEST_CASE("refineLocalTour's lazy search gives the shortest path over every planned edge", "[planner][refinement]") {
  // A room with a wall (a door at one end) and a closed box: straight legs, legs around the wall,
  // and viewpoints with no path, so that many straight-leg bounds are far below the costs.
  DenseMap map = roomWithWall();
  map.fill(openvdb::CoordBBox(openvdb::Coord(70, 5, 1), openvdb::Coord(90, 20, 28)), Occupancy::Occupied);
  map.fill(openvdb::CoordBBox(openvdb::Coord(71, 6, 2), openvdb::Coord(89, 19, 27)), Occupancy::Free);
  std::mt19937 rng(11);
  std::size_t planned = 0, edges = 0;
  for (int trial = 0; trial < 12; ++trial) {
    VehicleState vehicle = vehicleAt(1.0 + 0.3 * trial, rng);
    vehicle.velocity_W = trial % 2 ? Vec3d(0.0, 1.0, 0.0) : Vec3d::Zero();  // the direction term, sometimes
    const std::vector<std::vector<Viewpoint>> layers = randomLayers(rng, std::size_t(2 + trial % 5));
    const RefinementResult all = shortestLayeredPath(layeredCosts(map, vehicle, layers, {}, test::countedPaths()));
    const RefinementResult lazy = refineLocalTour(map, vehicle, layers, {}, test::countedPaths());
    CHECK(lazy.cost_s == all.cost_s);
    CHECK(lazy.choice == all.choice);
    planned += lazy.planned_edges;
    edges += layers[0].size();
    for (std::size_t l = 1; l < layers.size(); ++l) edges += layers[l - 1].size() * layers[l].size();

    // A budget the search needs anyway changes nothing.
    const RefinementResult enough =
        refineLocalTour(map, vehicle, layers, {}, test::countedPaths(), int(lazy.planned_edges));
    CHECK(enough.choice == lazy.choice);
    CHECK(enough.cost_s == lazy.cost_s);
    // A smaller one stops after the round that reaches it (a round plans at most one edge per
    // layer), with a path no dearer than the true shortest: unplanned edges count at their bound.
    const int half = std::max(1, int(lazy.planned_edges) / 2);
    const RefinementResult cut = refineLocalTour(map, vehicle, layers, {}, test::countedPaths(), half);
    CHECK(cut.planned_edges >= std::min<std::size_t>(std::size_t(half), lazy.planned_edges));
    CHECK(cut.planned_edges < std::size_t(half) + layers.size());
    CHECK(cut.cost_s <= lazy.cost_s);
  }
  INFO("planned " << planned << " of " << edges << " edges");
  CHECK(planned < edges / 2);  // the point of the lazy search: most edges are never planned
}

TEST_CASE("A refinement edge's cost depends on its two poses, not on their places in the layers",
          "[planner][refinement]") {
  const DenseMap map = roomWithWall();
  VehicleState vehicle;
  vehicle.position_W = Vec3d(1.0, 1.0, 1.0);
  // Legs that cross the wall are OMPL searches, whose paths depend on their seeds.
  const std::vector<std::vector<Viewpoint>> layers{{vp(8, 1, 20), vp(2, 2, 20), vp(8.5, 3, 20)},
                                                   {vp(3, 4, 20), vp(7, 1.5, 20)}};
  std::vector<std::vector<Viewpoint>> swapped = layers;
  std::reverse(swapped[0].begin(), swapped[0].end());
  std::reverse(swapped[1].begin(), swapped[1].end());
  const LayeredCosts a = layeredCosts(map, vehicle, layers, {}, test::countedPaths());
  const LayeredCosts b = layeredCosts(map, vehicle, swapped, {}, test::countedPaths());
  for (Eigen::Index k = 0; k < 3; ++k) {
    CHECK(a.first[std::size_t(k)] == b.first[std::size_t(2 - k)]);
    for (Eigen::Index j = 0; j < 2; ++j) CHECK(a.between[0](k, j) == b.between[0](2 - k, 1 - j));
  }
}

TEST_CASE("LegCostCache keeps ordered legs under their exact poses and forgets moved ends", "[planner][refinement]") {
  const FlatPose a{Vec3d(1, 2, 1), 0.5}, b{Vec3d(3, 2, 1), -0.5}, c{Vec3d(3, 4, 1), 0.0};
  LegCostCache cache;
  cache.insert(a, b, 2.0);
  cache.insert(b, c, 3.0);
  REQUIRE(cache.find(a, b).has_value());
  CHECK(*cache.find(a, b) == 2.0);
  CHECK_FALSE(cache.find(b, a).has_value());  // legs are ordered
  const FlatPose a_turned{a.position_W, 0.5000001};
  CHECK_FALSE(cache.find(a_turned, b).has_value());  // exact poses only
  cache.retainEndsIn({b, c});
  CHECK(cache.size() == 1);
  CHECK_FALSE(cache.find(a, b).has_value());
  CHECK(*cache.find(b, c) == 3.0);
}

TEST_CASE("refineLocalTour with a cache gives the same path and plans edges between viewpoints once",
          "[planner][refinement]") {
  const DenseMap map = roomWithWall();
  std::mt19937 rng(23);
  std::size_t planned_first = 0, planned_again = 0;
  for (int trial = 0; trial < 8; ++trial) {
    VehicleState vehicle = vehicleAt(1.0 + 0.4 * trial, rng);
    std::vector<std::vector<Viewpoint>> layers = randomLayers(rng, std::size_t(3 + trial % 3));

    LegCostCache cache;
    const RefinementResult first = refineLocalTour(map, vehicle, layers, {}, test::countedPaths(), 0, &cache);
    const RefinementResult fresh = shortestLayeredPath(layeredCosts(map, vehicle, layers, {}, test::countedPaths()));
    CHECK(first.choice == fresh.choice);
    CHECK(first.cost_s == fresh.cost_s);
    CHECK(first.reused_edges == 0);

    // The next replan, the vehicle a little further on: every kept edge is reused, and the
    // answer is the one of planning every edge now.
    vehicle.position_W.x() += 0.3;
    const std::size_t kept = cache.size();
    CHECK(kept + layers[0].size() >= first.planned_edges);  // every edge between viewpoints was kept
    const RefinementResult again = refineLocalTour(map, vehicle, layers, {}, test::countedPaths(), 0, &cache);
    const RefinementResult again_fresh =
        shortestLayeredPath(layeredCosts(map, vehicle, layers, {}, test::countedPaths()));
    CHECK(again.choice == again_fresh.choice);
    CHECK(again.cost_s == again_fresh.cost_s);
    CHECK(again.reused_edges == kept);
    planned_first += first.planned_edges;
    planned_again += again.planned_edges;

    // A viewpoint that moved: its legs are forgotten and planned anew.
    const FlatPose old{layers[1][0].position_W, layers[1][0].yaw_rad};
    layers[1][0].position_W.y() = std::min(5.5, layers[1][0].position_W.y() + 0.5);
    const RefinementResult moved = refineLocalTour(map, vehicle, layers, {}, test::countedPaths(), 0, &cache);
    const RefinementResult moved_fresh =
        shortestLayeredPath(layeredCosts(map, vehicle, layers, {}, test::countedPaths()));
    CHECK(moved.choice == moved_fresh.choice);
    CHECK(moved.cost_s == moved_fresh.cost_s);
    for (const Viewpoint& v : layers[0]) CHECK_FALSE(cache.find(FlatPose{v.position_W, v.yaw_rad}, old).has_value());
    for (const Viewpoint& v : layers[2]) CHECK_FALSE(cache.find(old, FlatPose{v.position_W, v.yaw_rad}).has_value());
  }
  INFO("planned " << planned_first << " edges, then " << planned_again);
  CHECK(planned_again * 2 < planned_first);
}
