// Ways out of a blocked start: a retreat goes back along the way flown to the newest (or the
// farthest) clear position within reach and forgets what lies beyond, along the way as the last loop
// closure corrected it; a straight escape moves away from the occupied voxels to a clear point
// within reach; both refuse when there is none.
#include "planner/planner_test_maps.hpp"

#include "vdbmap/planner/escape_planner.hpp"

#include <catch2/catch.hpp>

using namespace vdbmap;
using namespace vdbmap::planner;
using namespace vdbmap::planner::test;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
constexpr double kTolM = 1e-6;

/// A 6 x 2 x 2 m room at 0.1 m voxels (inside: voxels 1..58, 1..18, 1..18).
DenseMap room() { return makeRoom(Eigen::Vector3i(60, 20, 20)); }

EscapeConfig roomEscape() {
  EscapeConfig p;
  p.bounds_W = Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(6, 2, 2));
  return p;
}

/// Flown along x at y = z = 1 from x = 0.5 to `to_x`, a position every 0.1 m and 0.1 s (stamp = x).
void flyAlongX(EscapePlanner& e, double to_x) {
  for (double x = 0.5; x <= to_x + 1e-9; x += 0.1) e.recordFlown(Vec3d(x, 1.0, 1.0), x, 0.1);
}
}  // namespace

TEST_CASE("A retreat goes back along the way flown to the newest clear position, or the farthest within reach",
          "[planner][escape]") {
  DenseMap map = room();
  EscapeConfig params = roomEscape();
  params.retreat_reach_m = 2.0;
  const VehicleState here = at(Vec3d(4.0, 1.0, 1.0));

  SECTION("the farthest within reach") {
    EscapePlanner far(params);
    flyAlongX(far, 4.0);
    const std::optional<Trajectory> back = far.retreat(map, here, /*farthest=*/true);
    REQUIRE(back);
    const Vec3d end = back->sample(back->duration()).position_W;
    CHECK(end.x() == Approx(2.0).margin(0.1 + kTolM));  // 2 m of way back
    // The positions beyond the end are forgotten: the next retreat goes on backwards.
    const std::optional<Trajectory> again = far.retreat(map, at(end), true);
    REQUIRE(again);
    CHECK(again->sample(again->duration()).position_W.x() < end.x() - 0.5);
  }
  SECTION("the newest: a voxel or more away") {
    EscapePlanner near(params);
    flyAlongX(near, 4.0);
    const std::optional<Trajectory> back = near.retreat(map, here, /*farthest=*/false);
    REQUIRE(back);
    const double x = back->sample(back->duration()).position_W.x();
    CHECK(x < 4.0 - 0.1 + kTolM);
    CHECK(x > 3.5);
  }
  SECTION("an end must keep the clearance in the current map") {
    // Occupied voxels over the whole way back within reach (x = 1.9 to 3.9 m): no clear end.
    map.fill(CoordBBox(Coord(19, 1, 1), Coord(38, 18, 18)), Occupancy::Occupied);
    EscapePlanner blocked(params);
    flyAlongX(blocked, 4.0);
    CHECK_FALSE(blocked.retreat(map, here, true));
  }
  SECTION("only the way flown since flown_since_s") {
    // Stamps equal x: since t = 3.5 s the way reaches back to x = 3.5 m, not the 2 m of reach.
    EscapePlanner recent(params);
    flyAlongX(recent, 4.0);
    const std::optional<Trajectory> back = recent.retreat(map, here, /*farthest=*/true, {}, /*flown_since_s=*/3.5);
    REQUIRE(back);
    CHECK(back->sample(back->duration()).position_W.x() == Approx(3.5).margin(kTolM));
    // Nothing flown a voxel or more away since then: no retreat.
    CHECK_FALSE(recent.retreat(map, here, true, {}, /*flown_since_s=*/3.95));
  }
  SECTION("nothing flown: no retreat") {
    EscapePlanner fresh(params);
    CHECK_FALSE(fresh.retreat(map, here, true));
  }
}

TEST_CASE("A loop closure's history correction moves the way a retreat goes back along", "[planner][escape]") {
  // Odometry recorded the way at y = 1; the correction says the positions flown before t = 3 s were
  // at y = 0.5 (the drift the loop closure took out), the later ones where they were recorded.
  const DenseMap map = room();
  EscapeConfig params = roomEscape();
  params.retreat_reach_m = 2.0;
  EscapePlanner escapes(params);
  flyAlongX(escapes, 4.0);
  const auto corrected = [](const FlownViewpoint& v) {
    return FlatPose{v.stamp_s < 3.0 - 1e-9 ? Vec3d(v.position_W.x(), 0.5, 1.0) : v.position_W, v.yaw_rad};
  };
  escapes.correctHistory(corrected);
  const std::optional<Trajectory> back = escapes.retreat(map, at(Vec3d(4.0, 1.0, 1.0)), /*farthest=*/true);
  REQUIRE(back);
  const Vec3d end = back->sample(back->duration()).position_W;
  CHECK(end.x() < 3.0);                         // beyond the corrected step, 2 m of way back
  CHECK(end.y() == Approx(0.5).margin(kTolM));  // where the correction put the way, not y = 1
  CHECK(end.x() > 2.0 - 0.1 - kTolM);

  SECTION("a non-finite correction throws and leaves the way as it was") {
    EscapePlanner kept(params);
    flyAlongX(kept, 4.0);
    const auto bad = [](const FlownViewpoint& v) {
      return FlatPose{v.stamp_s < 1.0 ? Vec3d::Constant(std::nan("")) : Vec3d(0, 0, 0), 0.0};
    };
    CHECK_THROWS_WITH(kept.correctHistory(bad), Catch::Contains("t = "));
    const std::optional<Trajectory> same = kept.retreat(map, at(Vec3d(4.0, 1.0, 1.0)), true);
    REQUIRE(same);
    CHECK(same->sample(same->duration()).position_W.y() == Approx(1.0).margin(kTolM));
  }
}

TEST_CASE("A straight escape moves away from the occupied voxels to a clear point within reach", "[planner][escape]") {
  const DenseMap map = room();
  const EscapePlanner escapes(roomEscape());
  const Vec3d start(0.2, 1.0, 1.0);  // 0.2 m from the wall at x = 0
  const std::optional<Trajectory> out = escapes.straightEscape(map, at(start));
  REQUIRE(out);
  const Vec3d end = out->sample(out->duration()).position_W;
  CHECK(end.x() > start.x() + 0.05);
  CHECK((end - start).norm() <= 1.0 + kTolM);
  CHECK(bruteClear(map, end, roomEscape().clearance_m - 1e-9));

  EscapeConfig tiny = roomEscape();
  tiny.escape_reach_m = 0.05;  // less than a voxel: no point to try
  CHECK_FALSE(EscapePlanner(tiny).straightEscape(map, at(start)));
  tiny.escape_reach_m = 0.0;
  CHECK_THROWS_WITH(EscapePlanner(tiny), Catch::Contains("EscapeConfig.escape_reach_m"));
}
