// Take-off: the vehicle starts in space it has never seen. With a start box assumed free (as
// FUEL does) it can turn on the spot and fly into the free space its camera saw.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/assume_free_map.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/trajectory.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::planner;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
/// Unknown everywhere except what a camera at the origin looking along +x saw: the free frustum
/// from 0.1 m to 4 m (half-angles as FUEL's camera) and an occupied wall at x = 4.1 m.
DenseMap firstFrame() {
  DenseMap map(0.1, CoordBBox(Coord(-30), Coord(50, 30, 30)));
  const double tx = 320.0 / 387.229, ty = 240.0 / 387.229;
  for (auto it = map.extent().begin(); it; ++it) {
    const Vec3d p = map.voxelCenter(*it);
    if (p.x() < 0.1 || p.x() > 4.15) continue;
    if (std::abs(p.y()) > tx * p.x() || std::abs(p.z()) > ty * p.x()) continue;
    map.set(*it, p.x() < 4.05 ? Occupancy::Free : Occupancy::Occupied);
  }
  return map;
}
}  // namespace

TEST_CASE("Without a start box the vehicle cannot move; with one it turns and flies into seen space",
          "[planner][start]") {
  const DenseMap seen = firstFrame();
  VehicleState vehicle;  // at the origin, yaw 0, at rest
  const Vec3d goal(2.5, 0.0, 0.0);
  {
    PathPlanner planner(seen);
    CHECK(planner.plan(vehicle.position_W, goal).status == PathStatus::StartInvalid);
  }
  const AssumeFreeMap map(seen, {boxAround(vehicle.position_W, Vec3d(0.5, 0.5, 0.5))});
  PathPlanner planner(map);
  const PathResult path = planner.plan(vehicle.position_W, goal);
  REQUIRE(path.ok());
  const TrajectoryResult traj = planTrajectory(path.waypoints, vehicle, 0.4, map);
  REQUIRE(traj.status == TrajectoryStatus::Ok);
  CHECK(traj.trajectory.sample(traj.trajectory.duration()).position_W.isApprox(goal, 1e-12));
  // Turning on the spot, all the way round, is allowed too.
  const TrajectoryResult turn = planTrajectory({vehicle.position_W}, vehicle, M_PI, map);
  CHECK(turn.status == TrajectoryStatus::Ok);
  CHECK(turn.trajectory.duration() >= M_PI / 0.9);
}
