// The exploration manager: FUEL's finite-state logic (Zhou et al. 2021, exploration_fsm), on the
// planner's building blocks, knowing nothing of where the map and the vehicle state come from.
//
// The caller feeds it, once per map update (e.g. per integrated depth frame), the map (a MapQuery
// valid for that call only: re-create TsdfMapQuery every cycle), the region the map reports as
// changed, the vehicle's estimated state and the time. The manager then
//  1. refreshes frontiers in that region (FrontierMap::update) and the viewpoints of the clusters
//     that changed (computeViewpoints);
//  2. decides whether to replan, for one of FUEL's reasons:
//     - the current trajectory is nearly done (less than replan_time_left_s to go; FUEL thresh1),
//     - the target cluster is covered (more than covered_fraction of its frontier voxels are no
//       longer frontier) and the trajectory has run replan_covered_after_s (FUEL thresh2),
//     - periodically, replan_period_s into a trajectory (FUEL thresh3),
//     - collision risk: the rest of the trajectory no longer keeps collision_radius_m of
//       known-free space around it in the new map (checked every update),
//     - a frame shift (shiftFrame: a loop closure moved the estimate), or a failed replan to retry;
//     periodic and frame-shift replans keep the current target (keep_target);
//  3. replans: the global tour over the best viewpoint of every live cluster (planGlobalTour), local
//     refinement over the next clusters' top viewpoints (refineLocalTour), a path to the chosen
//     viewpoint (PathPlanner) and a trajectory along it (planTrajectory). When the first target
//     fails (no path, no trajectory) the next ones of the tour are tried, up to
//     max_targets_per_replan;
//  4. counts failures per target and blacklists targets that keep failing: a failure is a failed
//     path or trajectory to it, or a visit (the trajectory to it ended) after which most of the
//     frontier its viewpoint saw when planned is still frontier (it cannot be observed from
//     there; a large cluster, seen only in part from any viewpoint, is judged by that part, so a
//     visit that uncovers it is progress, not a failure). Failures are kept per
//     frontier voxel, because a cluster changes its id whenever its voxels change: a cluster counts
//     the median failure count of its voxels, and is blacklisted at max_failures. When no target
//     is left but clusters are (blacklisted, or without a viewpoint), every blacklisted cluster
//     gets one more try and every cluster's viewpoints are computed again in the map as it is now
//     (revisit_rounds). Before that, with final_min_cluster_size set, the frontier's min cluster
//     size drops once, so that the small clusters are visited in a final sweep;
//  5. with active loop closure on (alc_enabled; active_loop_closure.hpp), every global replan also
//     asks ActiveLoopClosure::decide, with the frontier tour's matrix, whether to fly first to a
//     nearby loop-closing cluster of old viewpoints; on such a detour, local refinement picks
//     among the cluster's viewpoints (alcRefinementLayers) and the vehicle flies there. The caller
//     reports detected loop closures (notifyLoopClosure); a detour ends with a loop closure, or
//     is given up after its timeout (a replan is triggered then, LoopDetourTimeout);
//  5b. a start blocked by occupied voxels within the clearance (a correction moved the map, or
//     thin structure shows up as the vehicle comes near) is left by retreating along the way
//     flown (up to 3 m back, to the newest flown position that is clear); without one, by a
//     straight move away from the voxels (at most 3 in a row). The target flown to gets a failure.
//     When every target tried fails from a clear start, the vehicle goes back along the way flown
//     to the farthest clear flown position within 3 m (at most twice without a plan in between):
//     it came in that way, and the map may have narrowed it since (thin structure seen on the way);
//  6. finishes when no target is left (no cluster with a viewpoint that is not blacklisted) and the
//     vehicle has come to rest: no reachable frontier is left.
// Before exploring, the vehicle turns once on the spot (initial_turn; FUEL's simulations start
// by looking around too), so that its zero-pitch camera sees all round the start.
//
// The vehicle is expected to follow command(t) (the current trajectory, in the frame of the
// vehicle's estimate); update() plans from the given state, which should be that command's state
// (position and yaw from the estimate, velocity from the command). Every planner piece reads the
// map through an AssumeFreeMap with a box around the start position, where unknown reads as free
// (the camera cannot see there at take-off).
//
// Expected outcomes are statuses, never exceptions: Planned, Continue (keep flying), NoFrontier
// (no target now, trajectory still running), Failed (a replan failed; it is retried on the next
// update while the old trajectory, or a hold, continues) and Finished.
//
// Determinism: with the same inputs and no time limit hit (OMPL, ATSP), the decisions repeat.
// Planner times (planner_ms) are measured wall times.
#pragma once

#include "vdbmap/planner/active_loop_closure.hpp"
#include "vdbmap/planner/cost.hpp"
#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/local_refinement.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/tour.hpp"
#include "vdbmap/planner/trajectory.hpp"
#include "vdbmap/planner/vehicle_state.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

namespace vdbmap::planner {

struct ExplorationParams {
  /// The exploration box (world frame): frontiers, viewpoints and paths stay inside. Required.
  Eigen::AlignedBox3d box_W;
  /// The pieces' parameters. Their bounds_W are set from box_W by the manager (viewpoints use
  /// box_W shrunk by viewpoint.min_clearance_m, so that a viewpoint's clear ball lies in the box).
  FrontierParams frontier;
  ViewpointParams viewpoint;
  CostParams cost;
  /// Paths the vehicle flies (a longer OMPL budget than the cost paths).
  PathParams path = flightPathDefaults();
  /// Paths only measured for costs (pair table, legs from the vehicle, refinement).
  PathParams cost_path = costPathDefaults();
  TourParams tour;
  RefinementParams refinement;
  TrajectoryParams trajectory;

  /// Half-sizes of the box around the start position where unknown space reads free; each
  /// [0, 10]. FUEL clears a box around the start too.
  Vec3d start_free_half_size_m = Vec3d(0.6, 0.6, 0.4);
  /// Turn once on the spot before exploring (FUEL-style look-around at take-off).
  bool initial_turn = true;
  /// Viewpoints keep at least this far from the box's bottom and top (and always
  /// viewpoint.min_clearance_m): from there a level camera still sees the floor and the ceiling
  /// from a metre away, and a vehicle whose height drifts keeps its distance from them; [0, 10]
  double viewpoint_margin_z_m = 0.5;

  /// Replan when less than this much of the trajectory is left (FUEL thresh_replan1); [0, 100]
  double replan_time_left_s = 0.5;
  /// Replan when the target is covered and the trajectory has run this long (FUEL thresh_replan2); [0, 100]
  double replan_covered_after_s = 0.5;
  /// Replan when the trajectory has run this long (FUEL thresh_replan3); (0, 1000]
  double replan_period_s = 1.5;
  /// A target is covered when more than this fraction of its frontier voxels (at planning time)
  /// are no longer frontier (a replan trigger); a visit succeeds when more than this fraction of
  /// the frontier samples its viewpoint saw (at planning time) are no longer frontier; (0, 1]
  double covered_fraction = 0.5;
  /// The rest of the trajectory must keep this much known-free space around it (the vehicle's
  /// radius; less than the planning clearance, so that a replan is not triggered by the margin
  /// alone); [0, path.clearance_m]
  double collision_radius_m = 0.15;
  /// Failures of a target (failed path or trajectory, or a visit that did not observe it) before
  /// it is blacklisted; [1, 100]
  int max_failures = 3;
  /// Times per run that, when no target is left but frontier clusters are (blacklisted, or with
  /// no viewpoint when they were last computed), every blacklisted cluster gets one more try
  /// (its failures drop to max_failures - 1) and every cluster's viewpoints are computed again
  /// in the current map: a cluster that failed or had no viewpoint
  /// early, in a half-known map, is often observable from the viewpoints the finished map
  /// allows. Off by default: in the warehouse one round added 30 % flight time for 0.2 % of
  /// coverage. 0: exploration finishes the first time no target is left; [0, 100]
  int revisit_rounds = 0;
  /// The final sweep: the first time no target is left, the frontier's min cluster size drops
  /// to this (when smaller than frontier.min_cluster_size), so that the small unknown pockets
  /// FUEL's cluster_min ignores (between shelves, behind posts) are visited once, in one tour,
  /// at the end. Cheaper than a smaller min cluster size throughout, whose small clusters come
  /// and go while the map grows. In the warehouse it raised coverage from 0.94 to 0.96 for about
  /// 200 s of flight; in the house it adds 5 s. 0: off; [0, 1e8]
  int final_min_cluster_size = 30;
  /// Targets tried per replan, in tour order, when the first ones fail; [1, 100]
  int max_targets_per_replan = 3;
  /// Periodic and frame-shift replans keep the current target first while it is a live target
  /// (its cluster, or the cluster re-made from most of its voxels; not covered, not blacklisted):
  /// the tour and the path are planned anew, but the vehicle flies on to where it was going until
  /// the visit is over and judged. Off, as in FUEL, the tour's first target wins every replan. In
  /// one warehouse run the vehicle then swung between clusters by the south wall for ten minutes,
  /// with a loop closure (and a re-integration re-making the clusters near it) every 5 s, and no
  /// visit ever ended: no failure was counted, nothing was blacklisted, and the run hit its time
  /// limit.
  bool keep_target = true;

  /// Active loop closure (active_loop_closure.hpp). Off by default, so that the manager is plain
  /// FUEL; alc.unreachable_cost_s is set from cost.unreachable_cost_s by the manager.
  bool alc_enabled = false;
  AlcParams alc;

  /// The defaults of `path` and `cost_path` (0.1 s and 0.01 s OMPL budgets).
  static PathParams flightPathDefaults();
  static PathParams costPathDefaults();
  /// Throws std::invalid_argument naming the field and its allowed range (including the pieces').
  void validate() const;
};

enum class ExplorationStatus {
  Continue,    ///< no replan needed: keep following command()
  Planned,     ///< a new trajectory starts now
  NoFrontier,  ///< no target left, the vehicle still moving: it finishes its trajectory
  Failed,      ///< a replan failed (retried on the next update); the old trajectory (or a hold) goes on
  Finished,    ///< no reachable frontier is left and the vehicle is at rest
};
const char* toString(ExplorationStatus s);

enum class ReplanReason {
  None,
  InitialTurn,    ///< the next part of the turn on the spot at take-off
  Start,          ///< the first plan after take-off (or after a hold)
  TrajectoryEnd,  ///< less than replan_time_left_s left
  TargetCovered,
  Periodic,
  CollisionRisk,
  FrameShift,     ///< shiftFrame() was called
  Retry,          ///< the previous replan failed
  LoopDetourTimeout,  ///< the loop-closure detour in progress ran out of time without a loop
};
const char* toString(ReplanReason r);

/// What the vehicle is doing at a moment: how a run's time is accounted (coverage.csv and
/// summary.json's activity_time_s).
enum class ExplorationActivity {
  InitialTurn,  ///< the turn on the spot at take-off
  ToTarget,     ///< flying to a frontier target's viewpoint
  FinalSweep,   ///< flying to a target once the final sweep (final_min_cluster_size) began
  LoopDetour,   ///< flying an active-loop-closure detour
  Escaping,     ///< moving straight out of a start blocked by occupied voxels
  Retreating,   ///< going back along the way flown
  Turning,      ///< at the goal, turning on the spot
  Holding,      ///< at rest, nothing left to fly (waiting for a replan, or finished)
};
inline constexpr int kExplorationActivities = 8;
const char* toString(ExplorationActivity a);

/// What one update() did.
struct ExplorationStep {
  ExplorationStatus status = ExplorationStatus::Continue;
  ReplanReason reason = ReplanReason::None;  ///< why a replan was attempted (None: not attempted)
  ClusterId target = 0;                      ///< cluster the new trajectory flies to (0: none, or a loop detour)
  bool loop_detour = false;                  ///< the new trajectory flies to a loop-closing cluster (ALC)
  std::optional<AlcStatus> alc_status;       ///< ALC's decision at this replan (when ALC is on and it was asked)
  std::size_t clusters = 0;                  ///< live clusters
  std::size_t targets = 0;                   ///< clusters with a viewpoint, not blacklisted
  std::size_t frontier_voxels = 0;
  double map_update_ms = 0.0;  ///< frontier and viewpoint refresh
  double replan_ms = 0.0;      ///< tour, refinement, path and trajectory (0 without a replan)
};

/// Counters over the manager's life.
struct ExplorationCounters {
  std::size_t updates = 0;
  std::size_t replans = 0;          ///< attempted (including the initial turn's parts)
  std::size_t replans_failed = 0;
  std::size_t collision_risks = 0;  ///< replans triggered by collision risk
  std::size_t target_failures = 0;  ///< failures counted against targets
  std::size_t blacklisted = 0;      ///< clusters skipped as blacklisted at the last replan
  std::size_t holds = 0;            ///< times the vehicle was stopped by a hold
  std::size_t escapes = 0;          ///< moves out of a start blocked by occupied voxels (retreats included)
  std::size_t retreats = 0;         ///< escapes back along the way flown
  std::size_t revisit_rounds = 0;   ///< ExplorationParams::revisit_rounds done
  std::size_t final_sweep_clusters = 0;  ///< clusters the final sweep (final_min_cluster_size) added
};

class ExplorationManager {
 public:
  /// Starts at `start` (at rest) at time t_s. Throws std::invalid_argument for invalid params or a
  /// start outside the box.
  ExplorationManager(const ExplorationParams& params, const VehicleState& start, double t_s);
  ~ExplorationManager();

  const ExplorationParams& params() const { return params_; }

  /// One cycle: refresh frontiers and viewpoints from `map` in `dirty` (the region changed since
  /// the last call; the first call scans the whole map), then decide and maybe replan from
  /// `vehicle` at time t_s (not before the previous call). `map` is read during the call only.
  ExplorationStep update(const MapQuery& map, const openvdb::CoordBBox& dirty, const VehicleState& vehicle,
                         double t_s);

  /// The commanded state at t_s: the current trajectory (held at its end), in the estimate frame.
  TrajectoryState command(double t_s) const;
  /// The current trajectory and when it started.
  const Trajectory& trajectory() const { return trajectory_; }
  double trajectoryStartTime() const { return trajectory_t0_; }
  bool trajectoryDone(double t_s) const { return t_s >= trajectory_t0_ + trajectory_.duration(); }

  /// The estimate frame moved (e.g. a loop closure re-anchored the odometry): a pose p in the old
  /// estimate frame is now `shift * p` (a yaw rotation and a translation). The current trajectory
  /// is re-expressed so that the vehicle's path in the world does not change, and a replan is
  /// requested for the next update (the map is being corrected too).
  void shiftFrame(const Eigen::Isometry3d& shift);

  /// A loop closure was detected at t_s (for ALC: it ends a detour and starts the quiet period at
  /// the next replan). `corrected`, when given, maps a recorded viewpoint (stamped with the t_s of
  /// the update() that fed it) to its corrected pose in the estimate frame after the correction;
  /// the viewpoint history moves with it. Without ALC, nothing happens.
  void notifyLoopClosure(double t_s, const std::function<PoseTarget(const FlownViewpoint&)>& corrected = {});

  /// Active loop closure (null when alc_enabled is false).
  const ActiveLoopClosure* alc() const { return alc_.get(); }
  /// ALC's counters up to the last update (zero without ALC).
  AlcStats alcStats() const { return alc_ ? alc_->stats(last_t_) : AlcStats{}; }
  /// True while the current trajectory flies a loop-closure detour.
  bool onLoopDetour() const { return on_detour_; }

  const FrontierMap& frontiers() const { return frontiers_; }
  /// The viewpoints of every live cluster (best first), by cluster id.
  const std::map<ClusterId, std::vector<Viewpoint>>& viewpoints() const { return views_; }
  /// Failures counted against a cluster (the median over its voxels).
  int failures(const FrontierCluster& cluster) const;
  bool isBlacklisted(const FrontierCluster& cluster) const { return failures(cluster) >= params_.max_failures; }
  /// The cluster the current trajectory flies to (0: none).
  ClusterId target() const { return target_; }
  /// True once the initial turn's last part has been flown (seen at the update after it).
  bool initialTurnDone() const { return !turning_; }
  /// What the current trajectory makes the vehicle do at t_s (not before the last update).
  ExplorationActivity activity(double t_s) const;
  const ExplorationCounters& counters() const { return counters_; }

 private:
  struct Target {
    ClusterId cluster;
    const std::vector<Viewpoint>* views;
  };
  enum class PlanOutcome { Ok, Failed, StartBlocked };
  struct CoordHash {
    std::size_t operator()(const openvdb::Coord& c) const noexcept {
      return std::size_t(c.x()) * 73856093u ^ std::size_t(c.y()) * 19349663u ^ std::size_t(c.z()) * 83492791u;
    }
  };
  void refreshFrontiers(const MapQuery& map, const openvdb::CoordBBox& dirty);
  /// Forgets the viewpoints of the removed clusters and computes those of the added ones.
  void applyFrontierUpdate(const FrontierUpdate& u, const MapQuery& map);
  /// Computes the viewpoints of `clusters` in `map` (in parallel) and stores them in views_.
  void computeViews(const std::vector<const FrontierCluster*>& clusters, const MapQuery& map);
  ReplanReason replanReason(const MapQuery& map, double t_s);
  bool remainingTrajectoryClear(const MapQuery& map, double t_s) const;
  double targetCoveredFraction() const;
  /// No target: target_ 0, its voxels and the samples its viewpoint saw cleared.
  void clearTarget();
  /// The index in `targets` of the current target: its cluster, or, when that was made anew
  /// (the map changed around it), the cluster holding most of its frontier voxels; targets.size()
  /// when there is none.
  std::size_t currentTargetIndex(const std::vector<Target>& targets) const;
  /// The fraction of target_promised_ no longer frontier (targetCoveredFraction when it is empty).
  double promisedCoveredFraction() const;
  void checkVisit();
  std::vector<Target> liveTargets(const MapQuery& map);
  ExplorationStatus replan(const MapQuery& map, const VehicleState& vehicle, double t_s, ExplorationStep& step);
  PlanOutcome planTo(const MapQuery& map, const VehicleState& vehicle, const Viewpoint& view, double t_s);
  /// The start is blocked by occupied voxels within the clearance (a correction moved the map,
  /// drift brought the vehicle close to a wall, or voxels of thin structure flicker as it comes
  /// near): gets out so that the next replan starts from a clear point. First back along the way
  /// flown (retreat), else straight away from the occupied voxels to the nearest clear point within
  /// kEscapeReach_m, at most kMaxChainedEscapes times in a row. False: neither was possible.
  bool escape(const MapQuery& map, const VehicleState& vehicle, double t_s);
  /// Flies back along flown_W_ to the newest flown position at least a voxel away that keeps the
  /// path clearance in the current map (the farthest such within reach, with `farthest`), within
  /// kRetreatReach_m of way. The vehicle flew that way, so the way's corridor reads free, occupied
  /// voxels too; the map only vets the end.
  bool retreat(const MapQuery& map, const VehicleState& vehicle, double t_s, bool farthest = false);
  /// Moves straight away from the occupied voxels within the clearance to the nearest clear point
  /// within kEscapeReach_m whose straight way crosses no occupied voxel.
  bool escapeStraight(const MapQuery& map, const VehicleState& vehicle, double t_s);
  /// Records the vehicle's position in flown_W_ (one voxel apart).
  void recordFlown(const Vec3d& p_W, double voxel_m);
  std::optional<AlcDecision> decideLoopDetour(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                              const std::vector<TourTarget>& tour_targets, const GlobalTour& global);
  void startTrajectory(Trajectory trajectory, double t_s);
  void hold(const VehicleState& vehicle, double t_s);
  void addFailure(const FrontierCluster& cluster);
  /// A failure against the current target (its voxels when it was planned); nothing without one.
  void addTargetFailure();

  ExplorationParams params_;
  std::vector<Eigen::AlignedBox3d> free_boxes_;
  /// The vehicle's positions at past updates, one voxel apart, newest last, at most kFlownKept;
  /// in the current estimate frame (moved with it on a frame shift).
  std::deque<Vec3d> flown_W_;
  int chained_escapes_ = 0;  ///< escapes since the last plan that started clear
  int chained_backtracks_ = 0;  ///< retreats after every target failed, since the last plan
  /// The end of the escape (or retreat) being flown: until then no replan but at its end or for a
  /// frame shift, and flown_W_ does not record
  double escape_end_t_ = -std::numeric_limits<double>::infinity();
  bool escape_is_retreat_ = false;  ///< the escape being flown goes back along the way flown
  bool final_sweep_ = false;        ///< the final sweep's small clusters became targets
  FrontierMap frontiers_;
  std::map<ClusterId, std::vector<Viewpoint>> views_;
  std::unique_ptr<PairCostTable> table_;
  std::unordered_map<openvdb::Coord, int, CoordHash> voxel_failures_;  ///< failures counted per frontier voxel

  Trajectory trajectory_;
  double trajectory_t0_ = 0.0;
  Eigen::Isometry3d shift_ = Eigen::Isometry3d::Identity();  ///< applied to trajectory_ (frame shifts since it was planned)
  ClusterId target_ = 0;
  std::vector<openvdb::Coord> target_voxels_;  ///< the target's frontier voxels when it was planned
  /// The target's frontier samples that the viewpoint flown to saw when it was planned: what a
  /// visit is judged by (checkVisit). A large cluster is seen in part from any one viewpoint.
  std::vector<openvdb::Coord> target_promised_;
  int turns_left_ = 0;                         ///< parts of the initial turn still to plan
  bool turning_ = false;                       ///< the initial turn is not over
  bool first_update_ = true;
  bool shift_requested_ = false;
  bool failed_last_ = false;
  bool was_moving_ = false;  ///< the current trajectory moves (not a hold or a turn on the spot)
  std::unique_ptr<ActiveLoopClosure> alc_;  ///< null without ALC
  bool loop_closed_ = false;                ///< a loop closure was notified since the last ALC decision
  bool on_detour_ = false;                  ///< the current trajectory flies to a loop-closing cluster
  double last_t_ = 0.0;
  ExplorationCounters counters_;
};

}  // namespace vdbmap::planner
