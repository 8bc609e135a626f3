#include "vdbmap/mapper.hpp"

#include "internal/consistency_policy.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/timing.hpp"

#include <sstream>
#include <stdexcept>
#include <utility>

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

IntegrationStats Mapper::addFrame(FrameId id, double timestamp_s, const SensorFrame& frame, const Pose3d& T_W_S) {
  const Stopwatch watch;
  IntegrationStats stats = policy_->addFrame(id, timestamp_s, frame, T_W_S);
  frame_ms_ = watch.ms();
  return stats;
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

CycleReport Mapper::reintegrate(const Vec3d& robot_W) {
  return policy_->runCycle(robot_W, std::exchange(frame_ms_, 0.0));
}
std::size_t Mapper::reintegrateAll(const Vec3d& robot_W) { return policy_->finishAll(robot_W); }
std::size_t Mapper::queuedFrames() const { return policy_->pendingFrames(); }
const TsdfVolume& Mapper::volume() const { return policy_->volume(); }
const MapperStats& Mapper::stats() const { return ledger_->stats; }
const KeyframeStore& Mapper::keyframes() const { return policy_->keyframes(); }
const FramePruner* Mapper::pruner() const { return policy_->pruner(); }

std::filesystem::path Mapper::keyframesPath(const std::filesystem::path& map_path) {
  std::filesystem::path p = map_path;
  return p.replace_extension(".keyframes");
}

void Mapper::save(const std::filesystem::path& map_path) const {
  if (queuedFrames() != 0)
    throw std::logic_error("Mapper::save: " + std::to_string(queuedFrames()) +
                           " frames still wait for background work; call reintegrateAll first");
  const bool keeps_frames = config_.mode == ConsistencyMode::All || config_.mode == ConsistencyMode::Keyframes;
  if (keeps_frames && map_path.extension() == ".keyframes")
    throw FileError("cannot write map " + map_path.string() + ": a name ending in .keyframes is the name of its "
                    "keyframe store; choose another");
  // One unit: the store and the companion are renamed before the map, all under one unit id.
  AtomicFileSet files;
  if (keeps_frames) keyframes().stageSave(keyframesPath(map_path), files);
  volume().stageSave(map_path, files);
  files.commit();
}

Mapper Mapper::load(const std::filesystem::path& map_path, const ReintegrationConfig& reintegration) {
  TsdfVolume volume = TsdfVolume::load(map_path);
  if (!volume.hasExactState())
    throw FileError(map_path.string() + ": no exact companion (" + TsdfVolume::exactStatePath(map_path).filename().string() +
                    "), so the map cannot be corrected exactly");
  const std::filesystem::path store_path = keyframesPath(map_path);
  if (!std::filesystem::is_regular_file(store_path))
    throw FileError(map_path.string() + ": no keyframe store " + store_path.string() +
                    " (integrate in all or keyframes mode writes it)");
  const std::string map_unit = TsdfVolume::savedUnitId(map_path), store_unit = KeyframeStore::savedUnitId(store_path);
  if (map_unit != store_unit)
    throw FileError(store_path.string() + " belongs to another save than " + map_path.string() + " (unit id " +
                    (store_unit.empty() ? "none" : store_unit) + ", the map's " + (map_unit.empty() ? "none" : map_unit) +
                    "): a save was stopped between its files, or two programs wrote the same map");
  KeyframeStore store = KeyframeStore::load(store_path);
  const std::map<FrameId, Pose3d> held = volume.integratedPoses();
  std::size_t integrated = 0;
  for (const auto& [id, kf] : store) {
    if (!kf.integrated) continue;
    ++integrated;
    const auto it = held.find(id);
    if (it == held.end())
      throw FileError(store_path.string() + ": keyframe " + std::to_string(id) + " is not in the map " + map_path.string());
    if (!(it->second.matrix() == kf.T_W_S_integrated.matrix()))
      throw FileError(store_path.string() + ": keyframe " + std::to_string(id) + " is held by the map at another pose");
  }
  if (integrated != held.size())
    throw FileError(map_path.string() + " holds " + std::to_string(held.size()) + " frames, its keyframe store " +
                    std::to_string(integrated) + ": they are not of the same run");
  MapperConfig config;
  config.mode = ConsistencyMode::All;
  config.tsdf = volume.config();
  config.integrator = volume.integratorConfig();
  config.reintegration = reintegration;
  Mapper mapper(config);
  mapper.policy_->restore(std::move(volume), std::move(store));
  return mapper;
}

openvdb::CoordBBox Mapper::takeDirtyRegion() {
  openvdb::CoordBBox box = ledger_->dirty;
  ledger_->dirty = openvdb::CoordBBox();
  return box;
}

}  // namespace vdbmap
