// The three consistency policies behind the Mapper (internal/consistency_policy.hpp).
#include "internal/consistency_policy.hpp"

#include "vdbmap/timing.hpp"

#include <openvdb/tools/Composite.h>
#include <openvdb/tools/GridTransformer.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <mutex>
#include <optional>
#include <set>
#include <tuple>

namespace vdbmap::internal {
namespace {

/// Whether the volume's integration pass itself gives the frame's footprint (projective depth).
bool footprintFromIntegration(const SensorFrame& frame, const MapperConfig& config) {
  return frame.isDepth() && config.integrator.ray_mode == RayMode::Projective;
}

/// The coarse cells of a frame at T_W_S when its integration gave no footprint (the ray modes).
CellSet raysCells(const SensorFrame& frame, const Pose3d& T_W_S, const MapperConfig& config) {
  const double cell_vox = config.set_cover.cell_size_vox;
  return frame.isDepth()
             ? visibleCells(frame.depthImage(), frame.intrinsics(), T_W_S, config.tsdf, config.integrator, cell_vox)
             : visibleCells(frame.points_S(), T_W_S, config.tsdf, config.integrator, cell_vox);
}

const KeyframeStore& emptyStore() {
  static const KeyframeStore store;
  return store;
}

bool beyondGate(const ReintegrationConfig& c, const Pose3d& a, const Pose3d& b) {
  const double dt = (a.translation() - b.translation()).norm();
  const double dr = Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
  return dt > c.gate_translation_m || dr > c.gate_rotation_deg;
}

// ---- none ----------------------------------------------------------------------------------

class DirectPolicy final : public ConsistencyPolicy {
 public:
  DirectPolicy(const MapperConfig& config, MapperLedger& ledger)
      : ledger_(ledger), volume_(config.tsdf, config.integrator), depth_unit_m_(config.depth_unit_m) {}

  IntegrationStats addFrame(FrameId id, double, const SensorFrame& frame, const Pose3d& T_W_S) override {
    if (volume_.isIntegrated(id)) throw FrameError("frame " + std::to_string(id) + " was already given to the mapper");
    ++ledger_.stats.frames_total;
    const IntegrationStats stats = volume_.integrate(id, EncodedFrame::quantize(frame, depth_unit_m_), T_W_S);
    ledger_.markDirty(stats.touched_voxels);
    return stats;
  }
  std::size_t updatePoses(const std::map<FrameId, Pose3d>&) override { return 0; }
  const TsdfVolume& volume() const override { return volume_; }
  const KeyframeStore& keyframes() const override { return emptyStore(); }

 private:
  MapperLedger& ledger_;
  TsdfVolume volume_;
  double depth_unit_m_;
};

// ---- submap --------------------------------------------------------------------------------

/// A rigid map between index spaces for openvdb::tools::GridResampler, computing each output
/// voxel's input position from the voxel itself. (Declared not affine for that: the affine path
/// steps from each input leaf's corner, so a voxel that two leaves reach gets positions differing
/// in the last bits, and which of the two the parallel merge keeps depends on the threads; the
/// fused map then differed between runs.)
struct PointwiseTransform {
  openvdb::Mat4R mat, inv;
  bool isAffine() const { return false; }
  openvdb::Vec3R transform(const openvdb::Vec3R& p) const { return mat.transformH(p); }
  openvdb::Vec3R invTransform(const openvdb::Vec3R& p) const { return inv.transformH(p); }
};

/// Resamples `in` (index space of a submap) into the world grid `out` by the rigid T_W_A, with
/// trilinear (box) sampling; the same on every run, whatever the threads.
void resampleInto(const openvdb::FloatGrid& in, openvdb::FloatGrid& out, const Pose3d& T_W_A, double voxel_size_m) {
  // Index-space map: i_W = S^-1 T_W_A S i_A with S = voxel scaling. OpenVDB matrices act on row
  // vectors, so the transpose goes in.
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.topLeftCorner<3, 3>() = T_W_A.linear();
  M.topRightCorner<3, 1>() = T_W_A.translation() / voxel_size_m;
  openvdb::Mat4R xform;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) xform(c, r) = M(r, c);
  openvdb::tools::GridResampler resampler;
  resampler.transformGrid<openvdb::tools::BoxSampler>(PointwiseTransform{xform, xform.inverse()}, in, out);
}

class SubmapPolicy final : public ConsistencyPolicy {
 public:
  SubmapPolicy(const MapperConfig& config, MapperLedger& ledger) : config_(config), ledger_(ledger) {}

  IntegrationStats addFrame(FrameId id, double, const SensorFrame& frame, const Pose3d& T_W_S) override {
    if (ids_.count(id)) throw FrameError("frame " + std::to_string(id) + " was already given to the mapper");
    if (submaps_.empty() || submaps_.back().frames >= config_.submap_frames) {
      Submap s;
      s.anchor_id = id;
      s.T_W_A_odom = s.T_W_A = T_W_S;
      s.volume = std::make_unique<TsdfVolume>(config_.tsdf, config_.integrator);
      submaps_.push_back(std::move(s));
      ++ledger_.stats.submaps;
    }
    Submap& s = submaps_.back();
    const IntegrationStats stats =
        s.volume->integrate(id, EncodedFrame::quantize(frame, config_.depth_unit_m), s.T_W_A_odom.inverse() * T_W_S);
    ids_.insert(id);
    ++ledger_.stats.frames_total;
    ++s.frames;
    s.stale = true;
    fused_stale_ = true;
    // The submap's box in the world is not tracked voxel-exactly; mark the frame's reach.
    const double r = config_.integrator.max_range_m + config_.tsdf.truncation_m();
    const Vec3d c = s.T_W_A * (s.T_W_A_odom.inverse() * T_W_S).translation();
    ledger_.markDirty(openvdb::CoordBBox(worldToVoxel(c - Vec3d::Constant(r)), worldToVoxel(c + Vec3d::Constant(r))));
    return stats;
  }

  std::size_t updatePoses(const std::map<FrameId, Pose3d>& T_W_S_by_id) override {
    std::size_t changed = 0;
    for (auto& s : submaps_) {
      const auto it = T_W_S_by_id.find(s.anchor_id);
      if (it == T_W_S_by_id.end() || !beyondGate(config_.reintegration, it->second, s.T_W_A)) continue;
      s.T_W_A = it->second;
      s.stale = true;
      fused_stale_ = true;
      ++changed;
    }
    if (changed) ledger_.markDirty(volume().activeBoundingBox());
    return changed;
  }

  /// The fusion of the submaps: the sum over submaps of resampled (w * tsdf) and w, both with
  /// background 0 so that interpolation near unobserved space does not mix in the +truncation
  /// background. Each submap's resampled grids are cached until it changes (a new frame, a moved
  /// anchor), so a rebuild resamples only the changed submaps. The caches are rebuilt under a
  /// lock, so concurrent const calls are safe (they change nothing observable).
  const TsdfVolume& volume() const override {
    const std::lock_guard<std::mutex> lock(cache_mutex_);
    if (!fused_stale_) return *fused_;
    auto wsdf_sum = openvdb::FloatGrid::create(0.0f);
    auto w_sum = openvdb::FloatGrid::create(0.0f);
    for (const Submap& s : submaps_) {
      if (s.stale) resample(s);
      openvdb::tools::compSum(*w_sum, *s.w_W->deepCopy());
      openvdb::tools::compSum(*wsdf_sum, *s.wsdf_W->deepCopy());
    }
    fused_ = std::make_unique<TsdfVolume>(
        TsdfVolume::fromWeightedSums(config_.tsdf, config_.integrator, *w_sum, *wsdf_sum));
    fused_stale_ = false;
    return *fused_;
  }
  const KeyframeStore& keyframes() const override { return emptyStore(); }

 private:
  /// A rigid submap: frames integrated in the frame A of its first keyframe, T_W_A movable.
  struct Submap {
    FrameId anchor_id = 0;
    Pose3d T_W_A_odom = Pose3d::Identity();  ///< anchor pose when the submap was started (fixed)
    Pose3d T_W_A = Pose3d::Identity();       ///< newest anchor pose
    std::unique_ptr<TsdfVolume> volume;
    int frames = 0;
    // The submap resampled into the world at T_W_A (cache of volume(); stale when it changed).
    mutable bool stale = true;
    mutable openvdb::FloatGrid::Ptr w_W, wsdf_W;
  };

  /// As TsdfVolume::worldToVoxel.
  openvdb::Coord worldToVoxel(const Vec3d& p_W) const {
    const double inv = 1.0 / config_.tsdf.voxel_size_m;
    return openvdb::Coord(int(std::floor(p_W.x() * inv + 0.5)), int(std::floor(p_W.y() * inv + 0.5)),
                          int(std::floor(p_W.z() * inv + 0.5)));
  }

  void resample(const Submap& s) const {
    auto weight = s.volume->weightGrid();
    auto tsdf = s.volume->tsdfGrid();
    auto wsdf = weight->deepCopy();
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(wsdf->tree());
    leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
      for (auto it = leaf.beginValueOn(); it; ++it) it.setValue(*it * tsdf->tree().getValue(it.getCoord()));
    });
    s.w_W = openvdb::FloatGrid::create(0.0f);
    s.wsdf_W = openvdb::FloatGrid::create(0.0f);
    resampleInto(*weight, *s.w_W, s.T_W_A, config_.tsdf.voxel_size_m);
    resampleInto(*wsdf, *s.wsdf_W, s.T_W_A, config_.tsdf.voxel_size_m);
    s.stale = false;
  }

  const MapperConfig config_;  // a copy: the Mapper, and with it its config, may move
  MapperLedger& ledger_;
  std::set<FrameId> ids_;
  std::vector<Submap> submaps_;
  mutable std::mutex cache_mutex_;  ///< guards fused_, fused_stale_ and the submaps' caches in volume()
  mutable std::unique_ptr<TsdfVolume> fused_;
  mutable bool fused_stale_ = true;
};

// ---- all, keyframes --------------------------------------------------------------------------

class ReintegratingPolicy final : public ConsistencyPolicy {
 public:
  ReintegratingPolicy(const MapperConfig& config, MapperLedger& ledger)
      : config_(config), ledger_(ledger), volume_(config.tsdf, config.integrator) {
    if (config.mode == ConsistencyMode::Keyframes)
      pruner_ = std::make_unique<FramePruner>(config.set_cover, config.tsdf.voxel_size_m);
  }

  IntegrationStats addFrame(FrameId id, double timestamp, const SensorFrame& frame, const Pose3d& T_W_S) override {
    settleCompression();
    if (store_.contains(id)) throw FrameError("frame " + std::to_string(id) + " was already given to the mapper");
    if (pruner_) checkPackable(id, T_W_S, config_.tsdf, config_.integrator, config_.set_cover.cell_size_vox);
    ++ledger_.stats.frames_total;
    // Coded raw here and compressed off this thread; decoded once, for integration and the pruner.
    SensorFrame decoded;
    EncodedFrame data = EncodedFrame::encodeRaw(frame, config_.depth_unit_m, decoded);
    // The pruner's cells come from the voxels this integration updates under projective
    // integration, else from the frame's rays.
    const bool with_footprint = pruner_ && footprintFromIntegration(decoded, config_);
    VoxelFootprint footprint;
    const IntegrationStats stats = volume_.integrate(id, decoded, T_W_S, with_footprint ? &footprint : nullptr);
    ledger_.markDirty(stats.touched_voxels);

    Keyframe kf;
    kf.id = id;
    kf.timestamp = timestamp;
    kf.T_W_S_integrated = kf.T_W_S_latest = T_W_S;
    kf.integrated = true;
    kf.data = std::move(data);
    // Started before the pruner's cells are worked out, so that the compression has the other
    // core meanwhile rather than sharing both with the next frame's integration.
    startCompression(store_.add(std::move(kf)));

    if (pruner_) {
      CellSet cells = with_footprint ? footprintCells(footprint, config_.set_cover.cell_size_vox)
                                     : raysCells(decoded, T_W_S, config_);
      pruner_->addFrame(id, T_W_S.translation(), std::move(cells));
      if (++frames_since_solve_ >= std::size_t(config_.set_cover.solve_period_frames)) prune();
    }
    return stats;
  }

  void restore(TsdfVolume volume, KeyframeStore store) override {
    settleCompression();
    if (store_.size() != 0 || pruner_)
      throw std::logic_error("a saved map is taken over by a new all-mode mapper only");
    volume_ = std::move(volume);
    store_ = std::move(store);
  }

  std::size_t updatePoses(const std::map<FrameId, Pose3d>& T_W_S_by_id) override {
    if (pruner_)  // all checked before any changes
      for (const auto& [id, T] : T_W_S_by_id)
        if (store_.contains(id)) checkPackable(id, T, config_.tsdf, config_.integrator, config_.set_cover.cell_size_vox);
    std::size_t changed = 0;
    for (const auto& [id, T] : T_W_S_by_id) {
      if (!store_.contains(id) || drops_.count(id)) continue;  // pruned, being dropped, or never given
      Keyframe& kf = store_.at(id);
      kf.T_W_S_latest = T;
      if (beyondGate(config_.reintegration, kf.T_W_S_latest, kf.T_W_S_integrated)) {
        queue_.insert(id);
        ++changed;
      } else {
        queue_.erase(id);  // corrected back to where the map holds it
      }
    }
    return changed;
  }

  /// Re-integrations and pending drops share one waiting list and one budget: nearest first, by
  /// set-cover block (Chebyshev distance) then by distance; a cycle stops before a frame that would
  /// likely overrun what is left of the time budget after `spent_ms` (by the recent cost per
  /// frame) or after budget_frames frames, and always does at least one, so progress never stops.
  CycleReport runCycle(const Vec3d& robot_W, double spent_ms) override {
    settleCompression();
    CycleReport report;
    if (queue_.empty() && drops_.empty()) return report;
    const Stopwatch cycle;
    const double block = config_.set_cover.block_size_m;
    auto blockOf = [block](const Vec3d& p) { return Eigen::Vector3i((p / block).array().floor().cast<int>()); };
    const Eigen::Vector3i robot_block = blockOf(robot_W);
    // (block distance, distance, id, is a drop)
    std::vector<std::tuple<int, double, FrameId, bool>> order;
    order.reserve(queue_.size() + drops_.size());
    const auto enlist = [&](FrameId id, const Vec3d& p, bool drop) {
      order.emplace_back((blockOf(p) - robot_block).cwiseAbs().maxCoeff(), (p - robot_W).norm(), id, drop);
    };
    for (const FrameId id : queue_) enlist(id, store_.at(id).T_W_S_latest.translation(), false);
    for (const FrameId id : drops_) enlist(id, store_.at(id).T_W_S_integrated.translation(), true);
    std::sort(order.begin(), order.end());
    const ReintegrationConfig& budget = config_.reintegration;
    for (const auto& [block_dist, dist, id, drop] : order) {
      const double elapsed_ms = cycle.ms();
      const std::size_t done = report.frames + report.frames_deintegrated;
      // A de-integration costs about half a re-integration: each kind has its own estimate.
      double& estimate_ms = drop ? drop_ms_estimate_ : reintegrate_ms_estimate_;
      if (done > 0 && spent_ms + elapsed_ms + estimate_ms > budget.budget_ms) break;
      if (drop) {
        deintegrateDropped(id);
        ++report.frames_deintegrated;
      } else {
        reintegrateFrame(store_.at(id));
        queue_.erase(id);
        ++report.frames;
      }
      const double frame_ms = cycle.ms() - elapsed_ms;
      estimate_ms = estimate_ms > 0.0 ? 0.8 * estimate_ms + 0.2 * frame_ms : frame_ms;
      if (budget.budget_frames > 0 && int(done + 1) >= budget.budget_frames) break;
    }
    report.ms = cycle.ms();
    report.queued_left = pendingFrames();
    MapperStats& s = ledger_.stats;
    ++s.reintegration_cycles;
    s.background_frames += report.frames + report.frames_deintegrated;
    s.reintegration_ms_total += report.ms;
    s.reintegration_ms_max_cycle = std::max(s.reintegration_ms_max_cycle, report.ms);
    return report;
  }

  std::size_t finishAll(const Vec3d& robot_W) override {
    settleCompression();
    std::size_t n = 0;
    while (true) {
      collectSolve();
      while (pendingFrames() > 0) {
        const CycleReport r = runCycle(robot_W, 0.0);
        n += r.frames + r.frames_deintegrated;
      }
      if (!pruner_ || frames_since_solve_ == 0) return n;
      prune();  // the last frames' solve; its drops are worked off above
    }
  }

  std::size_t pendingFrames() const override { return queue_.size() + drops_.size(); }
  const TsdfVolume& volume() const override { return volume_; }
  const KeyframeStore& keyframes() const override {
    settleCompression();
    return store_;
  }
  const FramePruner* pruner() const override { return pruner_.get(); }

 private:
  /// Compresses the new frame's payload on a worker thread while the caller goes on; the store
  /// holds it raw meanwhile, which decodes alike.
  void startCompression(const Keyframe& kf) {
    compressing_id_ = kf.id;
    compressing_ = std::async(std::launch::async, [raw = kf.data] { return raw.compressed(); });
  }

  /// Puts the compressed payload in the store, waiting for it if need be. Logically const (the
  /// frame decodes the same), so const readers settle too: keyframes() then returns the store as
  /// a save writes it. Only addFrame starts a compression, so once a reader has settled, none is
  /// in flight for any concurrent reader.
  void settleCompression() const {
    const std::lock_guard<std::mutex> lock(compress_mutex_);
    if (!compressing_.valid()) return;
    EncodedFrame packed = compressing_.get();  // rethrows what the worker threw
    if (store_.contains(compressing_id_)) store_.at(compressing_id_).data = std::move(packed);
  }

  /// Moves a frame from the pose the map holds to its newest; in keyframes mode the pruner then
  /// sees it where it now is.
  void reintegrateFrame(Keyframe& kf) {
    const SensorFrame frame = kf.data.decodeFrame();
    VoxelFootprint footprint;
    const bool with_footprint = pruner_ && footprintFromIntegration(frame, config_);
    const IntegrationStats s = volume_.reintegrate(kf.id, frame, kf.T_W_S_integrated, kf.T_W_S_latest,
                                                   with_footprint ? &footprint : nullptr);
    kf.T_W_S_integrated = kf.T_W_S_latest;
    if (pruner_)
      pruner_->updateFrame(kf.id, kf.T_W_S_integrated.translation(),
                           with_footprint ? footprintCells(footprint, config_.set_cover.cell_size_vox)
                                          : raysCells(frame, kf.T_W_S_integrated, config_));
    ledger_.markDirty(s.touched_voxels);
    ++ledger_.stats.reintegrated_frames;
  }

  /// Starts a solve of the dirty blocks, after collecting the previous one. In the background it
  /// runs on a worker thread until the next solve is due (or the mapper drains); the frames a
  /// solve drops wait in drops_ for the background cycles (a dropped frame stays in the map until
  /// its turn, which is correct, only redundant).
  void prune() {
    collectSolve();
    frames_since_solve_ = 0;
    auto job = std::make_unique<PruningSolve>(pruner_->beginSolve());
    ++ledger_.stats.pruning_solves;
    if (!config_.set_cover.solve_in_background || job->blockCount() == 0) {
      job->run();
      takeDrops(std::move(*job));
      return;
    }
    solving_ = std::move(job);
    solving_done_ = std::async(std::launch::async, [job = solving_.get()] { job->run(); });
  }

  /// Waits for the solve in flight, if any, and queues its drops.
  void collectSolve() {
    if (!solving_) return;
    const std::unique_ptr<PruningSolve> job = std::move(solving_);
    solving_done_.get();  // rethrows what the worker threw
    takeDrops(std::move(*job));
  }

  void takeDrops(PruningSolve&& job) {
    for (const FrameId id : pruner_->finishSolve(std::move(job)).dropped) {
      queue_.erase(id);
      drops_.insert(id);
    }
  }

  void deintegrateDropped(FrameId id) {
    Keyframe& kf = store_.at(id);
    if (kf.integrated) ledger_.markDirty(volume_.deintegrate(id, kf.data.decodeFrame(), kf.T_W_S_integrated).touched_voxels);
    store_.erase(id);
    drops_.erase(id);
    ++ledger_.stats.frames_dropped;
  }

  const MapperConfig config_;  // a copy: the Mapper, and with it its config, may move
  MapperLedger& ledger_;
  TsdfVolume volume_;
  mutable KeyframeStore store_;          ///< mutable for settleCompression() only
  std::set<FrameId> queue_;              ///< moved frames awaiting re-integration
  std::set<FrameId> drops_;              ///< frames set cover dropped, awaiting de-integration
  std::unique_ptr<FramePruner> pruner_;  ///< keyframes mode
  std::unique_ptr<PruningSolve> solving_;  ///< the solve on the worker thread, if any
  std::future<void> solving_done_;         ///< declared after solving_: waits for the worker first
  mutable std::mutex compress_mutex_;
  mutable std::future<EncodedFrame> compressing_;  ///< the newest frame's payload, compressed
  FrameId compressing_id_ = 0;
  std::size_t frames_since_solve_ = 0;
  double reintegrate_ms_estimate_ = 0.0;  ///< recent time per re-integration (moving average)
  double drop_ms_estimate_ = 0.0;         ///< recent time per de-integration of a dropped frame
};

}  // namespace

std::unique_ptr<ConsistencyPolicy> makeConsistencyPolicy(const MapperConfig& config, MapperLedger& ledger) {
  switch (config.mode) {
    case ConsistencyMode::None: return std::make_unique<DirectPolicy>(config, ledger);
    case ConsistencyMode::Submap: return std::make_unique<SubmapPolicy>(config, ledger);
    case ConsistencyMode::All:
    case ConsistencyMode::Keyframes: return std::make_unique<ReintegratingPolicy>(config, ledger);
  }
  throw std::invalid_argument("unknown consistency mode");
}

}  // namespace vdbmap::internal
