#include "vdbmap/mapper.hpp"

#include "internal/consistency_policy.hpp"

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

Mapper::Mapper(const MapperConfig& config)
    : config_(config), ledger_(std::make_unique<internal::MapperLedger>()) {
  config_.validate();
  policy_ = internal::makeConsistencyPolicy(config_, *ledger_);
}
Mapper::~Mapper() = default;
Mapper::Mapper(Mapper&&) noexcept = default;

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

IntegrationStats Mapper::addFrame(FrameId id, double timestamp, EncodedFrame data, const Pose3d& T_W_S) {
  return policy_->addFrame(id, timestamp, std::move(data), T_W_S);
}

std::size_t Mapper::updatePoses(const std::map<FrameId, Pose3d>& T_W_S_by_id) {
  for (const auto& [id, T] : T_W_S_by_id) {
    if (!isValidRigidTransform(T))
      throw FrameError("pose update for frame " + std::to_string(id) + " is not a rigid transform");
    if (T.translation().cwiseAbs().maxCoeff() > kMaxAbsPosition_m)
      throw FrameError("pose update for frame " + std::to_string(id) + ": translation beyond " +
                       std::to_string(int(kMaxAbsPosition_m)) + " m");
  }
  return policy_->updatePoses(T_W_S_by_id);
}

CycleReport Mapper::reintegrate(const Vec3d& robot_W) { return policy_->runCycle(robot_W); }
std::size_t Mapper::reintegrateAll(const Vec3d& robot_W) { return policy_->finishAll(robot_W); }
std::size_t Mapper::queuedFrames() const { return policy_->pendingFrames(); }
const TsdfVolume& Mapper::volume() const { return policy_->volume(); }
const MapperStats& Mapper::stats() const { return ledger_->stats; }
const KeyframeStore& Mapper::keyframes() const { return policy_->keyframes(); }
const FramePruner* Mapper::pruner() const { return policy_->pruner(); }

openvdb::CoordBBox Mapper::takeDirtyRegion() {
  openvdb::CoordBBox box = ledger_->dirty;
  ledger_->dirty = openvdb::CoordBBox();
  return box;
}

}  // namespace vdbmap
