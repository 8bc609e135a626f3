// Loop-closure detection (sim/loop_closure.hpp).
#include <catch2/catch.hpp>

#include "sim/sim_test_helpers.hpp"
#include "vdbmap/camera.hpp"
#include "vdbmap/sim/depth_camera.hpp"
#include "vdbmap/sim/loop_closure.hpp"

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// Feeds frames at 15 Hz along pose(t) for t in [0, duration]; returns the detections.
template <typename PoseFn>
std::vector<LoopClosure> fly(LoopDetector& detector, double duration, PoseFn pose, double overlap = 1.0) {
  std::vector<LoopClosure> out;
  for (std::size_t frame = 0; double(frame) / 15.0 <= duration + 1e-9; ++frame) {
    const double t = double(frame) / 15.0;
    if (const auto l = detector.addFrame(frame, t, pose(t), [&](std::size_t) { return overlap; })) out.push_back(*l);
  }
  return out;
}
}  // namespace

TEST_CASE("a loop closes on a revisit, and not otherwise", "[sim][loop]") {
  const LoopClosureConfig config;  // 0.5 m, 0.2 rad, 15 s, one per 5 s

  SECTION("out 10 m and back the same way: closes once back at the start, facing as then") {
    LoopDetector detector(config);
    // 0-20 s east at 0.5 m/s facing east, 20-24 s turn back on the spot, 24-44 s back west facing
    // west, 44-48 s turn to face east again at the start.
    auto pose = [](double t) -> FlatPose {
      if (t < 20) return {Vec3d(0.5 * t, 0, 1), 0.0};
      if (t < 24) return {Vec3d(10, 0, 1), M_PI * (t - 20) / 4};
      if (t < 44) return {Vec3d(10 - 0.5 * (t - 24), 0, 1), M_PI};
      return {Vec3d(0, 0, 1), M_PI * (1 + std::min(1.0, (t - 44) / 4))};
    };
    const auto loops = fly(detector, 48.0, pose);
    // Going back west the yaw differs by pi from the way out: no loop until the final turn at
    // the start brings the yaw within 0.2 rad of frame 0's.
    REQUIRE(loops.size() == 1);
    CHECK(loops[0].old_frame < 15);
    CHECK(loops[0].new_frame > 44 * 15);
    CHECK(loops[0].distance_m <= 0.5);
    CHECK(std::abs(loops[0].yaw_difference_rad) <= 0.2);
  }
  SECTION("a straight flight never revisits: no loop") {
    LoopDetector detector(config);
    CHECK(fly(detector, 60.0, [](double t) { return FlatPose{Vec3d(0.5 * t, 0.1 * t, 1), 0.3}; }).empty());
  }
  SECTION("hovering: the same place but never older than 15 s ... until it is, then one per 5 s") {
    LoopDetector detector(config);
    const auto loops = fly(detector, 30.0, [](double) { return FlatPose{Vec3d(1, 2, 1), 0.5}; });
    REQUIRE(loops.size() == 4);  // at 15, 20, 25 and 30 s
    CHECK(loops[0].new_frame == 15 * 15);
    CHECK(loops[1].new_frame - loops[0].new_frame == 5 * 15);
  }
  SECTION("always near an old pose but never facing the same way: no loop") {
    LoopDetector detector(config);
    // A 0.2 m circle keeps every pose within 0.4 m of every other, but each 10 s lap turns the
    // yaw by 2 rad: 2, 4 and 6 rad are all more than 0.2 rad from each other and from 0.
    const auto loops = fly(detector, 40.0, [](double t) {
      return FlatPose{Vec3d(0.2 * std::cos(0.2 * M_PI * t), 0.2 * std::sin(0.2 * M_PI * t), 1),
                      2.0 * std::floor(t / 10.0)};
    });
    CHECK(loops.empty());
  }
  SECTION("the view overlap gates detections") {
    LoopDetector blind(config), seeing(config);
    auto hover = [](double) { return FlatPose{Vec3d(1, 2, 1), 0.5}; };
    CHECK(fly(blind, 20.0, hover, 0.2).empty());
    CHECK(fly(seeing, 20.0, hover, 0.8).size() == 2);
  }
}

TEST_CASE("view overlap: the same view overlaps fully, a view through a wall not at all", "[sim][loop]") {
  const World world(test::roomWithBox());
  DepthCameraConfig cc;
  cc.intrinsics = {64, 48, 40.0, 40.0, 32.0, 24.0};
  const DepthCamera camera(cc);
  const Pose3d here = lookingPose(Vec3d(-1.8, 0.0, 1.2), 0.0);
  const DepthImage depth = camera.render(world, here);
  CHECK(viewOverlap(world, cc.intrinsics, 5.0, depth, here, here, 2) == Approx(1.0));
  // Turned around: sees the other half of the room.
  CHECK(viewOverlap(world, cc.intrinsics, 5.0, depth, here, lookingPose(Vec3d(-1.8, 0.0, 1.2), M_PI), 2) < 0.05);
  // Behind the box, facing the same way: the box hides most of what `here` sees of the wall.
  const double partial = viewOverlap(world, cc.intrinsics, 5.0, depth, here, lookingPose(Vec3d(0.0, 0.0, 1.2), 0.0), 2);
  CHECK(partial > 0.05);
  CHECK(partial < 0.95);
}
