// A camera circling the demo room (testing::AnalyticScene::demoRoom) and odometry drifting from
// it in yaw and y: the frames of the tests that correct drift (saved maps, bags, reintegrate).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/types.hpp"

#include <cmath>

namespace vdbmap::test {

/// The true sensor pose of frame i: 0.4 m from the room's centre at 1.2 m, turning 0.6 rad a frame.
inline Pose3d circlePose(int i) {
  return lookingPose({0.4 * std::cos(0.6 * i), 0.4 * std::sin(0.6 * i), 1.2}, 0.6 * i, 0.15);
}

/// The odometry of frame i: circlePose(i) after a drift of 0.015 rad of yaw and 0.02 m in y per frame.
inline Pose3d circleOdometry(int i) {
  Pose3d drift = Pose3d::Identity();
  drift.linear() = Eigen::AngleAxisd(0.015 * i, Vec3d::UnitZ()).toRotationMatrix();
  drift.translation() = Vec3d(0.0, 0.02 * i, 0.0);
  return drift * circlePose(i);
}

}  // namespace vdbmap::test
