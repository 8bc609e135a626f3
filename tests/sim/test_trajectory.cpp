// Time-parametrised trajectories and waypoint files (sim/trajectory.hpp).
#include <catch2/catch.hpp>

#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/test_io_helpers.hpp"

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::sim;

TEST_CASE("stop-and-go parametrisation respects the limits and passes every waypoint", "[sim][trajectory]") {
  const std::vector<FlatPose> path = {{Vec3d(0, 0, 1), 0.0},
                                      {Vec3d(10, 0, 1), 0.0},     // long: cruises at v_max
                                      {Vec3d(10, 0.5, 1), 3.0},   // short move, long turn: the turn sets the time
                                      {Vec3d(10, 0.5, 1), -2.0},  // a turn on the spot (the short way: 1.28 rad)
                                      {Vec3d(4, 3, 2.5), -2.0}};
  const MotionLimits limits;
  const SampledTrajectory traj = timeParametrize(path, limits, 0.005);
  const TrajectoryMaxima m = traj.maxima();
  CHECK(m.within(limits));
  CHECK(m.speed_mps == Approx(2.0).epsilon(1e-3));  // the 10 m leg reaches v_max
  // Waypoints are reached at rest, in order.
  std::size_t next = 1;
  for (const VehicleState& s : traj.states())
    if (next < path.size() && (s.position_W - path[next].position_W).norm() < 1e-9 && s.velocity_W.norm() < 1e-9 &&
        std::abs(angleDifference(s.yaw_rad, path[next].yaw_rad)) < 1e-9)
      ++next;
  CHECK(next == path.size());
  // Leg durations: 10 m at 2 m/s with 1 s ramps = 6 s; the 3 rad turn at 0.9 rad/s = 3.33 s; the
  // on-the-spot turn 1.28 rad / 0.9; the last leg of 6.87 m = 4.44 s.
  const double turn = std::abs(angleDifference(-2.0, 3.0));
  const double last = (Vec3d(4, 3, 2.5) - Vec3d(10, 0.5, 1)).norm();
  CHECK(traj.duration() == Approx(6.0 + 3.0 / 0.9 + turn / 0.9 + last / 2.0 + 1.0).epsilon(1e-3));
  CHECK(traj.sample(-1.0).position_W == path.front().position_W);
  CHECK(traj.sample(1e3).position_W.isApprox(path.back().position_W));
  CHECK(traj.sample(1e3).velocity_W.norm() == 0.0);
}

TEST_CASE("waypoint files: read what was written, yaw optional, errors name file and line", "[sim][trajectory]") {
  test::TempDir dir;
  const std::vector<FlatPose> w = {{Vec3d(1, 2, 3), 0.5}, {Vec3d(-1, 0.25, 1), -3.0}};
  writeWaypoints(dir / "w.txt", w);
  const std::vector<FlatPose> r = readWaypoints(dir / "w.txt");
  REQUIRE(r.size() == 2);
  CHECK(r[1].position_W.isApprox(w[1].position_W));
  CHECK(r[1].yaw_rad == Approx(-3.0));
  test::writeText(dir / "noyaw.txt", "# a square\n0 0 1\n\n2 0 1   # east\n2 2 1\n");
  const std::vector<FlatPose> s = readWaypoints(dir / "noyaw.txt");
  REQUIRE(s.size() == 3);
  CHECK(s[0].yaw_rad == Approx(0.0));  // faces the next waypoint
  CHECK(s[1].yaw_rad == Approx(M_PI / 2));
  CHECK(s[2].yaw_rad == Approx(M_PI / 2));  // the last keeps the previous yaw
  test::writeText(dir / "bad.txt", "0 0 1\n1 2\n");
  CHECK_THROWS_WITH(readWaypoints(dir / "bad.txt"), Catch::Contains("bad.txt:2"));
  test::writeText(dir / "nan.txt", "0 0 x\n");
  CHECK_THROWS_WITH(readWaypoints(dir / "nan.txt"), Catch::Contains("nan.txt:1"));
  test::writeText(dir / "empty.txt", "# nothing\n");
  CHECK_THROWS_WITH(readWaypoints(dir / "empty.txt"), Catch::Contains("no waypoint"));
  CHECK_THROWS_AS(readWaypoints(dir / "missing.txt"), std::runtime_error);
}
