// Active loop closure inside the exploration manager, on synthetic maps: the manager flies a loop
// detour when the loop cluster is where the vehicle is (cheap) and not when it lies 3 m behind,
// away from the frontier (expensive);
// a detour that finds no loop is given up at its timeout (a replan of its own), and the cluster is
// not chosen again until the suspension ends; a notified loop closure ends a detour; with ALC on,
// exploration still finishes.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/exploration_manager.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;
using test::at;

namespace {
constexpr double kVoxel = 0.1;

/// A 12 x 6 x 3 m room at 0.1 m: walls occupied, inside free up to x = 8 m, unknown beyond: the
/// plane x = 8 m is the frontier.
DenseMap corridorRoom() {
  DenseMap map(kVoxel, CoordBBox(Coord(-2), Coord(122, 62, 32)));
  map.fill(CoordBBox(Coord(0), Coord(119, 59, 29)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(1), Coord(79, 58, 28)), Occupancy::Free);
  map.fill(CoordBBox(Coord(80, 1, 1), Coord(118, 58, 28)), Occupancy::Unknown);
  return map;
}

/// The same room with every voxel inside known free: nothing to explore.
DenseMap closedRoom() {
  DenseMap map(kVoxel, CoordBBox(Coord(-2), Coord(122, 62, 32)));
  map.fill(CoordBBox(Coord(0), Coord(119, 59, 29)), Occupancy::Occupied);
  map.fill(CoordBBox(Coord(1), Coord(118, 58, 28)), Occupancy::Free);
  return map;
}

/// ALC for hand-fed histories: on from the start, clusters once viewpoints are 1 s old, a 2 s
/// give-up timeout and a 3 s suspension. Path budgets are counted (the wall-clock limits far above
/// what the searches take), so a loaded machine plans as an idle one does.
ExplorationManagerConfig alcParams() {
  ExplorationManagerConfig p;
  p.box_W = Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(12, 6, 3));
  p.initial_turn = false;
  p.path.time_limit_s = 1.0;
  p.path.max_iterations = 3000;
  p.cost_path.time_limit_s = 1.0;
  p.cost_path.max_iterations = 300;
  p.alc_enabled = true;
  p.alc.initial_period_s = 0.0;
  p.alc.clusters.min_age_s = 1.0;
  p.alc.give_up_timeout_s = 2.0;
  p.alc.suspension_s = 3.0;
  p.alc.loop_quiet_s = 3.0;
  return p;
}


/// Flies (as far as the manager can tell: the states it is given) through a place, 0.75 m along
/// +x from (place_x, 3, 1.5), then elsewhere (more than search_radius_m from `vehicle`, which ends
/// the place's run), then appears at `vehicle` once the place is old enough to be a loop cluster.
/// Returns the time reached.
double flyPlaceThenGo(ExplorationManager& m, const DenseMap& map, double place_x, const Vec3d& vehicle) {
  const Vec3d elsewhere(7.5, 0.6, 1.5);
  double t = 0.0;
  for (int k = 0; k < 4; ++k, t += 0.2) m.update(map, CoordBBox(), at(Vec3d(place_x + 0.25 * k, 3, 1.5)), t);
  for (; t < 2.5; t += 0.5) m.update(map, CoordBBox(), at(elsewhere), t);
  for (; t < 3.5; t += 0.5) m.update(map, CoordBBox(), at(vehicle), t);
  return t;
}

/// Forces a global replan now (a frame shift by the identity) with the vehicle at `vehicle`.
ExplorationStep replanAt(ExplorationManager& m, const DenseMap& map, const Vec3d& vehicle, double t) {
  m.shiftFrame(Eigen::Isometry3d::Identity());
  return m.update(map, CoordBBox(), at(vehicle), t);
}

/// The trajectory ends at one of the viewpoints of the loop cluster ALC is on.
bool endsAtLoopCluster(const ExplorationManager& m) {
  REQUIRE(m.alc() != nullptr);
  REQUIRE(m.alc()->detour());
  const VehicleState end = m.command(m.trajectoryStartTime() + m.trajectory().duration());
  for (const Viewpoint& v : m.alc()->clusters().viewpoints(m.alc()->history(), m.alc()->detour()->cluster))
    if ((v.position_W - end.position_W).norm() < 1e-6 && yawDistance(v.yaw_rad, end.yaw_rad) < 1e-6) return true;
  return false;
}
}  // namespace

TEST_CASE("ExplorationManagerConfig validates ALC's parameters only when ALC is on", "[planner][exploration][alc]") {
  ExplorationManagerConfig p = alcParams();
  p.alc.epsilon = -1.0;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("epsilon"));
  p.alc_enabled = false;
  CHECK_NOTHROW(p.validate());
  ExplorationManager off(p, at(Vec3d(1, 3, 1.5)), 0.0);
  CHECK(off.alc() == nullptr);
  CHECK(off.alcStats().detours == 0);
}

TEST_CASE("The manager detours to a loop cluster on the way, not to one behind it", "[planner][exploration][alc]") {
  const DenseMap map = corridorRoom();
  const Vec3d vehicle(4.5, 3, 1.5);  // the frontier (x = 8 m) lies ahead

  SECTION("cheap: the vehicle is back at the place (the cluster's centre)") {
    ExplorationManager m(alcParams(), at(Vec3d(4.0, 3, 1.5)), 0.0);
    const double t = flyPlaceThenGo(m, map, 4.0, vehicle);
    const ExplorationStep step = replanAt(m, map, vehicle, t);
    REQUIRE(step.alc_status.has_value());
    CHECK(*step.alc_status == AlcStatus::kDetour);
    CHECK(step.status == ExplorationStatus::Planned);
    CHECK(step.loop_detour);
    CHECK(m.onLoopDetour());
    CHECK(step.target == 0);  // not a frontier cluster
    CHECK(endsAtLoopCluster(m));
    CHECK(m.alcStats().detours == 1);
    // A detour is not replanned periodically: the next replan comes at its end.
    const double mid = m.trajectoryStartTime() + 0.5 * m.trajectory().duration();
    if (m.trajectory().duration() - 0.5 * m.trajectory().duration() > m.params().replan_time_left_s)
      CHECK(m.update(map, CoordBBox(), at(m.command(mid).position_W), mid).reason == ReplanReason::None);
  }
  SECTION("expensive: the cluster's centre lies 3 m behind the vehicle") {
    ExplorationManager m(alcParams(), at(Vec3d(1.0, 3, 1.5)), 0.0);
    const double t = flyPlaceThenGo(m, map, 1.0, vehicle);
    const ExplorationStep step = replanAt(m, map, vehicle, t);
    REQUIRE(step.alc_status.has_value());
    CHECK(*step.alc_status == AlcStatus::kFrontierCheaper);
    CHECK(step.status == ExplorationStatus::Planned);
    CHECK_FALSE(step.loop_detour);
    CHECK(step.target != 0);  // a frontier cluster
    CHECK(m.alcStats().detours == 0);
  }
}

TEST_CASE("A detour without a loop is given up at its timeout and its cluster waits out the suspension",
          "[planner][exploration][alc]") {
  const DenseMap map = corridorRoom();
  const Vec3d vehicle(4.5, 3, 1.5);
  const ExplorationManagerConfig p = alcParams();
  ExplorationManager m(p, at(Vec3d(4.0, 3, 1.5)), 0.0);
  double t = flyPlaceThenGo(m, map, 4.0, vehicle);
  REQUIRE(replanAt(m, map, vehicle, t).loop_detour);
  const double detour_start = t;
  const LoopClusterId cluster = m.alc()->detour()->cluster;

  SECTION("timeout, suspension, then the same cluster again") {
    // The vehicle stays put (it never reaches the cluster): at the timeout, a replan of its own.
    t = detour_start + p.alc.give_up_timeout_s + 0.05;
    ExplorationStep step = m.update(map, CoordBBox(), at(vehicle), t);
    CHECK(step.reason == ReplanReason::LoopDetourTimeout);
    REQUIRE(step.alc_status.has_value());
    CHECK(*step.alc_status == AlcStatus::kGaveUp);
    CHECK_FALSE(step.loop_detour);
    CHECK(step.status == ExplorationStatus::Planned);  // exploration goes on
    CHECK(m.alcStats().give_ups == 1);
    const double gave_up = t;
    REQUIRE(m.alc()->suspendedUntil().has_value());
    CHECK(*m.alc()->suspendedUntil() == Approx(gave_up + p.alc.suspension_s));

    for (t = gave_up + 0.5; t < gave_up + p.alc.suspension_s - 0.1; t += 1.0) {
      step = replanAt(m, map, vehicle, t);
      REQUIRE(step.alc_status.has_value());
      CHECK(*step.alc_status == AlcStatus::kSuspended);
      CHECK_FALSE(step.loop_detour);
    }
    step = replanAt(m, map, vehicle, gave_up + p.alc.suspension_s + 0.05);
    REQUIRE(step.alc_status.has_value());
    CHECK(*step.alc_status == AlcStatus::kDetour);
    CHECK(step.loop_detour);
    CHECK(m.alc()->detour()->cluster == cluster);
    CHECK(m.alc()->failures(cluster) == 1);
    CHECK(m.alcStats().detours == 2);
  }
  SECTION("a loop closure ends the detour; ALC is quiet after it") {
    t = detour_start + 0.5;
    m.notifyLoopClosure(t);
    const ExplorationStep step = replanAt(m, map, vehicle, t);  // the simulator shifts the frame too
    REQUIRE(step.alc_status.has_value());
    CHECK(*step.alc_status == AlcStatus::kQuietAfterLoop);
    CHECK_FALSE(step.loop_detour);
    CHECK_FALSE(m.onLoopDetour());
    const AlcStats stats = m.alcStats();
    CHECK(stats.detours == 1);
    CHECK(stats.loops_on_detour == 1);
    CHECK(stats.give_ups == 0);
    CHECK(stats.detour_time_s == Approx(0.5));
  }
  SECTION("a correction moves the history") {
    const Vec3d offset(0.0, 0.3, 0.0);
    m.notifyLoopClosure(t + 0.1, [&](const FlownViewpoint& v) { return FlatPose{v.position_W + offset, v.yaw_rad}; });
    CHECK((m.alc()->history()[0].position_W - Vec3d(4.0, 3.3, 1.5)).norm() < 1e-9);
  }
}

TEST_CASE("With ALC on, exploration of a room still finishes", "[planner][exploration][alc]") {
  // The map never changes, so every visited target stays unobserved until all are blacklisted;
  // ALC may send the vehicle back to old places on the way, but never keeps it from finishing.
  const DenseMap map = corridorRoom();
  ExplorationManagerConfig p = alcParams();
  ExplorationManager m(p, at(Vec3d(2, 3, 1.5)), 0.0);
  double t = 0.0;
  ExplorationStep step = m.update(map, CoordBBox(), at(Vec3d(2, 3, 1.5)), t);
  // The vehicle follows the commands exactly, at 4 Hz, for at most 500 s.
  for (int k = 0; k < 2000 && step.status != ExplorationStatus::Finished; ++k) {
    t += 0.25;
    const VehicleState c = m.command(t);
    VehicleState v = at(c.position_W, c.yaw_rad);
    v.velocity_W = c.velocity_W;
    step = m.update(map, CoordBBox(), v, t);
  }
  CHECK(step.status == ExplorationStatus::Finished);
  CHECK_FALSE(m.alc()->detour());  // no detour left in progress
  INFO("detours " << m.alcStats().detours << ", give-ups " << m.alcStats().give_ups);
  CHECK(m.alcStats().detours >= 1);  // old places were close and cheap in this corridor
}

TEST_CASE("With nothing left to explore, the manager closes a loop before finishing", "[planner][exploration][alc]") {
  const DenseMap map = closedRoom();
  ExplorationManagerConfig p = alcParams();  // a loop before finishing after 10 s without one; 2 s timeout
  const Vec3d vehicle(4.5, 3, 1.5);
  const auto follow = [&](ExplorationManager& m, double t) {
    const VehicleState c = m.command(t);
    VehicleState v = at(c.position_W, c.yaw_rad);
    v.velocity_W = c.velocity_W;
    return m.update(map, CoordBBox(), v, t);
  };

  SECTION("not before finish_loop_age_s; then a detour to the loop cluster") {
    ExplorationManager m(p, at(Vec3d(4.0, 3, 1.5)), 0.0);
    double t = flyPlaceThenGo(m, map, 4.0, vehicle);
    ExplorationStep step;
    for (; t < p.alc.finish_loop_age_s - 0.01; t += 0.5) {
      step = m.update(map, CoordBBox(), at(vehicle), t);
      CHECK(step.status == ExplorationStatus::Finished);
    }
    step = m.update(map, CoordBBox(), at(vehicle), p.alc.finish_loop_age_s);
    t = p.alc.finish_loop_age_s;
    REQUIRE(step.alc_status.has_value());
    CHECK(*step.alc_status == AlcStatus::kDetour);
    CHECK(step.status == ExplorationStatus::Planned);
    CHECK(step.loop_detour);
    CHECK(endsAtLoopCluster(m));
    CHECK(m.alcStats().finish_detours == 1);

    SECTION("a loop closure ends it: finished at once, where the vehicle is") {
      t += 0.25;
      m.notifyLoopClosure(t);
      step = follow(m, t);
      CHECK(step.status == ExplorationStatus::Finished);
      CHECK_FALSE(m.onLoopDetour());
      CHECK(m.alcStats().loops_on_detour == 1);
      CHECK(m.command(t + 1.0).velocity_W.norm() < 1e-9);  // holding
    }
    SECTION("no loop: the cluster's viewpoints in turn; finished after max_finish_detours timeouts") {
      const double start = t;
      const double timeouts = p.alc.max_finish_detours * p.alc.give_up_timeout_s;
      std::vector<Vec3d> ends{m.command(m.trajectoryStartTime() + m.trajectory().duration()).position_W};
      while (step.status != ExplorationStatus::Finished && t < start + timeouts + 10.0) {
        t += 0.05;
        step = follow(m, t);
        if (step.loop_detour) ends.push_back(m.command(m.trajectoryStartTime() + m.trajectory().duration()).position_W);
      }
      CHECK(step.status == ExplorationStatus::Finished);
      CHECK(t >= start + timeouts);
      CHECK(t < start + timeouts + 1.0);
      REQUIRE(ends.size() >= 2);
      CHECK((ends[0] - ends[1]).norm() > 1e-3);  // another viewpoint
      const AlcStats stats = m.alcStats();
      CHECK(stats.give_ups == 3);
      CHECK(stats.finish_detours == 3);
      for (int k = 0; k < 20; ++k) CHECK(follow(m, t += 0.5).status == ExplorationStatus::Finished);
      CHECK(m.alcStats().detours == 3);
    }
  }
  SECTION("finish_loop_age_s = 0: finished without a detour") {
    p.alc.finish_loop_age_s = 0.0;
    ExplorationManager m(p, at(Vec3d(4.0, 3, 1.5)), 0.0);
    double t = flyPlaceThenGo(m, map, 4.0, vehicle);
    for (; t < 30.0; t += 0.5) CHECK(m.update(map, CoordBBox(), at(vehicle), t).status == ExplorationStatus::Finished);
    CHECK(m.alcStats().detours == 0);
  }
}

TEST_CASE("A loop before finishing is priced from a start beside unknown voxels, as it is flown",
          "[planner][exploration][alc]") {
  // A sweep's last visit ends beside the unknown voxels it looked at: a pocket of 8 unknown voxels
  // 0.1 m from the vehicle, too small for a target, inside its clearance.
  DenseMap map = closedRoom();
  map.fill(CoordBBox(Coord(46, 30, 15), Coord(47, 31, 16)), Occupancy::Unknown);
  const ExplorationManagerConfig p = alcParams();
  const Vec3d vehicle(4.45, 3.05, 1.55);
  REQUIRE(p.path.clearance_m > 0.15);
  ExplorationManager m(p, at(Vec3d(1.0, 3, 1.5)), 0.0);  // the start's free box far from the pocket
  double t = flyPlaceThenGo(m, map, 1.0, vehicle);
  for (; t < p.alc.finish_loop_age_s - 0.01; t += 0.5)
    REQUIRE(m.update(map, CoordBBox(), at(vehicle), t).status == ExplorationStatus::Finished);
  const ExplorationStep step = m.update(map, CoordBBox(), at(vehicle), p.alc.finish_loop_age_s);
  REQUIRE(step.alc_status.has_value());
  CHECK(*step.alc_status == AlcStatus::kDetour);  // not kNoReachableCluster
  CHECK(step.status == ExplorationStatus::Planned);
  CHECK(endsAtLoopCluster(m));
}
