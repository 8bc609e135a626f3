// The vehicle's vocabulary, shared by the planner and the simulator: a flat pose (position and
// yaw), the full state at an instant, and yaw angles. The vehicle is flat: roll and pitch are zero
// and yaw turns about world +z (0 = +x), as for a multicopter flying slowly.
#pragma once

#include "vdbmap/types.hpp"

namespace vdbmap::planner {

/// Where the vehicle is and which way it faces: a pose to travel to (a viewpoint, a waypoint), or
/// what drift, loop closure and the simulator's pose graph act on.
struct FlatPose {
  Vec3d position_W = Vec3d::Zero();
  double yaw_rad = 0.0;
};

/// The vehicle's state at an instant (world frame): what a trajectory commands at a time and what
/// the planner starts from (acceleration and yaw rate may be left zero there).
struct VehicleState {
  Vec3d position_W = Vec3d::Zero();
  Vec3d velocity_W = Vec3d::Zero();
  Vec3d acceleration_W = Vec3d::Zero();
  double yaw_rad = 0.0;  ///< unwrapped along a trajectory (continuous, not limited to [-pi, pi])
  double yaw_rate_rad_s = 0.0;

  FlatPose pose() const { return {position_W, yaw_rad}; }
};

using PoseTarget [[deprecated("renamed FlatPose")]] = FlatPose;
using TrajectoryState [[deprecated("merged into VehicleState")]] = VehicleState;

/// An angle wrapped to (-pi, pi].
double wrapAngle(double a_rad);
/// The shortest signed angle from `from_rad` to `to_rad`, in (-pi, pi]: wrapAngle(to - from).
double angleDifference(double to_rad, double from_rad);
/// |b - a| wrapped to [0, pi].
double yawDistance(double a_rad, double b_rad);

}  // namespace vdbmap::planner
