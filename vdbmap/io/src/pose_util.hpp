// Private pose parsing shared by the trajectory, log and importer readers.
#pragma once

#include "vdbmap/types.hpp"

#include <string>

namespace vdbmap::io::detail {

/// A pose from translation and quaternion (x, y, z, w) read from a file. Returns an empty
/// string on success, else why the pose is invalid (non-finite value, quaternion norm off by
/// more than kQuaternionNormTolerance). The quaternion is normalised.
std::string poseFromTum(const double values[7], Pose3d& T);

/// A pose from a row-major 3x4 or 4x4 matrix (`rows` = 3 or 4). Returns an empty string on
/// success, else why it is invalid (non-finite, bottom row not 0 0 0 1, rotation not
/// orthonormal with det +1 within kRotationMatrixTolerance). The rotation is projected onto SO(3).
std::string poseFromMatrix(const double* m, int rows, Pose3d& T);

}  // namespace vdbmap::io::detail
