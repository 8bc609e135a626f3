#include "vdbmap/planner/recent_frames.hpp"
#include "vdbmap/field_check.hpp"
#include "vdbmap/planner/map_query.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace vdbmap::planner {

void RecentFramesConfig::validate() const {
  const FieldCheck check("RecentFramesConfig");
  if (!(window_s > 0.0 && window_s <= 600.0)) check.fail("window_s", "(0, 600]", window_s);
  if (pool_px < 1 || pool_px > 64) check.fail("pool_px", "[1, 64]", pool_px);
  if (!(max_range_m > 0.0 && max_range_m <= 1000.0)) check.fail("max_range_m", "(0, 1000]", max_range_m);
  check.inRange("free_margin_m", free_margin_m, 0.0, 10.0);
  if (!(dense_s > 0.0 && dense_s <= 600.0)) check.fail("dense_s", "(0, 600]", dense_s);
  check.inRange("sparse_period_s", sparse_period_s, 0.0, 60.0);
}

RecentFrames::RecentFrames(const RecentFramesConfig& config) : config_(config) { config_.validate(); }

void RecentFrames::add(double t_s, const DepthImage& depth, const CameraIntrinsics& K, const Pose3d& T_W_S) {
  if (!std::isfinite(t_s) || (!frames_.empty() && t_s < frames_.back().t_s))
    throw std::invalid_argument("RecentFrames::add: frame times must be finite and not go back in time");
  checkDepthImageSize(depth, K, "RecentFrames::add");
  if (!T_W_S.matrix().allFinite()) throw std::invalid_argument("RecentFrames::add: the pose is not finite");

  while (!frames_.empty() && frames_.front().t_s < t_s - config_.window_s) {
    uncount(frames_.front());
    frames_.pop_front();
  }
  if (!cleared_.empty()) {  // a clearing time matters while a frame at or before it is kept
    const std::uint64_t oldest = frames_.empty() ? next_seq_ : frames_.front().seq;
    for (auto it = cleared_.begin(); it != cleared_.end();)
      it = it->second <= oldest ? cleared_.erase(it) : std::next(it);
  }
  // Older than dense_s: each frame kept is at least sparse_period_s after the one kept before it
  // (walked from the oldest, so a frame kept once stays kept).
  double kept_t = -std::numeric_limits<double>::infinity();
  for (auto it = frames_.begin(); it != frames_.end() && it->t_s < t_s - config_.dense_s;) {
    if (it->t_s >= kept_t + config_.sparse_period_s) {
      kept_t = it->t_s;
      ++it;
    } else {
      uncount(*it);
      it = frames_.erase(it);
    }
  }

  // Pool: block (bu, bv) covers pixels [bu p, bu p + p) x [bv p, bv p + p); its centre ray goes
  // through pixel bu p + (p - 1) / 2, so the pooled camera has f / p and c' = (c - (p - 1) / 2) / p.
  const int p = config_.pool_px;
  Frame f;
  f.t_s = t_s;
  f.seq = next_seq_++;
  f.T_W_S = T_W_S;
  f.T_S_W = T_W_S.inverse();
  f.width = (depth.width + p - 1) / p;
  f.height = (depth.height + p - 1) / p;
  f.fx = K.fx / p;
  f.fy = K.fy / p;
  f.cx = (K.cx - 0.5 * (p - 1)) / p;
  f.cy = (K.cy - 0.5 * (p - 1)) / p;
  f.depth_m.assign(std::size_t(f.width) * std::size_t(f.height), 0.0f);
  std::vector<std::int32_t> nearest(f.depth_m.size(), -1);  // the pixel that holds each block's depth
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) {
      const float d = depth.at(u, v);
      if (!(d > 0.0f) || !std::isfinite(d)) continue;
      const std::size_t b = std::size_t(v / p) * std::size_t(f.width) + std::size_t(u / p);
      if (nearest[b] < 0 || d < f.depth_m[b]) {
        f.depth_m[b] = d;
        nearest[b] = v * depth.width + u;
      }
    }
  // Each block's surface point is its nearest pixel on that pixel's own ray: exactly on the
  // surface (the block's centre ray would put it in front of a wall seen at a grazing angle).
  for (std::size_t b = 0; b < nearest.size(); ++b) {
    const float d = f.depth_m[b];
    if (nearest[b] < 0 || d > config_.max_range_m) continue;
    const int u = nearest[b] % depth.width, v = nearest[b] / depth.width;
    f.surface_S.emplace_back(float((u - K.cx) * d / K.fx), float((v - K.cy) * d / K.fy), d);
  }
  frames_.push_back(std::move(f));
  if (voxel_size_m_ > 0.0) count(frames_.back());
}

void RecentFrames::shift(const Eigen::Isometry3d& shift) {
  if (!shift.matrix().allFinite()) throw std::invalid_argument("RecentFrames::shift: the shift is not finite");
  for (Frame& f : frames_) {
    f.T_W_S = shift * f.T_W_S;
    f.T_S_W = f.T_W_S.inverse();
  }
  if (voxel_size_m_ > 0.0) recount();
}

std::vector<double> RecentFrames::frameTimes() const {
  std::vector<double> times;
  times.reserve(frames_.size());
  for (const Frame& f : frames_) times.push_back(f.t_s);
  return times;
}

void RecentFrames::clear() {
  frames_.clear();
  voxels_.clear();
  index_.clear();
  cleared_.clear();
}

bool RecentFrames::frameSeesFree(const Frame& f, const Vec3d& p_W) const {
  const Vec3d p = f.T_S_W * p_W;
  if (!(p.z() > 0.0 && p.z() <= config_.max_range_m)) return false;
  const double u = f.fx * p.x() / p.z() + f.cx, v = f.fy * p.y() / p.z() + f.cy;
  const double bu = std::floor(u + 0.5), bv = std::floor(v + 0.5);
  if (bu < 0.0 || bv < 0.0 || bu >= f.width || bv >= f.height) return false;
  const float d = f.depth_m[std::size_t(bv) * std::size_t(f.width) + std::size_t(bu)];
  return d > 0.0f && p.z() + config_.free_margin_m <= double(d);
}

bool RecentFrames::frameSeesVoxelFree(const Frame& f, const openvdb::Coord& ijk) const {
  const Vec3d centre = voxelCenterOf(ijk, voxel_size_m_);
  if (!frameSeesFree(f, centre)) return false;
  const double h = 0.5 * voxel_size_m_;
  for (int corner = 0; corner < 8; ++corner)
    if (!frameSeesFree(f, centre + Vec3d(corner & 1 ? h : -h, corner & 2 ? h : -h, corner & 4 ? h : -h))) return false;
  return true;
}

bool RecentFrames::seesFree(const Vec3d& p_W, double since_t_s) const {
  for (auto it = frames_.rbegin(); it != frames_.rend() && it->t_s >= since_t_s; ++it)  // the newest first
    if (frameSeesFree(*it, p_W)) return true;
  return false;
}

Eigen::AlignedBox3d RecentFrames::reach_W() const {
  Eigen::AlignedBox3d box;  // empty
  for (const Frame& f : frames_) box.extend(f.T_W_S.translation());
  if (!box.isEmpty()) {
    box.min() -= Vec3d::Constant(config_.max_range_m);
    box.max() += Vec3d::Constant(config_.max_range_m);
  }
  return box;
}

const SurfaceVoxels& RecentFrames::surfaceVoxels(double voxel_size_m) {
  if (!(voxel_size_m > 0.0 && std::isfinite(voxel_size_m)))
    throw std::invalid_argument("RecentFrames::surfaceVoxels: voxel_size_m must be finite and > 0");
  if (voxel_size_m != voxel_size_m_) {
    voxel_size_m_ = voxel_size_m;
    recount();
  }
  return voxels_;
}

void RecentFrames::recount() {
  voxels_.clear();
  index_.clear();
  cleared_.clear();
  for (Frame& f : frames_) f.counted = false;
  for (Frame& f : frames_) count(f);
}

void RecentFrames::count(Frame& frame) {
  if (frame.counted) return;
  if (config_.newer_free_clears) {
    for (auto it = voxels_.begin(); it != voxels_.end();) {
      const openvdb::Coord& c = it->first;
      if (frameSeesVoxelFree(frame, c)) {
        cleared_[c] = frame.seq;
        index_.erase(c);
        it = voxels_.erase(it);
      } else {
        ++it;
      }
    }
  }
  frame.voxels.clear();
  frame.voxels.reserve(frame.surface_S.size());
  for (const Vec3f& s : frame.surface_S) frame.voxels.push_back(voxelOf(frame.T_W_S * s.cast<double>(), voxel_size_m_));
  std::sort(frame.voxels.begin(), frame.voxels.end());
  frame.voxels.erase(std::unique(frame.voxels.begin(), frame.voxels.end()), frame.voxels.end());
  for (const openvdb::Coord& c : frame.voxels)
    if (++voxels_[c] == 1) index_.insert(c);
  frame.counted = true;
}

void RecentFrames::uncount(Frame& frame) {
  if (!frame.counted) return;
  for (const openvdb::Coord& c : frame.voxels) {
    if (const auto cleared = cleared_.find(c); cleared != cleared_.end() && frame.seq < cleared->second)
      continue;  // no longer counted there
    const auto it = voxels_.find(c);
    if (--it->second == 0) {
      voxels_.erase(it);
      index_.erase(c);
    }
  }
  frame.voxels.clear();
  frame.counted = false;
}

}  // namespace vdbmap::planner
