// Time-stamped poses and the TUM RGB-D trajectory format ("timestamp tx ty tz qx qy qz qw" per
// line, '#' comments), used for groundtruth.txt and for the files under corrections/.
#pragma once

#include "vdbmap/types.hpp"

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace vdbmap::io {

/// A sensor pose T_W_S at a time (seconds).
struct StampedPose {
  double timestamp_s = 0.0;
  Pose3d T_W_S = Pose3d::Identity();
};

/// Tolerance when a quaternion read from a file is checked for unit length (files often hold
/// 4-6 decimals); within it the quaternion is normalised, beyond it the pose is rejected.
constexpr double kQuaternionNormTolerance = 1e-3;
/// Tolerance on R^T R = I and det R = 1 for rotation matrices read from files; within it the
/// rotation is projected back onto SO(3).
constexpr double kRotationMatrixTolerance = 1e-3;

/// Reads a TUM trajectory. Throws std::runtime_error "<file>:<line>: ..." on a line without 8
/// numbers, a non-finite value, a quaternion whose norm is off by more than
/// kQuaternionNormTolerance, or (when `require_increasing`) a timestamp not greater than the
/// previous one. `line_numbers`, when given, receives the line of each pose.
std::vector<StampedPose> readTumTrajectory(const std::filesystem::path& path, bool require_increasing = true,
                                           std::vector<std::size_t>* line_numbers = nullptr);

/// Writes a TUM trajectory atomically (temporary file, then rename): timestamps with 6 decimals,
/// pose values with 9 significant digits.
void writeTumTrajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses);

/// One TUM line without the newline, as writeTumTrajectory writes it.
std::string formatTumLine(const StampedPose& pose);

/// The timestamp as written in files (6 decimals), e.g. for corrections/<timestamp>.txt.
std::string formatTimestamp(double timestamp_s);

}  // namespace vdbmap::io
