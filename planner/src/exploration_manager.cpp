#include "vdbmap/planner/exploration_manager.hpp"
#include "vdbmap/field_check.hpp"
#include "vdbmap/timing.hpp"

#include "vdbmap/planner/assume_free_map.hpp"
#include "vdbmap/planner/cached_map.hpp"
#include "vdbmap/planner/recent_obstacle_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace vdbmap::planner {

namespace {
double yawOf(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

/// A declared odometry that does not drift at all (every term 0: s1).
bool declaresNoDrift(const std::optional<OdometryDrift>& odometry) {
  return odometry && odometry->displacement_m(1.0, 1.0) == 0.0;
}

/// The replan was triggered by the trajectory being blocked: if no new one is found, the vehicle stops.
bool blocked(ReplanReason r) { return r == ReplanReason::CollisionRisk || r == ReplanReason::EmergencyStop; }

/// The parameters with the pieces' bounds and the trajectory's clearance set from the manager's.
ExplorationManagerConfig derivedParams(ExplorationManagerConfig p) {
  p.validate();
  p.frontier.bounds_W = p.box_W;
  const double clearance = p.viewpoint.min_clearance_m;
  const Vec3d margin(clearance, clearance, std::max(clearance, p.viewpoint_margin_z_m));
  Eigen::AlignedBox3d view_box(p.box_W.min() + margin, p.box_W.max() - margin);
  p.viewpoint.bounds_W = view_box.isEmpty() ? p.box_W : view_box;
  p.viewpoint.frontier_bounds_W = p.box_W;
  p.path.bounds_W = p.box_W;
  p.cost_path.bounds_W = p.box_W;
  p.trajectory.clearance_m = p.path.clearance_m;
  if (p.safety.enabled && p.safety.face_travel) p.trajectory.yaw_along_travel = true;
  p.trajectory.check_step_m = p.path.check_step_m;
  p.escape.bounds_W = p.box_W;
  p.escape.clearance_m = p.path.clearance_m;
  p.escape.trajectory = p.trajectory;
  // An escape leaves a blocked start at once: facing the way would first turn on the spot (half a
  // turn for a retreat), seconds beside what blocked it while drift carries the vehicle on.
  p.escape.trajectory.yaw_along_travel = false;
  p.safety.recent.max_range_m = p.viewpoint.camera.max_range_m;
  p.safety.recent.free_margin_m = p.safety.clearance_m;
  p.safety.recent.dense_s = p.safety.recent.window_s;
  p.safety.recent.window_s = p.safety.window_s();
  if (p.alc_enabled) p.alc.unreachable_cost_s = p.cost.unreachable_cost_s;  // ALC's sums skip the legs M_frt marks so
  return p;
}

}  // namespace

const char* toString(ExplorationStatus s) {
  switch (s) {
    case ExplorationStatus::Continue: return "continue";
    case ExplorationStatus::Planned: return "planned";
    case ExplorationStatus::NoFrontier: return "no_frontier";
    case ExplorationStatus::Failed: return "failed";
    case ExplorationStatus::Finished: return "finished";
  }
  return "?";
}

const char* toString(PathDriftScope scope) {
  switch (scope) {
    case PathDriftScope::Off: return "off";
    case PathDriftScope::NearSurfaces: return "near";
    case PathDriftScope::Everywhere: return "on";
  }
  return "?";
}

const char* toString(ExplorationPhase p) {
  switch (p) {
    case ExplorationPhase::InitialTurn: return "initial_turn";
    case ExplorationPhase::Exploring: return "exploring";
    case ExplorationPhase::FinalSweep: return "final_sweep";
  }
  return "?";
}

const char* toString(FinalSweepScope s) {
  switch (s) {
    case FinalSweepScope::All: return "all";
    case FinalSweepScope::Pockets: return "pockets";
    case FinalSweepScope::PocketsOnce: return "once";
  }
  return "?";
}

const char* toString(FlightKind k) {
  switch (k) {
    case FlightKind::Hold: return "hold";
    case FlightKind::Turn: return "turn";
    case FlightKind::ToTarget: return "to_target";
    case FlightKind::LoopDetour: return "loop_detour";
    case FlightKind::Escape: return "escape";
    case FlightKind::Retreat: return "retreat";
    case FlightKind::Look: return "look";
  }
  return "?";
}

const char* toString(ExplorationActivity a) {
  switch (a) {
    case ExplorationActivity::InitialTurn: return "initial_turn";
    case ExplorationActivity::ToTarget: return "to_target";
    case ExplorationActivity::FinalSweep: return "final_sweep";
    case ExplorationActivity::LoopDetour: return "loop_detour";
    case ExplorationActivity::Escaping: return "escaping";
    case ExplorationActivity::Retreating: return "retreating";
    case ExplorationActivity::Turning: return "turning";
    case ExplorationActivity::Holding: return "holding";
    case ExplorationActivity::Looking: return "looking";
  }
  return "?";
}

const char* toString(PathFailure f) {
  switch (f) {
    case PathFailure::GoalBlocked: return "goal_blocked";
    case PathFailure::NoPath: return "no_path";
    case PathFailure::NoTrajectory: return "no_trajectory";
  }
  return "?";
}

const char* toString(ReplanReason r) {
  switch (r) {
    case ReplanReason::None: return "none";
    case ReplanReason::InitialTurn: return "initial_turn";
    case ReplanReason::Start: return "start";
    case ReplanReason::TrajectoryEnd: return "trajectory_end";
    case ReplanReason::TargetCovered: return "target_covered";
    case ReplanReason::Periodic: return "periodic";
    case ReplanReason::CollisionRisk: return "collision_risk";
    case ReplanReason::FrameShift: return "frame_shift";
    case ReplanReason::Retry: return "retry";
    case ReplanReason::LoopDetourTimeout: return "loop_detour_timeout";
    case ReplanReason::EmergencyStop: return "emergency_stop";
    case ReplanReason::LookAhead: return "look_ahead";
    case ReplanReason::WaySeen: return "way_seen";
  }
  return "?";
}

PathConfig ExplorationManagerConfig::flightPathDefaults() {
  PathConfig p;
  p.time_limit_s = 0.1;
  p.search = PathSearch::SamplingThenGrid;
  return p;
}

TourConfig ExplorationManagerConfig::tourDefaults() {
  // A burst of new clusters (a frontier component split anew) brought up to 585 new pairs at
  // once in the warehouse, 100-180 ms; 32 pairs take 5-35 ms there (docs/exploration.md, stops 44
  // and 45).
  TourConfig t;
  t.max_planned_pairs = 32;
  return t;
}

PathConfig ExplorationManagerConfig::costPathDefaults() {
  PathConfig p;
  p.time_limit_s = 0.01;
  return p;
}

void SafetyConfig::validate() const {
  const FieldCheck check("SafetyConfig");
  recent.validate();
  check.inRange("look_margin_m", look_margin_m, 0.0, 10.0);
  check.inRange("look_side_m", look_side_m, 0.0, 5.0);
  check.inRange("clearance_m", clearance_m, 0.0, 5.0);
  if (max_chained_looks < 1 || max_chained_looks > 100) check.fail("max_chained_looks", "[1, 100]", max_chained_looks);
  if (odometry) odometry->validate();
  if (!(max_window_s > 0.0 && max_window_s <= 600.0)) check.fail("max_window_s", "(0, 600]", max_window_s);
  check.inRange("drift_tolerance_m", drift_tolerance_m, 0.0, 10.0);
  check.inRange("drift_lever_m", drift_lever_m, 0.0, 100.0);
  if (near_drift_tolerance_m != 0.0 && !(near_drift_tolerance_m > 0.0 && near_drift_tolerance_m < drift_tolerance_m))
    check.fail("near_drift_tolerance_m", "0 (off) or (0, drift_tolerance_m)", near_drift_tolerance_m);
  check.inRange("vertical_margin_m", vertical_margin_m, 0.0, 2.0);
  check.inRange("vertical_margin_sigmas", vertical_margin_sigmas, 0.0, 10.0);
  check.inRange("max_vertical_margin_m", max_vertical_margin_m, 0.0, 2.0);
}

double SafetyConfig::verticalMargin_m(double map_age_s) const {
  validate();
  if (!(map_age_s >= 0.0 && std::isfinite(map_age_s)))
    throw std::invalid_argument("SafetyConfig::verticalMargin_m: map_age_s must be finite and >= 0");
  if (!odometry) return vertical_margin_m;
  if (declaresNoDrift(odometry)) return 0.0;
  const double grown = vertical_margin_sigmas * odometry->axisDisplacement_m(map_age_s);
  return std::clamp(grown, vertical_margin_m, std::max(vertical_margin_m, max_vertical_margin_m));
}

bool SafetyConfig::mapThinObstacles() const {
  validate();
  return map_thin_obstacles || (map_thin_without_drift && declaresNoDrift(odometry));
}

double SafetyConfig::trustedAge_s() const {
  validate();
  return odometry ? odometry->longestWithin(drift_tolerance_m, drift_lever_m, 0.0, 1e9) : 0.0;
}

double SafetyConfig::window_s() const {
  return std::clamp(trustedAge_s(), recent.window_s, std::max(recent.window_s, max_window_s));
}

double SafetyConfig::seenAge_s() const {
  const double window = window_s();
  return odometry ? std::min(window, std::max(kMinSeenAge_s, trustedAge_s())) : window;
}

double SafetyConfig::nearSeenAge_s() const {
  const double seen = seenAge_s();
  if (!odometry || near_drift_tolerance_m <= 0.0) return seen;
  return std::clamp(odometry->longestWithin(near_drift_tolerance_m, drift_lever_m, 0.0, 1e9),
                    std::min(kMinSeenAge_s, seen), seen);
}

void ExplorationManagerConfig::validate() const {
  const FieldCheck check("ExplorationManagerConfig");
  if (box_W.isEmpty() || !box_W.min().allFinite() || !box_W.max().allFinite())
    throw std::invalid_argument("ExplorationManagerConfig.box_W must be a finite, non-empty box");
  frontier.validate();
  viewpoint.validate();
  cost.validate();
  path.validate();
  cost_path.validate();
  tour.validate();
  refinement.validate();
  trajectory.validate();
  escape.validate();
  safety.validate();
  for (int a = 0; a < 3; ++a)
    if (!(start_free_half_size_m[a] >= 0.0 && start_free_half_size_m[a] <= 10.0))
      check.fail("start_free_half_size_m", "[0, 10] per axis");
  if (!(viewpoint_margin_z_m >= 0.0 && viewpoint_margin_z_m <= 10.0)) check.fail("viewpoint_margin_z_m", "[0, 10]");
  if (!(replan_time_left_s >= 0.0 && replan_time_left_s <= 100.0)) check.fail("replan_time_left_s", "[0, 100]");
  if (!(replan_covered_after_s >= 0.0 && replan_covered_after_s <= 100.0))
    check.fail("replan_covered_after_s", "[0, 100]");
  if (!(replan_period_s > 0.0 && replan_period_s <= 1000.0)) check.fail("replan_period_s", "(0, 1000]");
  if (!(covered_fraction > 0.0 && covered_fraction <= 1.0)) check.fail("covered_fraction", "(0, 1]");
  if (!(collision_radius_m >= 0.0 && collision_radius_m <= path.clearance_m))
    check.fail("collision_radius_m", "[0, path.clearance_m]");
  if (max_failures < 1 || max_failures > 100) check.fail("max_failures", "[1, 100]");
  check.inRange("all_failed_spacing_s", all_failed_spacing_s, 0.0, 60.0);
  if (revisit_rounds < 0 || revisit_rounds > 100) check.fail("revisit_rounds", "[0, 100]");
  if (late_large_min_visible_samples < 0 || late_large_min_visible_samples > 1000000)
    check.fail("late_large_min_visible_samples", "[0, 1e6]");
  if (final_min_cluster_size < 0 || final_min_cluster_size > 100000000)
    check.fail("final_min_cluster_size", "[0, 1e8]");
  if (max_targets_per_replan < 1 || max_targets_per_replan > 100) check.fail("max_targets_per_replan", "[1, 100]");
  if (initial_turn_parts < 3 || initial_turn_parts > 36) check.fail("initial_turn_parts", "[3, 36]");
  if (!(risk_check_spacing_vox > 0.0 && risk_check_spacing_vox <= 10.0))
    check.fail("risk_check_spacing_vox", "(0, 10]");
  if (max_chained_escapes < 0 || max_chained_escapes > 100) check.fail("max_chained_escapes", "[0, 100]");
  if (max_chained_backtracks < 0 || max_chained_backtracks > 100) check.fail("max_chained_backtracks", "[0, 100]");
  if (alc_enabled) alc.validate();
}

ExplorationManager::ExplorationManager(const ExplorationManagerConfig& params, const VehicleState& start, double t_s)
    : params_(derivedParams(params)), book_(params_.max_failures), escapes_(params_.escape) {
  if (!params_.box_W.contains(start.position_W))
    throw std::invalid_argument("ExplorationManager: the start position lies outside the exploration box");
  free_boxes_.push_back(boxAround(start.position_W, params_.start_free_half_size_m));
  frontiers_ = FrontierMap(params_.frontier);
  voxel_rule_ = params_.viewpoint;
  voxel_rule_.look_into_unknown = false;
  voxel_rule_.vertical_into_unknown = false;
  late_rule_ = params_.viewpoint;
  late_rule_.fallback.large_min_visible_samples =
      std::min(late_rule_.fallback.large_min_visible_samples, params_.late_large_min_visible_samples);
  late_rule_.vertical_into_unknown = false;
  table_ = std::make_unique<PairCostTable>(params_.cost, params_.cost_path);
  turns_left_ = params_.initial_turn ? params_.initial_turn_parts : 0;
  phase_ = params_.initial_turn ? ExplorationPhase::InitialTurn : ExplorationPhase::Exploring;
  trajectory_ = Trajectory::hold(start.position_W, start.yaw_rad);
  trajectory_t0_ = t_s;
  last_t_ = t_s;
  if (params_.alc_enabled) alc_ = std::make_unique<ActiveLoopClosure>(params_.alc, t_s);
  if (params_.safety.enabled) recent_ = std::make_unique<RecentFrames>(params_.safety.recent);
  start_t_ = t_s;
  map_trusted_until_s_ = t_s + params_.safety.trustedAge_s();
  map_thin_ = params_.safety.mapThinObstacles();
}

ExplorationManager::~ExplorationManager() = default;

// ---- the commanded trajectory ------------------------------------------------------------------

VehicleState ExplorationManager::command(double t_s) const {
  VehicleState s = trajectory_.sample(t_s - trajectory_t0_);
  s.position_W = shift_ * s.position_W;
  s.velocity_W = shift_.linear() * s.velocity_W;
  s.acceleration_W = shift_.linear() * s.acceleration_W;
  s.yaw_rad = wrapAngle(s.yaw_rad + yawOf(shift_));
  return s;
}

void ExplorationManager::shiftFrame(const Eigen::Isometry3d& shift) {
  shift_ = shift * shift_;
  if (last_flown_W_) last_flown_W_ = shift * *last_flown_W_;  // a correction is not a path flown
  escapes_.shiftFrame(shift);
  if (recent_) recent_->shift(shift);
  pending_.frame_shift = true;
}

void ExplorationManager::addDepthFrame(double t_s, const DepthImage& depth, const CameraIntrinsics& K,
                                       const Pose3d& T_W_S) {
  if (recent_) recent_->add(t_s, depth, K, T_W_S);
}

double ExplorationManager::verticalMarginAt_m(double t_s) const {
  if (!recent_) return 0.0;
  if (!(t_s >= start_t_))
    throw std::invalid_argument("ExplorationManager::verticalMarginAt_m: t_s is before the manager's start");
  return params_.safety.verticalMargin_m(t_s - start_t_);
}

void ExplorationManager::notifyLoopClosure(double t_s,
                                           const std::function<FlatPose(const FlownViewpoint&)>& corrected) {
  if (!std::isfinite(t_s)) throw std::invalid_argument("ExplorationManager::notifyLoopClosure: t_s must be finite");
  if (corrected) escapes_.correctHistory(corrected);
  if (!alc_) return;
  pending_.loop_closed = true;
  if (corrected) alc_->correctHistory(corrected);
}

void ExplorationManager::startTrajectory(Trajectory trajectory, double t_s, FlightKind kind) {
  trajectory_ = std::move(trajectory);
  trajectory_t0_ = t_s;
  shift_ = Eigen::Isometry3d::Identity();
  flight_ = kind;
  if (kind != FlightKind::Look) interrupted_.reset();
}

bool ExplorationManager::escaping(double t_s) const {
  return (flight_ == FlightKind::Escape || flight_ == FlightKind::Retreat) &&
         t_s <= trajectory_t0_ + trajectory_.duration();
}

ExplorationActivity ExplorationManager::activity(double t_s) const {
  if (phase_ == ExplorationPhase::InitialTurn) return ExplorationActivity::InitialTurn;
  if (escaping(t_s))
    return flight_ == FlightKind::Retreat ? ExplorationActivity::Retreating : ExplorationActivity::Escaping;
  const double t_rel = t_s - trajectory_t0_;
  if (t_rel >= trajectory_.duration()) return ExplorationActivity::Holding;
  if (flight_ == FlightKind::Look) return ExplorationActivity::Looking;
  if (t_rel >= trajectory_.motionDuration() || t_rel < trajectory_.motionStart()) return ExplorationActivity::Turning;
  if (flight_ == FlightKind::LoopDetour) return ExplorationActivity::LoopDetour;
  return phase_ == ExplorationPhase::FinalSweep ? ExplorationActivity::FinalSweep : ExplorationActivity::ToTarget;
}

void ExplorationManager::hold(const VehicleState& vehicle, double t_s) {
  if (trajectoryMoves() || !trajectoryDone(t_s)) ++counters_.holds;
  startTrajectory(Trajectory::hold(vehicle.position_W, vehicle.yaw_rad), t_s, FlightKind::Hold);
  book_.clearTarget();
}

// ---- frontiers, viewpoints, failures -----------------------------------------------------------

void ExplorationManager::refreshFrontiers(const MapQuery& map, const openvdb::CoordBBox& dirty) {
  const FrontierUpdate u = first_update_ ? frontiers_.rebuild(map) : frontiers_.update(map, dirty);
  first_update_ = false;
  applyFrontierUpdate(u, map);
}

void ExplorationManager::applyFrontierUpdate(const FrontierUpdate& u, const MapQuery& map) {
  for (ClusterId id : u.removed) views_.erase(id);
  std::vector<const FrontierCluster*> fresh;
  for (ClusterId id : u.added) {
    const FrontierCluster* c = frontiers_.find(id);
    if (!c) continue;
    const std::vector<std::size_t> pockets = openPockets(*c);
    if (pockets.empty() && smallInSweep(*c)) continue;  // no viewpoints: never a target
    if (!pockets.empty())                               // what remains of a pocket is part of it
      for (const openvdb::Coord& v : c->voxels) pocket_of_.emplace(v, pockets.front());
    fresh.push_back(c);
  }
  computeViews(fresh, map);
}

std::vector<std::size_t> ExplorationManager::openPockets(const FrontierCluster& cluster) const {
  std::vector<std::size_t> pockets;
  if (pocket_of_.empty()) return pockets;
  for (const openvdb::Coord& v : cluster.voxels) {
    const auto it = pocket_of_.find(v);
    if (it != pocket_of_.end() && !pocket_visited_[it->second]) pockets.push_back(it->second);
  }
  std::sort(pockets.begin(), pockets.end());
  pockets.erase(std::unique(pockets.begin(), pockets.end()), pockets.end());
  return pockets;
}

bool ExplorationManager::smallInSweep(const FrontierCluster& cluster) const {
  return phase_ == ExplorationPhase::FinalSweep && params_.final_sweep != FinalSweepScope::All &&
         cluster.component_voxels < std::size_t(params_.frontier.min_cluster_size);
}

bool ExplorationManager::outsideSweep(const FrontierCluster& cluster) const {
  return smallInSweep(cluster) && openPockets(cluster).empty();
}

void ExplorationManager::computeViews(const std::vector<const FrontierCluster*>& clusters, const MapQuery& map) {
  if (clusters.empty()) return;
  std::vector<std::vector<Viewpoint>> views =
      computeViewpoints(clusters, map, no_target_left_once_ ? late_rule_ : params_.viewpoint);
  for (std::size_t i = 0; i < clusters.size(); ++i) views_[clusters[i]->id] = std::move(views[i]);
}

std::vector<ExplorationManager::Target> ExplorationManager::liveTargets(const MapQuery& map) {
  std::vector<Target> targets;
  std::vector<const FrontierCluster*> stale;
  MapProbe probe(map);
  std::optional<MapProbe> own_sight;
  MapProbe& sight = &map.sightMap() == &map ? probe : own_sight.emplace(map.sightMap());
  counters_.blacklisted = 0;
  for (const FrontierCluster& c : frontiers_.clusters()) {
    auto it = views_.find(c.id);
    if (it == views_.end() || it->second.empty() || outsideSweep(c)) continue;
    if (book_.isBlacklisted(c)) {
      ++counters_.blacklisted;
      continue;
    }
    // Viewpoints were computed when the cluster appeared; the map may have changed around them:
    // the best one may no longer be clear, or no longer see the cluster (a wall found since
    // between them: its visit would promise nothing, and be judged by the whole cluster).
    const Viewpoint& best = it->second.front();
    if (!probe.isClear(best.position_W, params_.viewpoint.min_clearance_m) || !seesAny(sight, best, c))
      stale.push_back(&c);
    targets.push_back({c.id, &it->second});
  }
  if (stale.empty()) return targets;
  computeViews(stale, map);
  targets.erase(std::remove_if(targets.begin(), targets.end(), [](const Target& t) { return t.views->empty(); }),
                targets.end());
  return targets;
}

const ViewpointConfig& ExplorationManager::ruleOf(const Viewpoint& view) const {
  if (view.looks_into_unknown != params_.viewpoint.look_into_unknown) return voxel_rule_;
  return no_target_left_once_ ? late_rule_ : params_.viewpoint;
}

bool ExplorationManager::seesAny(MapProbe& sight, const Viewpoint& view, const FrontierCluster& cluster) const {
  return observesAny(sight, view.position_W, view.yaw_rad, cluster.samples, ruleOf(view));
}

// ---- decisions ---------------------------------------------------------------------------------

double ExplorationManager::riskCheckStep_s(double voxel_size_m) const {
  return params_.risk_check_spacing_vox * voxel_size_m / std::max(params_.trajectory.v_max_m_s, 1e-3);
}

bool ExplorationManager::remainingTrajectoryClear(const MapQuery& map, double t_s) const {
  const double t_rel = t_s - trajectory_t0_, t_end = trajectory_.motionDuration();
  if (t_rel >= t_end) return true;  // at rest (or turning at the goal): nothing left to fly through
  MapProbe probe(map);
  const double dt = riskCheckStep_s(map.voxelSize());
  Vec3d prev = shift_ * trajectory_.sample(t_rel).position_W;
  for (double t = t_rel + dt;; t += dt) {
    const Vec3d p = shift_ * trajectory_.sample(std::min(t, t_end)).position_W;
    if (!probe.isSegmentClear(prev, p, params_.collision_radius_m)) return false;
    if (t >= t_end) return true;
    prev = p;
  }
}

bool ExplorationManager::seenFree(MapProbe& map, const Vec3d& p_W, double since_t_s) const {
  if (recent_->seesFree(p_W, since_t_s)) return true;
  return last_t_ < map_trusted_until_s_ && map.isClear(p_W, params_.safety.clearance_m);
}

bool ExplorationManager::sideSeen(MapProbe& map, const Vec3d& p_W, double since_t_s) const {
  // Near a recent surface: within clearance_m of the surface itself, wherever in its voxel it
  // lies (seesFree covers what lies farther in front of it). Asked first, as the cheaper test.
  const double near_m = params_.safety.clearance_m + 0.5 * std::sqrt(3.0) * map.voxelSize();
  if (recent_map_ && recent_map_->nearSurface(p_W, near_m)) return true;
  if (recent_->seesFree(p_W, since_t_s)) return true;
  return last_t_ < map_trusted_until_s_ && map.atWorld(p_W) != Occupancy::Unknown;
}

std::optional<ExplorationManager::UnseenPoint> ExplorationManager::unseenWayAhead(const MapQuery& map,
                                                                                  const VehicleState& vehicle,
                                                                                  double t_s) const {
  const double t_rel = t_s - trajectory_t0_, t_end = trajectory_.motionDuration();
  // Nothing to check while the vehicle is at rest for a while yet (turning to face the way first).
  constexpr double kSoon_s = 0.2;
  if (!recent_ || t_rel >= t_end || t_rel + kSoon_s < trajectory_.motionStart()) return std::nullopt;
  const double v = vehicle.velocity_W.norm();
  const double way_m = v * v / (2.0 * params_.trajectory.a_max_m_s2) + params_.safety.look_margin_m;
  return firstUnseen(map, trajectory_, shift_, t_rel, way_m, vehicle.position_W);
}

std::optional<ExplorationManager::UnseenPoint> ExplorationManager::firstUnseen(const MapQuery& map,
                                                                               const Trajectory& trajectory,
                                                                               const Eigen::Isometry3d& shift,
                                                                               double t_from, double way_m,
                                                                               const Vec3d& origin_W) const {
  const double t_end = trajectory.motionDuration();
  const double dt = riskCheckStep_s(map.voxelSize());
  MapProbe probe(map);
  // What a level camera at origin_W can check of q: q itself when some yaw brings it into view;
  // above or below the view (look_steep), the steepest point of q's vertical line in view: what
  // stands beside a climb, walls and door jambs, stands at that height too. None within
  // clearance_m across, where the vehicle's own clearance lies. In view of a camera that faces q
  // only within start_facing_rad (and a little more, for the edge of the image), as a turn and a
  // look leave it: a point at the edge of the view of a camera facing it exactly was out of view
  // of every look that ended facing it 0.2 rad off, and the looks went on, one per frame.
  constexpr double kImageEdge_rad = 0.05;
  const CameraFrustum& camera = params_.viewpoint.camera;
  const double facing_rad =
      std::min(params_.trajectory.start_facing_rad + kImageEdge_rad, std::atan(camera.tan_half_fov_x));
  const double min_across_m =
      params_.safety.look_steep ? params_.safety.clearance_m : std::numeric_limits<double>::infinity();
  const auto checkable = [&](const Vec3d& q) {
    return camera.nearestInViewOnVertical(origin_W, q, min_across_m, facing_rad);
  };
  const double side_m = params_.safety.look_side_m;
  Vec3d prev = shift * trajectory.sample(t_from).position_W;
  double along_m = 0.0;
  // The frames that count at a point: those at most seenAge_s() old when the trajectory gets
  // there (seen_until_arrival), else every one.
  const double seen_age_s =
      params_.safety.seen_until_arrival ? params_.safety.seenAge_s() : std::numeric_limits<double>::infinity();
  // With path_drift, also by the path flown from a frame to the point.
  const PathDriftScope path_scope =
      params_.safety.seen_until_arrival && params_.safety.odometry ? params_.safety.path_drift : PathDriftScope::Off;
  const double length_now_m = path_scope != PathDriftScope::Off ? flownLengthAt(last_t_) : 0.0;
  const auto arrival = [&](double t) { return last_t_ + (std::min(t, t_end) - t_from); };
  const auto byPath = [&](double t, double along) {
    return oldestTrustedFrame_s(arrival(t), length_now_m + along, seen_age_s);
  };
  const auto since = [&](double t, double along) {
    return path_scope == PathDriftScope::Everywhere ? byPath(t, along) : arrival(t) - seen_age_s;
  };
  // Near a recent surface, only frames young enough at arrival that their drift cannot have moved
  // it by the clearance (nearSeenAge_s(), and the path flown with PathDriftScope::NearSurfaces):
  // it may stand nearer than the frames that saw it say.
  const double near_age_s = params_.safety.seen_until_arrival ? params_.safety.nearSeenAge_s() : seen_age_s;
  const bool near_path = path_scope == PathDriftScope::NearSurfaces;
  const double near_surface_m = params_.safety.clearance_m + params_.safety.drift_tolerance_m;
  const auto seenNow = [&](const Vec3d& way_W, const Vec3d& check_W, double t, double along, double oldest_s) {
    if (!seenFree(probe, check_W, oldest_s)) return false;
    if ((near_age_s >= seen_age_s && !near_path) || !recent_map_ || !recent_map_->nearSurface(way_W, near_surface_m))
      return true;
    const double near_oldest_s = std::max(oldest_s, arrival(t) - near_age_s);
    return seenFree(probe, check_W, near_path ? std::max(near_oldest_s, byPath(t, along)) : near_oldest_s);
  };
  for (double t = t_from + dt; along_m < way_m; t += dt) {
    const Vec3d p = shift * trajectory.sample(std::min(t, t_end)).position_W;
    along_m += (p - prev).norm();
    const double oldest_s = since(t, along_m);
    const Eigen::Vector2d travel = (p - prev).head<2>();
    prev = p;
    // Within clearance_m of origin_W the way is where the vehicle already is (its own camera never
    // sees that space free), as the emergency stop leaves out what lies that near the vehicle.
    if (const std::optional<Vec3d> c = checkable(p);
        c && (p - origin_W).norm() >= params_.safety.clearance_m && !seenNow(p, *c, t, along_m, oldest_s))
      return UnseenPoint{*c, along_m, false};
    // Beside the way, side_m to the left and right of the horizontal travel (all four sides when
    // the way is vertical there): a way seen free down its middle may pass a wall no frame saw.
    // Only where a camera facing the way from origin_W sees them: nearer, they lie beside the
    // vehicle, as the surface checks' exemption near the vehicle does.
    const bool level_travel = travel.norm() > 1e-9;
    const std::array<Vec3d, 2> lefts{level_travel ? Vec3d(side_m * Vec3d(-travel.y(), travel.x(), 0.0) / travel.norm())
                                                  : Vec3d(side_m * Vec3d::UnitX()),
                                     side_m * Vec3d::UnitY()};
    const std::size_t n_lefts = side_m <= 0.0 || along_m * camera.tan_half_fov_x < side_m ? 0 : level_travel ? 1 : 2;
    for (std::size_t k = 0; k < n_lefts; ++k)
      for (const double sign : {1.0, -1.0}) {
        const std::optional<Vec3d> c = checkable(p + sign * lefts[k]);
        if (c && !sideSeen(probe, *c, oldest_s)) return UnseenPoint{*c, along_m, true};
      }
    if (t >= t_end) break;
  }
  return std::nullopt;
}

void ExplorationManager::recordFlownLength(const Vec3d& position_W, double t_s) {
  const double step_m = last_flown_W_ ? (position_W - *last_flown_W_).norm() : 0.0;
  flown_length_.emplace_back(t_s, flown_length_.empty() ? 0.0 : flown_length_.back().second + step_m);
  last_flown_W_ = position_W;
  // What a frame's age at arrival can reach back to: the window, and the way ahead's seconds.
  const double keep_s = params_.safety.window_s() + 10.0;
  while (flown_length_.size() > 2 && flown_length_[1].first < t_s - keep_s) flown_length_.pop_front();
}

double ExplorationManager::flownLengthAt(double t_s) const {
  if (flown_length_.empty()) return 0.0;
  const auto after = std::lower_bound(flown_length_.begin(), flown_length_.end(), t_s,
                                      [](const std::pair<double, double>& e, double t) { return e.first < t; });
  if (after == flown_length_.begin()) return after->second;
  if (after == flown_length_.end()) return flown_length_.back().second;
  const auto& [t0, s0] = *std::prev(after);
  const auto& [t1, s1] = *after;
  return s0 + (s1 - s0) * (t_s - t0) / (t1 - t0);
}

double ExplorationManager::oldestTrustedFrame_s(double arrival_s, double arrival_length_m, double seen_age_s) const {
  const OdometryDrift& drift = *params_.safety.odometry;
  const double tolerance_m = params_.safety.drift_tolerance_m, lever_m = params_.safety.drift_lever_m;
  const auto trusted = [&](double frame_s) {
    const double path_m = std::max(0.0, arrival_length_m - flownLengthAt(frame_s));
    return drift.displacement_m(arrival_s - frame_s, lever_m, path_m) <= tolerance_m;
  };
  // The displacement grows as the frame gets older (both its age and the path since), so the
  // oldest trusted frame is where it reaches the tolerance: bisection to a millisecond.
  double newest = arrival_s - SafetyConfig::kMinSeenAge_s, oldest = arrival_s - seen_age_s;
  if (oldest >= newest || trusted(oldest)) return std::min(oldest, newest);
  if (!trusted(newest)) return newest;
  while (newest - oldest > 1e-3) {
    const double mid = 0.5 * (oldest + newest);
    (trusted(mid) ? newest : oldest) = mid;
  }
  return newest;
}

bool ExplorationManager::lookSawWay(const MapQuery& map, double t_s) const {
  if (!recent_) return false;
  // Facing the way, not just glimpsing the point: the replan that follows flies on along it.
  const VehicleState now = command(t_s);
  const Vec3d look_at = shift_ * look_at_W_;
  const Eigen::Vector2d toward = (look_at - now.position_W).head<2>();
  const bool facing = toward.norm() < 1e-3 || std::abs(wrapAngle(std::atan2(toward.y(), toward.x()) - now.yaw_rad)) <=
                                                  params_.trajectory.start_facing_rad;
  if (!facing) return false;
  MapProbe probe(map);
  const double any = -std::numeric_limits<double>::infinity();
  return look_at_side_ ? sideSeen(probe, look_at, any) : seenFree(probe, look_at, any);
}

namespace {
/// The part of `trajectory` from t_from on (mapped by `shift`) keeps `r` from the recent surfaces,
/// sampled every `dt`. Within r of its point at t_from, only what lies beyond counts: a start
/// closer than r to a surface (e.g. after an escape) is where the vehicle already is.
bool clearOfRecent(const RecentObstacleMap& recent, const Trajectory& trajectory, const Eigen::Isometry3d& shift,
                   double t_from, double dt, double r) {
  const double t_end = trajectory.motionDuration();
  if (t_from >= t_end) return true;
  const Vec3d now = shift * trajectory.sample(t_from).position_W;
  for (double t = t_from;; t += dt) {
    const Vec3d p = shift * trajectory.sample(std::min(t, t_end)).position_W;
    if ((p - now).norm() >= r && recent.nearSurface(p, r)) return false;
    if (t >= t_end) return true;
  }
}
}  // namespace

bool ExplorationManager::remainingTrajectoryClearOfRecent(const RecentObstacleMap& recent, double t_s) const {
  return clearOfRecent(recent, trajectory_, shift_, t_s - trajectory_t0_, riskCheckStep_s(recent.voxelSize()),
                       params_.safety.clearance_m);
}

std::optional<Trajectory> ExplorationManager::retreat(const MapQuery& map, const VehicleState& vehicle, bool farthest) {
  if (!recent_map_) return escapes_.retreat(map, vehicle, farthest);
  const auto clear_of_recent = [this](const Trajectory& back, const std::vector<Vec3d>& way_W) {
    // The vehicle flew the way within the recent window, so it bears the clearance it had there
    // when that was less than the safety clearance (a slot it descended into), less a quarter
    // voxel for the trajectory's smoothing of the way; never less than the collision radius.
    const double vs = recent_map_->voxelSize();
    double way_clearance = params_.safety.clearance_m;
    for (std::size_t k = 1; k < way_W.size(); ++k)
      way_clearance = std::min(way_clearance, recent_map_->surfaceDistance(way_W[k], way_clearance));
    const double r =
        std::max(params_.collision_radius_m, std::min(params_.safety.clearance_m, way_clearance - 0.25 * vs));
    return clearOfRecent(*recent_map_, back, Eigen::Isometry3d::Identity(), 0.0, riskCheckStep_s(vs), r);
  };
  // The way flown within the recent window: its drift relative to now is what the recent frames
  // bear; older, it may pass a wall the recent frames no longer hold.
  return escapes_.retreat(map, vehicle, farthest, clear_of_recent, last_t_ - params_.safety.recent.window_s);
}

ReplanReason ExplorationManager::replanReason(const MapQuery& map, const RecentObstacleMap* recent, double t_s) {
  if (phase_ == ExplorationPhase::InitialTurn) {
    if (!trajectoryDone(t_s)) return ReplanReason::None;
    if (turns_left_ > 0) return ReplanReason::InitialTurn;
    phase_ = ExplorationPhase::Exploring;  // the last part is done
  }
  if (pending_.frame_shift) return ReplanReason::FrameShift;
  // An escape is flown to its end, with no other replan on the way: it was planned through the
  // voxels that blocked its start (a retreat along the way flown), and leaves no target behind.
  const bool escaping = this->escaping(t_s);
  const bool on_detour = flight_ == FlightKind::LoopDetour;
  if (trajectoryMoves() && !escaping) {
    if (!remainingTrajectoryClear(map, t_s)) return ReplanReason::CollisionRisk;
    if (recent && !remainingTrajectoryClearOfRecent(*recent, t_s)) return ReplanReason::EmergencyStop;
  }
  if (flight_ == FlightKind::Look && !trajectoryDone(t_s))
    return lookSawWay(map, t_s) ? ReplanReason::WaySeen : ReplanReason::None;
  if (pending_.retry) return ReplanReason::Retry;
  if (alc_ && alc_->detourTimedOut(t_s)) return ReplanReason::LoopDetourTimeout;
  if (book_.target() == 0 && !on_detour && !escaping) return ReplanReason::Start;
  // An escape ends where the start is clear again; a replan before that end would plan from a
  // start still blocked, and so retreat again from rest, a few millimetres per frame.
  if (escaping && !trajectoryDone(t_s)) return ReplanReason::None;
  const double elapsed = t_s - trajectory_t0_;
  const double left = trajectory_t0_ + trajectory_.duration() - t_s;
  if (left < params_.replan_time_left_s) return ReplanReason::TrajectoryEnd;
  // A detour flies through known space to a pose flown before: new frontiers cannot change where
  // it goes, so it is not replanned periodically (that would also switch viewpoints just before
  // arriving, since refinement skips viewpoints near the vehicle).
  if (on_detour) return ReplanReason::None;
  if (elapsed > params_.replan_covered_after_s && book_.coveredFraction(frontiers_) > params_.covered_fraction)
    return ReplanReason::TargetCovered;
  if (elapsed > params_.replan_period_s) return ReplanReason::Periodic;
  return ReplanReason::None;
}

ExplorationStep ExplorationManager::update(const MapQuery& base_map, const openvdb::CoordBBox& dirty,
                                           const VehicleState& vehicle, double t_s) {
  if (t_s < last_t_) throw std::invalid_argument("ExplorationManager::update: time went backwards");
  last_t_ = t_s;
  ++counters_.updates;
  if (!escaping(t_s)) escapes_.recordFlown(vehicle.position_W, t_s, base_map.voxelSize());  // not an escape's way
  if (recent_ && params_.safety.path_drift != PathDriftScope::Off) recordFlownLength(vehicle.position_W, t_s);
  if (alc_) alc_->addFlownPose(vehicle.position_W, vehicle.yaw_rad, t_s);
  const AssumeFreeMap free_map(base_map, free_boxes_);
  // The map does not change during an update: its voxels are read once per block for the many
  // tests of paths, costs and trajectories.
  const CachedMap map(free_map);
  std::optional<RecentObstacleMap> recent_map;
  // With the safety layer, flight may leave the map's thin structure to the recent surfaces.
  const MapQuery& flight_base = recent_ && !map_thin_ ? map.sightMap() : map;
  if (recent_) {
    recent_map.emplace(flight_base, recent_->surfaceIndex(map.voxelSize()),
                       params_.safety.seen_free_is_free ? recent_.get() : nullptr,
                       int(std::lround(verticalMarginAt_m(t_s) / map.voxelSize())));
  }
  const MapQuery& flight_map = recent_map ? static_cast<const MapQuery&>(*recent_map) : map;
  // Retreats read the recent surfaces through recent_map_, for this update only.
  recent_map_ = recent_map ? &*recent_map : nullptr;
  struct Forget {
    const RecentObstacleMap*& recent;
    ~Forget() { recent = nullptr; }
  } forget_recent{recent_map_};
  ExplorationStep step;
  const Stopwatch map_update;
  refreshFrontiers(map, dirty);
  step.map_update_ms = map_update.ms();
  step.clusters = frontiers_.clusters().size();
  step.frontier_voxels = frontiers_.frontierVoxelCount();

  step.reason = replanReason(flight_base, recent_map ? &*recent_map : nullptr, t_s);
  std::optional<UnseenPoint> unseen;
  if (step.reason == ReplanReason::None && flight_ != FlightKind::Look && !escaping(t_s)) {
    unseen = unseenWayAhead(map, vehicle, t_s);
    if (unseen)
      step.reason = ReplanReason::LookAhead;
    else if (trajectoryMoves() && t_s < trajectory_t0_ + trajectory_.motionDuration())
      chained_looks_ = 0;
  }
  if (step.reason == ReplanReason::None) {
    step.status = ExplorationStatus::Continue;
    step.targets = std::size_t(-1);
    return step;
  }
  const Stopwatch replan_watch;
  ++counters_.replans;
  if (step.reason == ReplanReason::CollisionRisk) ++counters_.collision_risks;
  if (step.reason == ReplanReason::EmergencyStop) ++counters_.emergency_stops;
  pending_.frame_shift = false;
  if (step.reason == ReplanReason::LookAhead) {
    ++counters_.look_stops;
    step.status = lookAhead(flight_map, vehicle, *unseen, t_s);
  } else if (step.reason == ReplanReason::WaySeen && resumeAfterLook(flight_map, vehicle, t_s)) {
    step.status = ExplorationStatus::Planned;
  } else if (step.reason == ReplanReason::InitialTurn) {
    --turns_left_;
    VehicleState at_rest = vehicle;
    at_rest.velocity_W.setZero();
    const TrajectoryResult turn =
        planTrajectory({vehicle.position_W}, at_rest,
                       wrapAngle(vehicle.yaw_rad + 2.0 * M_PI / params_.initial_turn_parts), map, params_.trajectory);
    if (turn.ok()) {
      startTrajectory(turn.trajectory, t_s, FlightKind::Turn);
      step.status = ExplorationStatus::Planned;
    } else {
      turns_left_ = 0;  // cannot turn here: start exploring right away
      phase_ = ExplorationPhase::Exploring;
      step.status = ExplorationStatus::Failed;
    }
  } else {
    step.status = replan(flight_map, vehicle, t_s, step);
  }
  pending_.retry = step.status == ExplorationStatus::Failed;
  if (pending_.retry) ++counters_.replans_failed;
  counters_.target_failures = book_.failuresAdded();
  step.replan_ms = replan_watch.ms();
  return step;
}

// ---- replanning --------------------------------------------------------------------------------

std::optional<AlcDecision> ExplorationManager::decideLoopDetour(const MapQuery& map, const VehicleState& vehicle,
                                                                double t_s, const std::vector<TourTarget>& tour_targets,
                                                                const GlobalTour& global) {
  if (!alc_) return std::nullopt;
  const bool loop_closed = std::exchange(pending_.loop_closed, false);
  return alc_->decide(vehicle, t_s, loop_closed, tour_targets, global.costs, mapLegCosts(map, *table_), &global.tour);
}

ExplorationStatus ExplorationManager::replan(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                             ExplorationStep& step) {
  // A visit is over when its trajectory ended (it is judged by what the target's viewpoint saw) or
  // its target was covered on the way; the final sweep's PocketsOnce visits the target's pockets
  // no more.
  const bool arrived = step.reason == ReplanReason::TrajectoryEnd && flight_ != FlightKind::LoopDetour;
  if ((arrived || step.reason == ReplanReason::TargetCovered) && book_.target() != 0)
    for (std::size_t p : target_pockets_) pocket_visited_[p] = true;
  if (arrived) {
    const VisitJudgement visit = book_.judgeVisit(frontiers_, params_.covered_fraction);
    step.visit_failed = visit.failed;
    if (visit.failed) {
      step.failed_visit = {book_.target(), target_view_W_, visit.judged_voxels, visit.gone_fraction};
      ++counters_.visit_failures;
    }
  }
  const std::vector<Target> targets = gatherTargets(map);
  step.targets = targets.size();
  // A replan ends a detour's own rules: if it fails, the vehicle flies on as to any target.
  if (flight_ == FlightKind::LoopDetour) flight_ = FlightKind::ToTarget;
  if (targets.empty()) return finishOrWait(map, vehicle, t_s, step);
  const TourChoice choice = chooseTour(map, vehicle, t_s, targets, step);
  if (choice.detour)
    if (const std::optional<ExplorationStatus> status = flyDetour(map, vehicle, t_s, choice, step)) return *status;
  return flyToTargets(map, vehicle, t_s, targets, choice, step);
}

std::vector<ExplorationManager::Target> ExplorationManager::gatherTargets(const MapQuery& map) {
  std::vector<Target> targets = liveTargets(map);
  if (targets.empty() && !no_target_left_once_) {
    beginLateTargets(map);
    targets = liveTargets(map);
  }
  if (targets.empty() && !frontiers_.clusters().empty() &&
      counters_.revisit_rounds < std::size_t(params_.revisit_rounds)) {
    // Only blacklisted clusters, or clusters without a viewpoint, are left: give each one more
    // try, with every cluster's viewpoints computed in the map as it is now.
    ++counters_.revisit_rounds;
    book_.forgiveBlacklisted();
    std::vector<const FrontierCluster*> all;
    for (const FrontierCluster& c : frontiers_.clusters())
      if (!outsideSweep(c)) all.push_back(&c);
    computeViews(all, map);
    targets = liveTargets(map);
  }
  return targets;
}

void ExplorationManager::beginLateTargets(const MapQuery& map) {
  no_target_left_once_ = true;  // computeViews takes late_rule_ from now on
  // Without a viewpoint, and with a lower threshold or FUEL's rule alone now.
  const bool rule_changed = late_rule_.vertical_into_unknown != params_.viewpoint.vertical_into_unknown;
  std::vector<const FrontierCluster*> lowered;
  for (const FrontierCluster& c : frontiers_.clusters()) {
    const auto it = views_.find(c.id);
    if ((it == views_.end() || it->second.empty()) &&
        (rule_changed || late_rule_.fallback.minVisibleSamples(c) < params_.viewpoint.fallback.minVisibleSamples(c)))
      lowered.push_back(&c);
  }
  counters_.late_large_clusters = lowered.size();
  computeViews(lowered, map);
  if (params_.final_min_cluster_size > 0 && params_.final_min_cluster_size < frontiers_.params().min_cluster_size) {
    // The final sweep: the small clusters, ignored so far, become targets (once: the frontier
    // keeps the smaller size from now on).
    const FrontierUpdate u = frontiers_.setMinClusterSize(map, params_.final_min_cluster_size);
    counters_.final_sweep_clusters += u.added.size();
    phase_ = ExplorationPhase::FinalSweep;
    if (params_.final_sweep != FinalSweepScope::All)
      for (ClusterId id : u.added) {  // the sweep's pockets
        const FrontierCluster* c = frontiers_.find(id);
        for (const openvdb::Coord& v : c->voxels) pocket_of_.emplace(v, pocket_visited_.size());
        pocket_visited_.push_back(false);
      }
    applyFrontierUpdate(u, map);
  }
}

ExplorationStatus ExplorationManager::finishOrWait(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                                   ExplorationStep& step) {
  book_.clearTarget();
  bool over = trajectoryDone(t_s) || blocked(step.reason);
  if (alc_ && (over || alc_->detour())) {
    const bool finishing = alc_->detour() && alc_->detour()->before_finish;
    // Legs priced as planTo flies them: the vehicle is where it stands, so space within its
    // clearance reads free (a sweep's visit ends beside unknown voxels, which block every start).
    const AssumeFreeMap start_free(
        map, {boxAround(vehicle.position_W, Vec3d::Constant(params_.path.clearance_m + map.voxelSize()))});
    const AlcDecision decision =
        alc_->decideFinish(vehicle, t_s, std::exchange(pending_.loop_closed, false), mapLegCosts(start_free, *table_));
    step.alc_status = decision.status;
    if (decision.detour()) return flyFinishDetour(map, vehicle, t_s, decision, over, step);
    over = over || finishing;  // the detour before finishing ended (a loop, or given up): finish now
  }
  if (!over) return ExplorationStatus::NoFrontier;
  if (!trajectoryDone(t_s) || trajectoryMoves()) hold(vehicle, t_s);
  return ExplorationStatus::Finished;
}

ExplorationStatus ExplorationManager::flyFinishDetour(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                                      const AlcDecision& decision, bool flight_over,
                                                      ExplorationStep& step) {
  const std::vector<Viewpoint>& views = decision.cluster_viewpoints;
  for (std::size_t k = 0; k < views.size(); ++k) {
    const PlanOutcome outcome =
        planTo(map, vehicle, views[(finish_views_flown_ + k) % views.size()], t_s, FlightKind::LoopDetour);
    if (outcome == PlanOutcome::Ok) {
      finish_views_flown_ += k + 1;
      step.loop_detour = true;
      return ExplorationStatus::Planned;
    }
    if (outcome == PlanOutcome::StartBlocked) {
      if (escape(map, vehicle, t_s)) return ExplorationStatus::Planned;
      break;
    }
  }
  // No way to the cluster now: try again at the next update, at rest, until ALC gives up.
  if (!flight_over) return ExplorationStatus::NoFrontier;
  if (!trajectoryDone(t_s) || trajectoryMoves()) hold(vehicle, t_s);
  return ExplorationStatus::Failed;
}

ExplorationManager::TourChoice ExplorationManager::chooseTour(const MapQuery& map, const VehicleState& vehicle,
                                                              double t_s, const std::vector<Target>& targets,
                                                              ExplorationStep& step) {
  // The global tour over every target's best viewpoint; with ALC, the decision whether to visit a
  // loop-closing cluster first; then local refinement of the tour's start.
  std::vector<TourTarget> tour_targets;
  std::vector<std::vector<Viewpoint>> target_views;
  for (const Target& t : targets) {
    tour_targets.push_back({t.cluster, t.views->front().pose()});
    target_views.push_back(*t.views);
  }
  TourChoice choice;
  const GlobalTour global = planGlobalTour(map, vehicle, tour_targets, *table_, params_.tour);
  choice.decision = decideLoopDetour(map, vehicle, t_s, tour_targets, global);
  if (choice.decision) step.alc_status = choice.decision->status;
  choice.detour = choice.decision && choice.decision->detour();
  choice.order = choice.decision ? choice.decision->order() : global.tour.order;
  if (params_.keep_target && !choice.detour && book_.target() != 0 &&
      (step.reason == ReplanReason::Periodic || step.reason == ReplanReason::FrameShift ||
       flight_ == FlightKind::Look)) {
    // The current target stays first; the rest keep the tour's order.
    std::vector<ClusterId> ids;
    for (const Target& t : targets) ids.push_back(t.cluster);
    const std::size_t current = book_.findTarget(ids, frontiers_);
    const auto kept = std::find(choice.order.begin(), choice.order.end(), current);
    if (kept != choice.order.end()) std::rotate(choice.order.begin(), kept, kept + 1);
  }
  // Refinement follows the order the targets are tried in: off a detour that is the frontier
  // tour with a kept target rotated first (ALC's own layers would refine the tour's first cluster
  // and fly to its viewpoint while the kept target is recorded).
  if (choice.detour) {
    choice.layers = alcRefinementLayers(vehicle, *choice.decision, target_views, params_.refinement);
  } else {
    std::vector<std::vector<Viewpoint>> in_order;
    for (std::size_t i : choice.order) in_order.push_back(target_views[i]);
    choice.layers = refinementLayers(vehicle, in_order, params_.refinement);
  }
  choice.refined = refineLocalTour(map, vehicle, choice.layers, params_.cost, params_.cost_path,
                                   params_.refinement.max_planned_edges, &refinement_legs_);
  return choice;
}

std::optional<ExplorationStatus> ExplorationManager::flyDetour(const MapQuery& map, const VehicleState& vehicle,
                                                               double t_s, const TourChoice& choice,
                                                               ExplorationStep& step) {
  // Fly to the loop cluster's refined viewpoint. If that fails, explore on: the detour stays in
  // progress (another viewpoint at the next replan) until ALC gives it up.
  const std::vector<Viewpoint>& first = choice.layers[0];
  const Viewpoint& view = choice.refined.choice.empty() ? first.front() : first[choice.refined.choice[0]];
  const PlanOutcome outcome = planTo(map, vehicle, view, t_s, FlightKind::LoopDetour);
  if (outcome == PlanOutcome::Ok) {
    book_.clearTarget();
    step.loop_detour = true;
    return ExplorationStatus::Planned;
  }
  if (outcome == PlanOutcome::StartBlocked) {
    if (escape(map, vehicle, t_s)) return ExplorationStatus::Planned;  // the detour goes on from there
    if (blocked(step.reason)) hold(vehicle, t_s);
    return ExplorationStatus::Failed;
  }
  return std::nullopt;
}

ExplorationStatus ExplorationManager::flyToTargets(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                                   const std::vector<Target>& targets, const TourChoice& choice,
                                                   ExplorationStep& step) {
  // Fly to the refined viewpoint of the first cluster; if that fails, to the next clusters' best.
  const std::size_t tries = std::min<std::size_t>(choice.order.size(), std::size_t(params_.max_targets_per_replan));
  bool start_was_clear = true;
  // Failures are counted once the replan's outcome is known (all_failed_spacing_s).
  std::vector<FailedPath> failed;
  const auto countFailures = [&](bool all_failed) {
    if (all_failed && t_s - last_all_failed_t_ < params_.all_failed_spacing_s) return;
    if (all_failed) last_all_failed_t_ = t_s;
    for (const FailedPath& f : failed) book_.addFailure(*frontiers_.find(f.cluster));
    step.failed_paths.insert(step.failed_paths.end(), failed.begin(), failed.end());
    step.path_failures += failed.size();
    counters_.path_failures += failed.size();
  };
  for (std::size_t k = 0; k < tries; ++k) {
    const Target& t = targets[choice.order[k]];
    const FrontierCluster* cluster = frontiers_.find(t.cluster);
    const bool refined_here = k == 0 && !choice.detour && !choice.refined.choice.empty();
    const Viewpoint& view = refined_here ? choice.layers[0][choice.refined.choice[0]] : t.views->front();
    const PlanOutcome outcome = planTo(map, vehicle, view, t_s, FlightKind::ToTarget);
    if (outcome == PlanOutcome::Ok) {
      countFailures(false);
      MapProbe probe(map.sightMap());
      // Pockets are visited (marked) only with PocketsOnce.
      target_pockets_ =
          params_.final_sweep == FinalSweepScope::PocketsOnce ? openPockets(*cluster) : std::vector<std::size_t>{};
      // The visit is judged by what the viewpoint was scored by.
      book_.setTarget(*cluster, observedSamples(probe, view.position_W, view.yaw_rad, cluster->samples, ruleOf(view)));
      target_view_W_ = view.position_W;
      step.target = t.cluster;
      return ExplorationStatus::Planned;
    }
    if (outcome == PlanOutcome::StartBlocked) {
      // Not this target's fault, but the way to the one flown to so far ended blocked: one failure
      // for that, so that a target whose approach keeps getting blocked is given up.
      book_.addTargetFailure();
      start_was_clear = false;
      countFailures(false);
      if (!escape(map, vehicle, t_s)) break;
      book_.clearTarget();
      return ExplorationStatus::Planned;
    }
    const PathFailure why = outcome == PlanOutcome::GoalBlocked ? PathFailure::GoalBlocked
                            : outcome == PlanOutcome::NoPath    ? PathFailure::NoPath
                                                                : PathFailure::NoTrajectory;
    failed.push_back({t.cluster, vehicle.position_W, view.position_W, why});
  }
  // (A blocked start counted them already; from a clear start every target tried failed.)
  const bool all_failed = tries > 0 && start_was_clear;
  if (start_was_clear) countFailures(all_failed);
  // Every target failed from a clear start: the vehicle may have squeezed into a place whose way
  // out is narrower, in the map as it reads now, than a path search can find (a corridor behind
  // shelving that thin structure, seen on the way in, narrowed). It goes back the way it came.
  if (all_failed && chained_backtracks_ < params_.max_chained_backtracks) {
    if (std::optional<Trajectory> back = retreat(map, vehicle, /*farthest=*/true)) {
      startTrajectory(std::move(*back), t_s, FlightKind::Retreat);
      ++chained_backtracks_;
      ++counters_.retreats;
      book_.clearTarget();
      return ExplorationStatus::Planned;
    }
  }
  if (blocked(step.reason)) hold(vehicle, t_s);
  return ExplorationStatus::Failed;
}

ExplorationManager::PlanOutcome ExplorationManager::planTo(const MapQuery& map, const VehicleState& vehicle,
                                                           const Viewpoint& view, double t_s, FlightKind kind) {
  // Seeded by the replan count, so that a retry samples differently from the attempt before.
  const std::uint64_t query_seed = counters_.replans;
  PathResult path = PathPlanner(map, params_.path).plan(vehicle.position_W, view.position_W, query_seed);
  const MapQuery* plan_map = &map;
  std::unique_ptr<AssumeFreeMap> start_free;
  if (path.status == PathStatus::StartInvalid) {
    // The vehicle stands where the map has unknown voxels within the clearance (e.g. where a
    // re-integrated frame moved the map): it is there, so space within its clearance reads free.
    const double r = params_.path.clearance_m + map.voxelSize();
    start_free = std::make_unique<AssumeFreeMap>(
        map, std::vector<Eigen::AlignedBox3d>{boxAround(vehicle.position_W, Vec3d::Constant(r))});
    plan_map = start_free.get();
    path = PathPlanner(*plan_map, params_.path).plan(vehicle.position_W, view.position_W, query_seed);
    if (path.status == PathStatus::StartInvalid) return PlanOutcome::StartBlocked;
  }
  if (path.status == PathStatus::GoalInvalid) return PlanOutcome::GoalBlocked;
  if (!path.ok()) return PlanOutcome::NoPath;
  TrajectoryResult traj = planFlight(path.waypoints, vehicle, view.yaw_rad, *plan_map);
  if (!traj.ok()) return PlanOutcome::NoTrajectory;
  startTrajectory(std::move(traj.trajectory), t_s, kind);
  if (!start_free) chained_escapes_ = 0;
  chained_backtracks_ = 0;
  return PlanOutcome::Ok;
}

TrajectoryResult ExplorationManager::planFlight(const std::vector<Vec3d>& path_W, const VehicleState& vehicle,
                                                double goal_yaw_rad, const MapQuery& map) const {
  TrajectoryConfig tc = params_.trajectory;
  TrajectoryResult traj;
  // How far along `flight` the way is seen, short of the look-ahead margin (infinite: all of it).
  const double all = std::numeric_limits<double>::infinity();
  const auto seenWay_m = [&](const Trajectory& flight) {
    const std::optional<UnseenPoint> unseen =
        firstUnseen(map, flight, Eigen::Isometry3d::Identity(), 0.0, all, vehicle.position_W);
    return unseen ? std::max(0.0, unseen->along_m - params_.safety.look_margin_m) : all;
  };
  if (tc.yaw_along_travel && recent_) {
    // Facing the way costs turns; a way the recent frames saw free all along does not need it,
    // and keeps the yaw spread over the motion. Else the vehicle may fly, while it turns, the
    // part of the way seen free short of the look-ahead margin.
    tc.yaw_along_travel = false;
    traj = planTrajectory(path_W, vehicle, goal_yaw_rad, map, tc);
    if (const double free_way_m = traj.ok() ? seenWay_m(traj.trajectory) : all; free_way_m < all) {
      tc.yaw_along_travel = true;
      tc.free_way_m = free_way_m;
    }
  }
  if (tc.yaw_along_travel || !traj.ok()) traj = planTrajectory(path_W, vehicle, goal_yaw_rad, map, tc);
  // The flight that faces the way reaches each point later than the one checked above (it turns
  // first, or slows while it turns), so frames young enough for that one may be too old for it:
  // its own first unseen point bounds the way it may fly before it faces the way. The bound only
  // shrinks, and at 0 the vehicle turns on the spot before it moves.
  constexpr int kMaxRefits = 3;
  for (int i = 0; i < kMaxRefits && tc.yaw_along_travel && recent_ && traj.ok() && tc.free_way_m > 0.0; ++i) {
    const double free_way_m = seenWay_m(traj.trajectory);
    if (free_way_m >= tc.free_way_m) break;
    tc.free_way_m = free_way_m;
    TrajectoryResult refit = planTrajectory(path_W, vehicle, goal_yaw_rad, map, tc);
    if (!refit.ok()) break;  // the last one stands, and a look stop guards it
    traj = std::move(refit);
  }
  return traj;
}

bool ExplorationManager::resumeAfterLook(const MapQuery& map, const VehicleState& vehicle, double t_s) {
  if (!interrupted_) return false;
  const Interrupted was = std::move(*interrupted_);
  interrupted_.reset();
  // The interrupted way from its point nearest the vehicle (the look braked along it), as a
  // polyline of points kResume_m apart, to the goal it was flying to.
  constexpr double kResume_m = 0.3;
  const Trajectory& old = was.trajectory;
  const Eigen::Isometry3d shift = shift_ * was.shift;
  const double t_end = old.motionDuration();
  const double dt = riskCheckStep_s(map.voxelSize());
  double t_near = was.t_from_s, d_near = std::numeric_limits<double>::infinity();
  for (double t = was.t_from_s; t <= t_end; t += dt) {
    const double d = (shift * old.sample(t).position_W - vehicle.position_W).norm();
    if (d < d_near) {
      t_near = t;
      d_near = d;
    }
  }
  std::vector<Vec3d> path{vehicle.position_W};
  for (double t = t_near + dt;; t += dt) {
    const Vec3d p = shift * old.sample(std::min(t, t_end)).position_W;
    if ((p - path.back()).norm() >= kResume_m || (t >= t_end && (p - path.back()).norm() > 1e-3)) path.push_back(p);
    if (t >= t_end) break;
  }
  const double goal_yaw = wrapAngle(old.sample(old.duration()).yaw_rad + yawOf(shift));
  TrajectoryResult traj = planFlight(path, vehicle, goal_yaw, map);
  if (!traj.ok()) return false;
  startTrajectory(std::move(traj.trajectory), t_s, was.kind);
  ++counters_.looks_resumed;
  return true;
}

ExplorationStatus ExplorationManager::lookAhead(const MapQuery& map, const VehicleState& vehicle,
                                                const UnseenPoint& unseen, double t_s) {
  if (++chained_looks_ > params_.safety.max_chained_looks) {
    // Looking did not show the way (hidden behind a corner, or out of reach of the camera): the
    // way to this target counts as failed, as a blocked start does.
    chained_looks_ = 0;
    book_.addTargetFailure();
    hold(vehicle, t_s);
    return ExplorationStatus::Failed;
  }
  // Brake straight along the velocity: the shortest stop. The trajectory's own points up to the
  // braking distance run a few degrees off a drifting estimate's velocity, and a velocity that
  // exceeds v_max by a hair cannot be matched at all; either made the trajectory generator take a
  // lead-in along the velocity past the stop and back (2 m out and back, 5 s, in a house run at
  // s3). The trajectory's points, then a stop on the spot, remain as fallbacks.
  const TrajectoryConfig& tc = params_.trajectory;
  const double t_rel = t_s - trajectory_t0_;
  VehicleState moving = vehicle;
  const double v = std::min(vehicle.velocity_W.norm(), tc.v_max_m_s);
  if (v > 0.0) moving.velocity_W *= v / vehicle.velocity_W.norm();
  const double brake_m = v * v / (2.0 * tc.a_max_m_s2);
  std::vector<Vec3d> straight{vehicle.position_W};
  if (brake_m > 0.01) straight.push_back(vehicle.position_W + brake_m * moving.velocity_W.normalized());
  const Eigen::Vector2d toward = (unseen.p_W - straight.back()).head<2>();
  const double yaw = toward.norm() > 1e-3 ? std::atan2(toward.y(), toward.x()) : vehicle.yaw_rad;
  TrajectoryResult look = planTrajectory(straight, moving, yaw, map, tc);
  if (!look.ok()) {
    const double t_end = trajectory_.motionDuration();
    const double dt = 0.5 * map.voxelSize() / std::max(tc.v_max_m_s, 1e-3);
    std::vector<Vec3d> path{vehicle.position_W};
    double along_m = 0.0;
    for (double t = t_rel + dt; along_m < brake_m && t - dt < t_end; t += dt) {
      const Vec3d p = shift_ * trajectory_.sample(std::min(t, t_end)).position_W;
      along_m += (p - path.back()).norm();
      if ((p - path.back()).norm() >= 0.01) path.push_back(p);
    }
    look = planTrajectory(path, moving, yaw, map, tc);
  }
  if (!look.ok()) look = planTrajectory({vehicle.position_W}, moving, yaw, map, tc);
  if (!look.ok()) {
    hold(vehicle, t_s);
    return ExplorationStatus::Failed;
  }
  interrupted_ = Interrupted{trajectory_, shift_, t_rel, flight_};
  startTrajectory(std::move(look.trajectory), t_s, FlightKind::Look);
  look_at_W_ = unseen.p_W;
  look_at_side_ = unseen.side;
  return ExplorationStatus::Planned;
}

bool ExplorationManager::escape(const MapQuery& map, const VehicleState& vehicle, double t_s) {
  if (std::optional<Trajectory> back = retreat(map, vehicle, /*farthest=*/false)) {
    startTrajectory(std::move(*back), t_s, FlightKind::Retreat);
    ++counters_.retreats;
  } else if (chained_escapes_ >= params_.max_chained_escapes) {
    return false;
  } else if (std::optional<Trajectory> out = escapes_.straightEscape(map, vehicle)) {
    startTrajectory(std::move(*out), t_s, FlightKind::Escape);
    ++chained_escapes_;
  } else {
    return false;
  }
  ++counters_.escapes;
  return true;
}

}  // namespace vdbmap::planner
