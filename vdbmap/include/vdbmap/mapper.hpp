// The mapper: one engine, four ways to keep the map consistent when loop closure corrects poses.
//
//  - none:      integrate with the odometry poses, ignore corrections (Voxblox-like baseline);
//  - submap:    a new rigid submap every `submap_frames` frames, integrated in the frame of its
//               first keyframe (its anchor); corrections move anchors only; queries and exports
//               fuse the submaps (C-blox-like baseline);
//  - all:       keep every frame and re-integrate every frame whose pose changed (no pruning);
//  - keyframes: ours: keep only the frames a greedy set cover selects (set_cover.hpp) and
//               re-integrate those.
// Background work is budgeted per cycle (one cycle per incoming frame): frames nearest to the robot
// (by block, then distance) go first; a frame may be corrected any number of times (it is
// de-integrated at the pose the map holds and integrated at its newest pose), and the frames set
// cover drops wait in the same list to be de-integrated. Each mode is a policy
// (src/internal/consistency_policy.hpp) holding only its own state.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/sensor_frame.hpp"
#include "vdbmap/set_cover.hpp"
#include "vdbmap/tsdf_volume.hpp"
#include "vdbmap/types.hpp"

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace vdbmap {

enum class ConsistencyMode { None, Submap, All, Keyframes };
const char* toString(ConsistencyMode m);
/// Parses none / submap / all / keyframes; throws std::invalid_argument listing the choices.
ConsistencyMode parseConsistencyMode(const std::string& text);

struct ReintegrationConfig {
  double gate_translation_m = 0.01;  ///< a pose change below both gates is ignored; [0, 1e3]
  double gate_rotation_deg = 0.5;    ///< [0, 180]
  /// Time budget of one frame's cycle: its addFrame() and the reintegrate() call after it. That
  /// call stops before a frame that would likely overrun what the frame's integration left (by
  /// the recent time per frame), and processes at least one frame so progress never stops; a call
  /// without a new frame since the last one has the whole budget; (0, 1e6]
  double budget_ms = 20.0;
  int budget_frames = 0;             ///< also stop after this many frames per cycle; 0 = no limit

  void validate() const;
};

struct MapperConfig {
  ConsistencyMode mode = ConsistencyMode::Keyframes;
  TsdfConfig tsdf;
  IntegratorConfig integrator;
  ReintegrationConfig reintegration;
  SetCoverConfig set_cover;       ///< keyframes mode
  int submap_frames = 50;         ///< submap mode: frames per rigid submap; [1, 1e6]
  double depth_unit_m = 0.001;    ///< keyframe store quantization of depth and points; (0, 0.1]

  void validate() const;
};

/// What one background cycle did (re-integration of moved frames, de-integration of the frames
/// set cover dropped).
struct CycleReport {
  std::size_t frames = 0;               ///< frames re-integrated in this cycle
  std::size_t frames_deintegrated = 0;  ///< dropped frames de-integrated and released in this cycle
  double ms = 0.0;                      ///< time spent
  std::size_t queued_left = 0;          ///< frames still waiting (both kinds)
};

struct MapperStats {
  std::size_t frames_total = 0;          ///< frames given to the mapper
  std::size_t frames_dropped = 0;        ///< dropped by pruning, then de-integrated and released
  std::size_t reintegrated_frames = 0;   ///< re-integrations done (a frame may count many times)
  std::size_t background_frames = 0;     ///< frames the background cycles processed (both kinds)
  std::size_t reintegration_cycles = 0;  ///< background cycles that processed at least one frame
  double reintegration_ms_total = 0.0;   ///< time in background cycles
  double reintegration_ms_max_cycle = 0.0;
  std::size_t pruning_solves = 0;
  std::size_t submaps = 0;
};

namespace internal {
class ConsistencyPolicy;
struct MapperLedger;
}  // namespace internal

class Mapper {
 public:
  explicit Mapper(const MapperConfig& config);
  ~Mapper();
  Mapper(Mapper&&) noexcept;

  const MapperConfig& config() const { return config_; }

  /// Stores (except in none mode) and integrates a frame seen from T_W_S (odometry): a depth
  /// image projectively (RayMode::Projective) or a point cloud by rays. What is integrated is the
  /// frame as the store decodes it (depth quantized to depth_unit_m), so that a later
  /// re-integration removes exactly what went in. Throws FrameError for an id given before, a
  /// pose that is not rigid or lies beyond the map's range.
  IntegrationStats addFrame(FrameId id, double timestamp_s, const SensorFrame& frame, const Pose3d& T_W_S);

  [[deprecated("use addFrame(id, t, SensorFrame::depth(depth, K), T_W_S)")]]
  IntegrationStats addDepthFrame(FrameId id, double timestamp, const DepthImage& depth,
                                 std::shared_ptr<const CameraIntrinsics> K, const Pose3d& T_W_S) {
    return addFrame(id, timestamp, SensorFrame::depth(depth, std::move(K)), T_W_S);
  }
  [[deprecated("use addFrame(id, t, SensorFrame::points(points_S), T_W_S)")]]
  IntegrationStats addPointFrame(FrameId id, double timestamp, const PointCloud& points_S, const Pose3d& T_W_S) {
    return addFrame(id, timestamp, SensorFrame::points(points_S), T_W_S);
  }

  /// New pose estimates T_W_S by frame id (a loop-closure correction). Frames whose pose moved
  /// beyond the gates are queued for re-integration (all, keyframes), or the submaps they anchor
  /// move (submap); none ignores corrections. Unknown ids (e.g. pruned frames) are skipped.
  /// Returns how many frames (or anchors) changed.
  std::size_t updatePoses(const std::map<FrameId, Pose3d>& T_W_S_by_id);

  /// One budgeted background cycle, nearest frames to `robot_W` first: frames waiting for
  /// re-integration and frames set cover dropped (de-integrated here, never in a burst) share
  /// one waiting list and one budget (ReintegrationConfig), which also covers the latest
  /// addFrame(). Call it once per incoming frame, after addFrame().
  /// In keyframes mode a re-integrated frame's cells are refreshed in the pruner, so the next
  /// solves see it where it now is: with a time budget, which frames that are depends on the
  /// machine (as on a robot); with a frame count alone (budget_ms large) runs repeat exactly.
  CycleReport reintegrate(const Vec3d& robot_W);
  /// Works off every waiting frame and the last pruning solve (end of a log); returns frames
  /// processed.
  std::size_t reintegrateAll(const Vec3d& robot_W);
  /// Frames waiting for background work (re-integrations and drops). The drops of a set-cover
  /// solve running in the background (SetCoverConfig::solve_in_background) count once it is
  /// collected: when the next solve is due, or in reintegrateAll.
  std::size_t queuedFrames() const;

  /// The map: in submap mode the fusion of all submaps (rebuilt when a submap changed,
  /// approximate state; the rebuild is locked, so const calls may run concurrently, as with
  /// every const member).
  const TsdfVolume& volume() const;
  /// Voxel box changed since the last call (integration, re-integration, pruning, anchors);
  /// empty when nothing changed. Planners refresh frontiers and distances there.
  openvdb::CoordBBox takeDirtyRegion();

  const MapperStats& stats() const;
  /// Frames whose data the mapper keeps (0 in none and submap modes), those waiting to be
  /// dropped included.
  std::size_t keyframesKept() const { return keyframes().size(); }
  std::size_t keyframeStoreBytes() const { return keyframes().bytes(); }
  const KeyframeStore& keyframes() const;
  /// The set-cover pruner in keyframes mode (each held frame's cells where the map now holds
  /// it), else nullptr. While a solve runs in the background it still holds the frames that solve
  /// will drop.
  const FramePruner* pruner() const;

  // ---- files: correcting a saved map later -----------------------------------------------------
  /// MAP.vdb -> MAP.keyframes.
  static std::filesystem::path keyframesPath(const std::filesystem::path& map_path);
  /// Writes the map (`map_path` with its exact companion, TsdfVolume::save) and, in all and
  /// keyframes modes, the keyframe store beside it (keyframesPath): what load() needs to correct
  /// the map later. Throws std::logic_error while background work is queued (reintegrateAll
  /// first), FileError naming a file that cannot be written.
  void save(const std::filesystem::path& map_path) const;
  /// A mapper holding a saved map and its keyframe store, in all mode (its tsdf and integrator
  /// from the map, `reintegration` for its cycles): updatePoses then reintegrateAll correct it
  /// exactly, as if its frames had been integrated at the new poses. Throws FileError naming the
  /// file when the map has no exact companion, the store is missing or malformed, or the two
  /// disagree (a frame the map holds that the store lacks, or holds at another pose).
  static Mapper load(const std::filesystem::path& map_path, const ReintegrationConfig& reintegration = {});

 private:
  MapperConfig config_;
  std::unique_ptr<internal::MapperLedger> ledger_;
  std::unique_ptr<internal::ConsistencyPolicy> policy_;
  double frame_ms_ = 0.0;  ///< the latest addFrame()'s time, until a reintegrate() charges it to its cycle
};

}  // namespace vdbmap
