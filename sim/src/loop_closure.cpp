#include "vdbmap/sim/loop_closure.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

void LoopClosureConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("LoopClosureConfig." + what); };
  if (!(max_distance_m > 0.0 && max_distance_m <= 100.0)) fail("max_distance_m must be in (0, 100]");
  if (!(max_yaw_rad > 0.0 && max_yaw_rad <= M_PI)) fail("max_yaw_rad must be in (0, pi]");
  if (!(min_age_s >= 0.0 && min_age_s <= 1e6)) fail("min_age_s must be in [0, 1e6]");
  if (!(min_interval_s >= 0.0 && min_interval_s <= 1e6)) fail("min_interval_s must be in [0, 1e6]");
  if (!(min_view_overlap >= 0.0 && min_view_overlap <= 1.0)) fail("min_view_overlap must be in [0, 1]");
  if (overlap_pixel_stride < 1 || overlap_pixel_stride > 1000) fail("overlap_pixel_stride must be in [1, 1000]");
  if (max_overlap_checks < 1 || max_overlap_checks > 1000) fail("max_overlap_checks must be in [1, 1000]");
}

double viewOverlap(const World& world, const CameraIntrinsics& K, double max_range_m, const DepthImage& depth_now,
                   const Pose3d& T_W_S_now, const Pose3d& T_W_S_old, int stride, double occlusion_tolerance_m) {
  if (stride < 1) throw std::invalid_argument("viewOverlap: stride must be >= 1");
  const Pose3d T_old_now = T_W_S_old.inverse() * T_W_S_now;
  const Vec3d origin_old = T_W_S_old.translation();
  std::size_t valid = 0, seen = 0;
  for (int v = stride / 2; v < depth_now.height; v += stride)
    for (int u = stride / 2; u < depth_now.width; u += stride) {
      const double z = depth_now.at(u, v);
      if (!(z > 0.0)) continue;
      ++valid;
      const Vec3d p_now((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
      const Vec3d p_old = T_old_now * p_now;
      if (!(p_old.z() > 0.0) || p_old.z() > max_range_m) continue;
      const double u_old = K.fx * p_old.x() / p_old.z() + K.cx, v_old = K.fy * p_old.y() / p_old.z() + K.cy;
      if (u_old < -0.5 || v_old < -0.5 || u_old > K.width - 0.5 || v_old > K.height - 0.5) continue;
      const Vec3d p_W = T_W_S_now * p_now;
      const double range = (p_W - origin_old).norm();
      const RayHit hit = world.raycast(origin_old, (p_W - origin_old) / range, range + occlusion_tolerance_m);
      if (hit.hit() && hit.t >= range - occlusion_tolerance_m) ++seen;
    }
  return valid > 0 ? double(seen) / double(valid) : 0.0;
}

LoopDetector::LoopDetector(const LoopClosureConfig& config) : config_(config) { config_.validate(); }

std::optional<LoopClosure> LoopDetector::addFrame(std::size_t frame, double t_s, const FlatPose& truth,
                                                  const OverlapFn& overlap) {
  if (!history_.empty() && (frame <= history_.back().frame || t_s <= history_.back().t_s))
    throw std::invalid_argument("LoopDetector::addFrame: frame " + std::to_string(frame) + " does not follow frame " +
                                std::to_string(history_.back().frame) + " in index and time");
  history_.push_back({frame, t_s, truth});
  if (last_loop_t_s_ && t_s - *last_loop_t_s_ < config_.min_interval_s) return std::nullopt;

  std::vector<std::pair<double, std::size_t>> candidates;  // (distance, history index)
  for (std::size_t k = 0; k + 1 < history_.size(); ++k) {
    const Entry& e = history_[k];
    if (t_s - e.t_s < config_.min_age_s) break;  // history is in time order: the rest are younger
    const double d = (e.truth.position_W - truth.position_W).norm();
    if (d > config_.max_distance_m) continue;
    if (std::abs(angleDifference(truth.yaw_rad, e.truth.yaw_rad)) > config_.max_yaw_rad) continue;
    candidates.emplace_back(d, k);
  }
  std::sort(candidates.begin(), candidates.end());
  const std::size_t checks = std::min(candidates.size(), std::size_t(config_.max_overlap_checks));
  for (std::size_t c = 0; c < checks; ++c) {
    const Entry& old = history_[candidates[c].second];
    const double o = overlap ? overlap(old.frame) : 1.0;
    if (o < config_.min_view_overlap) continue;
    last_loop_t_s_ = t_s;
    ++detections_;
    return LoopClosure{old.frame, frame, candidates[c].first, angleDifference(truth.yaw_rad, old.truth.yaw_rad), o};
  }
  return std::nullopt;
}

}  // namespace vdbmap::sim
