#include "vdbmap/io/pose_interpolation.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace vdbmap::io {

Pose3d interpolatePose(const Pose3d& a, const Pose3d& b, double w) {
  const Eigen::Quaterniond qa(a.linear()), qb(b.linear());
  Pose3d T = Pose3d::Identity();
  T.linear() = qa.slerp(w, qb).normalized().toRotationMatrix();
  T.translation() = (1.0 - w) * a.translation() + w * b.translation();
  return T;
}

std::optional<Pose3d> poseAt(const std::vector<StampedPose>& track, double t_s) {
  if (track.empty() || t_s < track.front().timestamp_s || t_s > track.back().timestamp_s) return std::nullopt;
  const auto it = std::lower_bound(track.begin(), track.end(), t_s,
                                   [](const StampedPose& p, double t) { return p.timestamp_s < t; });
  if (it->timestamp_s == t_s) return it->T_W_S;
  const StampedPose& a = *(it - 1);
  return interpolatePose(a.T_W_S, it->T_W_S, (t_s - a.timestamp_s) / (it->timestamp_s - a.timestamp_s));
}

std::vector<Pose3d> applyCorrection(const std::vector<StampedPose>& frames, const std::vector<StampedPose>& corrected) {
  if (corrected.empty()) throw std::invalid_argument("applyCorrection: the correction lists no pose");
  // The correction at each corrected stamp, against the odometry there.
  std::vector<StampedPose> delta;
  delta.reserve(corrected.size());
  for (const StampedPose& c : corrected) {
    const std::optional<Pose3d> odometry = poseAt(frames, c.timestamp_s);
    if (!odometry)
      throw std::invalid_argument("applyCorrection: corrected stamp " + formatTimestamp(c.timestamp_s) +
                                  " is outside the frames' span, where the odometry is unknown");
    delta.push_back({c.timestamp_s, c.T_W_S * odometry->inverse()});
  }
  std::vector<Pose3d> out;
  out.reserve(frames.size());
  for (const StampedPose& f : frames) {
    const auto it = std::lower_bound(corrected.begin(), corrected.end(), f.timestamp_s,
                                     [](const StampedPose& p, double t) { return p.timestamp_s < t; });
    if (it != corrected.end() && it->timestamp_s == f.timestamp_s) {
      out.push_back(it->T_W_S);  // exactly, not through C x T_odometry
      continue;
    }
    const std::size_t k = std::size_t(it - corrected.begin());
    Pose3d C;
    if (k == 0) C = delta.front().T_W_S;
    else if (k == delta.size()) C = delta.back().T_W_S;
    else C = interpolatePose(delta[k - 1].T_W_S, delta[k].T_W_S,
                             (f.timestamp_s - delta[k - 1].timestamp_s) / (delta[k].timestamp_s - delta[k - 1].timestamp_s));
    out.push_back(C * f.T_W_S);
  }
  return out;
}

}  // namespace vdbmap::io
