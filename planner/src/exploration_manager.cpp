#include "vdbmap/planner/exploration_manager.hpp"
#include "vdbmap/field_check.hpp"
#include "vdbmap/timing.hpp"

#include "vdbmap/planner/assume_free_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_set>
#include <utility>

namespace vdbmap::planner {

namespace {
/// Parts of the initial turn on the spot: three turns of 120 deg (each shorter than half a turn,
/// so the trajectory's shortest-way yaw profile turns the intended way).
constexpr int kInitialTurnParts = 3;
/// Spacing of the collision-risk check along the trajectory, in voxels.
constexpr double kRiskCheckSpacingVox = 0.5;
/// Flown positions kept for retreats (one voxel apart), and how far back along them a retreat goes.
constexpr std::size_t kFlownKept = 100;
constexpr double kRetreatReach_m = 3.0;
/// Straight escapes in a row (without a plan from a clear start in between) before giving up: a
/// chain of them creeps wherever the map's errors push it (once, into shelving through a board).
constexpr int kMaxChainedEscapes = 3;
/// How far a straight escape looks for a clear point.
constexpr double kEscapeReach_m = 1.0;
/// Back-tracks in a row (without a plan in between) after every target failed.
constexpr int kMaxChainedBacktracks = 2;

double yawOf(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

/// A box around each segment of `way`, grown by `grow_m`: where an escape's trajectory may pass
/// voxels that blocked its start (AssumeFreeMap with occupied_too).
std::vector<Eigen::AlignedBox3d> corridorAround(const std::vector<Vec3d>& way, double grow_m) {
  std::vector<Eigen::AlignedBox3d> boxes;
  const Vec3d grow = Vec3d::Constant(grow_m);
  for (std::size_t k = 1; k < way.size(); ++k)
    boxes.emplace_back(way[k - 1].cwiseMin(way[k]) - grow, way[k - 1].cwiseMax(way[k]) + grow);
  return boxes;
}

/// The fraction of `voxels` that are no longer frontier (1 when there are none).
double noLongerFrontierFraction(const FrontierMap& frontiers, const std::vector<openvdb::Coord>& voxels) {
  if (voxels.empty()) return 1.0;
  std::size_t gone = 0;
  for (const openvdb::Coord& v : voxels) gone += frontiers.isFrontier(v) ? 0 : 1;
  return double(gone) / double(voxels.size());
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
  }
  return "?";
}

PathParams ExplorationParams::flightPathDefaults() {
  PathParams p;
  p.time_limit_s = 0.1;
  return p;
}

PathParams ExplorationParams::costPathDefaults() {
  PathParams p;
  p.time_limit_s = 0.01;
  return p;
}

void ExplorationParams::validate() const {
  const FieldCheck check("ExplorationParams");
  if (box_W.isEmpty() || !box_W.min().allFinite() || !box_W.max().allFinite())
    throw std::invalid_argument("ExplorationParams.box_W must be a finite, non-empty box");
  frontier.validate();
  viewpoint.validate();
  cost.validate();
  path.validate();
  cost_path.validate();
  tour.validate();
  refinement.validate();
  trajectory.validate();
  for (int a = 0; a < 3; ++a)
    if (!(start_free_half_size_m[a] >= 0.0 && start_free_half_size_m[a] <= 10.0))
      check.fail("start_free_half_size_m", "[0, 10] per axis");
  if (!(viewpoint_margin_z_m >= 0.0 && viewpoint_margin_z_m <= 10.0)) check.fail("viewpoint_margin_z_m", "[0, 10]");
  if (!(replan_time_left_s >= 0.0 && replan_time_left_s <= 100.0)) check.fail("replan_time_left_s", "[0, 100]");
  if (!(replan_covered_after_s >= 0.0 && replan_covered_after_s <= 100.0)) check.fail("replan_covered_after_s", "[0, 100]");
  if (!(replan_period_s > 0.0 && replan_period_s <= 1000.0)) check.fail("replan_period_s", "(0, 1000]");
  if (!(covered_fraction > 0.0 && covered_fraction <= 1.0)) check.fail("covered_fraction", "(0, 1]");
  if (!(collision_radius_m >= 0.0 && collision_radius_m <= path.clearance_m))
    check.fail("collision_radius_m", "[0, path.clearance_m]");
  if (max_failures < 1 || max_failures > 100) check.fail("max_failures", "[1, 100]");
  if (revisit_rounds < 0 || revisit_rounds > 100) check.fail("revisit_rounds", "[0, 100]");
  if (final_min_cluster_size < 0 || final_min_cluster_size > 100000000) check.fail("final_min_cluster_size", "[0, 1e8]");
  if (max_targets_per_replan < 1 || max_targets_per_replan > 100) check.fail("max_targets_per_replan", "[1, 100]");
  if (alc_enabled) alc.validate();
}

ExplorationManager::ExplorationManager(const ExplorationParams& params, const VehicleState& start, double t_s)
    : params_(params) {
  params_.validate();
  if (!params_.box_W.contains(start.position_W))
    throw std::invalid_argument("ExplorationManager: the start position lies outside the exploration box");
  params_.frontier.bounds_W = params_.box_W;
  const double clearance = params_.viewpoint.min_clearance_m;
  const Vec3d margin(clearance, clearance, std::max(clearance, params_.viewpoint_margin_z_m));
  Eigen::AlignedBox3d view_box(params_.box_W.min() + margin, params_.box_W.max() - margin);
  params_.viewpoint.bounds_W = view_box.isEmpty() ? params_.box_W : view_box;
  params_.path.bounds_W = params_.box_W;
  params_.cost_path.bounds_W = params_.box_W;
  params_.trajectory.clearance_m = params_.path.clearance_m;
  params_.trajectory.check_step_m = params_.path.check_step_m;
  free_boxes_.push_back(boxAround(start.position_W, params_.start_free_half_size_m));
  frontiers_ = FrontierMap(params_.frontier);
  table_ = std::make_unique<PairCostTable>(params_.cost, params_.cost_path);
  turns_left_ = params_.initial_turn ? kInitialTurnParts : 0;
  turning_ = params_.initial_turn;
  trajectory_ = Trajectory::hold(start.position_W, start.yaw_rad);
  trajectory_t0_ = t_s;
  last_t_ = t_s;
  if (params_.alc_enabled) {
    params_.alc.unreachable_cost_s = params_.cost.unreachable_cost_s;  // ALC's sums skip the legs M_frt marks so
    alc_ = std::make_unique<ActiveLoopClosure>(params_.alc, t_s);
  }
}

ExplorationManager::~ExplorationManager() = default;

// ---- the commanded trajectory ------------------------------------------------------------------

TrajectoryState ExplorationManager::command(double t_s) const {
  TrajectoryState s = trajectory_.sample(t_s - trajectory_t0_);
  s.position_W = shift_ * s.position_W;
  s.velocity_W = shift_.linear() * s.velocity_W;
  s.acceleration_W = shift_.linear() * s.acceleration_W;
  s.yaw_rad = wrapAngle(s.yaw_rad + yawOf(shift_));
  return s;
}

void ExplorationManager::shiftFrame(const Eigen::Isometry3d& shift) {
  shift_ = shift * shift_;
  for (Vec3d& p : flown_W_) p = shift * p;
  shift_requested_ = true;
}

void ExplorationManager::notifyLoopClosure(double t_s,
                                           const std::function<PoseTarget(const FlownViewpoint&)>& corrected) {
  if (!std::isfinite(t_s)) throw std::invalid_argument("ExplorationManager::notifyLoopClosure: t_s must be finite");
  if (!alc_) return;
  loop_closed_ = true;
  if (corrected) alc_->correctHistory(corrected);
}

void ExplorationManager::startTrajectory(Trajectory trajectory, double t_s) {
  trajectory_ = std::move(trajectory);
  trajectory_t0_ = t_s;
  shift_ = Eigen::Isometry3d::Identity();
  was_moving_ = trajectory_.motionDuration() > 0.0;
  escape_end_t_ = -std::numeric_limits<double>::infinity();
}

ExplorationActivity ExplorationManager::activity(double t_s) const {
  if (turning_) return ExplorationActivity::InitialTurn;
  if (t_s <= escape_end_t_) return escape_is_retreat_ ? ExplorationActivity::Retreating : ExplorationActivity::Escaping;
  const double t_rel = t_s - trajectory_t0_;
  if (t_rel >= trajectory_.duration()) return ExplorationActivity::Holding;
  if (t_rel >= trajectory_.motionDuration()) return ExplorationActivity::Turning;
  if (on_detour_) return ExplorationActivity::LoopDetour;
  return final_sweep_ ? ExplorationActivity::FinalSweep : ExplorationActivity::ToTarget;
}

void ExplorationManager::hold(const VehicleState& vehicle, double t_s) {
  if (was_moving_ || !trajectoryDone(t_s)) ++counters_.holds;
  startTrajectory(Trajectory::hold(vehicle.position_W, vehicle.yaw_rad), t_s);
  target_ = 0;
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
  for (ClusterId id : u.added)
    if (const FrontierCluster* c = frontiers_.find(id)) fresh.push_back(c);
  computeViews(fresh, map);
}

void ExplorationManager::computeViews(const std::vector<const FrontierCluster*>& clusters, const MapQuery& map) {
  if (clusters.empty()) return;
  std::vector<std::vector<Viewpoint>> views = computeViewpoints(clusters, map, params_.viewpoint);
  for (std::size_t i = 0; i < clusters.size(); ++i) views_[clusters[i]->id] = std::move(views[i]);
}

int ExplorationManager::failures(const FrontierCluster& cluster) const {
  if (voxel_failures_.empty() || cluster.voxels.empty()) return 0;
  std::vector<int> counts;
  counts.reserve(cluster.voxels.size());
  for (const openvdb::Coord& v : cluster.voxels) {
    const auto it = voxel_failures_.find(v);
    counts.push_back(it == voxel_failures_.end() ? 0 : it->second);
  }
  // The median: a cluster inherits failures when most of its voxels failed before.
  const auto mid = counts.begin() + std::ptrdiff_t(counts.size() / 2);
  std::nth_element(counts.begin(), mid, counts.end());
  return *mid;
}

void ExplorationManager::addFailure(const FrontierCluster& cluster) {
  const int count = failures(cluster) + 1;
  for (const openvdb::Coord& v : cluster.voxels) {
    int& f = voxel_failures_[v];
    f = std::max(f, count);
  }
  ++counters_.target_failures;
}

std::vector<ExplorationManager::Target> ExplorationManager::liveTargets(const MapQuery& map) {
  std::vector<Target> targets;
  std::vector<const FrontierCluster*> stale;
  MapProbe probe(map);
  counters_.blacklisted = 0;
  for (const FrontierCluster& c : frontiers_.clusters()) {
    auto it = views_.find(c.id);
    if (it == views_.end() || it->second.empty()) continue;
    if (isBlacklisted(c)) {
      ++counters_.blacklisted;
      continue;
    }
    // Viewpoints were computed when the cluster appeared; the map may have changed around them.
    if (!probe.isClear(it->second.front().position_W, params_.viewpoint.min_clearance_m)) stale.push_back(&c);
    targets.push_back({c.id, &it->second});
  }
  if (stale.empty()) return targets;
  computeViews(stale, map);
  targets.erase(std::remove_if(targets.begin(), targets.end(), [](const Target& t) { return t.views->empty(); }),
                targets.end());
  return targets;
}

// ---- decisions ---------------------------------------------------------------------------------

std::size_t ExplorationManager::currentTargetIndex(const std::vector<Target>& targets) const {
  for (std::size_t i = 0; i < targets.size(); ++i)
    if (targets[i].cluster == target_) return i;
  // The map changed around the target and its cluster was made anew (new id): the target is the
  // cluster holding most of its frontier voxels.
  const std::unordered_set<openvdb::Coord, CoordHash> voxels(target_voxels_.begin(), target_voxels_.end());
  std::size_t best = targets.size(), best_count = 0;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const FrontierCluster* c = frontiers_.find(targets[i].cluster);
    if (!c) continue;
    std::size_t count = 0;
    for (const openvdb::Coord& v : c->voxels) count += voxels.count(v);
    if (count > best_count) best = i, best_count = count;
  }
  return best;
}

void ExplorationManager::clearTarget() {
  target_ = 0;
  target_voxels_.clear();
  target_promised_.clear();
}

double ExplorationManager::promisedCoveredFraction() const {
  return target_promised_.empty() ? targetCoveredFraction() : noLongerFrontierFraction(frontiers_, target_promised_);
}

double ExplorationManager::targetCoveredFraction() const { return noLongerFrontierFraction(frontiers_, target_voxels_); }

bool ExplorationManager::remainingTrajectoryClear(const MapQuery& map, double t_s) const {
  const double t_rel = t_s - trajectory_t0_, t_end = trajectory_.motionDuration();
  if (t_rel >= t_end) return true;  // at rest (or turning at the goal): nothing left to fly through
  MapProbe probe(map);
  const double v_max = std::max(params_.trajectory.v_max_m_s, 1e-3);
  const double dt = kRiskCheckSpacingVox * map.voxelSize() / v_max;
  Vec3d prev = shift_ * trajectory_.sample(t_rel).position_W;
  for (double t = t_rel + dt;; t += dt) {
    const Vec3d p = shift_ * trajectory_.sample(std::min(t, t_end)).position_W;
    if (!probe.isSegmentClear(prev, p, params_.collision_radius_m)) return false;
    if (t >= t_end) return true;
    prev = p;
  }
}

ReplanReason ExplorationManager::replanReason(const MapQuery& map, double t_s) {
  if (turning_) {
    if (!trajectoryDone(t_s)) return ReplanReason::None;
    if (turns_left_ > 0) return ReplanReason::InitialTurn;
    turning_ = false;  // the last part is done
  }
  if (shift_requested_) return ReplanReason::FrameShift;
  // An escape is flown to its end, with no other replan on the way: it was planned through the
  // voxels that blocked its start (a retreat along the way flown), and leaves no target behind.
  const bool escaping = t_s <= escape_end_t_;
  if (was_moving_ && !escaping && !remainingTrajectoryClear(map, t_s)) return ReplanReason::CollisionRisk;
  if (failed_last_) return ReplanReason::Retry;
  if (alc_ && alc_->detourTimedOut(t_s)) return ReplanReason::LoopDetourTimeout;
  if (target_ == 0 && !on_detour_ && !escaping) return ReplanReason::Start;
  const double elapsed = t_s - trajectory_t0_;
  const double left = trajectory_t0_ + trajectory_.duration() - t_s;
  if (left < params_.replan_time_left_s) return ReplanReason::TrajectoryEnd;
  // A detour flies through known space to a pose flown before: new frontiers cannot change where
  // it goes, so it is not replanned periodically (that would also switch viewpoints just before
  // arriving, since refinement skips viewpoints near the vehicle).
  if (on_detour_ || escaping) return ReplanReason::None;
  if (elapsed > params_.replan_covered_after_s && targetCoveredFraction() > params_.covered_fraction)
    return ReplanReason::TargetCovered;
  if (elapsed > params_.replan_period_s) return ReplanReason::Periodic;
  return ReplanReason::None;
}

ExplorationStep ExplorationManager::update(const MapQuery& base_map, const openvdb::CoordBBox& dirty,
                                           const VehicleState& vehicle, double t_s) {
  if (t_s < last_t_) throw std::invalid_argument("ExplorationManager::update: time went backwards");
  last_t_ = t_s;
  ++counters_.updates;
  if (t_s > escape_end_t_) recordFlown(vehicle.position_W, base_map.voxelSize());  // not an escape's way
  if (alc_) alc_->addFlownPose(vehicle.position_W, vehicle.yaw_rad, t_s);
  const AssumeFreeMap map(base_map, free_boxes_);
  ExplorationStep step;
  const Stopwatch map_update;
  refreshFrontiers(map, dirty);
  step.map_update_ms = map_update.ms();
  step.clusters = frontiers_.clusters().size();
  step.frontier_voxels = frontiers_.frontierVoxelCount();

  step.reason = replanReason(map, t_s);
  if (step.reason == ReplanReason::None) {
    step.status = ExplorationStatus::Continue;
    step.targets = std::size_t(-1);
    return step;
  }
  const Stopwatch replan_watch;
  ++counters_.replans;
  if (step.reason == ReplanReason::CollisionRisk) ++counters_.collision_risks;
  shift_requested_ = false;
  if (step.reason == ReplanReason::InitialTurn) {
    --turns_left_;
    VehicleState at_rest = vehicle;
    at_rest.velocity_W.setZero();
    const TrajectoryResult turn = planTrajectory({vehicle.position_W}, at_rest,
                                                 wrapAngle(vehicle.yaw_rad + 2.0 * M_PI / kInitialTurnParts), map,
                                                 params_.trajectory);
    if (turn.ok()) {
      startTrajectory(turn.trajectory, t_s);
      step.status = ExplorationStatus::Planned;
    } else {
      turns_left_ = 0;  // cannot turn here: start exploring right away
      turning_ = false;
      step.status = ExplorationStatus::Failed;
    }
  } else {
    step.status = replan(map, vehicle, t_s, step);
  }
  failed_last_ = step.status == ExplorationStatus::Failed;
  if (failed_last_) ++counters_.replans_failed;
  step.replan_ms = replan_watch.ms();
  return step;
}

// ---- replanning --------------------------------------------------------------------------------

void ExplorationManager::checkVisit() {
  // The vehicle reached (or nearly reached) its target: if the frontier its viewpoint saw is still
  // mostly there, the target cannot be observed from that viewpoint.
  if (target_ == 0 || target_voxels_.empty()) return;
  if (promisedCoveredFraction() > params_.covered_fraction) return;
  addTargetFailure();
}

void ExplorationManager::addTargetFailure() {
  if (target_ == 0 || target_voxels_.empty()) return;
  FrontierCluster target;
  target.voxels = target_voxels_;
  addFailure(target);
}

std::optional<AlcDecision> ExplorationManager::decideLoopDetour(const MapQuery& map, const VehicleState& vehicle,
                                                                double t_s, const std::vector<TourTarget>& tour_targets,
                                                                const GlobalTour& global) {
  if (!alc_) return std::nullopt;
  const bool loop_closed = std::exchange(loop_closed_, false);
  return alc_->decide(vehicle, t_s, loop_closed, tour_targets, global.costs, mapLegCosts(map, *table_), &global.tour);
}

ExplorationStatus ExplorationManager::replan(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                             ExplorationStep& step) {
  if (step.reason == ReplanReason::TrajectoryEnd && !on_detour_) checkVisit();
  std::vector<Target> targets = liveTargets(map);
  if (targets.empty() && params_.final_min_cluster_size > 0 &&
      params_.final_min_cluster_size < frontiers_.params().min_cluster_size) {
    // The final sweep: the small clusters, ignored so far, become targets (once: the frontier
    // keeps the smaller size from now on).
    const FrontierUpdate u = frontiers_.setMinClusterSize(map, params_.final_min_cluster_size);
    counters_.final_sweep_clusters += u.added.size();
    final_sweep_ = true;
    applyFrontierUpdate(u, map);
    targets = liveTargets(map);
  }
  if (targets.empty() && !frontiers_.clusters().empty() &&
      counters_.revisit_rounds < std::size_t(params_.revisit_rounds)) {
    // Only blacklisted clusters, or clusters without a viewpoint, are left: give each one more
    // try, with every cluster's viewpoints computed in the map as it is now.
    ++counters_.revisit_rounds;
    for (auto& [voxel, count] : voxel_failures_) count = std::min(count, params_.max_failures - 1);
    std::vector<const FrontierCluster*> all;
    for (const FrontierCluster& c : frontiers_.clusters()) all.push_back(&c);
    computeViews(all, map);
    targets = liveTargets(map);
  }
  step.targets = targets.size();
  on_detour_ = false;
  if (targets.empty()) {
    if (alc_ && alc_->detour()) {  // nothing left to explore: the detour ends (decide's kNoFrontier)
      GlobalTour nothing;
      nothing.costs = RealCostMatrix(1);
      step.alc_status = decideLoopDetour(map, vehicle, t_s, {}, nothing)->status;
    }
    clearTarget();
    if (!trajectoryDone(t_s) && step.reason != ReplanReason::CollisionRisk) return ExplorationStatus::NoFrontier;
    if (!trajectoryDone(t_s) || was_moving_) hold(vehicle, t_s);
    return ExplorationStatus::Finished;
  }

  // The global tour over every target's best viewpoint; with ALC, the decision whether to visit a
  // loop-closing cluster first; then local refinement of the tour's start.
  std::vector<TourTarget> tour_targets;
  std::vector<std::vector<Viewpoint>> target_views;
  for (const Target& t : targets) {
    tour_targets.push_back({t.cluster, {t.views->front().position_W, t.views->front().yaw_rad}});
    target_views.push_back(*t.views);
  }
  const GlobalTour global = planGlobalTour(map, vehicle, tour_targets, *table_, params_.tour);
  const std::optional<AlcDecision> decision = decideLoopDetour(map, vehicle, t_s, tour_targets, global);
  if (decision) step.alc_status = decision->status;
  const bool detour = decision && decision->detour();
  std::vector<std::size_t> order = decision ? decision->order() : global.tour.order;
  if (params_.keep_target && !detour && target_ != 0 &&
      (step.reason == ReplanReason::Periodic || step.reason == ReplanReason::FrameShift)) {
    // The current target stays first; the rest keep the tour's order.
    const std::size_t current = currentTargetIndex(targets);
    const auto kept = std::find(order.begin(), order.end(), current);
    if (kept != order.end()) std::rotate(order.begin(), kept, kept + 1);
  }
  // Refinement follows `order`, the order the targets are tried in below: off a detour that is
  // the frontier tour with a kept target rotated first (ALC's own layers would refine the tour's
  // first cluster and fly to its viewpoint while the kept target is recorded).
  std::vector<std::vector<Viewpoint>> layers;
  if (detour) {
    layers = alcRefinementLayers(vehicle, *decision, target_views, params_.refinement);
  } else {
    std::vector<std::vector<Viewpoint>> in_order;
    for (std::size_t i : order) in_order.push_back(target_views[i]);
    layers = refinementLayers(vehicle, in_order, params_.refinement);
  }
  const RefinementResult refined = refineLocalTour(map, vehicle, layers, params_.cost, params_.cost_path);

  if (detour) {
    // Fly to the loop cluster's refined viewpoint. If that fails, explore on: the detour stays in
    // progress (another viewpoint at the next replan) until ALC gives it up.
    const Viewpoint& view = refined.choice.empty() ? layers[0].front() : layers[0][refined.choice[0]];
    const PlanOutcome outcome = planTo(map, vehicle, view, t_s);
    if (outcome == PlanOutcome::Ok) {
      on_detour_ = true;
      clearTarget();
      step.loop_detour = true;
      return ExplorationStatus::Planned;
    }
    if (outcome == PlanOutcome::StartBlocked) {
      if (escape(map, vehicle, t_s)) return ExplorationStatus::Planned;  // the detour goes on from there
      if (step.reason == ReplanReason::CollisionRisk) hold(vehicle, t_s);
      return ExplorationStatus::Failed;
    }
  }

  // Fly to the refined viewpoint of the first cluster; if that fails, to the next clusters' best.
  const std::size_t tries = std::min<std::size_t>(order.size(), std::size_t(params_.max_targets_per_replan));
  bool start_was_clear = true;
  for (std::size_t k = 0; k < tries; ++k) {
    const Target& t = targets[order[k]];
    const FrontierCluster* cluster = frontiers_.find(t.cluster);
    const bool refined_here = k == 0 && !detour && !refined.choice.empty();
    const Viewpoint& view = refined_here ? layers[0][refined.choice[0]] : t.views->front();
    const PlanOutcome outcome = planTo(map, vehicle, view, t_s);
    if (outcome == PlanOutcome::Ok) {
      target_ = t.cluster;
      target_voxels_ = cluster->voxels;
      MapProbe probe(map.sightMap());
      target_promised_ =
          visibleVoxels(probe, view.position_W, view.yaw_rad, cluster->samples, params_.viewpoint.camera);
      step.target = t.cluster;
      return ExplorationStatus::Planned;
    }
    if (outcome == PlanOutcome::StartBlocked) {
      // Not this target's fault, but the way to the one flown to so far ended blocked: one failure
      // for that, so that a target whose approach keeps getting blocked is given up.
      addTargetFailure();
      start_was_clear = false;
      if (!escape(map, vehicle, t_s)) break;
      clearTarget();
      return ExplorationStatus::Planned;
    }
    addFailure(*cluster);
  }
  // Every target failed from a clear start: the vehicle may have squeezed into a place whose way
  // out is narrower, in the map as it reads now, than a path search can find (a corridor behind
  // shelving that thin structure, seen on the way in, narrowed). It goes back the way it came.
  if (tries > 0 && start_was_clear && chained_backtracks_ < kMaxChainedBacktracks &&
      retreat(map, vehicle, t_s, /*farthest=*/true)) {
    ++chained_backtracks_;
    ++counters_.retreats;
    escape_end_t_ = t_s + trajectory_.duration();
    escape_is_retreat_ = true;
    clearTarget();
    return ExplorationStatus::Planned;
  }
  if (step.reason == ReplanReason::CollisionRisk) hold(vehicle, t_s);
  return ExplorationStatus::Failed;
}

ExplorationManager::PlanOutcome ExplorationManager::planTo(const MapQuery& map, const VehicleState& vehicle,
                                                           const Viewpoint& view, double t_s) {
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
  if (!path.ok()) return PlanOutcome::Failed;
  TrajectoryResult traj = planTrajectory(path.waypoints, vehicle, view.yaw_rad, *plan_map, params_.trajectory);
  if (!traj.ok()) return PlanOutcome::Failed;
  startTrajectory(std::move(traj.trajectory), t_s);
  if (!start_free) chained_escapes_ = 0;
  chained_backtracks_ = 0;
  return PlanOutcome::Ok;
}

void ExplorationManager::recordFlown(const Vec3d& p_W, double voxel_m) {
  if (!flown_W_.empty() && (p_W - flown_W_.back()).norm() < voxel_m) return;
  flown_W_.push_back(p_W);
  if (flown_W_.size() > kFlownKept) flown_W_.pop_front();
}

bool ExplorationManager::retreat(const MapQuery& map, const VehicleState& vehicle, double t_s, bool farthest) {
  const double vs = map.voxelSize(), r = params_.path.clearance_m;
  MapProbe probe(map);
  std::vector<Vec3d> way{vehicle.position_W};
  double length = 0.0;
  std::size_t keep = 0;      // flown positions left once back at the end: those flown before it
  std::size_t way_end = 0;  // the end's index in `way`
  for (std::size_t i = flown_W_.size(); i-- > 0;) {
    const Vec3d& q = flown_W_[i];
    const double step = (q - way.back()).norm();
    if (length + step > kRetreatReach_m) break;
    if (step < 1e-3) continue;
    length += step;
    way.push_back(q);
    if (length >= vs && params_.box_W.contains(q) && probe.isClear(q, r)) {
      keep = i + 1;
      way_end = way.size() - 1;
      if (!farthest) break;
    }
  }
  if (keep == 0) return false;
  way.resize(way_end + 1);
  const AssumeFreeMap corridor_map(map, corridorAround(way, r + vs), /*occupied_too=*/true);
  // From rest: a lead-in along the current velocity would first fly on toward what blocked it.
  VehicleState at_rest = vehicle;
  at_rest.velocity_W.setZero();
  TrajectoryResult traj = planTrajectory(way, at_rest, vehicle.yaw_rad, corridor_map, params_.trajectory);
  if (!traj.ok()) return false;
  // The positions between here and the end are forgotten, so that a retreat from the end goes on
  // backwards instead of returning here.
  flown_W_.resize(keep);
  startTrajectory(std::move(traj.trajectory), t_s);
  return true;
}

bool ExplorationManager::escape(const MapQuery& map, const VehicleState& vehicle, double t_s) {
  if (retreat(map, vehicle, t_s)) {
    ++counters_.retreats;
    escape_is_retreat_ = true;
  } else if (chained_escapes_ < kMaxChainedEscapes && escapeStraight(map, vehicle, t_s)) {
    ++chained_escapes_;
    escape_is_retreat_ = false;
  } else {
    return false;
  }
  ++counters_.escapes;
  escape_end_t_ = t_s + trajectory_.duration();
  return true;
}

bool ExplorationManager::escapeStraight(const MapQuery& map, const VehicleState& vehicle, double t_s) {
  const double vs = map.voxelSize(), r = params_.path.clearance_m;
  const Vec3d& p = vehicle.position_W;
  MapProbe probe(map);

  // Away from the occupied voxels within the clearance (+ a voxel for their extent).
  Vec3d away = Vec3d::Zero();
  const int n = int(std::ceil((r + vs) / vs));
  const openvdb::Coord c = map.worldToVoxel(p);
  for (int dx = -n; dx <= n; ++dx)
    for (int dy = -n; dy <= n; ++dy)
      for (int dz = -n; dz <= n; ++dz) {
        const openvdb::Coord v = c.offsetBy(dx, dy, dz);
        const Vec3d d = p - map.voxelCenter(v);
        if (d.norm() > r + vs || probe.at(v) != Occupancy::Occupied) continue;
        away += d.norm() > 1e-9 ? Vec3d(d.normalized()) : Vec3d::Zero();
      }
  // Candidate directions: away first, then the 26 grid directions most aligned with it.
  const Vec3d a = away.norm() > 1e-9 ? Vec3d(away.normalized()) : Vec3d::Zero();
  std::vector<Vec3d> dirs;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) dirs.push_back(Vec3d(x, y, z).normalized());
  std::stable_sort(dirs.begin(), dirs.end(), [&a](const Vec3d& u, const Vec3d& w) { return u.dot(a) > w.dot(a); });
  if (!a.isZero()) dirs.insert(dirs.begin(), a);

  // The nearest clear point (preferring the away direction) whose straight way crosses no
  // occupied voxel beyond the vehicle's own.
  const auto wayFree = [&](const Vec3d& q) {
    const double len = (q - p).norm();
    for (double t = 0.5 * vs; t <= len; t += 0.5 * vs)
      if (probe.atWorld(p + (q - p) * (t / len)) == Occupancy::Occupied) return false;
    return true;
  };
  for (double d = vs; d <= kEscapeReach_m + 1e-9; d += vs) {
    for (const Vec3d& u : dirs) {
      const Vec3d q = p + u * d;
      if (!params_.box_W.contains(q) || !probe.isClear(q, r) || !wayFree(q)) continue;
      // The move was checked here: let the trajectory pass the voxels near the start.
      const AssumeFreeMap escape_map(map, corridorAround({p, q}, r + vs), /*occupied_too=*/true);
      TrajectoryResult traj = planTrajectory({p, q}, vehicle, vehicle.yaw_rad, escape_map, params_.trajectory);
      if (!traj.ok()) continue;
      startTrajectory(std::move(traj.trajectory), t_s);
      return true;
    }
  }
  return false;
}

}  // namespace vdbmap::planner
