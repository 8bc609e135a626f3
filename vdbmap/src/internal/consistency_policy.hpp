// How the Mapper keeps the map consistent when poses are corrected: one policy per
// ConsistencyMode (private to the library; the Mapper holds one and forwards to it).
//
//  - DirectPolicy (none): integrate with the poses given, keep nothing, ignore corrections;
//  - SubmapPolicy (submap): rigid submaps whose anchors corrections move; the map is their fusion;
//  - ReintegratingPolicy (all, keyframes): every frame stored; moved frames re-integrated in
//    budgeted background cycles; in keyframes mode set cover picks the frames to keep and the
//    dropped ones are de-integrated in the same background cycles.
// Each policy holds only its own state; the ledger (stats, dirty region) is the Mapper's.
#pragma once

#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <map>
#include <memory>
#include <stdexcept>

namespace vdbmap::internal {

/// What every policy reports into: the Mapper's statistics and the voxel box changed since the
/// planner last asked.
struct MapperLedger {
  MapperStats stats;
  openvdb::CoordBBox dirty;
  void markDirty(const openvdb::CoordBBox& box) {
    if (!box.empty()) dirty.expand(box);
  }
};

class ConsistencyPolicy {
 public:
  virtual ~ConsistencyPolicy() = default;

  /// Integrates a new frame seen from T_W_S (odometry), quantized to MapperConfig::depth_unit_m
  /// as its keyframe stores it (EncodedFrame::quantize); keeps it when the policy needs it later.
  virtual IntegrationStats addFrame(FrameId id, double timestamp, const SensorFrame& frame, const Pose3d& T_W_S) = 0;
  /// New pose estimates by frame id; returns how many frames (or anchors) changed.
  virtual std::size_t updatePoses(const std::map<FrameId, Pose3d>& T_W_S_by_id) = 0;
  /// One budgeted cycle of background work, nearest to `robot_W` first; `spent_ms` of the cycle's
  /// budget went to the frame's integration already.
  virtual CycleReport runCycle(const Vec3d& robot_W, double spent_ms) { return {}; }
  /// Runs cycles (and a last pruning solve) until no background work is left; returns frames done.
  virtual std::size_t finishAll(const Vec3d& robot_W) { return 0; }
  /// Frames waiting for background work.
  virtual std::size_t pendingFrames() const { return 0; }
  /// The map as the policy holds it now.
  virtual const TsdfVolume& volume() const = 0;
  /// Frames the policy keeps (empty when it keeps none).
  virtual const KeyframeStore& keyframes() const = 0;
  /// The set-cover pruner (keyframes mode), else nullptr.
  virtual const FramePruner* pruner() const { return nullptr; }
  /// Takes over a saved map and the keyframes it holds (Mapper::load); only the re-integrating
  /// policies can, and only before any frame was added.
  virtual void restore(TsdfVolume volume, KeyframeStore store) {
    throw std::logic_error("only the all and keyframes modes can take over a saved map");
  }
};

/// The policy of `config.mode` (it keeps a copy of `config`), reporting into `ledger`, which must
/// outlive it.
std::unique_ptr<ConsistencyPolicy> makeConsistencyPolicy(const MapperConfig& config, MapperLedger& ledger);

}  // namespace vdbmap::internal
