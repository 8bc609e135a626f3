// Basic types shared by every module: poses, points and frame identifiers.
//
// Frames are named in variables: T_W_S is the pose of the sensor S in the world W (it maps
// points_S to points_W); points_S are points in the sensor frame. Units are metres and radians.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

namespace vdbmap {

/// A rigid transform; by convention T_A_B maps coordinates in frame B to frame A.
using Pose3d = Eigen::Isometry3d;
using Vec3d = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;

/// Points in one frame (which frame is said by the variable's suffix, e.g. points_S).
using PointCloud = std::vector<Vec3f>;

/// Identifies an integrated frame for its whole life (de-integration, re-integration).
using FrameId = std::uint64_t;

/// Builds a pose from a translation and a unit quaternion given as (x, y, z, w).
Pose3d poseFromTranslationQuaternion(const Vec3d& t, double qx, double qy, double qz, double qw);

/// True when every entry is finite and the rotation block is orthonormal with determinant +1
/// within `tolerance`.
bool isValidRigidTransform(const Pose3d& T, double tolerance = 1e-4);

}  // namespace vdbmap
