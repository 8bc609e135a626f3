// The 4-DOF pose graph (sim/pose_graph.hpp).
#include <catch2/catch.hpp>

#include "vdbmap/sim/pose_graph.hpp"
#include "vdbmap/sim/trajectory.hpp"

#include <cmath>
#include <random>

using namespace vdbmap;
using namespace vdbmap::sim;

TEST_CASE("relativePose and compose are inverse, across the yaw wrap", "[sim][pose_graph]") {
  const FlatPose a{Vec3d(1, 2, 3), 3.0}, b{Vec3d(-2, 0.5, 1), -3.0};
  const FlatPose r = relativePose(a, b);
  CHECK(std::abs(r.yaw_rad) < M_PI);  // the short way round: 2 pi - 6 rad
  const FlatPose b2 = compose(a, r);
  CHECK((b2.position_W - b.position_W).norm() < 1e-12);
  CHECK(std::abs(angleDifference(b2.yaw_rad, b.yaw_rad)) < 1e-12);
}

TEST_CASE("a perfect loop edge removes most of the end-point error of a drifted square loop", "[sim][pose_graph]") {
  // A 10 m square flown counter-clockwise in 160 steps (turning 90 deg at the corners); odometry
  // steps carry a yaw bias and Gaussian noise, so the estimate ends far from the start it returned to.
  std::vector<FlatPose> truth;
  for (int side = 0; side < 4; ++side)
    for (int k = 0; k < 40; ++k) {
      const double yaw = side * M_PI / 2;
      const Vec3d corner = side == 0   ? Vec3d(0, 0, 1)
                           : side == 1 ? Vec3d(10, 0, 1)
                           : side == 2 ? Vec3d(10, 10, 1)
                                       : Vec3d(0, 10, 1);
      truth.push_back({corner + Eigen::AngleAxisd(yaw, Vec3d::UnitZ()) * Vec3d(0.25 * k, 0, 0), yaw});
    }
  truth.push_back({Vec3d(0, 0, 1), 2 * M_PI});  // back at the start
  std::mt19937 rng(5);
  std::normal_distribution<double> noise_t(0.0, 0.01), noise_yaw(0.0, 0.002);
  PoseGraph4Dof graph;
  FlatPose odom = truth[0];
  graph.addNode(odom);
  for (std::size_t i = 1; i < truth.size(); ++i) {
    FlatPose step = relativePose(truth[i - 1], truth[i]);
    step.position_W += Vec3d(noise_t(rng), noise_t(rng), noise_t(rng));
    step.yaw_rad += 0.004 + noise_yaw(rng);  // a yaw bias, as s3/s4 drift has
    odom = compose(odom, step);
    graph.addNode(odom);
    graph.addEdge({i - 1, i, step, 0.01, 0.005});
  }
  const std::size_t last = truth.size() - 1;
  const double error_before = (graph.pose(last).position_W - truth[last].position_W).norm();
  REQUIRE(error_before > 1.0);
  // The loop closure: the true relative pose of the last node seen from the first.
  graph.addEdge({0, last, relativePose(truth[0], truth[last]), 0.001, 0.0005});
  const PoseGraphSummary s = graph.optimize();
  CHECK(s.final_cost < s.initial_cost);
  const double error_after = (graph.pose(last).position_W - truth[last].position_W).norm();
  CHECK(error_after < 0.05 * error_before);
  CHECK(std::abs(angleDifference(graph.pose(last).yaw_rad, truth[last].yaw_rad)) < 0.01);
  // The rest of the loop improves too: the worst position error drops by more than half.
  double worst_before = 0.0, worst_after = 0.0;
  FlatPose o = truth[0];
  for (std::size_t i = 1; i < truth.size(); ++i) {
    o = compose(o, graph.edges()[i - 1].relative);
    worst_before = std::max(worst_before, (o.position_W - truth[i].position_W).norm());
    worst_after = std::max(worst_after, (graph.pose(i).position_W - truth[i].position_W).norm());
  }
  CHECK(worst_after < 0.5 * worst_before);
  CHECK((graph.pose(0).position_W - truth[0].position_W).norm() == 0.0);  // node 0 is held fixed
}

TEST_CASE("pose graph misuse throws", "[sim][pose_graph][bad-input]") {
  PoseGraph4Dof graph;
  CHECK_THROWS_AS(graph.optimize(), std::logic_error);
  graph.addNode({});
  graph.addNode({});
  CHECK_THROWS_AS(graph.addEdge({0, 2, {}, 0.1, 0.1}), std::invalid_argument);
  CHECK_THROWS_AS(graph.addEdge({1, 1, {}, 0.1, 0.1}), std::invalid_argument);
  CHECK_THROWS_AS(graph.addEdge({0, 1, {}, 0.0, 0.1}), std::invalid_argument);
  CHECK_THROWS_AS(graph.addNode({Vec3d(NAN, 0, 0), 0.0}), std::invalid_argument);
}
