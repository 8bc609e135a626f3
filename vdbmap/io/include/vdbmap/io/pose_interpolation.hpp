// Poses between stamps, and corrections known at some stamps applied to every frame.
//
// Interpolation is linear in translation and spherical (slerp) in rotation. A correction event
// (e.g. VINS-Fusion's loop_fusion, which corrects keyframes only) gives corrected poses
// T_corrected(t_k) at some stamps t_k; the odometry is known at the frames' stamps. Each stamp's
// correction is C_k = T_corrected(t_k) x T_odometry(t_k)^-1 (T_odometry interpolated between the
// frames around t_k); a frame at t gets C(t) x T_odometry(t), where C(t) is interpolated between
// the nearest corrected stamps on either side and held constant before the first and after the
// last. A frame at exactly a corrected stamp gets T_corrected itself.
#pragma once

#include "vdbmap/io/tum_trajectory.hpp"

#include <optional>
#include <vector>

namespace vdbmap::io {

/// The pose a fraction w in [0, 1] of the way from a to b (w outside extrapolates the translation
/// and clamps nothing).
Pose3d interpolatePose(const Pose3d& a, const Pose3d& b, double w);

/// The pose of `track` (stamps strictly increasing) at t_s: interpolated between the two poses
/// around it, exact at a stamp; empty outside [first stamp, last stamp] or for an empty track.
std::optional<Pose3d> poseAt(const std::vector<StampedPose>& track, double t_s);

/// Every frame's corrected pose (see above). `frames`: the odometry poses at the frames' stamps
/// (strictly increasing); `corrected`: the event's corrected poses (strictly increasing, each
/// within the frames' span). Throws std::invalid_argument when `corrected` is empty, or a
/// corrected stamp lies outside the frames' span (the odometry is unknown there).
std::vector<Pose3d> applyCorrection(const std::vector<StampedPose>& frames, const std::vector<StampedPose>& corrected);

}  // namespace vdbmap::io
