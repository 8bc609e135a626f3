#include "vdbmap/mapper.hpp"

#include <openvdb/tools/Composite.h>
#include <openvdb/tools/GridTransformer.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace vdbmap {

const char* toString(ConsistencyMode m) {
  switch (m) {
    case ConsistencyMode::None: return "none";
    case ConsistencyMode::Submap: return "submap";
    case ConsistencyMode::All: return "all";
    case ConsistencyMode::Keyframes: return "keyframes";
  }
  return "?";
}

ConsistencyMode parseConsistencyMode(const std::string& text) {
  if (text == "none") return ConsistencyMode::None;
  if (text == "submap") return ConsistencyMode::Submap;
  if (text == "all") return ConsistencyMode::All;
  if (text == "keyframes") return ConsistencyMode::Keyframes;
  throw std::invalid_argument("mode must be none, submap, all or keyframes, got '" + text + "'");
}

namespace {
void fail(const std::string& field, const std::string& range, double value) {
  std::ostringstream msg;
  msg << field << " must be in " << range << ", got " << value;
  throw std::invalid_argument(msg.str());
}
double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

void ReintegrationConfig::validate() const {
  if (!(gate_translation_m >= 0.0 && gate_translation_m <= 1e3))
    fail("ReintegrationConfig.gate_translation_m", "[0, 1000]", gate_translation_m);
  if (!(gate_rotation_deg >= 0.0 && gate_rotation_deg <= 180.0))
    fail("ReintegrationConfig.gate_rotation_deg", "[0, 180]", gate_rotation_deg);
  if (!(budget_ms > 0.0 && budget_ms <= 1e6)) fail("ReintegrationConfig.budget_ms", "(0, 1e6]", budget_ms);
  if (budget_frames < 0) fail("ReintegrationConfig.budget_frames", "[0, inf)", budget_frames);
}

void MapperConfig::validate() const {
  tsdf.validate();
  integrator.validate();
  reintegration.validate();
  set_cover.validate();
  if (submap_frames < 1 || submap_frames > 1000000) fail("MapperConfig.submap_frames", "[1, 1e6]", submap_frames);
  if (!(depth_unit_m > 0.0 && depth_unit_m <= 0.1)) fail("MapperConfig.depth_unit_m", "(0, 0.1]", depth_unit_m);
}

/// A rigid submap: frames integrated in the frame A of its first keyframe, T_W_A movable.
struct Mapper::Submap {
  FrameId anchor_id = 0;
  Pose3d T_W_A_odom = Pose3d::Identity();  ///< anchor pose when the submap was started (fixed)
  Pose3d T_W_A = Pose3d::Identity();       ///< newest anchor pose
  std::unique_ptr<TsdfVolume> volume;
  int frames = 0;
};

Mapper::Mapper(const MapperConfig& config) : config_(config), volume_(config.tsdf, config.integrator) {
  config_.validate();
  if (config_.mode == ConsistencyMode::Keyframes)
    pruner_ = std::make_unique<FramePruner>(config_.set_cover, config_.tsdf.voxel_size_m);
}
Mapper::~Mapper() = default;
Mapper::Mapper(Mapper&&) noexcept = default;

void Mapper::markDirty(const openvdb::CoordBBox& box) {
  if (!box.empty()) dirty_.expand(box);
}

openvdb::CoordBBox Mapper::takeDirtyRegion() {
  openvdb::CoordBBox box = dirty_;
  dirty_ = openvdb::CoordBBox();
  return box;
}

IntegrationStats Mapper::addDepthFrame(FrameId id, double timestamp, const DepthImage& depth,
                                       std::shared_ptr<const CameraIntrinsics> K, const Pose3d& T_W_S) {
  // Frames the mapper keeps are compressed; in none mode a frame is decoded once and dropped.
  const bool store = config_.mode != ConsistencyMode::None;
  return addFrame(id, timestamp, EncodedFrame::fromDepth(depth, std::move(K), config_.depth_unit_m, 1, store), T_W_S);
}

IntegrationStats Mapper::addPointFrame(FrameId id, double timestamp, const PointCloud& points_S, const Pose3d& T_W_S) {
  const bool store = config_.mode != ConsistencyMode::None;
  return addFrame(id, timestamp, EncodedFrame::fromPoints(points_S, config_.depth_unit_m, store), T_W_S);
}

namespace {
/// A stored frame decoded once: a depth image with its intrinsics, or points.
struct DecodedFrame {
  std::optional<DepthImage> depth;
  std::shared_ptr<const CameraIntrinsics> K;
  PointCloud points_S;
};

DecodedFrame decodeFrame(const EncodedFrame& frame) {
  DecodedFrame d;
  if (frame.isDepth()) {
    d.depth = frame.decodeDepth();
    d.K = frame.intrinsics();
  } else {
    d.points_S = frame.decode();
  }
  return d;
}

/// Integrates (add) or de-integrates a decoded frame as the volume's integrator takes it best:
/// depth frames as images (projective), point frames as points. Always the decoded frame, so that
/// a later de-integration removes exactly what went in.
IntegrationStats applyDecoded(TsdfVolume& volume, FrameId id, const DecodedFrame& frame, const Pose3d& T_W_S, bool add) {
  if (frame.depth)
    return add ? volume.integrate(id, *frame.depth, *frame.K, T_W_S) : volume.deintegrate(id, *frame.depth, *frame.K, T_W_S);
  return add ? volume.integrate(id, frame.points_S, T_W_S) : volume.deintegrate(id, frame.points_S, T_W_S);
}

IntegrationStats applyFrame(TsdfVolume& volume, FrameId id, const EncodedFrame& frame, const Pose3d& T_W_S, bool add) {
  return applyDecoded(volume, id, decodeFrame(frame), T_W_S, add);
}

/// Integrates a decoded frame for the pruner too: returns its set, the coarse cells its integration
/// touches. Projective integration records them in the same pass (the footprint); the ray modes
/// walk the frame's rays again on the coarse grid (visibleCells).
IntegrationStats integrateWithCells(TsdfVolume& volume, FrameId id, const DecodedFrame& frame, const Pose3d& T_W_S,
                                    const MapperConfig& config, CellSet& cells) {
  const double cell_vox = config.set_cover.cell_size_vox;
  if (frame.depth && config.integrator.ray_mode == RayMode::Projective) {
    VoxelFootprint footprint;
    const IntegrationStats stats = volume.integrate(id, *frame.depth, *frame.K, T_W_S, &footprint);
    cells = footprintCells(footprint, cell_vox);
    return stats;
  }
  const IntegrationStats stats = applyDecoded(volume, id, frame, T_W_S, true);
  cells = frame.depth ? visibleCells(*frame.depth, *frame.K, T_W_S, config.tsdf, config.integrator, cell_vox)
                      : visibleCells(frame.points_S, T_W_S, config.tsdf, config.integrator, cell_vox);
  return stats;
}
}  // namespace

IntegrationStats Mapper::addFrame(FrameId id, double timestamp, EncodedFrame data, const Pose3d& T_W_S) {
  if (store_.contains(id) || (config_.mode == ConsistencyMode::None && volume_.isIntegrated(id)))
    throw FrameError("frame " + std::to_string(id) + " was already given to the mapper");
  IntegrationStats stats;
  ++stats_.frames_total;

  if (config_.mode == ConsistencyMode::Submap) {
    if (submaps_.empty() || submaps_.back()->frames >= config_.submap_frames) {
      auto s = std::make_unique<Submap>();
      s->anchor_id = id;
      s->T_W_A_odom = s->T_W_A = T_W_S;
      s->volume = std::make_unique<TsdfVolume>(config_.tsdf, config_.integrator);
      submaps_.push_back(std::move(s));
      ++stats_.submaps;
    }
    Submap& s = *submaps_.back();
    stats = applyFrame(*s.volume, id, data, s.T_W_A_odom.inverse() * T_W_S, true);
    ++s.frames;
    fused_.reset();
    // The submap's box in the world is not tracked voxel-exactly; mark the frame's reach.
    const double r = config_.integrator.max_range_m + config_.tsdf.truncation_m();
    const Vec3d c = s.T_W_A * (s.T_W_A_odom.inverse() * T_W_S).translation();
    markDirty(openvdb::CoordBBox(volume_.worldToVoxel(c - Vec3d::Constant(r)), volume_.worldToVoxel(c + Vec3d::Constant(r))));
    return stats;
  }

  const DecodedFrame decoded = decodeFrame(data);  // once, for integration and the pruner's set
  CellSet cells;
  stats = config_.mode == ConsistencyMode::Keyframes ? integrateWithCells(volume_, id, decoded, T_W_S, config_, cells)
                                                     : applyDecoded(volume_, id, decoded, T_W_S, true);
  markDirty(stats.touched_voxels);
  if (config_.mode == ConsistencyMode::None) return stats;

  Keyframe kf;
  kf.id = id;
  kf.timestamp = timestamp;
  kf.T_W_S_integrated = kf.T_W_S_latest = T_W_S;
  kf.integrated = true;
  kf.data = std::move(data);
  store_.add(std::move(kf));

  if (config_.mode == ConsistencyMode::Keyframes) {
    pruner_->addFrame(id, T_W_S.translation(), std::move(cells));
    if (++frames_since_solve_ >= std::size_t(config_.set_cover.solve_period_frames)) prune();
  }
  return stats;
}

void Mapper::prune() {
  frames_since_solve_ = 0;
  const FramePruner::Result result = pruner_->solve();
  ++stats_.pruning_solves;
  for (const FrameId id : result.dropped) {
    Keyframe& kf = store_.at(id);
    if (kf.integrated) {
      const IntegrationStats s = applyFrame(volume_, id, kf.data, kf.T_W_S_integrated, false);
      markDirty(s.touched_voxels);
    }
    queue_.erase(id);
    store_.erase(id);
    ++stats_.frames_dropped;
  }
}

bool Mapper::beyondGate(const Pose3d& a, const Pose3d& b) const {
  const double dt = (a.translation() - b.translation()).norm();
  const double dr = Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
  return dt > config_.reintegration.gate_translation_m || dr > config_.reintegration.gate_rotation_deg;
}

std::size_t Mapper::updatePoses(const std::map<FrameId, Pose3d>& T_W_S_by_id) {
  std::size_t changed = 0;
  for (const auto& [id, T] : T_W_S_by_id)
    if (!isValidRigidTransform(T))
      throw FrameError("pose update for frame " + std::to_string(id) + " is not a rigid transform");
  switch (config_.mode) {
    case ConsistencyMode::None: return 0;
    case ConsistencyMode::Submap:
      for (auto& s : submaps_) {
        const auto it = T_W_S_by_id.find(s->anchor_id);
        if (it == T_W_S_by_id.end() || !beyondGate(it->second, s->T_W_A)) continue;
        s->T_W_A = it->second;
        fused_.reset();
        ++changed;
      }
      if (changed) markDirty(volume().activeBoundingBox());
      return changed;
    case ConsistencyMode::All:
    case ConsistencyMode::Keyframes:
      for (const auto& [id, T] : T_W_S_by_id) {
        if (!store_.contains(id)) continue;  // pruned, or never given
        Keyframe& kf = store_.at(id);
        kf.T_W_S_latest = T;
        if (beyondGate(kf.T_W_S_latest, kf.T_W_S_integrated)) {
          queue_.insert(id);
          ++changed;
        } else {
          queue_.erase(id);  // corrected back to where the map holds it
        }
      }
      return changed;
  }
  return changed;
}

void Mapper::reintegrateFrame(Keyframe& kf) {
  const IntegrationStats s =
      kf.data.isDepth()
          ? volume_.reintegrate(kf.id, kf.data.decodeDepth(), *kf.data.intrinsics(), kf.T_W_S_integrated, kf.T_W_S_latest)
          : volume_.reintegrate(kf.id, kf.data.decode(), kf.T_W_S_integrated, kf.T_W_S_latest);
  kf.T_W_S_integrated = kf.T_W_S_latest;
  markDirty(s.touched_voxels);
  ++stats_.reintegrated_frames;
}

CycleReport Mapper::reintegrate(const Vec3d& robot_W) {
  CycleReport report;
  if (queue_.empty()) return report;
  const auto t0 = std::chrono::steady_clock::now();
  // Nearest first: by block (Chebyshev distance between set-cover blocks), then by distance.
  const double block = config_.set_cover.block_size_m;
  auto blockOf = [block](const Vec3d& p) { return Eigen::Vector3i((p / block).array().floor().cast<int>()); };
  const Eigen::Vector3i robot_block = blockOf(robot_W);
  std::vector<std::pair<std::pair<int, double>, FrameId>> order;
  order.reserve(queue_.size());
  for (const FrameId id : queue_) {
    const Vec3d p = store_.at(id).T_W_S_latest.translation();
    const int block_dist = (blockOf(p) - robot_block).cwiseAbs().maxCoeff();
    order.push_back({{block_dist, (p - robot_W).norm()}, id});
  }
  std::sort(order.begin(), order.end());
  for (const auto& entry : order) {
    // Stop before a frame that would likely overrun the budget (by the recent cost per frame);
    // the first frame always goes, so progress never stops.
    const double elapsed_ms = msSince(t0);
    if (report.frames > 0 && elapsed_ms + frame_ms_estimate_ > config_.reintegration.budget_ms) break;
    reintegrateFrame(store_.at(entry.second));
    queue_.erase(entry.second);
    ++report.frames;
    const double frame_ms = msSince(t0) - elapsed_ms;
    frame_ms_estimate_ = frame_ms_estimate_ > 0.0 ? 0.8 * frame_ms_estimate_ + 0.2 * frame_ms : frame_ms;
    if (config_.reintegration.budget_frames > 0 && int(report.frames) >= config_.reintegration.budget_frames) break;
  }
  report.ms = msSince(t0);
  report.queued_left = queue_.size();
  ++stats_.reintegration_cycles;
  stats_.reintegration_ms_total += report.ms;
  stats_.reintegration_ms_max_cycle = std::max(stats_.reintegration_ms_max_cycle, report.ms);
  return report;
}

std::size_t Mapper::reintegrateAll(const Vec3d& robot_W) {
  std::size_t n = 0;
  while (!queue_.empty()) n += reintegrate(robot_W).frames;
  if (pruner_ && frames_since_solve_ > 0) prune();
  return n;
}

namespace {
/// Resamples `in` (index space of a submap) into the world grid `out` by the rigid T_W_A.
void resampleInto(const openvdb::FloatGrid& in, openvdb::FloatGrid& out, const Pose3d& T_W_A, double voxel_size_m) {
  // Index-space map: i_W = S^-1 T_W_A S i_A with S = voxel scaling. OpenVDB matrices act on row
  // vectors, so the transpose goes in.
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.topLeftCorner<3, 3>() = T_W_A.linear();
  M.topRightCorner<3, 1>() = T_W_A.translation() / voxel_size_m;
  openvdb::Mat4R xform;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) xform(c, r) = M(r, c);
  openvdb::tools::GridTransformer transformer(xform);
  transformer.transformGrid<openvdb::tools::BoxSampler, openvdb::FloatGrid>(in, out);
}
}  // namespace

const TsdfVolume& Mapper::volume() const {
  if (config_.mode != ConsistencyMode::Submap) return volume_;
  if (fused_) return *fused_;
  // Fuse: sum over submaps of resampled (w * tsdf) and w, both with background 0 so that
  // interpolation near unobserved space does not mix in the +truncation background.
  auto wsdf_sum = openvdb::FloatGrid::create(0.0f);
  auto w_sum = openvdb::FloatGrid::create(0.0f);
  const double vs = config_.tsdf.voxel_size_m;
  for (const auto& s : submaps_) {
    auto weight = s->volume->weightGrid();
    auto tsdf = s->volume->tsdfGrid();
    auto wsdf = weight->deepCopy();
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(wsdf->tree());
    leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
      for (auto it = leaf.beginValueOn(); it; ++it) it.setValue(*it * tsdf->tree().getValue(it.getCoord()));
    });
    auto w_W = openvdb::FloatGrid::create(0.0f), wsdf_W = openvdb::FloatGrid::create(0.0f);
    resampleInto(*weight, *w_W, s->T_W_A, vs);
    resampleInto(*wsdf, *wsdf_W, s->T_W_A, vs);
    openvdb::tools::compSum(*w_sum, *w_W);
    openvdb::tools::compSum(*wsdf_sum, *wsdf_W);
  }
  fused_ = std::make_unique<TsdfVolume>(
      TsdfVolume::fromWeightedSums(config_.tsdf, config_.integrator, *w_sum, *wsdf_sum));
  return *fused_;
}

}  // namespace vdbmap
