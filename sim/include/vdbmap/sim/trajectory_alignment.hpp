// The 4-DOF alignment of an estimated trajectory (or a map built along it) with the truth.
//
// A visual-inertial estimate is anchored at its first frame; position and yaw drift, roll and pitch
// do not (gravity keeps them observable). Drift in the seconds before the first loop closure can
// connect anything therefore stays in the whole estimate as one rigid offset, a yaw about z and a
// translation, that no loop closure to a drifted place can observe. Aligning by the best such
// transform (as trajectory benchmarks align before their absolute trajectory error) separates that
// offset from the estimate's inner consistency: the error left after alignment is what loop
// closure can still improve.
#pragma once

#include "vdbmap/sim/trajectory.hpp"
#include "vdbmap/types.hpp"

#include <vector>

namespace vdbmap::sim {

/// The yaw about world z and the translation T (a FlatPose: p' = Rz(T.yaw_rad) p + T.position_W)
/// that minimise sum |T(from[i]) - to[i]|^2: the yaw and x-y translation by Eigen::umeyama over
/// the x-y coordinates (no scaling), the z translation as the mean difference. Throws
/// std::invalid_argument when the sizes differ, fewer than 2 points are given, or a value is not
/// finite. Points that do not span the x-y plane (all at one x-y position) give yaw 0.
FlatPose alignYawTranslation(const std::vector<Vec3d>& from, const std::vector<Vec3d>& to);

/// Applies an alignment: Rz(T.yaw_rad) p + T.position_W.
Vec3d applyAlignment(const FlatPose& T, const Vec3d& p);

/// RMS of |T(from[i]) - to[i]| (the sizes must match; 0 for no points).
double alignedRmse(const FlatPose& T, const std::vector<Vec3d>& from, const std::vector<Vec3d>& to);

}  // namespace vdbmap::sim
