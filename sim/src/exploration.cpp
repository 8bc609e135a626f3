#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/field_check.hpp"

#include "vdbmap/sim/collision_events.hpp"

#include "vdbmap/eval.hpp"
#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/timing.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/sim/pose_graph.hpp"
#include "vdbmap/sim/trajectory_alignment.hpp"
#include "internal/summary_json.hpp"
#include "text_format.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace vdbmap::sim {

namespace {

/// The inverse of a flat pose (compose(inverse(a), a) = identity).
FlatPose inverse(const FlatPose& a) { return relativePose(a, FlatPose{}); }

/// Far surfaces are reported up to this distance, beyond the sensor's range, so that rays toward
/// them carve free space up to the range (within the 16-bit PNG range of the logs).
constexpr double kFarClip_m = 30.0;
}  // namespace

SimulatorConfig ExplorationConfig::defaultSimulator() {
  SimulatorConfig c;
  c.camera.far_clip_m = kFarClip_m;
  return c;
}

void ExplorationConfig::validate() const {
  const FieldCheck check("ExplorationConfig");
  simulator.validate();
  mapper.validate();
  planner.validate();
  if (!start.position_W.allFinite() || !std::isfinite(start.yaw_rad)) check.fail("start", "finite values");
  if (!(max_time_s > 0.0 && max_time_s <= 1e5)) check.fail("max_time_s", "(0, 1e5]");
  if (!(vehicle_radius_m >= 0.0 && vehicle_radius_m <= 10.0)) check.fail("vehicle_radius_m", "[0, 10]");
}

// ---- the closed loop ---------------------------------------------------------------------------

namespace {

/// The vehicle in closed loop: true pose from the command through the true <- estimate offset,
/// collision events, path length.
class Vehicle {
 public:
  Vehicle(const World& world, const Simulator& sim, const planner::ExplorationManager& manager, double radius_m)
      : world_(world), sim_(sim), manager_(manager), radius_(radius_m), last_(sim.bodyTrue()), events_(radius_m) {}

  /// The true pose at t: the commanded pose (estimate frame) through the offset of the last step.
  FlatPose truthAt(double t) {
    const FlatPose offset = compose(sim_.bodyTrue(), inverse(sim_.bodyEstimate()));
    const planner::VehicleState cmd = manager_.command(t);
    FlatPose truth = compose(offset, FlatPose{cmd.position_W, cmd.yaw_rad});
    truth.yaw_rad = last_.yaw_rad + angleDifference(truth.yaw_rad, last_.yaw_rad);  // continuous yaw
    checkCollision(truth.position_W);
    path_length_m_ += (truth.position_W - last_.position_W).norm();
    last_ = truth;
    return truth;
  }

  std::size_t collisions() const { return events_.count(); }
  double minClearance() const { return events_.minClearance(); }
  double pathLength() const { return path_length_m_; }

 private:
  void checkCollision(const Vec3d& p_W) { events_.add(world_.distance(p_W, 2.0 * radius_)); }

  const World& world_;
  const Simulator& sim_;
  const planner::ExplorationManager& manager_;
  double radius_;
  FlatPose last_;
  CollisionEvents events_;
  double path_length_m_ = 0.0;
};

planner::VehicleState vehicleState(const FlatPose& estimate, const planner::VehicleState& command) {
  planner::VehicleState s;
  s.position_W = estimate.position_W;
  s.yaw_rad = planner::wrapAngle(estimate.yaw_rad);
  s.velocity_W = command.velocity_W;
  return s;
}

std::map<FrameId, Pose3d> byFrameId(const CorrectionEvent& event) {
  std::map<FrameId, Pose3d> poses;
  for (const auto& [i, T] : event.T_W_S_by_frame) poses.emplace(FrameId(i), T);
  return poses;
}

/// The corrected body pose of a viewpoint the manager recorded: the manager is updated once per
/// frame with the frame's time, so a viewpoint's stamp names its frame (the nearest frame time).
/// Viewpoints of frames the event does not list keep their pose.
std::function<planner::FlatPose(const planner::FlownViewpoint&)> correctedViewpoints(
    const CorrectionEvent& event, const std::vector<double>& frame_times, const Pose3d& T_B_S) {
  return [&event, &frame_times, T_S_B = T_B_S.inverse()](const planner::FlownViewpoint& v) {
    auto it = std::lower_bound(frame_times.begin(), frame_times.end(), v.stamp_s);
    if (it == frame_times.end() || (it != frame_times.begin() && v.stamp_s - *(it - 1) < *it - v.stamp_s)) --it;
    const auto pose = event.T_W_S_by_frame.find(std::size_t(it - frame_times.begin()));
    if (it == frame_times.end() || pose == event.T_W_S_by_frame.end()) return planner::FlatPose{v.position_W, v.yaw_rad};
    const Pose3d T_W_B = pose->second * T_S_B;
    return planner::FlatPose{T_W_B.translation(), std::atan2(T_W_B.linear()(1, 0), T_W_B.linear()(0, 0))};
  };
}

double estimateErrorRmse(const std::vector<io::StampedPose>& truth, const std::vector<io::StampedPose>& estimate) {
  double sum = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i)
    sum += (truth[i].T_W_S.translation() - estimate[i].T_W_S.translation()).squaredNorm();
  return truth.empty() ? 0.0 : std::sqrt(sum / double(truth.size()));
}

/// The kept keyframes' positions where the final map holds them (every correction applied) and
/// their true ones, `truth` indexed by frame id: what the map's accuracy follows, where
/// estimateErrorRmse follows the online estimate. Empty when the map keeps no frames (modes none
/// and submap).
struct KeyframePositions {
  std::vector<Vec3d> map_W, true_W;
};
KeyframePositions keyframePositions(const KeyframeStore& keyframes, const std::vector<io::StampedPose>& truth) {
  KeyframePositions k;
  for (const auto& [id, keyframe] : keyframes) {
    if (!keyframe.integrated) continue;
    if (id >= truth.size() || std::abs(truth[id].timestamp_s - keyframe.timestamp) > 1e-6)
      throw std::logic_error("keyframe " + std::to_string(id) + " is not the frame of that index");
    k.map_W.push_back(keyframe.T_W_S_integrated.translation());
    k.true_W.push_back(truth[id].T_W_S.translation());
  }
  return k;
}
}  // namespace

ExplorationResult runExploration(const World& world, const ExplorationConfig& config, const ExplorationRecordConfig& options) {
  config.validate();
  if (!(options.coverage_period_s > 0.0 && options.coverage_period_s <= 1e4))
    throw std::invalid_argument("ExplorationRecordConfig.coverage_period_s must be in (0, 1e4]");
  const Stopwatch wall;
  if (!world.isClear(config.start.position_W, config.vehicle_radius_m))
    throw std::invalid_argument("runExploration: the start position is within vehicle_radius_m of a surface");

  Simulator sim(world, config.simulator, config.start, 0.0);
  MapperConfig mc = config.mapper;
  mc.integrator.min_range_m = config.simulator.camera.min_range_m;
  mc.integrator.max_range_m = config.simulator.camera.max_range_m;
  ExplorationResult result;
  result.mapper = std::make_unique<Mapper>(mc);
  Mapper& mapper = *result.mapper;
  const auto K = std::make_shared<const CameraIntrinsics>(sim.camera().intrinsics());

  planner::ExplorationManager manager(config.planner, vehicleState(config.start, planner::VehicleState{}), 0.0);
  Vehicle vehicle(world, sim, manager, config.vehicle_radius_m);
  std::unique_ptr<FlightRecorder> recorder;
  if (!options.log_dir.empty()) recorder = std::make_unique<FlightRecorder>(options.log_dir, sim, options.overwrite);

  std::vector<double> map_ms, frame_ms, frame_times, mapper_ms, integrate_ms_all, update_ms;
  ExplorationProgress progress;
  std::size_t collisions_seen = 0;
  Stopwatch frame_watch;
  double next_coverage_t = 0.0, hold_start_t = -1.0, prev_t = 0.0;
  auto prev_activity = planner::ExplorationActivity::InitialTurn;
  const auto sampleCoverage = [&](double t_s, const TsdfVolume& volume, std::size_t clusters,
                                  planner::ExplorationActivity activity) {
    CoverageSample c;
    c.t_s = t_s;
    c.coverage = options.observable->coverage(planner::TsdfMapQuery(volume));
    c.coverage_seen = options.observable->coverage(*result.seen);
    c.path_length_m = vehicle.pathLength();
    c.clusters = clusters;
    c.loop_closures = result.loop_closures;
    c.estimate_error_m = (result.trajectory_true.back().T_W_S.translation() -
                          result.trajectory_estimate.back().T_W_S.translation()).norm();
    c.activity = activity;
    result.coverage_timeline.push_back(c);
  };
  if (options.observable) result.seen = std::make_unique<SeenSurface>(mc.tsdf.voxel_size_m);
  const auto onFrame = [&](SimFrame& frame) {
    if (recorder) recorder->record(frame);
    if (result.seen) result.seen->addFrame(frame.depth, *K, frame.T_W_S_true, mc.integrator.max_range_m);
    result.trajectory_true.push_back({frame.t_s, frame.T_W_S_true});
    result.trajectory_estimate.push_back({frame.t_s, frame.T_W_S_estimate});
    frame_times.push_back(frame.t_s);
    Stopwatch update_watch;  // the planner's whole work for the frame: the layer's frame and the update
    manager.addDepthFrame(frame.t_s, frame.depth, *K, frame.T_W_S_estimate);  // the safety layer's, when on
    double update_ms_this_frame = update_watch.ms();
    const SensorFrame data = SensorFrame::depth(std::move(frame.depth), K);  // the frame is not used after this
    Stopwatch mapper_watch;  // the mapper's own work only: integration, correction, background cycle
    mapper.addFrame(FrameId(frame.index), frame.t_s, data, frame.T_W_S_estimate);
    const double integrate_ms = mapper_watch.ms();
    double mapper_ms_this_frame = integrate_ms;
    if (frame.correction) {
      ++result.loop_closures;
      result.events.push_back({frame.t_s, "loop_closure"});
      mapper_watch.restart();
      mapper.updatePoses(byFrameId(*frame.correction));
      mapper_ms_this_frame += mapper_watch.ms();
      // The estimate jumped: the pose believed at capture is now sim.bodyEstimate().
      const FlatPose shift = compose(sim.bodyEstimate(), inverse(frame.body_estimate));
      manager.shiftFrame(bodyPose(shift));
      manager.notifyLoopClosure(frame.t_s, correctedViewpoints(*frame.correction, frame_times, sim.T_B_S()));
    }
    if (vehicle.collisions() > collisions_seen) {  // the flight up to this frame began an event
      collisions_seen = vehicle.collisions();
      result.events.push_back({frame.t_s, "collision"});
    }
    const FlatPose estimate = sim.bodyEstimate();
    mapper_watch.restart();
    mapper.reintegrate(estimate.position_W);
    mapper_ms_this_frame += mapper_watch.ms();
    integrate_ms_all.push_back(integrate_ms);
    mapper_ms.push_back(mapper_ms_this_frame);
    const planner::TsdfMapQuery map(mapper.volume());  // re-created every cycle: the volume changed
    const planner::AlcStats alc_before = manager.alcStats();
    update_watch.restart();
    const planner::ExplorationStep step =
        manager.update(map, mapper.takeDirtyRegion(), vehicleState(estimate, manager.command(frame.t_s)), frame.t_s);
    update_ms_this_frame += update_watch.ms();
    update_ms.push_back(update_ms_this_frame);
    // Counted, not read from step.alc_status: at the finish a give-up and the next detour share a decision.
    if (manager.alcStats().give_ups > alc_before.give_ups) result.events.push_back({frame.t_s, "alc_gave_up"});
    if (manager.alcStats().detours > alc_before.detours) result.events.push_back({frame.t_s, "alc_detour"});
    if (step.reason == planner::ReplanReason::EmergencyStop) result.events.push_back({frame.t_s, "emergency_stop"});
    if (step.visit_failed) result.events.push_back({frame.t_s, "visit_failed", step.failed_visit});
    for (const planner::FailedPath& failed : step.failed_paths)
      result.events.push_back({frame.t_s, "path_failed", std::nullopt, failed});
    map_ms.push_back(step.map_update_ms);
    const bool replanned = step.reason != planner::ReplanReason::None;
    if (replanned) result.planner_ms.push_back(step.map_update_ms + step.replan_ms);
    if (step.status == planner::ExplorationStatus::Finished && mapper.queuedFrames() == 0) result.finished = true;

    // Time accounting: the interval since the previous frame counts for the activity its update left.
    const planner::ExplorationActivity activity = manager.activity(frame.t_s);
    result.activity_time_s[std::size_t(prev_activity)] += frame.t_s - prev_t;
    if (activity == planner::ExplorationActivity::Holding) {
      if (hold_start_t < 0.0) hold_start_t = frame.t_s;
      result.longest_hold_s = std::max(result.longest_hold_s, frame.t_s - hold_start_t);
    } else {
      hold_start_t = -1.0;
    }
    prev_activity = activity;
    prev_t = frame.t_s;
    if (options.observable && frame.t_s >= next_coverage_t - 1e-9) {
      sampleCoverage(frame.t_s, mapper.volume(), step.clusters, activity);
      while (next_coverage_t <= frame.t_s + 1e-9) next_coverage_t += options.coverage_period_s;
    }

    result.frames_total = frame.index + 1;
    result.exploration_time_s = frame.t_s;
    frame_ms.push_back(frame_watch.ms());
    frame_watch.restart();
    result.cycles.push_back({frame.t_s, mapper_ms_this_frame, replanned ? step.map_update_ms + step.replan_ms : 0.0,
                             update_ms_this_frame, frame_ms.back(), mapper.queuedFrames(), activity, step.reason});
    if (options.progress) {
      progress.t_s = frame.t_s;
      progress.frames = result.frames_total;
      progress.clusters = step.clusters;
      progress.frontier_voxels = step.frontier_voxels;
      progress.replans = manager.counters().replans;
      progress.loop_closures = result.loop_closures;
      progress.collisions = vehicle.collisions();
      progress.path_length_m = vehicle.pathLength();
      progress.status = step.status;
      options.progress(progress);
    }
  };
  const auto truthAt = [&](double t) { return vehicle.truthAt(t); };
  while (!result.finished && sim.nextFrameTime() <= config.max_time_s + 1e-9)
    flyAlong(sim, truthAt, sim.nextFrameTime(), onFrame);

  mapper.reintegrateAll(sim.bodyEstimate().position_W);
  if (options.observable && !result.trajectory_true.empty()) {  // the map as finally corrected
    if (!result.coverage_timeline.empty() && result.coverage_timeline.back().t_s >= prev_t)
      result.coverage_timeline.pop_back();
    sampleCoverage(prev_t, mapper.volume(), manager.frontiers().clusters().size(), prev_activity);
  }
  result.path_length_m = vehicle.pathLength();
  result.collisions = vehicle.collisions();
  result.min_clearance_m = vehicle.minClearance();
  result.planner_ms_median = percentile(result.planner_ms, 0.5);
  result.planner_ms_max = result.planner_ms.empty() ? 0.0 : *std::max_element(result.planner_ms.begin(), result.planner_ms.end());
  result.map_update_ms_median = percentile(map_ms, 0.5);
  result.update_ms_median = percentile(update_ms, 0.5);
  result.update_ms_p99 = percentile(update_ms, 0.99);
  result.update_ms_max = percentile(update_ms, 1.0);
  result.frame_wall_ms_median = percentile(frame_ms, 0.5);
  result.frame_wall_ms_p99 = percentile(frame_ms, 0.99);
  result.frame_wall_ms_max = percentile(frame_ms, 1.0);
  result.integrate_ms_median = percentile(integrate_ms_all, 0.5);
  result.mapper_ms_median = percentile(mapper_ms, 0.5);
  result.mapper_ms_p99 = percentile(mapper_ms, 0.99);
  result.mapper_ms_max = percentile(mapper_ms, 1.0);
  result.background_frames = mapper.stats().background_frames;
  result.pruned_frames_deintegrated = mapper.stats().frames_dropped;
  result.planner_counters = manager.counters();
  result.alc = manager.alcStats();
  result.keyframes_kept = mapper.keyframesKept();
  result.reintegrated_frames = mapper.stats().reintegrated_frames;
  if (recorder) result.flight = recorder->finish(config.simulator, options.description, result.exploration_time_s, result.path_length_m);
  result.wall_s = wall.s();
  return result;
}

// ---- world defaults ----------------------------------------------------------------------------

Eigen::AlignedBox3d defaultExplorationBox(const World& world) { return world.bounds(); }

Vec3d defaultStartPosition(const World& world, const Eigen::AlignedBox3d& box, double start_height_m,
                           double start_clearance_m) {
  constexpr double kStep_m = 0.1;
  const double z = box.min().z() + start_height_m;
  const Eigen::Vector2d centre = box.center().head<2>();
  const int nx = int(std::floor(0.5 * box.sizes().x() / kStep_m)), ny = int(std::floor(0.5 * box.sizes().y() / kStep_m));
  Vec3d best = Vec3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double best_d2 = std::numeric_limits<double>::infinity();
  // Candidates in rings of growing distance: the first clear one in a ring closer than the best wins.
  for (int ix = -nx; ix <= nx; ++ix)
    for (int iy = -ny; iy <= ny; ++iy) {
      const double d2 = double(ix * ix + iy * iy) * kStep_m * kStep_m;
      if (d2 >= best_d2) continue;
      const Vec3d p(centre.x() + ix * kStep_m, centre.y() + iy * kStep_m, z);
      if (box.contains(p) && world.isClear(p, start_clearance_m)) {
        best = p;
        best_d2 = d2;
      }
    }
  if (!best.allFinite())
    throw std::invalid_argument("defaultStartPosition: no point at height " + std::to_string(start_height_m) +
                                " m keeps " + std::to_string(start_clearance_m) + " m from every surface");
  return best;
}

const char* toString(BudgetMode mode) {
  switch (mode) {
    case BudgetMode::WallClock: return "wall-clock";
    case BudgetMode::Counted: return "counted";
  }
  return "?";
}

BudgetMode parseBudgetMode(const std::string& text) {
  if (text == "wall-clock") return BudgetMode::WallClock;
  if (text == "counted") return BudgetMode::Counted;
  throw std::invalid_argument("budgets must be counted or wall-clock, got '" + text + "'");
}

void setBudgets(ExplorationConfig& config, BudgetMode mode) {
  planner::ExplorationManagerConfig& p = config.planner;
  const planner::PathConfig flight = planner::ExplorationManagerConfig::flightPathDefaults();
  const planner::PathConfig cost = planner::ExplorationManagerConfig::costPathDefaults();
  const planner::TourConfig tour;
  const bool counted = mode == BudgetMode::Counted;
  const double backstop = counted ? 20.0 : 1.0;
  p.path.time_limit_s = backstop * flight.time_limit_s;
  p.path.max_iterations = counted ? kCountedFlightPathIterations : 0;
  p.cost_path.time_limit_s = backstop * cost.time_limit_s;
  p.cost_path.max_iterations = counted ? kCountedCostPathIterations : 0;
  for (planner::TourConfig* t : {&p.tour, &p.alc.tour}) {
    t->time_limit_s = backstop * tour.time_limit_s;
    t->max_iterations = counted ? kCountedTourIterations : 0;
  }
  setReintegrationBudget(config.mapper.reintegration, mode);
}

void setReintegrationBudget(ReintegrationConfig& reintegration, BudgetMode mode) {
  const ReintegrationConfig defaults;
  const bool counted = mode == BudgetMode::Counted;
  reintegration.budget_ms = counted ? 1e6 : defaults.budget_ms;
  reintegration.budget_frames = counted ? kCountedReintegrationFrames : defaults.budget_frames;
}

planner::OdometryDrift odometryDriftOf(const DriftConfig& drift) {
  drift.validate();
  planner::OdometryDrift o;
  o.position_m_per_sqrt_s = std::sqrt(drift.sigma2_xyz_m2ps2 / drift.rate_hz);
  o.position_bias_m_per_s = drift.mu_xyz_mps;
  o.yaw_rad_per_sqrt_s = std::sqrt(drift.sigma2_yaw_rad2ps2 / drift.rate_hz);
  o.yaw_bias_rad_per_s = drift.mu_yaw_radps;
  return o;
}

void setDrift(ExplorationConfig& config, const DriftConfig& drift) {
  config.simulator.drift = drift;
  config.planner.safety.odometry = odometryDriftOf(drift);
}

void setSeed(ExplorationConfig& config, std::uint64_t seed) {
  config.simulator.drift.seed = seed;
  config.planner.path.seed = seed;
  config.planner.cost_path.seed = seed;
  config.planner.tour.seed = seed;
  config.planner.alc.tour.seed = seed;
}

ExplorationConfig explorationConfigFor(const World& world, const std::string& drift_level, std::uint64_t seed,
                                       double voxel_size_m) {
  ExplorationConfig config;
  setDrift(config, DriftConfig::preset(drift_level, seed));
  setSeed(config, seed);
  config.mapper.tsdf.voxel_size_m = voxel_size_m;
  config.planner.box_W = defaultExplorationBox(world);
  config.start.position_W = defaultStartPosition(world, config.planner.box_W);
  config.start.yaw_rad = 0.0;
  setBudgets(config, BudgetMode::Counted);
  return config;
}

// ---- the run folder ----------------------------------------------------------------------------

namespace {
nlohmann::json summaryJson(const ExplorationSummary& s, const ExplorationResult& r, const ExplorationConfig& c,
                           const ExplorationRunConfig& options, const WorldConfig& world) {
  nlohmann::json j;
  j["exploration_time_s"] = s.exploration_time_s;
  j["path_length_m"] = s.path_length_m;
  j["coverage"] = s.coverage;
  j["coverage_seen"] = s.coverage_seen;
  j["loop_closures"] = s.loop_closures;
  j["collisions"] = s.collisions;
  j["planner_ms_median"] = s.planner_ms_median;
  j["planner_ms_max"] = s.planner_ms_max;
  j["frames_total"] = s.frames_total;
  j["keyframes_kept"] = s.keyframes_kept;
  j["accuracy_rmse_m"] = s.accuracy_rmse_m;
  j["completeness"] = s.completeness;
  j["finished"] = s.finished;
  j["complete"] = s.complete;
  j["alc_enabled"] = s.alc_enabled;
  j["epsilon"] = s.epsilon;
  j["alc_detours"] = s.alc_detours;
  j["alc_time_s"] = s.alc_time_s;
  j["alc_give_ups"] = s.alc_give_ups;
  j["alc_finish_detours"] = s.alc_finish_detours;
  j["alc_detour_loops"] = s.alc_detour_loops;
  j["description"] = options.description;
  if (!options.world.empty()) j["world"] = options.world;
  if (std::isfinite(world.ceiling_clip_z_m))  // how the world was cut, to load it again the same way
    j["world_ceiling"] = {{"clip_z_m", world.ceiling_clip_z_m}, {"capped", world.cap_ceiling}};
  j["mode"] = toString(c.mapper.mode);
  j["loop_closure"] = toString(c.simulator.loop_closure);
  j["voxel_size_m"] = c.mapper.tsdf.voxel_size_m;
  j["max_time_s"] = c.max_time_s;
  j["budgets"] = {{"path_max_iterations", c.planner.path.max_iterations},
                  {"path_time_limit_s", c.planner.path.time_limit_s},
                  {"cost_path_max_iterations", c.planner.cost_path.max_iterations},
                  {"cost_path_time_limit_s", c.planner.cost_path.time_limit_s},
                  {"tour_max_iterations", c.planner.tour.max_iterations},
                  {"tour_max_stale_iterations", c.planner.tour.max_stale_iterations},
                  {"tour_max_planned_pairs", c.planner.tour.max_planned_pairs},
                  {"tour_time_limit_s", c.planner.tour.time_limit_s},
                  {"reintegration_budget_frames", c.mapper.reintegration.budget_frames},
                  {"reintegration_budget_ms", c.mapper.reintegration.budget_ms}};
  j["start"] = {c.start.position_W.x(), c.start.position_W.y(), c.start.position_W.z(), c.start.yaw_rad};
  j["box"] = {{"min", {c.planner.box_W.min().x(), c.planner.box_W.min().y(), c.planner.box_W.min().z()}},
              {"max", {c.planner.box_W.max().x(), c.planner.box_W.max().y(), c.planner.box_W.max().z()}}};
  j["min_clearance_m"] = r.min_clearance_m;
  j["vehicle_radius_m"] = c.vehicle_radius_m;
  j["replans"] = r.planner_counters.replans;
  j["replans_failed"] = r.planner_counters.replans_failed;
  j["collision_risk_replans"] = r.planner_counters.collision_risks;
  j["target_failures"] = r.planner_counters.target_failures;
  j["visit_failures"] = r.planner_counters.visit_failures;
  j["path_failures"] = r.planner_counters.path_failures;
  j["blacklisted_clusters"] = r.planner_counters.blacklisted;
  j["holds"] = r.planner_counters.holds;
  j["escapes"] = r.planner_counters.escapes;
  j["retreats"] = r.planner_counters.retreats;
  j["revisit_rounds"] = r.planner_counters.revisit_rounds;
  j["final_sweep_clusters"] = r.planner_counters.final_sweep_clusters;
  j["late_large_clusters"] = r.planner_counters.late_large_clusters;
  j["initial_turn"] = c.planner.initial_turn;
  j["view_score"] = planner::viewScoreName(c.planner.viewpoint.look_into_unknown);
  j["fallback_min_visible"] = c.planner.viewpoint.fallback.min_visible_samples;
  j["fallback_large_cluster_voxels"] = c.planner.viewpoint.fallback.large_cluster_voxels;
  j["fallback_large_min_visible"] = c.planner.viewpoint.fallback.large_min_visible_samples;
  j["fallback_large_min_visible_late"] = c.planner.late_large_min_visible_samples;
  j["vertical_frontier"] = planner::viewScoreName(c.planner.viewpoint.vertical_into_unknown);
  j["safety_layer"] = c.planner.safety.enabled;
  j["safety_seen_free"] = c.planner.safety.enabled && c.planner.safety.seen_free_is_free;
  j["safety_map_thin"] = !c.planner.safety.enabled || c.planner.safety.mapThinObstacles();
  j["safety_free_clears"] = c.planner.safety.enabled && c.planner.safety.recent.newer_free_clears;
  j["safety_path_drift"] =
      planner::toString(c.planner.safety.enabled ? c.planner.safety.path_drift : planner::PathDriftScope::Off);
  j["safety_near_drift_tolerance_m"] = c.planner.safety.enabled ? c.planner.safety.near_drift_tolerance_m : 0.0;
  // The vertical margin at the start and at the end (grown with the map's age under declared drift).
  j["safety_vertical_margin_m"] =
      c.planner.safety.enabled ? nlohmann::json(c.planner.safety.verticalMargin_m()) : nlohmann::json();
  j["safety_vertical_margin_end_m"] = c.planner.safety.enabled
                                          ? nlohmann::json(c.planner.safety.verticalMargin_m(s.exploration_time_s))
                                          : nlohmann::json();
  // How long the layer trusted its recent frames (widened from recent.window_s by the declared drift).
  j["safety_window_s"] = c.planner.safety.enabled ? nlohmann::json(c.planner.safety.window_s()) : nlohmann::json();
  j["emergency_stops"] = r.planner_counters.emergency_stops;
  j["look_stops"] = r.planner_counters.look_stops;
  j["map_update_ms_median"] = r.map_update_ms_median;
  j["update_ms_median"] = r.update_ms_median;
  j["update_ms_p99"] = r.update_ms_p99;
  j["update_ms_max"] = r.update_ms_max;
  j["frame_wall_ms_median"] = r.frame_wall_ms_median;
  j["frame_wall_ms_p99"] = r.frame_wall_ms_p99;
  j["frame_wall_ms_max"] = r.frame_wall_ms_max;
  j["ms_per_frame_median"] = r.integrate_ms_median;
  j["cycle_ms_median"] = r.mapper_ms_median;
  j["ms_per_frame_p99"] = r.mapper_ms_p99;
  j["ms_per_frame_max"] = r.mapper_ms_max;
  j["background_frames"] = r.background_frames;
  j["pruned_frames_deintegrated"] = r.pruned_frames_deintegrated;
  j["reintegrated_frames"] = r.reintegrated_frames;
  j["estimate_error_rmse_m"] = s.estimate_error_rmse_m;
  j["keyframe_error_rmse_m"] = internal::knownOrNull(s.keyframe_error_rmse_m);
  j["keyframe_error_aligned_rmse_m"] = internal::knownOrNull(s.keyframe_error_aligned_rmse_m);
  j["accuracy_aligned_rmse_m"] = internal::knownOrNull(s.accuracy_aligned_rmse_m);
  j["map_alignment"] = {
      {"yaw_deg", s.map_alignment.yaw_rad * 180.0 / M_PI},
      {"translation_m",
       {s.map_alignment.position_W.x(), s.map_alignment.position_W.y(), s.map_alignment.position_W.z()}}};
  if (r.flight.frames > 0) {  // the log's statistics (with a log only)
    j["estimate_error_max_m"] = r.flight.estimate_error_max_m;
    j["odometry_error_final_m"] = r.flight.odometry_error_final_m;
  }
  j["observable_surface"] = {{"samples_in_box", s.observable.samples_in_box},
                             {"observable_samples", s.observable.observable},
                             {"observable_area_m2", s.observable.observable_area_m2},
                             {"reachable_cells", s.observable.reachable_cells}};
  nlohmann::json to_coverage = nlohmann::json::object();
  for (std::size_t i = 0; i < kCoverageMilestones.size(); ++i)
    to_coverage[format("%.2f", kCoverageMilestones[i])] =
        s.time_to_coverage_s[i] >= 0.0 ? nlohmann::json(s.time_to_coverage_s[i]) : nlohmann::json(nullptr);
  j["time_to_coverage_s"] = to_coverage;
  j["mean_speed_mps"] = s.mean_speed_mps;
  nlohmann::json activity = nlohmann::json::object();
  for (int a = 0; a < planner::kExplorationActivities; ++a)
    activity[toString(planner::ExplorationActivity(a))] = r.activity_time_s[std::size_t(a)];
  j["activity_time_s"] = activity;
  j["longest_hold_s"] = r.longest_hold_s;
  j["wall_s"] = s.wall_s;
  nlohmann::json events = nlohmann::json::array();
  for (const ExplorationEvent& e : r.events) {
    nlohmann::json event = {{"t_s", e.t_s}, {"what", e.what}};
    if (e.visit) {
      event["cluster"] = e.visit->cluster;
      event["view_W"] = {e.visit->view_W.x(), e.visit->view_W.y(), e.visit->view_W.z()};
      event["judged_voxels"] = e.visit->judged_voxels;
      event["gone_fraction"] = e.visit->gone_fraction;
    }
    if (e.path) {
      event["cluster"] = e.path->cluster;
      event["from_W"] = {e.path->from_W.x(), e.path->from_W.y(), e.path->from_W.z()};
      event["view_W"] = {e.path->view_W.x(), e.path->view_W.y(), e.path->view_W.z()};
      event["why"] = toString(e.path->why);
    }
    events.push_back(std::move(event));
  }
  j["events"] = events;
  return j;
}

void writeCoverageCsv(const std::filesystem::path& path, const std::vector<CoverageSample>& timeline) {
  vdbmap::writeFileAtomically(path, [&](std::ostream& os) {
    os << "t_s,coverage,coverage_seen,path_length_m,clusters,loop_closures,estimate_error_m,activity\n";
    for (const CoverageSample& c : timeline)
      os << format("%.4f", c.t_s) << ',' << format("%.6f", c.coverage) << ',' << format("%.6f", c.coverage_seen) << ','
         << format("%.3f", c.path_length_m) << ',' << c.clusters << ',' << c.loop_closures << ','
         << format("%.4f", c.estimate_error_m) << ',' << toString(c.activity) << '\n';
  });
}

void writeCyclesCsv(const std::filesystem::path& path, const std::vector<CycleSample>& cycles) {
  vdbmap::writeFileAtomically(path, [&](std::ostream& os) {
    os << "t_s,mapper_ms,planner_ms,update_ms,frame_wall_ms,queued_frames,activity,replan\n";
    for (const CycleSample& c : cycles)
      os << format("%.4f", c.t_s) << ',' << format("%.3f", c.mapper_ms) << ',' << format("%.3f", c.planner_ms) << ','
         << format("%.3f", c.update_ms) << ',' << format("%.3f", c.frame_wall_ms) << ',' << c.queued_frames << ','
         << toString(c.activity) << ',' << toString(c.replan) << '\n';
  });
}
}  // namespace

ExplorationSummary exploreToFolder(const World& world, const ExplorationConfig& config,
                                   const std::filesystem::path& run_dir, const ExplorationRunConfig& options) {
  config.validate();
  if (!(options.completeness_threshold_vox > 0.0 && options.completeness_threshold_vox <= 100.0))
    throw std::invalid_argument("ExplorationRunConfig.completeness_threshold_vox must be in (0, 100]");
  const Stopwatch wall;
  const auto report = [&](const std::string& line) {
    if (options.report) options.report(line);
  };
  if (std::filesystem::exists(run_dir / "summary.json") && !options.overwrite)
    throw std::runtime_error(run_dir.string() + " already holds an exploration run (summary.json); overwrite it explicitly");
  std::filesystem::create_directories(run_dir);

  // The observable surface first: it fails early on a start the coverage cannot use.
  SurfaceCoverageConfig cc = options.coverage;
  const planner::CameraFrustum& camera = config.planner.viewpoint.camera;
  cc.max_view_distance_m = camera.max_range_m;
  cc.half_fov_vertical_rad = std::atan(camera.tan_half_fov_y);
  const ObservableSurface observable(world, config.planner.box_W, config.start.position_W, cc);
  report("observable surface: " + std::to_string(observable.stats().observable) + " of " +
         std::to_string(observable.stats().samples_in_box) + " samples in the box (" +
         std::to_string(int(observable.stats().observable_area_m2)) + " m^2)");

  ExplorationRecordConfig eo;
  if (options.write_log) eo.log_dir = run_dir / "log";
  eo.overwrite = options.overwrite;
  eo.description = options.description;
  eo.progress = options.progress;
  eo.observable = &observable;
  ExplorationResult r = runExploration(world, config, eo);
  const TsdfVolume& volume = r.mapper->volume();

  ExplorationSummary s;
  s.exploration_time_s = r.exploration_time_s;
  s.path_length_m = r.path_length_m;
  s.coverage = observable.coverage(planner::TsdfMapQuery(volume));
  s.coverage_seen = observable.coverage(*r.seen);
  s.loop_closures = r.loop_closures;
  s.collisions = r.collisions;
  s.planner_ms_median = r.planner_ms_median;
  s.planner_ms_max = r.planner_ms_max;
  s.frames_total = r.frames_total;
  s.keyframes_kept = r.keyframes_kept;
  s.finished = r.finished;
  s.complete = s.finished && s.coverage >= kCompleteCoverage;
  s.alc_enabled = config.planner.alc_enabled;
  s.epsilon = config.planner.alc_enabled ? config.planner.alc.epsilon : 0.0;
  s.alc_detours = r.alc.detours;
  s.alc_time_s = r.alc.detour_time_s;
  s.alc_give_ups = r.alc.give_ups;
  s.alc_finish_detours = r.alc.finish_detours;
  s.alc_detour_loops = r.alc.loops_on_detour;
  s.estimate_error_rmse_m = estimateErrorRmse(r.trajectory_true, r.trajectory_estimate);
  const KeyframePositions keyframe_positions = keyframePositions(r.mapper->keyframes(), r.trajectory_true);
  if (!keyframe_positions.map_W.empty())
    s.keyframe_error_rmse_m = alignedRmse(FlatPose{}, keyframe_positions.map_W, keyframe_positions.true_W);
  if (keyframe_positions.map_W.size() >= 2) {
    s.map_alignment = alignYawTranslation(keyframe_positions.map_W, keyframe_positions.true_W);
    s.keyframe_error_aligned_rmse_m = alignedRmse(s.map_alignment, keyframe_positions.map_W, keyframe_positions.true_W);
  }
  s.observable = observable.stats();
  s.time_to_coverage_s.fill(-1.0);
  for (std::size_t i = 0; i < kCoverageMilestones.size(); ++i)
    for (const CoverageSample& c : r.coverage_timeline)
      if (c.coverage >= kCoverageMilestones[i]) {
        s.time_to_coverage_s[i] = c.t_s;
        break;
      }
  s.mean_speed_mps = s.exploration_time_s > 0.0 ? s.path_length_m / s.exploration_time_s : 0.0;
  s.activity_time_s = r.activity_time_s;
  s.longest_hold_s = r.longest_hold_s;
  s.emergency_stops = r.planner_counters.emergency_stops;
  s.look_stops = r.planner_counters.look_stops;

  const TriangleMesh mesh = extractMesh(volume);
  if (options.write_map) {
    volume.save(run_dir / "map.vdb");
    io::writePlyMesh(run_dir / "mesh.ply", mesh);
  }
  if (!mesh.vertices.empty()) {
    EvalConfig eval;
    eval.completeness_threshold_m = options.completeness_threshold_vox * config.mapper.tsdf.voxel_size_m;
    eval.sample_spacing_m = 0.5 * config.mapper.tsdf.voxel_size_m;
    const SurfaceEval e = evaluateSurface(mesh, world.mesh(), eval);
    s.accuracy_rmse_m = e.accuracy_rmse_m;
    s.completeness = e.completeness;
    if (s.keyframe_error_aligned_rmse_m >= 0.0) {
      TriangleMesh aligned = mesh;
      for (Vec3f& v : aligned.vertices) v = applyAlignment(s.map_alignment, v.cast<double>()).cast<float>();
      s.accuracy_aligned_rmse_m = evaluateSurface(aligned, world.mesh(), eval).accuracy_rmse_m;
    }
  }
  io::writeTumTrajectory(run_dir / "trajectory_true.txt", r.trajectory_true);
  io::writeTumTrajectory(run_dir / "trajectory_odom.txt", r.trajectory_estimate);
  std::vector<io::StampedPose> keyframes;  // where the final map holds them, every correction applied
  for (const auto& [id, keyframe] : r.mapper->keyframes())
    if (keyframe.integrated) keyframes.push_back({keyframe.timestamp, keyframe.T_W_S_integrated});
  io::writeTumTrajectory(run_dir / "trajectory_keyframes.txt", keyframes);
  writeCoverageCsv(run_dir / "coverage.csv", r.coverage_timeline);
  writeCyclesCsv(run_dir / "cycles.csv", r.cycles);
  s.wall_s = wall.s();
  const nlohmann::json j = summaryJson(s, r, config, options, world.config());
  vdbmap::writeFileAtomically(run_dir / "summary.json", [&](std::ostream& os) { os << j.dump(2) << "\n"; });
  report("wrote " + run_dir.string());
  return s;
}

namespace {
/// summary.json's value at `key`, as T; names the file and the key when it is missing or of another type.
template <class T>
T summaryValue(const nlohmann::json& j, const char* key, const std::filesystem::path& file) {
  const auto it = j.find(key);
  if (it == j.end()) throw std::runtime_error(file.string() + ": no \"" + std::string(key) + "\"");
  try {
    return it->get<T>();
  } catch (const nlohmann::json::exception&) {
    throw std::runtime_error(file.string() + ": \"" + std::string(key) + "\" is " + it->dump() +
                             ", not the type it should be");
  }
}
}  // namespace

nlohmann::json internal::readSummaryJson(const std::filesystem::path& summary_json) {
  std::ifstream in(summary_json);
  if (!in) throw std::runtime_error("cannot open " + summary_json.string());
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(summary_json.string() + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw std::runtime_error(summary_json.string() + ": not a JSON object");
  return j;
}

ExplorationSummary readExplorationSummary(const std::filesystem::path& summary_json) {
  return internal::explorationSummaryOf(internal::readSummaryJson(summary_json), summary_json);
}

ExplorationSummary internal::explorationSummaryOf(const nlohmann::json& j, const std::filesystem::path& f) {
  ExplorationSummary s;
  s.exploration_time_s = summaryValue<double>(j, "exploration_time_s", f);
  s.path_length_m = summaryValue<double>(j, "path_length_m", f);
  s.coverage = summaryValue<double>(j, "coverage", f);
  s.coverage_seen = summaryValue<double>(j, "coverage_seen", f);
  s.loop_closures = summaryValue<std::size_t>(j, "loop_closures", f);
  s.collisions = summaryValue<std::size_t>(j, "collisions", f);
  s.alc_enabled = summaryValue<bool>(j, "alc_enabled", f);
  s.epsilon = summaryValue<double>(j, "epsilon", f);
  s.alc_detours = summaryValue<std::size_t>(j, "alc_detours", f);
  s.alc_time_s = summaryValue<double>(j, "alc_time_s", f);
  s.alc_give_ups = summaryValue<std::size_t>(j, "alc_give_ups", f);
  s.alc_detour_loops = summaryValue<std::size_t>(j, "alc_detour_loops", f);
  s.alc_finish_detours = summaryValue<std::size_t>(j, "alc_finish_detours", f);
  s.estimate_error_rmse_m = summaryValue<double>(j, "estimate_error_rmse_m", f);
  // Older summaries lack these errors (the alignment's, before stop 89); null: not known.
  const auto optional_length = [&](const char* key) {
    const auto it = j.find(key);
    return it != j.end() && !it->is_null() ? summaryValue<double>(j, key, f) : -1.0;
  };
  s.keyframe_error_rmse_m = optional_length("keyframe_error_rmse_m");
  s.keyframe_error_aligned_rmse_m = optional_length("keyframe_error_aligned_rmse_m");
  s.accuracy_aligned_rmse_m = optional_length("accuracy_aligned_rmse_m");
  if (const auto alignment = j.find("map_alignment"); alignment != j.end()) {
    const auto t = summaryValue<std::vector<double>>(*alignment, "translation_m", f);
    if (t.size() != 3)
      throw std::runtime_error(f.string() + ": \"map_alignment\".\"translation_m\" has " + std::to_string(t.size()) +
                               " values, not 3");
    s.map_alignment.yaw_rad = summaryValue<double>(*alignment, "yaw_deg", f) * M_PI / 180.0;
    s.map_alignment.position_W = Vec3d(t[0], t[1], t[2]);
  }
  s.planner_ms_median = summaryValue<double>(j, "planner_ms_median", f);
  s.planner_ms_max = summaryValue<double>(j, "planner_ms_max", f);
  s.frames_total = summaryValue<std::size_t>(j, "frames_total", f);
  s.keyframes_kept = summaryValue<std::size_t>(j, "keyframes_kept", f);
  s.accuracy_rmse_m = summaryValue<double>(j, "accuracy_rmse_m", f);
  s.completeness = summaryValue<double>(j, "completeness", f);
  s.finished = summaryValue<bool>(j, "finished", f);
  s.complete = summaryValue<bool>(j, "complete", f);
  const auto observable = summaryValue<nlohmann::json>(j, "observable_surface", f);
  s.observable.samples_in_box = summaryValue<std::size_t>(observable, "samples_in_box", f);
  s.observable.observable = summaryValue<std::size_t>(observable, "observable_samples", f);
  s.observable.observable_area_m2 = summaryValue<double>(observable, "observable_area_m2", f);
  s.observable.reachable_cells = summaryValue<std::size_t>(observable, "reachable_cells", f);
  const auto to_coverage = summaryValue<nlohmann::json>(j, "time_to_coverage_s", f);
  for (std::size_t i = 0; i < kCoverageMilestones.size(); ++i) {
    const std::string key = format("%.2f", kCoverageMilestones[i]);
    const auto t = summaryValue<nlohmann::json>(to_coverage, key.c_str(), f);
    s.time_to_coverage_s[i] = t.is_null() ? -1.0 : summaryValue<double>(to_coverage, key.c_str(), f);
  }
  s.mean_speed_mps = summaryValue<double>(j, "mean_speed_mps", f);
  const auto activity = summaryValue<nlohmann::json>(j, "activity_time_s", f);
  for (int a = 0; a < planner::kExplorationActivities; ++a)
    s.activity_time_s[std::size_t(a)] = summaryValue<double>(activity, toString(planner::ExplorationActivity(a)), f);
  s.longest_hold_s = summaryValue<double>(j, "longest_hold_s", f);
  s.emergency_stops = summaryValue<std::size_t>(j, "emergency_stops", f);
  s.look_stops = summaryValue<std::size_t>(j, "look_stops", f);
  s.wall_s = summaryValue<double>(j, "wall_s", f);
  return s;
}

}  // namespace vdbmap::sim
