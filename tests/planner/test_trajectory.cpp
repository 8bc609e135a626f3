// Trajectories: limits hold at every sample (dense sampling), the trajectory stays in free space
// (brute force), it is consistent (position derivatives match velocity), starts from the vehicle's
// state and ends at rest at the goal with the goal yaw.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/trajectory.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// The first time (to 1 ms) the yaw lies within `within_rad` of `yaw_rad`.
double firstFacing(const Trajectory& traj, double yaw_rad, double within_rad) {
  double t = 0.0;
  while (yawDistance(traj.sample(t).yaw_rad, yaw_rad) > within_rad) t += 1e-3;
  return t;
}

/// How far from `from_W` the vehicle would come to rest braking at a_max from its state at t_s.
double stoppingPointAt(const Trajectory& traj, const Vec3d& from_W, double t_s, double a_max_m_s2) {
  const VehicleState s = traj.sample(t_s);
  return (s.position_W - from_W).norm() + s.velocity_W.squaredNorm() / (2.0 * a_max_m_s2);
}

/// Checks every limit at samples 1 ms apart, continuity between samples, that position
/// differences match velocity, and (when `map` is given) clearance by brute force.
void checkTrajectory(const Trajectory& traj, const TrajectoryConfig& p, const DenseMap* map) {
  const double dt = 1e-3;
  const double tol = 1e-9;
  VehicleState prev = traj.sample(0.0);
  for (double t = dt; t <= traj.duration() + 0.5 * dt; t += dt) {
    const VehicleState s = traj.sample(t);
    REQUIRE(s.velocity_W.norm() <= p.v_max_m_s * (1 + tol));
    REQUIRE(s.acceleration_W.norm() <= p.a_max_m_s2 * (1 + 1e-6));
    REQUIRE(std::abs(s.yaw_rate_rad_s) <= p.yaw_rate_max_rad_s * (1 + tol));
    // Continuity: no jumps in position, velocity or yaw between samples.
    REQUIRE((s.position_W - prev.position_W).norm() <= p.v_max_m_s * dt * (1 + 1e-6) + 1e-12);
    REQUIRE((s.velocity_W - prev.velocity_W).norm() <= p.a_max_m_s2 * dt * (1 + 1e-6) + 1e-12);
    REQUIRE(yawDistance(prev.yaw_rad, s.yaw_rad) <= p.yaw_rate_max_rad_s * dt * (1 + 1e-6) + 1e-12);
    // The derivatives are those of the sampled motion (midpoint rule, O(dt^2)).
    const Vec3d mid_velocity = (s.position_W - prev.position_W) / dt;
    REQUIRE((mid_velocity - 0.5 * (s.velocity_W + prev.velocity_W)).norm() <= p.a_max_m_s2 * dt + 1e-9);
    if (map) REQUIRE(test::bruteClear(*map, s.position_W, p.clearance_m));
    prev = s;
  }
}
}  // namespace

TEST_CASE("A straight 10 m leg from rest takes exactly the bang-cruise-bang time", "[planner][trajectory]") {
  DenseMap map = test::makeRoom(Eigen::Vector3i(140, 40, 30));
  TrajectoryConfig p;
  VehicleState start;
  start.position_W = Vec3d(2, 2, 1.5);
  const TrajectoryResult r = planTrajectory({start.position_W, Vec3d(12, 2, 1.5)}, start, 0.0, map, p);
  REQUIRE(r.status == TrajectoryStatus::Ok);
  // 1 s to reach 2 m/s (1 m), 4 s cruising 8 m, 1 s braking (1 m).
  CHECK(r.trajectory.duration() == Approx(6.0).epsilon(1e-9));
  CHECK(r.trajectory.sample(0.5).velocity_W.isApprox(Vec3d(1, 0, 0), 1e-9));
  CHECK(r.trajectory.sample(3.0).velocity_W.isApprox(Vec3d(2, 0, 0), 1e-9));
  CHECK(r.trajectory.sample(3.0).position_W.isApprox(Vec3d(7, 2, 1.5), 1e-9));
  CHECK(r.trajectory.sample(6.0).position_W.isApprox(Vec3d(12, 2, 1.5), 1e-12));
  CHECK(r.trajectory.sample(6.0).velocity_W.norm() == Approx(0.0).margin(1e-9));
  checkTrajectory(r.trajectory, p, &map);
}

TEST_CASE("Along a planned path: limits at every sample, clear of the map, from rest to rest at the goal yaw",
          "[planner][trajectory]") {
  const DenseMap map = test::wallRoom();
  const PathConfig pp = test::countedPaths(5000);
  TrajectoryConfig tp;
  tp.clearance_m = pp.clearance_m;
  PathPlanner planner(map, pp);
  VehicleState start;
  start.position_W = Vec3d(2, 1, 1);
  start.yaw_rad = 0.3;
  const Vec3d goal(8, 1.2, 1.4);
  const PathResult path = planner.plan(start.position_W, goal);
  REQUIRE(path.status == PathStatus::Planned);
  const TrajectoryResult r = planTrajectory(path.waypoints, start, -2.5, map, tp);
  REQUIRE(r.status == TrajectoryStatus::Ok);
  const Trajectory& traj = r.trajectory;
  checkTrajectory(traj, tp, &map);
  const VehicleState s0 = traj.sample(0.0), s1 = traj.sample(traj.duration());
  CHECK(s0.position_W == start.position_W);
  CHECK(s0.velocity_W.norm() == 0.0);
  CHECK(s0.yaw_rad == Approx(0.3));
  CHECK(s1.position_W.isApprox(goal, 1e-12));
  CHECK(s1.velocity_W.norm() == 0.0);
  CHECK(yawDistance(s1.yaw_rad, -2.5) < 1e-9);
  // Corners are rounded, not stopped at, and the time is near the length at v_max.
  CHECK(traj.stopCorners() == 0);
  CHECK(traj.duration() > path.length_m / tp.v_max_m_s);
  CHECK(traj.duration() < path.length_m / tp.v_max_m_s + 6.0);
}

TEST_CASE("A moving start keeps the vehicle's velocity through a clear lead-in", "[planner][trajectory]") {
  const DenseMap map = test::wallRoom();
  TrajectoryConfig tp;
  VehicleState start;
  start.position_W = Vec3d(2, 3, 1.2);
  start.velocity_W = Vec3d(0, 1.5, 0.2);  // sideways to the path
  const std::vector<Vec3d> path{start.position_W, Vec3d(4, 3, 1.2)};
  const TrajectoryResult r = planTrajectory(path, start, 0.0, map, tp);
  REQUIRE(r.status == TrajectoryStatus::Ok);
  CHECK(r.trajectory.sample(0.0).velocity_W.isApprox(start.velocity_W, 1e-9));
  CHECK(r.trajectory.corners().size() == 3);  // start, lead-in, goal
  checkTrajectory(r.trajectory, tp, &map);
  CHECK(r.trajectory.sample(r.trajectory.duration()).position_W.isApprox(Vec3d(4, 3, 1.2), 1e-12));
}

TEST_CASE("Moving straight at a wall: the start is slowed and the status says so", "[planner][trajectory]") {
  const DenseMap map = test::wallRoom();
  TrajectoryConfig tp;
  VehicleState start;
  start.position_W = Vec3d(4.5, 1.0, 1.2);  // 0.5 m before the wall, flying at it
  start.velocity_W = Vec3d(2.0, 0, 0);
  const TrajectoryResult r = planTrajectory({start.position_W, Vec3d(3, 1, 1.2)}, start, 0.0, map, tp);
  REQUIRE(r.status == TrajectoryStatus::StartVelocityReduced);
  CHECK(r.trajectory.sample(0.0).velocity_W.norm() < 2.0);
  checkTrajectory(r.trajectory, tp, &map);
}

TEST_CASE("A single-point path turns on the spot within the yaw-rate limit", "[planner][trajectory]") {
  const DenseMap map = test::wallRoom();
  TrajectoryConfig tp;
  VehicleState start;
  start.position_W = Vec3d(2, 2, 1);
  start.yaw_rad = 3.0;
  const TrajectoryResult r = planTrajectory({start.position_W}, start, -3.0, map, tp);  // 0.28 rad the short way
  REQUIRE(r.status == TrajectoryStatus::Ok);
  // Triangle profile (peak rate sqrt(2 * 0.283) < 0.9): 2 sqrt(0.283 / 2) s.
  const double turn = 2.0 * M_PI - 6.0;
  CHECK(r.trajectory.duration() == Approx(2.0 * std::sqrt(turn / tp.yaw_acc_max_rad_s2)));
  CHECK(yawDistance(r.trajectory.sample(r.trajectory.duration()).yaw_rad, -3.0) < 1e-9);
  checkTrajectory(r.trajectory, tp, &map);
  for (double t = 0; t < r.trajectory.duration(); t += 0.1) CHECK(r.trajectory.sample(t).position_W == start.position_W);
  // Holding still: no time, no motion.
  const Trajectory still = Trajectory::hold(start.position_W, 1.0);
  CHECK(still.duration() == 0.0);
  CHECK(still.sample(5.0).position_W == start.position_W);
  CHECK(still.sample(5.0).yaw_rad == 1.0);
  CHECK(still.sample(5.0).velocity_W.norm() == 0.0);
  // A half turn takes at least pi / 0.9 s.
  const TrajectoryResult half = planTrajectory({start.position_W}, start, 3.0 - M_PI, map, tp);
  CHECK(half.trajectory.duration() >= M_PI / tp.yaw_rate_max_rad_s);
}

TEST_CASE("A corner whose arc would clip an obstacle is tightened or stopped, never cut", "[planner][trajectory]") {
  // An L-shaped corridor 0.8 m wide: the path hugs the inner corner.
  DenseMap map(0.1, CoordBBox(Coord(-2), Coord(62, 62, 22)));
  map.fill(CoordBBox(Coord(0), Coord(60, 60, 20)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(1, 1, 1), Coord(59, 8, 19)), Occupancy::Free);   // along x, y 0.1-0.8
  map.fill(CoordBBox(Coord(52, 1, 1), Coord(59, 59, 19)), Occupancy::Free); // along y, x 5.2-5.9
  TrajectoryConfig tp;
  tp.clearance_m = 0.25;
  VehicleState start;
  start.position_W = Vec3d(1.0, 0.45, 1.0);
  const std::vector<Vec3d> path{start.position_W, Vec3d(5.55, 0.45, 1.0), Vec3d(5.55, 5.0, 1.0)};
  MapProbe probe(map);
  REQUIRE(probe.isSegmentClear(path[0], path[1], 0.25));
  REQUIRE(probe.isSegmentClear(path[1], path[2], 0.25));
  const TrajectoryResult r = planTrajectory(path, start, M_PI / 2, map, tp);
  REQUIRE(r.ok());
  checkTrajectory(r.trajectory, tp, &map);
  CHECK(r.trajectory.sample(r.trajectory.duration()).position_W.isApprox(path.back(), 1e-12));
}

TEST_CASE("A path through an obstacle is refused", "[planner][trajectory]") {
  const DenseMap map = test::wallRoom();
  VehicleState start;
  start.position_W = Vec3d(2, 1, 1);
  const TrajectoryResult r = planTrajectory({start.position_W, Vec3d(8, 1, 1)}, start, 0.0, map);
  CHECK(r.status == TrajectoryStatus::PathNotClear);
  CHECK_FALSE(r.ok());
  CHECK_THROWS_AS(planTrajectory({Vec3d(3, 3, 1)}, start, 0.0, map), std::invalid_argument);  // not at the vehicle
}

TEST_CASE("TrajectoryConfig::validate names the field", "[planner][trajectory]") {
  TrajectoryConfig p;
  p.normal_acc_share = 1.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("normal_acc_share"));
  p = TrajectoryConfig{};
  p.corner_fraction = 0.6;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("corner_fraction"));
}

TEST_CASE(
    "With yaw_along_travel the camera faces the way while moving, within the yaw limits, and ends at the "
    "goal yaw",
    "[planner][trajectory]") {
  const DenseMap map = test::makeRoom(Eigen::Vector3i(100, 100, 30));
  TrajectoryConfig tp;
  tp.yaw_along_travel = true;
  VehicleState start;
  start.position_W = Vec3d(1, 1, 1.2);
  start.yaw_rad = M_PI / 2;  // facing +y; the way goes +x, then +y
  const std::vector<Vec3d> path{start.position_W, Vec3d(8, 1, 1.2), Vec3d(8, 8, 1.2)};
  const double goal_yaw = M_PI;
  const TrajectoryResult r = planTrajectory(path, start, goal_yaw, map, tp);
  REQUIRE(r.status == TrajectoryStatus::Ok);
  const Trajectory& traj = r.trajectory;
  checkTrajectory(traj, tp, &map);
  // Yaw acceleration within the limit between 1 ms samples.
  for (double t = 1e-3; t <= traj.duration(); t += 1e-3)
    REQUIRE(std::abs(traj.sample(t).yaw_rate_rad_s - traj.sample(t - 1e-3).yaw_rate_rad_s) <=
            tp.yaw_acc_max_rad_s2 * 1e-3 * (1 + 1e-6) + 1e-12);
  // Once turned to the way (a quarter turn from rest: 2.2 s at most), the direction of travel stays
  // within the camera's half field of view (40 deg) until the turn to the goal yaw begins (a
  // quarter turn before the end of the motion).
  const double quarter = M_PI / 2 / tp.yaw_rate_max_rad_s + tp.yaw_rate_max_rad_s / tp.yaw_acc_max_rad_s2;
  const double half_fov = std::atan(320.0 / 387.229);
  int checked = 0;
  for (double t = quarter; t < traj.motionDuration() - quarter - 0.1; t += 0.05) {
    const VehicleState s = traj.sample(t);
    if (s.velocity_W.head<2>().norm() < 0.2) continue;
    CHECK(yawDistance(s.yaw_rad, std::atan2(s.velocity_W.y(), s.velocity_W.x())) <= half_fov);
    ++checked;
  }
  CHECK(checked > 50);
  CHECK(yawDistance(traj.sample(traj.duration()).yaw_rad, goal_yaw) < 1e-3);
  CHECK(traj.sample(traj.duration()).position_W.isApprox(path.back(), 1e-12));
  // Without it the same path spreads the turn to the goal over the whole motion: the camera looks
  // away from the way for much of it.
  tp.yaw_along_travel = false;
  const Trajectory spread = planTrajectory(path, start, goal_yaw, map, tp).trajectory;
  int away = 0;
  for (double t = quarter; t < spread.motionDuration() - quarter - 0.1; t += 0.05) {
    const VehicleState s = spread.sample(t);
    away += s.velocity_W.head<2>().norm() >= 0.2 &&
            yawDistance(s.yaw_rad, std::atan2(s.velocity_W.y(), s.velocity_W.x())) > half_fov;
  }
  CHECK(away > 20);
}

TEST_CASE(
    "From rest with yaw_along_travel, the vehicle moves off while it still turns only as far as it can stop within "
    "free_way_m until it faces the way",
    "[planner][trajectory]") {
  const DenseMap map = test::makeRoom(Eigen::Vector3i(100, 100, 30));
  TrajectoryConfig tp;
  tp.yaw_along_travel = true;
  VehicleState start;
  start.position_W = Vec3d(1, 1, 1.2);
  start.yaw_rad = M_PI;  // its back to the way, which goes +x
  const std::vector<Vec3d> path{start.position_W, Vec3d(8, 1, 1.2)};
  const Trajectory on_spot = planTrajectory(path, start, 0.0, map, tp).trajectory;
  // The turn on the spot: until the way lies within start_facing_rad.
  CHECK(yawDistance(on_spot.sample(on_spot.motionStart()).yaw_rad, 0.0) <= tp.start_facing_rad + 0.01);
  CHECK(yawDistance(on_spot.sample(on_spot.motionStart() - 0.05).yaw_rad, 0.0) > tp.start_facing_rad);

  for (const double free_m : {0.5, 2.0}) {
    CAPTURE(free_m);
    tp.free_way_m = free_m;
    const Trajectory traj = planTrajectory(path, start, 0.0, map, tp).trajectory;
    checkTrajectory(traj, tp, &map);
    CHECK(traj.motionStart() < on_spot.motionStart() - 0.1);
    // It faces the way when the turn on the spot did, and not before; until then, braking at
    // a_max stops it within free_way_m (to a 10 ms step of the yaw track).
    const double faced_s = firstFacing(traj, 0.0, tp.start_facing_rad);
    CHECK(faced_s == Approx(on_spot.motionStart()).margin(0.02));
    double stop_m = 0.0;
    for (double t = 0.0; t <= faced_s; t += 1e-3)
      stop_m = std::max(stop_m, stoppingPointAt(traj, start.position_W, t, tp.a_max_m_s2));
    CHECK(stop_m <= free_m + tp.v_max_m_s * 0.01);
    CHECK(stop_m >= free_m - 0.1);  // and it uses what it may
    CHECK(yawDistance(traj.sample(traj.duration()).yaw_rad, 0.0) < 1e-3);
  }
  // A way free all along: no wait at all.
  tp.free_way_m = 100.0;
  CHECK(planTrajectory(path, start, 0.0, map, tp).trajectory.motionStart() == 0.0);
  tp.free_way_m = -1.0;
  CHECK_THROWS_WITH(tp.validate(), Catch::Contains("TrajectoryConfig.free_way_m"));
}

TEST_CASE(
    "Moving with its back to the way, the vehicle slows over free_way_m just enough to face the way before its "
    "stopping point leaves it",
    "[planner][trajectory]") {
  const DenseMap map = test::makeRoom(Eigen::Vector3i(200, 60, 30));
  TrajectoryConfig tp;
  tp.yaw_along_travel = true;
  VehicleState start;
  start.position_W = Vec3d(1, 3, 1.2);
  start.velocity_W = Vec3d(1.5, 0, 0);
  start.yaw_rad = M_PI;  // flying backwards, as a yaw spread over a way seen free leaves it
  const std::vector<Vec3d> path{start.position_W, Vec3d(18, 3, 1.2)};
  tp.free_way_m = 100.0;
  const Trajectory fast = planTrajectory(path, start, 0.0, map, tp).trajectory;
  const auto facedAt = [&](const Trajectory& t) { return firstFacing(t, 0.0, tp.start_facing_rad); };
  const auto stopPointAt = [&](const Trajectory& t, double t_s) {
    return stoppingPointAt(t, start.position_W, t_s, tp.a_max_m_s2);
  };
  // Unslowed, it passes 3 m of way (its stopping point) long before it faces the way.
  REQUIRE(stopPointAt(fast, facedAt(fast)) > 5.0);

  tp.free_way_m = 3.0;
  const TrajectoryResult r = planTrajectory(path, start, 0.0, map, tp);
  REQUIRE(r.status == TrajectoryStatus::Ok);  // the vehicle's velocity kept
  const Trajectory& slow = r.trajectory;
  checkTrajectory(slow, tp, &map);
  const double faced = facedAt(slow);
  for (double t = 0.0; t < faced; t += 1e-3) REQUIRE(stopPointAt(slow, t) <= tp.free_way_m + 0.05);
  CHECK(stopPointAt(slow, faced) >= tp.free_way_m - 0.5);  // it does not crawl more than it must
  CHECK(slow.motionDuration() > fast.motionDuration());
  CHECK(slow.sample(slow.duration()).position_W.isApprox(path.back(), 1e-12));

  // A stopping point beyond the free way already: nothing to gain by slowing; left to a look stop.
  tp.free_way_m = 0.4;
  CHECK(planTrajectory(path, start, 0.0, map, tp).trajectory.motionDuration() == fast.motionDuration());
}

TEST_CASE("TrajectoryConfig::validate names yaw_lead_s", "[planner][trajectory]") {
  TrajectoryConfig tp;
  tp.yaw_lead_s = 0.0;
  CHECK_THROWS_WITH(tp.validate(), Catch::Contains("TrajectoryConfig.yaw_lead_s"));
}

TEST_CASE(
    "A moving start turns onto a path across its velocity at its speed where the arc is clear, sooner "
    "than through a straight lead-in",
    "[planner][trajectory]") {
  DenseMap map = test::makeRoom(Eigen::Vector3i(140, 80, 30));
  TrajectoryConfig at_speed;
  TrajectoryConfig straight = at_speed;
  straight.lead_in_at_speed = false;
  VehicleState start;
  start.position_W = Vec3d(4, 2, 1.5);
  start.velocity_W = Vec3d(1.5, 0, 0);
  const std::vector<Vec3d> path{start.position_W, Vec3d(4, 7, 1.5)};  // 5 m across the velocity
  const TrajectoryResult wide = planTrajectory(path, start, 0.0, map, at_speed);
  const TrajectoryResult tight = planTrajectory(path, start, 0.0, map, straight);
  REQUIRE(wide.status == TrajectoryStatus::Ok);
  REQUIRE(tight.status == TrajectoryStatus::Ok);
  checkTrajectory(wide.trajectory, at_speed, &map);
  checkTrajectory(tight.trajectory, straight, &map);
  // The arc starts at the vehicle with its velocity and a radius of v^2 / a_n (1 % wider): no
  // braking on it; the straight lead-ins brake into a tighter corner.
  const double turn_radius = 1.01 * 1.5 * 1.5 / (at_speed.normal_acc_share * at_speed.a_max_m_s2);
  double slowest_wide = 1e9, slowest_tight = 1e9;
  for (double t = 0.0; t < 1.0; t += 1e-3) {
    slowest_wide = std::min(slowest_wide, wide.trajectory.sample(t).velocity_W.norm());
    slowest_tight = std::min(slowest_tight, tight.trajectory.sample(t).velocity_W.norm());
  }
  CHECK(slowest_wide >= 1.5 * (1.0 - 1e-9));
  CHECK(slowest_tight < 1.2);
  // Turning from the start: at 0.05 s the vehicle is on the arc at its speed cap, v^2 / R = a_n.
  const VehicleState early = wide.trajectory.sample(0.05);
  CHECK(early.velocity_W.norm() ==
        Approx(std::sqrt(at_speed.normal_acc_share * at_speed.a_max_m_s2 * turn_radius)).epsilon(1e-3));
  CHECK(early.acceleration_W.norm() == Approx(at_speed.normal_acc_share * at_speed.a_max_m_s2));
  CHECK(wide.trajectory.duration() < tight.trajectory.duration() - 0.2);
}
