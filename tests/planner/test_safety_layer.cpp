// The safety layer in closed loop (SafetyConfig): a world whose global map drift put 0.5 m off,
// where the planner without the layer flies into a wall it cannot see, and with it does not.
//
// The true world is a corridor 12 x 2 x 2.5 m with a block narrowing it to a 0.8 m gap along its
// +y wall. The global map holds all of it shifted by +0.5 m in y (what 0.5 m of drift since it
// was seen leaves), known up to x = 6 m: the map's gap lies 0.5 m into the true +y wall, and the
// frontier beyond it draws the vehicle through. The vehicle starts facing away (-x), so the wall
// is outside the camera's view. The test flies the manager's commands exactly (the vehicle is
// where its estimate says), renders depth from the TRUE world at each frame, and measures the
// true clearance along the flight.
#include "common/quarter_camera.hpp"
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/exploration_manager.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;
using vdbmap::test::quarterCamera;

namespace {
constexpr double kVoxel = 0.1;
/// A collision: the true position closer than this to a surface (the simulator's vehicle radius).
constexpr double kVehicleRadiusM = 0.2;
constexpr double kFramePeriodS = 1.0 / 15.0;

/// The true world: inside the corridor box, outside the block.
const Eigen::AlignedBox3d kCorridor(Vec3d(0, 0, 0), Vec3d(12, 2, 2.5));
const Eigen::AlignedBox3d kBlock(Vec3d(3, 0, 0), Vec3d(3.5, 1.2, 2.5));
/// Drift: the map holds the world shifted by this.
const Vec3d kMapOffset(0.0, 0.5, 0.0);

double trueClearance(const Vec3d& p) {
  if (!kCorridor.contains(p)) return 0.0;
  const double to_walls = std::min((p - kCorridor.min()).minCoeff(), (kCorridor.max() - p).minCoeff());
  return std::min(to_walls, kBlock.exteriorDistance(p));
}

/// Depth along the optical axis from the true world, for a camera at T_W_S.
DepthImage renderTrue(const CameraIntrinsics& K, const Pose3d& T_W_S) {
  DepthImage depth(K.width, K.height);
  const Vec3d o = T_W_S.translation();
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Vec3d d = T_W_S.linear() * Vec3d((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);  // optical z = 1
      double t = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a)  // leaving the corridor (o is inside)
        if (d[a] != 0.0) t = std::min(t, ((d[a] > 0.0 ? kCorridor.max()[a] : kCorridor.min()[a]) - o[a]) / d[a]);
      double t0 = 0.0, t1 = t;  // entering the block
      for (int a = 0; a < 3 && t0 <= t1; ++a) {
        const double ta = (kBlock.min()[a] - o[a]) / d[a], tb = (kBlock.max()[a] - o[a]) / d[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
      }
      depth.at(u, v) = float(t0 <= t1 && t0 > 0.0 ? t0 : t);
    }
  return depth;
}

/// The global map: the world moved by map_offset (in y), known for x < 6 m, unknown beyond.
DenseMap driftedMap(const Vec3d& map_offset = kMapOffset) {
  const auto vox = [](double m) { return int(std::lround(m / kVoxel)); };
  const Coord off(0, vox(map_offset.y()), 0);
  DenseMap map(kVoxel, CoordBBox(Coord(-2), Coord(vox(12) + 2, vox(2.5) + 8, vox(2.5) + 2)));
  map.fill(CoordBBox(Coord(0) + off, Coord(vox(12), vox(2), vox(2.5)) + off), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(1) + off, Coord(vox(6), vox(2) - 1, vox(2.5) - 1) + off), Occupancy::Free);
  map.fill(CoordBBox(Coord(vox(6) + 1, 1, 1) + off, Coord(vox(12) - 1, vox(2) - 1, vox(2.5) - 1) + off),
           Occupancy::Unknown);
  map.fill(CoordBBox(Coord(vox(3), 0, 0) + off, Coord(vox(3.5), vox(1.2), vox(2.5)) + off), Occupancy::Occupied);
  return map;
}

/// The most `t` flies back toward its start from the farthest point it has reached (0 for a
/// trajectory that only moves away, as braking does).
double flownBack(const Trajectory& t) {
  const Vec3d from = t.sample(0.0).position_W;
  double farthest = 0.0, back = 0.0;
  for (double s = 0.0; s <= t.duration(); s += 0.01) {
    const double d = (t.sample(s).position_W - from).norm();
    farthest = std::max(farthest, d);
    back = std::max(back, farthest - d);
  }
  return back;
}

struct Flight {
  double min_clearance_m = std::numeric_limits<double>::infinity();
  double max_x_m = 0.0;  ///< how far along the corridor the vehicle got
  ExplorationCounters counters;
  int ways_seen = 0;  ///< looks that ended early: the vehicle faced the way and saw it free
  bool finished = false;
  double fastest_look_m_s = 0.0;  ///< the highest speed a look began at
  /// The most any look flew back toward its start from the farthest point it reached (0: each
  /// look brakes and stops).
  double look_return_m = 0.0;
};

/// The manager's config for these flights: exploring `box_W`, no initial turn, and path budgets
/// counted, so that a flight is the same on any machine.
ExplorationManagerConfig countedConfig(const Eigen::AlignedBox3d& box_W) {
  ExplorationManagerConfig p;
  p.box_W = box_W;
  p.initial_turn = false;
  p.path.seed = 3;
  p.path.time_limit_s = 1.0;
  p.path.max_iterations = 3000;
  p.cost_path.time_limit_s = 1.0;
  p.cost_path.max_iterations = 300;
  return p;
}

/// Flies the manager for up to max_time_s against the drifted map, rendering the true world.
Flight fly(bool safety, bool face_travel = true, double max_time_s = 60.0, const Vec3d& map_offset = kMapOffset,
           const std::optional<OdometryDrift>& odometry = std::nullopt, bool noisy_velocity = false,
           double vertical_margin_m = SafetyConfig{}.vertical_margin_m, bool look_at_way_only = false,
           bool lead_in_at_speed = TrajectoryConfig{}.lead_in_at_speed) {
  const CameraIntrinsics K = quarterCamera();
  ExplorationManagerConfig p = countedConfig(Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(12, 3, 2.5)));
  p.trajectory.lead_in_at_speed = lead_in_at_speed;
  p.safety.enabled = safety;
  p.safety.face_travel = face_travel;
  p.safety.odometry = odometry;
  p.safety.vertical_margin_m = vertical_margin_m;
  if (look_at_way_only) {  // the way's middle, in view by some yaw: stop 61's look-ahead
    p.safety.look_side_m = 0.0;
    p.safety.look_steep = false;
  }
  const DenseMap map = driftedMap(map_offset);
  const Vec3d start(1.0, 1.3, 1.2);
  ExplorationManager m(p, planner::test::at(start, M_PI), 0.0);
  Flight f;
  Vec3d interrupted_goal = Vec3d::Constant(std::numeric_limits<double>::quiet_NaN());
  for (double t = 0.0; t <= max_time_s; t += kFramePeriodS) {
    for (double s = std::max(0.0, t - kFramePeriodS); s <= t; s += 0.005) {  // the flight since the last frame
      const Vec3d x = m.command(s).position_W;
      f.min_clearance_m = std::min(f.min_clearance_m, trueClearance(x));
      f.max_x_m = std::max(f.max_x_m, x.x());
    }
    const VehicleState c = m.command(t);
    VehicleState v = planner::test::at(c.position_W, c.yaw_rad);
    v.velocity_W = c.velocity_W;
    // A drifting estimate's velocity: a few degrees off the trajectory and up to a hair above v_max.
    if (noisy_velocity) v.velocity_W = 1.0002 * (Eigen::AngleAxisd(0.035, Vec3d::UnitZ()) * c.velocity_W);
    const Pose3d T_W_S = lookingPose(v.position_W, v.yaw_rad);
    m.addDepthFrame(t, renderTrue(K, T_W_S), K, T_W_S);
    const Vec3d goal_before = m.command(1e9).position_W;  // where the current flight ends
    const std::size_t resumed_before = m.counters().looks_resumed;
    const ExplorationStep step = m.update(map, CoordBBox(), v, t);
    if (step.reason == ReplanReason::LookAhead) {
      interrupted_goal = goal_before;
      f.fastest_look_m_s = std::max(f.fastest_look_m_s, v.velocity_W.norm());
      f.look_return_m = std::max(f.look_return_m, flownBack(m.trajectory()));
    }
    if (m.counters().looks_resumed > resumed_before) {  // flies on to where the interrupted flight went
      CHECK(step.reason == ReplanReason::WaySeen);
      CHECK(m.flight() == FlightKind::ToTarget);
      CHECK((m.command(1e9).position_W - interrupted_goal).norm() < 1e-6);
    }
    f.ways_seen += step.reason == ReplanReason::WaySeen;
    if (step.status == ExplorationStatus::Finished) {
      f.finished = true;
      break;
    }
  }
  f.counters = m.counters();
  return f;
}
}  // namespace

TEST_CASE("SafetyConfig::validate names the field", "[planner][safety]") {
  SafetyConfig c;
  CHECK_NOTHROW(c.validate());
  c.look_margin_m = -0.1;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.look_margin_m"));
  c = SafetyConfig{};
  c.look_side_m = 5.5;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.look_side_m"));
  c = {};
  c.max_chained_looks = 0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.max_chained_looks"));
  c = {};
  c.clearance_m = 6.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.clearance_m"));
  c = {};
  c.recent.pool_px = 100;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("RecentFramesConfig.pool_px"));
  c = {};
  c.max_window_s = 0.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.max_window_s"));
  c = {};
  c.drift_tolerance_m = -0.1;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.drift_tolerance_m"));
  c = {};
  c.drift_lever_m = 1e3;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.drift_lever_m"));
  c = {};
  c.vertical_margin_m = 2.5;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.vertical_margin_m"));
  c = {};
  c.vertical_margin_sigmas = -1.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.vertical_margin_sigmas"));
  c = {};
  c.max_vertical_margin_m = 3.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("SafetyConfig.max_vertical_margin_m"));
  c = {};
  c.odometry = OdometryDrift{};
  c.odometry->yaw_rad_per_sqrt_s = -1.0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("OdometryDrift.yaw_rad_per_sqrt_s"));
}

TEST_CASE("The vertical margin applies unless the declared odometry does not drift", "[planner][safety]") {
  SafetyConfig c;
  CHECK(c.verticalMargin_m() == 0.2);  // unknown drift
  c.odometry = OdometryDrift{};
  CHECK(c.verticalMargin_m() == 0.0);  // none declared
  c.odometry->position_bias_m_per_s = -0.001;
  CHECK(c.verticalMargin_m() == 0.2);
  c.vertical_margin_m = 0.35;
  CHECK(c.verticalMargin_m() == 0.35);
}

TEST_CASE("The vertical margin grows with the map's age to vertical_margin_sigmas of the declared vertical drift",
          "[planner][safety]") {
  SafetyConfig c;  // margin 0.2 m, 2 sigmas, at most 0.3 m
  c.odometry = OdometryDrift{};
  c.odometry->position_m_per_sqrt_s = 0.01;
  c.odometry->yaw_rad_per_sqrt_s = 0.3;  // the yaw's drift does not lift a ceiling
  const auto sigmas = [&](double age_s) { return 2.0 * 0.01 * std::sqrt(age_s); };
  CHECK(c.verticalMargin_m(0.0) == 0.2);  // young maps keep vertical_margin_m
  CHECK(c.verticalMargin_m(64.0) == 0.2);
  CHECK(c.verticalMargin_m(156.25) == Approx(sigmas(156.25)));  // 0.25 m
  CHECK(c.verticalMargin_m(400.0) == 0.3);                      // 0.4 m, capped
  double previous = 0.0;
  for (double age_s = 0.0; age_s <= 1000.0; age_s += 7.0) {
    const double m = c.verticalMargin_m(age_s);
    CHECK(m >= previous);
    CHECK(m == Approx(std::clamp(sigmas(age_s), 0.2, 0.3)));
    previous = m;
  }
  // A cap below the margin leaves the margin; no sigmas, a constant margin; an unknown drift
  // cannot grow it.
  c.max_vertical_margin_m = 0.1;
  CHECK(c.verticalMargin_m(400.0) == 0.2);
  c.max_vertical_margin_m = 0.3;
  c.vertical_margin_sigmas = 0.0;
  CHECK(c.verticalMargin_m(400.0) == 0.2);
  c.vertical_margin_sigmas = 2.0;
  c.odometry.reset();
  CHECK(c.verticalMargin_m(400.0) == 0.2);
  CHECK_THROWS(c.verticalMargin_m(-1.0));
}

TEST_CASE("The manager keeps the margin for a map as old as its flight, and none without the layer",
          "[planner][safety]") {
  ExplorationManagerConfig p = countedConfig(Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(12, 3, 2.5)));
  p.safety.odometry = OdometryDrift{};
  p.safety.odometry->position_m_per_sqrt_s = 0.01;
  const VehicleState start = planner::test::at(Vec3d(1.0, 1.3, 1.2), M_PI);
  const ExplorationManager off(p, start, 50.0);
  CHECK(off.verticalMarginAt_m(206.25) == 0.0);
  p.safety.enabled = true;
  const ExplorationManager on(p, start, 50.0);  // started at 50 s: its map is 156.25 s old at 206.25 s
  CHECK(on.verticalMarginAt_m(50.0) == 0.2);
  CHECK(on.verticalMarginAt_m(206.25) == Approx(p.safety.verticalMargin_m(156.25)));
  CHECK(on.verticalMarginAt_m(206.25) == Approx(0.25));
  CHECK_THROWS(on.verticalMarginAt_m(49.0));
}

TEST_CASE(
    "The recent frames are trusted for as long as the declared drift allows, never less than recent.window_s; "
    "a way counts as seen by frames as old as the drift bears",
    "[planner][safety]") {
  ExplorationManagerConfig p;
  p.box_W = Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(12, 3, 2.5));
  p.safety.enabled = true;
  const auto windowOf = [&](const std::optional<OdometryDrift>& odometry) {
    p.safety.odometry = odometry;
    const ExplorationManager m(p, planner::test::at(Vec3d(1.0, 1.3, 1.2), 0.0), 0.0);
    CHECK(m.recentFrames()->config().dense_s == p.safety.recent.window_s);  // all frames of the base window kept
    return m.recentFrames()->config().window_s;
  };
  CHECK(windowOf(std::nullopt) == 10.0);  // unknown drift: the base window
  CHECK(p.safety.window_s() == 10.0);
  CHECK(windowOf(OdometryDrift{}) == p.safety.max_window_s);  // none: the longest
  OdometryDrift walk;  // 0.01 m and 0.01 rad per sqrt(s): at 2 m, 0.0373 m per sqrt(s)
  walk.position_m_per_sqrt_s = 0.01;
  walk.yaw_rad_per_sqrt_s = 0.01;
  const double expected = std::pow(0.2 / (std::sqrt(3.0) * 0.01 + 2.0 * 0.01), 2);
  CHECK(windowOf(walk) == Approx(expected));
  CHECK(expected > 10.0);
  CHECK(expected < 60.0);
  CHECK(p.safety.seenAge_s() == Approx(expected));  // a way counts as seen by all of the window
  walk.position_m_per_sqrt_s = 0.05;  // drift beyond the tolerance within the base window: the base window
  CHECK(windowOf(walk) == 10.0);
  // ... but a way counts as seen only by frames as old as the drift bears: 0.2 m at 2 m.
  const double bearable = std::pow(0.2 / (std::sqrt(3.0) * 0.05 + 2.0 * 0.01), 2);
  CHECK(bearable < 10.0);
  CHECK(p.safety.seenAge_s() == Approx(bearable).margin(1e-3));
  walk.position_m_per_sqrt_s = 0.5;  // never below a couple of seconds: the way ahead is a second's flight
  p.safety.odometry = walk;
  CHECK(p.safety.seenAge_s() == SafetyConfig::kMinSeenAge_s);
  p.safety.odometry.reset();
  CHECK(p.safety.seenAge_s() == 10.0);  // unknown drift: the window
  p.safety.max_window_s = 5.0;          // shorter than the base window: no widening
  CHECK(windowOf(OdometryDrift{}) == 10.0);
}

TEST_CASE("The scene is what the test says: the map's gap lies in the true wall, and the true gap is open",
          "[planner][safety]") {
  const DenseMap map = driftedMap();
  MapProbe probe(map);
  CHECK(probe.isClear(Vec3d(3.25, 2.1, 1.2), 0.35));           // the map's gap, 0.4 m from both sides
  CHECK(trueClearance(Vec3d(3.25, 2.1, 1.2)) == 0.0);          // is inside the true wall
  CHECK(trueClearance(Vec3d(3.25, 1.6, 1.2)) == Approx(0.4));  // the true gap
  CHECK(probe.atWorld(Vec3d(7.0, 1.5, 1.2)) == Occupancy::Unknown);
  const DepthImage ahead = renderTrue(quarterCamera(), lookingPose(Vec3d(1, 0.6, 1.2), 0.0));
  CHECK(ahead.at(79, 59) == Approx(2.0).margin(0.05));               // the block's face at x = 3, straight ahead
  CHECK(ahead.at(0, 59) == Approx(1.4 * 96.8 / 79.5).margin(0.05));  // the wall at y = 2 m, to the left
}

TEST_CASE(
    "Under 0.5 m of drift, the planner flies into a wall outside the camera's view; with the safety "
    "layer it turns to face the way first, sees the wall, stops and keeps clear",
    "[planner][safety]") {
  const Flight without = fly(/*safety=*/false);
  INFO("without: clearance " << without.min_clearance_m << " m, reached x " << without.max_x_m << " m");
  CHECK(without.max_x_m > 3.5);                      // through the map's gap
  CHECK(without.min_clearance_m < kVehicleRadiusM);  // a collision
  CHECK(without.counters.emergency_stops == 0);
  CHECK(without.counters.look_stops == 0);

  // Trajectories that face the way turn on the spot before moving off: the camera sees the wall
  // across the trajectory planned through the map's gap, and the vehicle stops and replans.
  const Flight with = fly(/*safety=*/true);
  INFO("with: clearance " << with.min_clearance_m << " m, reached x " << with.max_x_m << " m, looks "
                          << with.counters.look_stops << ", emergency stops " << with.counters.emergency_stops);
  CHECK(with.min_clearance_m >= kVehicleRadiusM);
  CHECK(with.counters.emergency_stops >= 1);
  CHECK(with.finished);  // the gap is blocked by what it saw: the target is given up

  // With the yaw spread over the motion instead, the vehicle starts off looking away: the way
  // ahead is unseen, so it brakes and looks first (a look stop). Facing the way, it sees the wall
  // across it: the way is blocked, it plans anew, and gives the target up.
  const Flight looking = fly(/*safety=*/true, /*face_travel=*/false);
  INFO("looking: clearance " << looking.min_clearance_m << " m, reached x " << looking.max_x_m << " m, looks "
                             << looking.counters.look_stops << ", emergency stops "
                             << looking.counters.emergency_stops);
  CHECK(looking.min_clearance_m >= kVehicleRadiusM);
  CHECK(looking.counters.look_stops >= 1);
  CHECK(looking.ways_seen >= 1);
  CHECK(looking.max_x_m < 2.0);
  CHECK(looking.finished);
}

TEST_CASE("Without drift declared, the map counts as seen: no look where it holds the way clear", "[planner][safety]") {
  // The map is the true world. Facing away from its way with the yaw spread over the motion, the
  // vehicle brakes to look when no drift is declared, and each time, as soon as it faces the way
  // and sees it free, before its turn toward it ends, flies on to where it was going (fly()
  // checks the goal), through the gap; declared without drift, the map is as good as a recent
  // frame, and it flies through the gap with no look. Both keep clear and finish.
  const Vec3d exact = Vec3d::Zero();
  const Flight unknown = fly(/*safety=*/true, /*face_travel=*/false, 60.0, exact);
  const Flight declared = fly(/*safety=*/true, /*face_travel=*/false, 60.0, exact, OdometryDrift{});
  INFO("unknown drift: looks " << unknown.counters.look_stops << ", reached x " << unknown.max_x_m
                               << " m; no drift: looks " << declared.counters.look_stops << ", reached x "
                               << declared.max_x_m << " m");
  CHECK(unknown.counters.look_stops >= 1);
  CHECK(unknown.counters.looks_resumed >= 1);
  CHECK(declared.counters.look_stops == 0);
  for (const Flight* f : {&unknown, &declared}) {
    CHECK(f->max_x_m > 3.5);  // through the true gap
    CHECK(f->min_clearance_m >= kVehicleRadiusM);
    CHECK(f->finished);
  }
  // Drift the map is not trusted with beyond its age: s3's walk trusts it for its first 9.4 s.
  OdometryDrift s3;
  s3.position_m_per_sqrt_s = s3.yaw_rad_per_sqrt_s = std::sqrt(5e-2 / 200.0);
  s3.yaw_bias_rad_per_s = 1e-3;
  SafetyConfig c;
  c.odometry = s3;
  CHECK(c.trustedAge_s() == Approx(9.4).margin(0.05));
  CHECK(SafetyConfig{}.trustedAge_s() == 0.0);
  c.odometry = OdometryDrift{};
  CHECK(c.trustedAge_s() == 1e9);
}

TEST_CASE("A look brakes straight along the velocity, also when the estimate's velocity is off the trajectory",
          "[planner][safety]") {
  // A drifting estimate's velocity runs a few degrees off the trajectory and can exceed v_max by a
  // hair; braking along the trajectory's own points then made the trajectory generator fly a
  // lead-in past the stop and back (2 m out and back in a house run at s3).
  // (The map is 0.3 m off in y alone: without the vertical margin, looking at the way's middle in
  // view only, and with straight lead-ins, the flight meets its look at 1.04 m/s; its climb to the
  // viewpoint's height is steep. With the map 0.5 m off, the first look, at take-off, sees the way
  // blocked.)
  const Flight noisy = fly(/*safety=*/true, /*face_travel=*/false, 60.0, Vec3d(0.0, 0.3, 0.0), std::nullopt,
                           /*noisy_velocity=*/true, /*vertical_margin_m=*/0.0, /*look_at_way_only=*/true,
                           /*lead_in_at_speed=*/false);
  INFO("looks " << noisy.counters.look_stops << ", fastest at " << noisy.fastest_look_m_s << " m/s, flew back "
                << noisy.look_return_m << " m");
  CHECK(noisy.counters.look_stops >= 1);
  CHECK(noisy.fastest_look_m_s > 0.5);  // a look at speed, where braking takes room
  // Within 0.2 m/s of rest the look stops at its start, which takes the generator's shortest
  // lead-in, 0.1 m out and back; at speed it flew back 1.2 m.
  CHECK(noisy.look_return_m <= 0.1 + 1e-6);
  CHECK(noisy.min_clearance_m >= kVehicleRadiusM);
}

TEST_CASE(
    "Why a look brakes along the velocity: braking along points a few degrees off it flies past the stop and back",
    "[planner][safety]") {
  // The house run at s3 that showed it: 2 m/s along -x, the trajectory's next metre 2 degrees off
  // the estimate's velocity, which exceeds v_max = 2 m/s by 1e-4.
  DenseMap open(kVoxel, CoordBBox(Coord(-100, -50, -5), Coord(100, 50, 30)));
  open.fill(CoordBBox(Coord(-100, -50, -5), Coord(100, 50, 30)), Occupancy::Free);
  const TrajectoryConfig tc;
  VehicleState v = planner::test::at(Vec3d(6.375, -0.2, 1.19), 1.5);
  v.velocity_W = Vec3d(-2.0, -0.019, 0.019);
  const double brake_m = tc.v_max_m_s * tc.v_max_m_s / (2.0 * tc.a_max_m_s2);
  std::vector<Vec3d> along_points{v.position_W};
  for (double s = 0.05; s <= brake_m + 1e-9; s += 0.05)
    along_points.push_back(v.position_W + s * Vec3d(-1.0, 0.0, -0.035).normalized());
  const TrajectoryResult old_way = planTrajectory(along_points, v, M_PI, open, tc);
  REQUIRE(old_way.ok());
  CHECK(flownBack(old_way.trajectory) > 1.0);
  // What lookAhead does: the speed capped at v_max, a straight stop along the velocity.
  VehicleState capped = v;
  capped.velocity_W *= tc.v_max_m_s / v.velocity_W.norm();
  const TrajectoryResult look =
      planTrajectory({v.position_W, v.position_W + brake_m * capped.velocity_W.normalized()}, capped, M_PI, open, tc);
  REQUIRE(look.status == TrajectoryStatus::Ok);
  CHECK(flownBack(look.trajectory) < 1e-3);
  CHECK(look.trajectory.motionDuration() == Approx(1.0).margin(0.05));  // v / a_max
}

namespace {
/// A map whose flight reading holds a ghost over its base: the voxels of `ghost` read occupied,
/// as TsdfMapQuery's thin-structure rules read the end points a surface left where an earlier
/// drift put it. Lines of sight (sightMap) read the base alone, as TsdfMapQuery's do.
class GhostMap : public MapQuery {
 public:
  GhostMap(const DenseMap& base, const CoordBBox& ghost) : base_(base), ghost_(ghost) {}
  double voxelSize() const override { return base_.voxelSize(); }
  CoordBBox knownBounds() const override { return base_.knownBounds(); }
  std::unique_ptr<MapReader> reader() const override { return std::make_unique<Reader>(base_.reader(), ghost_); }
  const MapQuery& sightMap() const override { return base_; }

 private:
  struct Reader : MapReader {
    Reader(std::unique_ptr<MapReader> b, const CoordBBox& g) : base(std::move(b)), ghost(g) {}
    Occupancy at(const Coord& ijk) override { return ghost.isInside(ijk) ? Occupancy::Occupied : base->at(ijk); }
    std::unique_ptr<MapReader> base;
    CoordBBox ghost;
  };
  const DenseMap& base_;
  CoordBBox ghost_;
};

/// wallRoom's 10 x 6 m room, its wall at x = 5 m with a door at y 2.5-3.5 m; unknown beyond x =
/// 7 m (the frontier).
DenseMap doorRoom() {
  DenseMap base = planner::test::wallRoom();
  base.fill(CoordBBox(Coord(70, 1, 1), Coord(98, 58, 28)), Occupancy::Unknown);
  return base;
}
/// A slab 0.2 m before doorRoom's wall across y 2-4 m, which only the thin-structure reading holds.
const CoordBBox kSlabBeforeDoor(Coord(47, 20, 1), Coord(47, 40, 28));

/// Where the first flight ends of a manager with the layer (`safety`, enabled here) standing at
/// (2, 3, 1) facing the door, optionally with a frame that sees a wall `wall_ahead_m` ahead.
Vec3d firstFlightEnd(const MapQuery& map, SafetyConfig safety, const std::optional<float>& wall_ahead_m = {}) {
  const VehicleState start = planner::test::at(Vec3d(2.0, 3.0, 1.0), 0.0);
  ExplorationManagerConfig p = countedConfig(Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(10, 6, 3)));
  p.safety = std::move(safety);
  p.safety.enabled = true;
  ExplorationManager m(p, start, 0.0);
  if (wall_ahead_m) {
    const CameraIntrinsics K = quarterCamera();
    const Pose3d T_W_S = lookingPose(start.position_W, start.yaw_rad);
    m.addDepthFrame(0.0, DepthImage(K.width, K.height, *wall_ahead_m), K, T_W_S);
  }
  m.update(map, CoordBBox(), start, 0.0);
  return m.command(1e9).position_W;
}
}  // namespace

TEST_CASE(
    "With the map's thin structure left to the recent surfaces, a door its ghost closes is open, and what "
    "the camera sees there still blocks it",
    "[planner][safety]") {
  // The slab is a ghost: the end points of the wall seen at another drift. No odometry is declared.
  const DenseMap base = doorRoom();
  const GhostMap map(base, kSlabBeforeDoor);
  REQUIRE(MapProbe(map).atWorld(Vec3d(4.7, 3.0, 1.0)) == Occupancy::Occupied);
  REQUIRE(MapProbe(map.sightMap()).atWorld(Vec3d(4.7, 3.0, 1.0)) == Occupancy::Free);
  SafetyConfig thin, recent_only;
  thin.map_thin_obstacles = true;
  // The map's thin structure read: the ghost closes the door, no flight gets through.
  CHECK(firstFlightEnd(map, thin).x() < 5.0);
  // Left to the recent surfaces (none yet): the door is open.
  const Vec3d through = firstFlightEnd(map, recent_only);
  INFO("without the map's thin structure the flight ends at " << through.transpose());
  CHECK(through.x() > 5.0);
  // A wall the camera sees 2.5 m ahead (x = 4.5 m, across the door's approach) blocks it again.
  CHECK(firstFlightEnd(map, recent_only, 2.5f).x() < 4.5);
}

TEST_CASE(
    "With the layer the map's thin structure is read where the declared odometry does not drift, and left to "
    "the recent surfaces where it does",
    "[planner][safety]") {
  // The slab is what the map's thin-structure rules read: real thin structure without drift (a
  // surface seen again lands where it was), possibly a ghost under drift.
  const DenseMap base = doorRoom();
  const GhostMap map(base, kSlabBeforeDoor);
  const auto withOdometry = [](const std::optional<OdometryDrift>& odometry, bool without_drift) {
    SafetyConfig safety;
    safety.odometry = odometry;
    safety.map_thin_without_drift = without_drift;
    return safety;
  };
  OdometryDrift drifting;
  drifting.position_m_per_sqrt_s = 0.016;
  drifting.yaw_rad_per_sqrt_s = 0.016;
  CHECK(firstFlightEnd(map, withOdometry(OdometryDrift{}, true)).x() < 5.0);   // no drift: the slab blocks
  CHECK(firstFlightEnd(map, withOdometry(drifting, true)).x() > 5.0);          // drift: the recent frames'
  CHECK(firstFlightEnd(map, withOdometry(std::nullopt, true)).x() > 5.0);      // none declared: it may drift
  CHECK(firstFlightEnd(map, withOdometry(OdometryDrift{}, false)).x() > 5.0);  // the rule off
}

namespace {
/// A manager with the layer in the exact corridor, at `start` with `velocity` and facing -x, whose
/// only view of the way ahead (+x) is a frame from x = 0.2 m at t = 0; at t_plan it sees the wall
/// behind it and plans toward the frontier at x = 6 m.
std::unique_ptr<ExplorationManager> plannedFacingAway(const DenseMap& map, const Vec3d& start, const Vec3d& velocity,
                                                      double t_plan, bool seen_until_arrival = true) {
  const CameraIntrinsics K = quarterCamera();
  ExplorationManagerConfig p = countedConfig(Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(12, 3, 2.5)));
  p.safety.enabled = true;
  p.safety.seen_until_arrival = seen_until_arrival;
  VehicleState s0 = planner::test::at(start, M_PI);
  s0.velocity_W = velocity;
  auto m = std::make_unique<ExplorationManager>(p, s0, 0.0);
  const Pose3d ahead = lookingPose(Vec3d(0.2, start.y(), start.z()), 0.0), behind = lookingPose(start, M_PI);
  m->addDepthFrame(0.0, renderTrue(K, ahead), K, ahead);
  m->addDepthFrame(t_plan, renderTrue(K, behind), K, behind);
  REQUIRE(m->update(map, CoordBBox(), s0, t_plan).status == ExplorationStatus::Planned);
  return m;
}

/// Flies `m` exactly along its commands, a frame of the true world every kFramePeriodS from
/// t_from on, until t_to or until `on_step(t, vehicle, step)` returns false.
template <class OnStep>
void flyCommands(ExplorationManager& m, const DenseMap& map, double t_from, double t_to, OnStep&& on_step) {
  const CameraIntrinsics K = quarterCamera();
  for (double t = t_from + kFramePeriodS; t <= t_to; t += kFramePeriodS) {
    const VehicleState c = m.command(t);
    VehicleState v = planner::test::at(c.position_W, c.yaw_rad);
    v.velocity_W = c.velocity_W;
    const Pose3d T_W_S = lookingPose(v.position_W, v.yaw_rad);
    m.addDepthFrame(t, renderTrue(K, T_W_S), K, T_W_S);
    if (!on_step(t, v, m.update(map, CoordBBox(), v, t))) return;
  }
}
}  // namespace

TEST_CASE("A way seen only by frames that leave the window before the vehicle gets there counts as unseen",
          "[planner][safety]") {
  // The corridor without drift, seen at t = 0 by a frame looking along it from x = 0.2 m; at
  // t = 9 s the vehicle faces away (its newest frame sees the wall behind it) and plans to the
  // frontier ahead. The old frame leaves the 10 s window at t = 10 s, so the way beyond where the
  // vehicle gets by then is unseen (seen_until_arrival), and it turns to face the way before it
  // flies there. Counting every frame in the window, the way is all seen: it flies off looking
  // back, its yaw spread over the motion, and 1 m out, as the old frame leaves the window, the way
  // ahead is unseen at speed.
  const DenseMap map = driftedMap(Vec3d::Zero());
  const Vec3d start(1.0, 1.3, 1.2);
  const double t_plan = 9.0;
  // The angle between the yaw and the direction of travel (toward where the vehicle is 0.5 s
  // later, as TrajectoryConfig::yaw_along_travel faces it) when the first trajectory has flown
  // 1 m from the start.
  const auto yawOffTravel = [&](bool until_arrival) {
    const std::unique_ptr<ExplorationManager> planned =
        plannedFacingAway(map, start, Vec3d::Zero(), t_plan, until_arrival);
    const ExplorationManager& m = *planned;
    REQUIRE(m.command(1e9).position_W.x() > 3.0);  // past the block, toward the frontier at x = 6 m
    double s = t_plan;
    while ((m.command(s).position_W - start).norm() < 1.0) s += 0.01;
    REQUIRE(s < m.trajectoryStartTime() + m.trajectory().motionDuration());
    const VehicleState c = m.command(s);
    const Eigen::Vector2d travel = (m.command(s + 0.5).position_W - c.position_W).head<2>();
    return std::abs(wrapAngle(std::atan2(travel.y(), travel.x()) - c.yaw_rad));
  };
  const double facing_rad = TrajectoryConfig{}.start_facing_rad;
  CHECK(yawOffTravel(true) <= facing_rad);
  CHECK(yawOffTravel(false) > M_PI / 2);  // flies off looking back
}

namespace {
/// s3's drift as the simulator declares it (sim::odometryDriftOf).
OdometryDrift s3Drift() {
  OdometryDrift s3;
  s3.position_m_per_sqrt_s = s3.yaw_rad_per_sqrt_s = std::sqrt(5e-2 / 200.0);
  s3.yaw_bias_rad_per_s = 1e-3;
  return s3;
}

/// In the exact corridor, with s3's drift declared and the layer set by `configure`: a frame looks
/// along the corridor from x = 0.2 m at t = 0, and at t_plan the vehicle, at rest at `start` and
/// facing away (its frame sees the wall behind it), plans to the frontier at x = 6 m through the
/// gap beside the block (x 3-3.5 m). Returns the angle between its yaw and its direction of travel
/// (toward where it is 0.5 s later) where `reached(position)` first holds.
template <class Configure, class Reached>
double yawOffTravelWhere(const DenseMap& map, const Vec3d& start, double t_plan, Configure&& configure,
                         Reached&& reached) {
  const CameraIntrinsics K = quarterCamera();
  ExplorationManagerConfig p = countedConfig(Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(12, 3, 2.5)));
  p.safety.enabled = true;
  p.safety.odometry = s3Drift();
  configure(p.safety);
  const VehicleState s0 = planner::test::at(start, M_PI);
  ExplorationManager m(p, s0, -60.0);  // the map is a minute old: not trusted as seen
  const Pose3d ahead = lookingPose(Vec3d(0.2, start.y(), start.z()), 0.0), behind = lookingPose(start, M_PI);
  m.addDepthFrame(0.0, renderTrue(K, ahead), K, ahead);
  m.addDepthFrame(t_plan, renderTrue(K, behind), K, behind);
  REQUIRE(m.update(map, CoordBBox(), s0, t_plan).status == ExplorationStatus::Planned);
  REQUIRE(m.command(1e9).position_W.x() > 3.5);  // through the gap, toward the frontier
  double s = t_plan;
  while (!reached(m.command(s).position_W)) s += 0.01;
  const VehicleState c = m.command(s);
  const Eigen::Vector2d travel = (m.command(s + 0.5).position_W - c.position_W).head<2>();
  return std::abs(wrapAngle(std::atan2(travel.y(), travel.x()) - c.yaw_rad));
}
}  // namespace

TEST_CASE("Near a surface seen seconds before, only frames young at arrival count: the vehicle faces the way first",
          "[planner][safety]") {
  // The exact corridor, seen at t = 0 by a frame looking along it from x = 0.2 m, with s3's drift
  // declared: that frame counts for 9.4 s (seenAge_s). At t = 4 s the vehicle, facing away,
  // plans to the frontier at x = 6 m through the 0.8 m gap beside the block (x 3-3.5 m). Where
  // the way passes within clearance_m + drift_tolerance_m of the block, the frame may be off by
  // the clearance (s3's drift after 5 s at 2 m: 0.14 m), so there only frames at most 2.6 s old
  // at arrival count (nearSeenAge_s): the flight faces the way before it gets there. Without that
  // rule (off by default) the whole way counts as seen, and it flies past the block looking back.
  const DenseMap map = driftedMap(Vec3d::Zero());
  const OdometryDrift s3 = s3Drift();
  const Vec3d start(1.0, 1.3, 1.2);
  const double t_plan = 4.0;
  const auto yawOffTravelAtBlock = [&](double near_drift_tolerance_m) {
    return yawOffTravelWhere(
        map, start, t_plan, [&](SafetyConfig& c) { c.near_drift_tolerance_m = near_drift_tolerance_m; },
        [](const Vec3d& p) { return p.x() >= 2.7; });  // 0.3 m before the block
  };
  SafetyConfig c;
  c.odometry = s3;
  CHECK(c.seenAge_s() == Approx(9.4).margin(0.05));
  CHECK(c.nearSeenAge_s() == c.seenAge_s());  // the rule is off by default
  c.near_drift_tolerance_m = 0.1;
  CHECK(c.nearSeenAge_s() == Approx(2.6).margin(0.05));
  const double near_rule = yawOffTravelAtBlock(0.1);
  const double without = yawOffTravelAtBlock(SafetyConfig{}.near_drift_tolerance_m);
  INFO("yaw off the travel 0.3 m before the block: " << near_rule << " rad with the rule, " << without << " without");
  CHECK(near_rule <= TrajectoryConfig{}.start_facing_rad);
  CHECK(without > M_PI / 2);
  // Without declared drift the rule has nothing to go by.
  c.odometry.reset();
  CHECK(c.nearSeenAge_s() == c.seenAge_s());
}

TEST_CASE("A frame counts for less time when the vehicle flies far since: the yaw drift turns the path flown",
          "[planner][safety]") {
  // The exact corridor, seen at t = 0 by a frame looking along it from x = 0.2 m, with s3's drift
  // declared. At t = 5 s the vehicle, at rest and facing away, plans to the frontier at x = 6 m.
  // By age alone the frame counts for 9.4 s, so the whole way is seen and the vehicle flies off
  // looking back. Counting the path flown since the frame (path_drift), the yaw drift of those
  // seconds turns every metre of it: 2 m out, about 6.5 s after the frame, its drift is over
  // drift_tolerance_m, and the vehicle faces the way before it gets there, whether the path counts
  // everywhere or only near recent surfaces (there the way passes the block beside the gap).
  const DenseMap map = driftedMap(Vec3d::Zero());
  const OdometryDrift s3 = s3Drift();
  const Vec3d start(1.0, 1.3, 1.2);
  const double t_plan = 5.0;
  const auto yawOffTravelOut = [&](PathDriftScope scope) {
    return yawOffTravelWhere(
        map, start, t_plan, [&](SafetyConfig& c) { c.path_drift = scope; },
        [&](const Vec3d& p) { return (p - start).norm() >= 2.0; });
  };
  // What the rule reads: 6.5 s and 2 m after a frame, s3's drift passes the tolerance only with
  // the path; at rest the frame counts as long as before.
  const SafetyConfig c;
  CHECK(s3.displacement_m(6.5, c.drift_lever_m) < c.drift_tolerance_m);
  CHECK(s3.displacement_m(6.5, c.drift_lever_m, 2.0) > c.drift_tolerance_m);
  CHECK(c.path_drift == PathDriftScope::Off);  // off by default
  const double everywhere = yawOffTravelOut(PathDriftScope::Everywhere);
  const double near = yawOffTravelOut(PathDriftScope::NearSurfaces);
  const double by_age = yawOffTravelOut(PathDriftScope::Off);
  INFO("yaw off the travel 2 m out: " << everywhere << " rad counting the path everywhere, " << near
                                      << " near surfaces, " << by_age << " by age alone");
  CHECK(everywhere <= TrajectoryConfig{}.start_facing_rad);
  CHECK(near <= TrajectoryConfig{}.start_facing_rad);
  CHECK(by_age > M_PI / 2);
}

TEST_CASE("Where the vehicle stands counts as seen: looks do not wait for its own position", "[planner][safety]") {
  // As above, the vehicle faces away from the way at t_plan = 9 s, and only the frame of t = 0
  // saw the way, including where the vehicle stands. The trajectory turns on the spot before it
  // moves, so its first points lie (within rounding) where the vehicle is, reached when that
  // frame no longer counts; no frame from where the vehicle stands sees its own position. Those
  // points lie within the vehicle's clearance and count as seen: the vehicle turns, looks beside
  // the way, and flies on. Checked like the rest of the way, they were never seen: three looks
  // in a row on the spot, and the target counted as failed.
  const DenseMap map = driftedMap(Vec3d::Zero());
  const Vec3d start(1.0, 1.3, 1.2);
  const double t_plan = 9.0;
  const std::unique_ptr<ExplorationManager> m = plannedFacingAway(map, start, Vec3d::Zero(), t_plan);
  double moved_m = 0.0;
  flyCommands(*m, map, t_plan, t_plan + 8.0, [&](double, const VehicleState& v, const ExplorationStep&) {
    moved_m = std::max(moved_m, (v.position_W - start).norm());
    return moved_m <= 1.0;
  });
  CHECK(m->counters().target_failures == 0);
  CHECK(moved_m > 1.0);  // within 8 s
}

TEST_CASE("A flight that faces the way is planned from its own arrival times, so a look does not stop it at once",
          "[planner][safety]") {
  // The vehicle flies backwards along the corridor (+x, camera facing -x) when it replans toward
  // the frontier at x = 6 m, at t_plan = 8.75 s; only the frame of t = 0 saw the way ahead, and it
  // counts for points reached within 1.25 s. Checked on the flight with the yaw spread over the
  // motion, the way is seen far ahead, so the flight that faces the way may cruise a long way
  // while it turns. But that flight, slowed to turn, gets there later, when the old frame no
  // longer counts: its own first unseen point bounds how far it flies before it faces the way.
  // Then it is not stopped by a look at the next update, and it flies more than a metre in 3 s;
  // planned from the spread flight's arrival times, a look stopped it at once (0.1-0.6 m).
  const double speed_m_s = GENERATE(0.5, 1.0, 1.5);
  INFO("speed " << speed_m_s << " m/s");
  const DenseMap map = driftedMap(Vec3d::Zero());
  const Vec3d start(1.0, 1.5, 1.2);
  const double t_plan = 8.75;
  const std::unique_ptr<ExplorationManager> m = plannedFacingAway(map, start, Vec3d(speed_m_s, 0, 0), t_plan);
  bool looked_at_once = false;
  double moved_m = 0.0;
  flyCommands(*m, map, t_plan, t_plan + 3.0, [&](double t, const VehicleState& v, const ExplorationStep& step) {
    if (t < t_plan + 1.5 * kFramePeriodS) looked_at_once = step.reason == ReplanReason::LookAhead;
    moved_m = std::max(moved_m, (v.position_W - start).norm());
    return true;
  });
  CHECK_FALSE(looked_at_once);
  CHECK(moved_m > 1.0);
}
