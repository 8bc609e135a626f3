// The vehicle as the planner sees it (position, velocity, yaw), target poses, and yaw angles.
#pragma once

#include "vdbmap/types.hpp"

namespace vdbmap::planner {

/// Where the vehicle is and how it moves (world frame; yaw about +z, 0 = +x).
struct VehicleState {
  Vec3d position_W = Vec3d::Zero();
  Vec3d velocity_W = Vec3d::Zero();
  double yaw_rad = 0.0;
};

/// A pose to travel to: e.g. a viewpoint's position and yaw.
struct PoseTarget {
  Vec3d position_W = Vec3d::Zero();
  double yaw_rad = 0.0;
};

/// An angle wrapped to (-pi, pi].
double wrapAngle(double a_rad);
/// |b - a| wrapped to [0, pi].
double yawDistance(double a_rad, double b_rad);

}  // namespace vdbmap::planner
