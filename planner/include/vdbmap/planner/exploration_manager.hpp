// The exploration manager: FUEL's finite-state logic (Zhou et al. 2021, exploration_fsm), on the
// planner's building blocks, knowing nothing of where the map and the vehicle state come from.
// docs/exploration.md ("The manager") describes each decision and why it is made.
//
// The caller feeds it, once per map update (e.g. per integrated depth frame), the map (a MapQuery
// valid for that call only), the region the map reports as changed, the vehicle's estimated state
// and the time. Each update
//  1. refreshes frontiers in that region and the viewpoints of the clusters that changed;
//  2. decides whether to replan (ReplanReason: FUEL's three triggers, collision risk on the rest
//     of the trajectory, a frame shift, a failed replan, an ALC detour that timed out; with the
//     safety layer, SafetyConfig, an emergency stop or a look along the way);
//  3. replans: the global tour over the best viewpoint of every target, with ALC the choice of a
//     loop-closing detour, local refinement, a path and a trajectory to the first target that
//     can be reached (up to max_targets_per_replan), counting failures against targets and
//     blacklisting those that keep failing; a start blocked by occupied voxels is left by
//     retreating along the way flown or, without one, by a short straight escape; when every
//     target fails from a clear start, the vehicle goes back the way it came;
//  4. finishes when no target is left and the vehicle has come to rest.
//
// Its state is explicit: the phase of the run (ExplorationPhase: the turn on the spot at take-off,
// exploring, the final sweep of small clusters), what the current trajectory is for (FlightKind:
// hold, turn, to a target, loop detour, escape, retreat), and the events waiting for the next
// update (a frame shift, a failed replan, a loop closure). activity() reads them for reporting.
//
// The vehicle is expected to follow command(t) (the current trajectory, in the frame of the
// vehicle's estimate); update() plans from the given state, which should be that command's state
// (position and yaw from the estimate, velocity from the command). Every planner piece reads the
// map through an AssumeFreeMap with a box around the start position, where unknown reads as free
// (the camera cannot see there at take-off).
//
// Expected outcomes are statuses, never exceptions: Planned, Continue, NoFrontier, Failed (retried
// on the next update while the old trajectory, or a hold, continues) and Finished.
//
// Determinism: with the same inputs and no time limit hit (OMPL, ATSP), the decisions repeat.
// Planner times (planner_ms) are measured wall times.
#pragma once

#include "vdbmap/planner/active_loop_closure.hpp"
#include "vdbmap/planner/cost.hpp"
#include "vdbmap/planner/escape_planner.hpp"
#include "vdbmap/planner/frontier.hpp"
#include "vdbmap/planner/local_refinement.hpp"
#include "vdbmap/planner/odometry_drift.hpp"
#include "vdbmap/planner/path_planner.hpp"
#include "vdbmap/planner/recent_frames.hpp"
#include "vdbmap/planner/recent_obstacle_map.hpp"
#include "vdbmap/planner/target_book.hpp"
#include "vdbmap/planner/tour.hpp"
#include "vdbmap/planner/trajectory.hpp"
#include "vdbmap/planner/vehicle_state.hpp"
#include "vdbmap/planner/viewpoint.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

namespace vdbmap::planner {

/// Where the safety layer's checks of the way count the path flown since a frame in its drift
/// (SafetyConfig::path_drift).
enum class PathDriftScope {
  Off,           ///< nowhere: a frame's age alone
  NearSurfaces,  ///< where the way passes within clearance_m + drift_tolerance_m of a recent surface
  Everywhere,    ///< at every point of the way checked
};
const char* toString(PathDriftScope scope);

/// The drift-free safety layer near the vehicle: the last seconds of depth frames
/// (ExplorationManager::addDepthFrame, recent_frames.hpp). With it, every update
///  - checks that the rest of the trajectory keeps clearance_m from the recent frames' surfaces
///    (recent_obstacle_map.hpp); if it does not, while the global map finds it clear, the manager
///    replans at once and stops if no plan is found (an emergency stop,
///    ReplanReason::EmergencyStop);
///  - looks where the vehicle flies: the way ahead within its braking distance plus look_margin_m
///    must have been seen free by a recent frame young enough when the vehicle gets there
///    (seen_until_arrival, seenAge_s()) (or, while the whole map is younger than
///    trustedAge_s(), be clear in the map), and the points look_side_m to its left and right must
///    have been seen (free, or near a recent surface); else the vehicle brakes along its velocity
///    and turns toward that point (ReplanReason::LookAhead, FlightKind::Look). As soon as it faces
///    it and a frame sees it (ReplanReason::WaySeen), it flies on along the rest of the way
///    it was flying; else it replans at rest. A point more steeply above or below the vehicle
///    than the camera's vertical half field of view, which no yaw brings into view, is checked
///    at the steepest point of its vertical line in view (look_steep: walls and door jambs beside
///    a climb are vertical); within clearance_m across, where the vehicle's own clearance lies,
///    it is exempt.
/// Paths and trajectories are planned with the recent surfaces as obstacles too (and, with
/// seen_free_is_free, the space recent frames saw free as free), and (face_travel) their yaw faces
/// the way while moving.
struct SafetyConfig {
  bool enabled = false;
  /// Trajectories to targets face the direction of travel while moving
  /// (TrajectoryConfig::yaw_along_travel), so that the camera sees the way it flies and looks are
  /// rare, unless the recent frames saw all of their way free already (then the yaw is spread
  /// over the motion, which turns less).
  bool face_travel = true;
  /// The window and pooling of the recent frames; max_range_m and free_margin_m are set by the
  /// manager (the viewpoint camera's max range, clearance_m), and so are window_s (to window_s())
  /// and dense_s (to the window_s given here).
  RecentFramesConfig recent;
  /// The odometry's expected drift, when known (a VIO's noise spec; the simulator declares its
  /// drift level's). With it the recent frames are trusted for as long as that drift allows, up
  /// to max_window_s (window_s()); without it, for recent.window_s.
  std::optional<OdometryDrift> odometry;
  /// The longest window the odometry's drift may widen recent.window_s to; (0, 600]
  double max_window_s = 60.0;
  /// The drift (one sigma) a recent frame may carry relative to the vehicle, at a point
  /// drift_lever_m from the camera. 0.2 m at 2 m is what the 10 s window bore at s3 and s4
  /// without collision (those levels predict 0.21 and 0.27 m; docs/exploration.md); [0, 10]
  double drift_tolerance_m = 0.2;
  double drift_lever_m = 2.0;  ///< [0, 100]
  /// What the rest of the trajectory keeps from recent surface voxels' centres (the vehicle's
  /// radius, plus a margin for voxels: the simulator's vehicle is 0.2 m); also how far in front of
  /// a surface a point must be to be seen free; [0, 5]
  double clearance_m = 0.25;
  /// The way ahead that must have been seen free: the braking distance v^2 / (2 a_max) plus this
  /// (a frame period of flight, and the vehicle's radius); [0, 10]
  double look_margin_m = 0.5;
  /// How far to the left and right of the way ahead must have been seen too (free, or near a
  /// recent surface): a way seen free down its middle may pass a wall no frame saw, under drift
  /// a wall the global map holds elsewhere; 0: the middle only; [0, 5]
  double look_side_m = 0.25;
  /// A point of the way ahead more steeply above or below the vehicle than the camera's vertical
  /// half field of view is checked at the steepest point of its vertical line in view (true), or
  /// exempt (false)
  bool look_steep = true;
  /// A point of a way counts as seen only by frames at most seenAge_s() old when the vehicle gets
  /// there (flying the trajectory as planned). A way seen only by frames about to leave the window
  /// is unseen by the time it is flown (a look stop then finds it unseen within the braking
  /// distance, at speed, the camera turned away); and where the window is longer than the
  /// declared drift bears (s4), what its older frames saw free may lie a wall's clearance off.
  /// False: any frame in the window counts.
  bool seen_until_arrival = true;
  /// With seen_until_arrival and a declared drift, where a frame's drift at arrival also counts
  /// the path the vehicle flies from the frame's capture to the point (OdometryDrift::displacement_m
  /// with path_m): the yaw error turns every metre flown, so at speed a frame is trusted for less
  /// time (at s3 9.4 s at rest, about 3.2 s at 1.5 m/s, never below kMinSeenAge_s). Off (the
  /// default until its runs are measured on every report world; docs/exploration.md, "Stop 76"):
  /// by the frame's age alone.
  PathDriftScope path_drift = PathDriftScope::Off;
  /// With seen_until_arrival and a declared drift: where the way passes within clearance_m +
  /// drift_tolerance_m of a recent surface, a frame counts as having seen it only while its
  /// declared drift at arrival stays within this (nearSeenAge_s()). A surface seen some seconds
  /// before may sit drift_tolerance_m nearer than it looks, which is all the clearance there is:
  /// near one, the way must have been seen lately, so the vehicle faces it (or looks) before it
  /// passes. 0 (the default until its runs are measured on every report world; 0.1 m tried in
  /// docs/exploration.md, "Stop 70"): no tighter rule near surfaces; 0 or [0, drift_tolerance_m)
  double near_drift_tolerance_m = 0.0;
  /// Looks in a row that leave the way ahead unseen before the target gets a failure and the
  /// vehicle holds (the way may be hidden behind a corner); [1, 100]
  int max_chained_looks = 3;
  /// Paths and trajectories also read free the voxels a recent frame saw free, whatever the
  /// global map says (recent_obstacle_map.hpp): a door that drift closed in the map, seen open now,
  /// is open. The runs behind the default: docs/exploration.md, "Stop 59".
  bool seen_free_is_free = true;
  /// Paths and trajectories read the global map's thin structure as obstacles
  /// (TsdfMapQueryConfig: tsdf valleys and free voxels holding surface end points). Off, they read
  /// the map's own states (MapQuery::sightMap) and only the recent surfaces stand for thin
  /// structure. Under drift end points do not average as the tsdf does: a surface seen again at
  /// another drift leaves its earlier end points in what the map now holds free, a ghost of it,
  /// and those read as walls (a door closed by the ghost of the corridor's wall). The runs behind
  /// the default: docs/exploration.md, "Stop 59". mapThinObstacles() says what flight reads.
  bool map_thin_obstacles = false;
  /// Read the global map's thin structure also when the declared odometry does not drift at all
  /// (s1): a surface seen again then lands where it was, so no ghost is left, and a post or a
  /// board's end thinner than a voxel is in the map only as thin structure (the recent frames
  /// hold it only while they see it; docs/exploration.md, "Stop 88").
  bool map_thin_without_drift = true;
  /// How far paths and trajectories keep from the global map's surfaces straight above and below,
  /// beyond their clearance (RecentObstacleMap's vertical margin, rounded to voxels). The camera
  /// sees neither straight up nor down, so drift can bring a beam overhead closer than the map
  /// holds without any look showing it. Applied only when the odometry may drift; with a declared
  /// odometry it grows with the map's age (verticalMargin_m()); [0, 2]
  double vertical_margin_m = 0.2;
  /// With a declared odometry the margin grows to this many sigmas of its vertical drift over the
  /// map's age: a surface mapped t seconds ago may sit that much off relative to the vehicle
  /// (OdometryDrift::axisDisplacement_m); [0, 10]
  double vertical_margin_sigmas = 2.0;
  /// The most the margin grows to (it never falls below vertical_margin_m). Each 0.1 m more takes
  /// 0.2 m from the band a path may use under a door's lintel (docs/exploration.md, "Stop 61":
  /// at 0.5 m the offices' runs failed far more paths and ended early); [0, 2]
  double max_vertical_margin_m = 0.3;

  void validate() const;
  /// The vertical margin while the oldest frame in the map is map_age_s >= 0 seconds old: 0 when
  /// the declared odometry does not drift at all (every term 0); vertical_margin_m without a
  /// declared odometry; else vertical_margin_sigmas x its vertical drift after map_age_s, clamped
  /// to [vertical_margin_m, max(vertical_margin_m, max_vertical_margin_m)]. Throws
  /// std::invalid_argument for an invalid config or a negative or non-finite age.
  double verticalMargin_m(double map_age_s = 0.0) const;
  /// Whether paths and trajectories read the global map's thin structure as obstacles:
  /// map_thin_obstacles, or map_thin_without_drift with a declared odometry that does not drift
  /// at all. Throws std::invalid_argument for an invalid config.
  bool mapThinObstacles() const;
  /// How long the recent frames are trusted: trustedAge_s() clamped to [recent.window_s,
  /// max_window_s] (recent.window_s without a known odometry, or when max_window_s is shorter).
  /// Throws std::invalid_argument for an invalid config.
  double window_s() const;
  /// How old a frame may be and still sit within drift_tolerance_m of where the declared odometry
  /// says (OdometryDrift::longestWithin up to 1e9 s, i.e. always without drift); 0 when no
  /// odometry is declared. While the whole map is younger, it counts as seen by recent frames.
  double trustedAge_s() const;
  /// How old, when the vehicle gets to a point of its way, a frame may be and still count as
  /// having seen it (seen_until_arrival): window_s(), or shorter where the declared drift of that
  /// age exceeds drift_tolerance_m (trustedAge_s(); s4: 6 s of its 10 s window), never below
  /// kMinSeenAge_s (the way ahead at v_max is a second's flight). Throws std::invalid_argument for
  /// an invalid config.
  double seenAge_s() const;
  /// How old, when the vehicle gets to a point of its way that passes near a recent surface
  /// (near_drift_tolerance_m), a frame may be and still count as having seen it: the age whose
  /// declared drift at drift_lever_m reaches near_drift_tolerance_m (s3: 2.6 s), within
  /// [kMinSeenAge_s, seenAge_s()]; seenAge_s() without declared drift or with the rule off (0).
  /// Throws std::invalid_argument for an invalid config.
  double nearSeenAge_s() const;
  static constexpr double kMinSeenAge_s = 2.0;
};

/// Which small clusters the final sweep visits (ExplorationManagerConfig::final_sweep). A pocket
/// is a small cluster (of a component below frontier.min_cluster_size) left when the sweep began;
/// a cluster made since from one of its voxels (what remains of it after part of it was seen)
/// belongs to it. Clusters of components of frontier.min_cluster_size or more are targets always.
enum class FinalSweepScope {
  All,          ///< every small cluster, also those that appear during the sweep (e.g. where a loop
                ///< correction moved a surface), until covered or blacklisted
  Pockets,      ///< the pockets, until covered or blacklisted
  PocketsOnce,  ///< each pocket until the visit of one of its clusters is over (judged at the
                ///< viewpoint, or covered on the way)
};
const char* toString(FinalSweepScope s);

struct ExplorationManagerConfig {
  /// The exploration box (world frame): frontiers, viewpoints and paths stay inside. Required.
  Eigen::AlignedBox3d box_W;
  /// The pieces' parameters. Their bounds_W are set from box_W by the manager (viewpoints use
  /// box_W shrunk by viewpoint.min_clearance_m, so that a viewpoint's clear ball lies in the box).
  FrontierConfig frontier;
  ViewpointConfig viewpoint;
  CostConfig cost;
  /// Paths the vehicle flies: a longer OMPL budget than the cost paths, and the lattice where
  /// RRTConnect finds nothing (a door narrowed by drift; docs/exploration.md, "Stop 64").
  PathConfig path = flightPathDefaults();
  /// Paths only measured for costs (pair table, legs from the vehicle, refinement).
  PathConfig cost_path = costPathDefaults();
  TourConfig tour = tourDefaults();
  RefinementConfig refinement;
  TrajectoryConfig trajectory;

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
  /// When every target tried at a replan fails from a clear start, their failures count only if
  /// the last such replan whose failures counted is at least this long ago. A failed replan is
  /// retried at the next frame: in a map still being corrected around the vehicle (a loop
  /// closure's re-integration), fifteen such retries a second are one piece of evidence, and
  /// would otherwise blacklist every target within a second and end the run; [0, 60]
  double all_failed_spacing_s = 1.0;
  /// Times per run that, when no target is left but frontier clusters are (blacklisted, or with
  /// no viewpoint when they were last computed), every blacklisted cluster gets one more try
  /// (its failures drop to max_failures - 1) and every cluster's viewpoints are computed again
  /// in the current map. 0: exploration finishes the first time no target is left; [0, 100]
  int revisit_rounds = 0;
  /// The final sweep: the first time no target is left, the frontier's min cluster size drops
  /// to this (when smaller than frontier.min_cluster_size), so that the small unknown pockets
  /// FUEL's cluster_min ignores (between shelves, behind posts) are visited at the end, in one
  /// tour (final_sweep says which). 0: off; [0, 1e8]
  int final_min_cluster_size = 30;
  /// From the first time no target is left (where the final sweep begins), a cluster of at least
  /// viewpoint.fallback.large_cluster_voxels frontier voxels takes this fallback threshold
  /// (ViewpointFallback::large_min_visible_samples) when it is lower than the one it had, and the
  /// large clusters still without a viewpoint get theirs computed again then. Goods on shelving,
  /// seen a few voxels per gap, are looked into at the end, not in many looks among aisles still
  /// being explored (docs/exploration.md, "Stop 84"). From then on viewpoints also score by FUEL's
  /// rule alone (ViewpointConfig::vertical_into_unknown off), and every cluster that had none by
  /// the vertical rule gets its viewpoints computed again. 15 or more: off; [0, 1e6]
  int late_large_min_visible_samples = 5;
  /// Which small clusters the final sweep visits (docs/exploration.md, "Final sweep").
  FinalSweepScope final_sweep = FinalSweepScope::PocketsOnce;
  /// Targets tried per replan, in tour order, when the first ones fail; [1, 100]
  int max_targets_per_replan = 3;
  /// Periodic and frame-shift replans, and the replan that ends a look (SafetyConfig), keep the
  /// current target first while it is a live target
  /// (its cluster, or the cluster re-made from most of its voxels; not covered, not blacklisted):
  /// the tour and the path are planned anew, but the vehicle flies on to where it was going until
  /// the visit is over and judged. Off, as in FUEL, the tour's first target wins every replan.
  bool keep_target = true;

  /// Parts of the initial turn: 360 deg in this many turns, each shorter than half a turn so
  /// that the trajectory's shortest-way yaw profile turns the intended way; [3, 36]
  int initial_turn_parts = 3;
  /// Spacing of the collision-risk check along the rest of the trajectory, in voxels; (0, 10]
  double risk_check_spacing_vox = 0.5;
  /// Retreats and straight escapes out of a blocked start: how many flown positions are kept and
  /// how far each reaches (bounds_W, clearance_m and trajectory are set by the manager; the
  /// trajectory never faces the way, so an escape moves off at once, holding its yaw).
  EscapeConfig escape;
  /// Straight escapes in a row (without a plan from a clear start in between) before giving up:
  /// a chain of them creeps wherever the map's errors push it; [0, 100]
  int max_chained_escapes = 3;
  /// Goings back the way flown in a row (without a plan in between) after every target failed
  /// from a clear start; [0, 100]
  int max_chained_backtracks = 2;

  /// The drift-free safety layer near the vehicle (SafetyConfig); off by default.
  SafetyConfig safety;

  /// Active loop closure (active_loop_closure.hpp). Off by default, so that the manager is plain
  /// FUEL; alc.unreachable_cost_s is set from cost.unreachable_cost_s by the manager.
  bool alc_enabled = false;
  AlcConfig alc;

  /// The defaults of `path` and `cost_path` (0.1 s and 0.01 s OMPL budgets; `path` falls back
  /// to the lattice).
  static PathConfig flightPathDefaults();
  static PathConfig costPathDefaults();
  /// The default of `tour`: at most 32 pairs of targets planned per replan (TourConfig::max_planned_pairs).
  static TourConfig tourDefaults();
  /// Throws std::invalid_argument naming the field and its allowed range (including the pieces').
  void validate() const;
};
using ExplorationParams [[deprecated("renamed ExplorationManagerConfig")]] = ExplorationManagerConfig;

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
  FrameShift,         ///< shiftFrame() was called
  Retry,              ///< the previous replan failed
  LoopDetourTimeout,  ///< the loop-closure detour in progress ran out of time without a loop
  EmergencyStop,      ///< the recent frames see the rest of the trajectory blocked; the global map does not
  LookAhead,          ///< the way ahead was not seen free by the recent frames: brake and look (SafetyConfig)
  WaySeen,            ///< a look (LookAhead) saw the way free before it came to rest
};
const char* toString(ReplanReason r);

/// The phase of a run. InitialTurn -> Exploring -> FinalSweep, never back; a run without an
/// initial turn starts Exploring, one without a final sweep never leaves it.
enum class ExplorationPhase {
  InitialTurn,  ///< turning on the spot at take-off (initial_turn)
  Exploring,    ///< flying to frontier targets
  FinalSweep,   ///< the small clusters (final_min_cluster_size) became targets
};
const char* toString(ExplorationPhase p);

/// What the current trajectory is for.
enum class FlightKind {
  Hold,        ///< at rest where the vehicle was (the start, or after a hold)
  Turn,        ///< a part of the initial turn on the spot
  ToTarget,    ///< to a frontier target's viewpoint (or on along a trajectory whose detour ended)
  LoopDetour,  ///< to a loop-closing viewpoint (ALC); no periodic replans on the way
  Escape,      ///< straight out of a start blocked by occupied voxels; no replans but at its end
  Retreat,     ///< back along the way flown; no replans but at its end
  Look,        ///< braking along the way, turning to look along it (SafetyConfig); replanned at its end or once
               ///< the way is seen free
};
const char* toString(FlightKind k);

/// What the vehicle is doing at a moment: how a run's time is accounted (coverage.csv and
/// summary.json's activity_time_s).
enum class ExplorationActivity {
  InitialTurn,  ///< the turn on the spot at take-off
  ToTarget,     ///< flying to a frontier target's viewpoint
  FinalSweep,   ///< flying to a target once the final sweep (final_min_cluster_size) began
  LoopDetour,   ///< flying an active-loop-closure detour
  Escaping,     ///< moving straight out of a start blocked by occupied voxels
  Retreating,   ///< going back along the way flown
  Turning,      ///< turning on the spot: at the goal, or before moving off to face the way
  Holding,      ///< at rest, nothing left to fly (waiting for a replan, or finished)
  Looking,      ///< braking and turning to look along the way ahead (FlightKind::Look, SafetyConfig)
};
inline constexpr int kExplorationActivities = 9;
const char* toString(ExplorationActivity a);

/// A visit that did not see its target, for diagnosis.
struct FailedVisit {
  ClusterId cluster = 0;          ///< the target, as planned
  Vec3d view_W = Vec3d::Zero();   ///< the viewpoint flown to (the estimate's world frame)
  std::size_t judged_voxels = 0;  ///< frontier voxels the visit was judged by (VisitJudgement)
  double gone_fraction = 0.0;     ///< of them, no longer frontier (at most covered_fraction)
};

/// Why a target's path failed from a clear start.
enum class PathFailure {
  GoalBlocked,   ///< the viewpoint is not clear (PathStatus::GoalInvalid)
  NoPath,        ///< no path within the search's budget (PathStatus::NoPath)
  NoTrajectory,  ///< a path, but no collision-free trajectory along it
};
const char* toString(PathFailure f);

/// A target whose path failed, for diagnosis.
struct FailedPath {
  ClusterId cluster = 0;
  Vec3d from_W = Vec3d::Zero();  ///< the vehicle's position (the estimate's world frame)
  Vec3d view_W = Vec3d::Zero();  ///< the viewpoint it tried to reach
  PathFailure why = PathFailure::NoPath;
};

/// What one update() did.
struct ExplorationStep {
  ExplorationStatus status = ExplorationStatus::Continue;
  ReplanReason reason = ReplanReason::None;  ///< why a replan was attempted (None: not attempted)
  ClusterId target = 0;                      ///< cluster the new trajectory flies to (0: none, or a loop detour)
  bool loop_detour = false;                  ///< the new trajectory flies to a loop-closing cluster (ALC)
  std::optional<AlcStatus> alc_status;       ///< ALC's decision at this replan (when ALC is on and it was asked)
  std::size_t clusters = 0;                  ///< live clusters
  std::size_t targets = 0;                   ///< clusters with a viewpoint, not blacklisted
  bool visit_failed = false;                 ///< the visit judged at this replan did not see its target
  FailedVisit failed_visit;                  ///< which visit, when visit_failed
  std::size_t path_failures = 0;             ///< targets whose path or trajectory failed at this replan
  std::vector<FailedPath> failed_paths;      ///< which, and why (path_failures of them)
  std::size_t frontier_voxels = 0;
  double map_update_ms = 0.0;  ///< frontier and viewpoint refresh
  double replan_ms = 0.0;      ///< tour, refinement, path and trajectory (0 without a replan)
};

/// Counters over the manager's life.
struct ExplorationCounters {
  std::size_t updates = 0;
  std::size_t replans = 0;  ///< attempted (including the initial turn's parts)
  std::size_t replans_failed = 0;
  std::size_t collision_risks = 0;       ///< replans triggered by collision risk
  std::size_t target_failures = 0;       ///< failures counted against targets (all kinds)
  std::size_t visit_failures = 0;        ///< visits whose viewpoint did not see the target
  std::size_t path_failures = 0;         ///< targets without a path or trajectory at a replan
  std::size_t blacklisted = 0;           ///< clusters skipped as blacklisted at the last replan
  std::size_t holds = 0;                 ///< times the vehicle was stopped by a hold
  std::size_t escapes = 0;               ///< moves out of a start blocked by occupied voxels (retreats included)
  std::size_t retreats = 0;              ///< escapes back along the way flown
  std::size_t revisit_rounds = 0;        ///< ExplorationManagerConfig::revisit_rounds done
  std::size_t final_sweep_clusters = 0;  ///< clusters the final sweep (final_min_cluster_size) added
  /// clusters without a viewpoint looked at again when no target was left: large ones
  /// (late_large_min_visible_samples), and every one when viewpoint.vertical_into_unknown was on
  std::size_t late_large_clusters = 0;
  std::size_t emergency_stops = 0;       ///< ReplanReason::EmergencyStop replans (SafetyConfig)
  std::size_t look_stops = 0;            ///< ReplanReason::LookAhead: brakings to look along the way (SafetyConfig)
  std::size_t looks_resumed = 0;         ///< looks after which the vehicle flew on along the way it was flying
};

class ExplorationManager {
 public:
  /// Starts at `start` (at rest) at time t_s. Throws std::invalid_argument for invalid params or a
  /// start outside the box.
  ExplorationManager(const ExplorationManagerConfig& params, const VehicleState& start, double t_s);
  ~ExplorationManager();

  const ExplorationManagerConfig& params() const { return params_; }

  /// One cycle: refresh frontiers and viewpoints from `map` in `dirty` (the region changed since
  /// the last call; the first call scans the whole map), then decide and maybe replan from
  /// `vehicle` at time t_s (not before the previous call). `map` is read during the call only.
  ExplorationStep update(const MapQuery& map, const openvdb::CoordBBox& dirty, const VehicleState& vehicle, double t_s);

  /// The commanded state at t_s: the current trajectory (held at its end), in the estimate frame.
  VehicleState command(double t_s) const;
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
  /// the way flown that retreats go back along moves with it, and with ALC the viewpoint history.
  void notifyLoopClosure(double t_s, const std::function<FlatPose(const FlownViewpoint&)>& corrected = {});

  /// A depth frame captured at t_s from the sensor pose T_W_S (the estimate frame, as the
  /// trajectory), for the safety layer (SafetyConfig); ignored when it is off. Frames must come
  /// in time order. Throws std::invalid_argument for an image whose size differs from K's.
  void addDepthFrame(double t_s, const DepthImage& depth, const CameraIntrinsics& K, const Pose3d& T_W_S);
  /// The safety layer's recent frames (null when it is off).
  const RecentFrames* recentFrames() const { return recent_.get(); }
  /// The vertical margin an update at t_s keeps (SafetyConfig::verticalMargin_m for a map as old as
  /// the manager); 0 when the layer is off. Throws std::invalid_argument for a t_s before the start.
  double verticalMarginAt_m(double t_s) const;

  /// Active loop closure (null when alc_enabled is false).
  const ActiveLoopClosure* alc() const { return alc_.get(); }
  /// ALC's counters up to the last update (zero without ALC).
  AlcStats alcStats() const { return alc_ ? alc_->stats(last_t_) : AlcStats{}; }
  /// True while the current trajectory flies a loop-closure detour.
  bool onLoopDetour() const { return flight_ == FlightKind::LoopDetour; }

  const FrontierMap& frontiers() const { return frontiers_; }
  /// The viewpoints of every live cluster (best first), by cluster id.
  const std::map<ClusterId, std::vector<Viewpoint>>& viewpoints() const { return views_; }
  /// Failures counted against a cluster (the median over its voxels).
  int failures(const FrontierCluster& cluster) const { return book_.failures(cluster); }
  bool isBlacklisted(const FrontierCluster& cluster) const { return book_.isBlacklisted(cluster); }
  /// The cluster the current trajectory flies to (0: none).
  ClusterId target() const { return book_.target(); }
  /// True once the initial turn's last part has been flown (seen at the update after it).
  bool initialTurnDone() const { return phase_ != ExplorationPhase::InitialTurn; }
  ExplorationPhase phase() const { return phase_; }
  /// What the current trajectory is for.
  FlightKind flight() const { return flight_; }
  /// What the current trajectory makes the vehicle do at t_s (not before the last update).
  ExplorationActivity activity(double t_s) const;
  const ExplorationCounters& counters() const { return counters_; }

 private:
  struct Target {
    ClusterId cluster;
    const std::vector<Viewpoint>* views;
  };
  /// A replan's choice over the targets: the tour, ALC's decision, the order targets are tried in
  /// and the refined viewpoints of the first ones.
  struct TourChoice {
    std::optional<AlcDecision> decision;  ///< when ALC is on
    bool detour = false;                  ///< fly to a loop-closing viewpoint first
    std::vector<std::size_t> order;       ///< indices into the targets, in the order they are tried
    std::vector<std::vector<Viewpoint>> layers;
    RefinementResult refined;
  };
  enum class PlanOutcome { Ok, StartBlocked, GoalBlocked, NoPath, NoTrajectory };
  /// Events that wait for the next update.
  struct Pending {
    bool frame_shift = false;  ///< shiftFrame() was called: replan
    bool retry = false;        ///< the last replan failed: replan
    bool loop_closed = false;  ///< a loop closure was notified since the last ALC decision
  };
  // ---- frontiers, viewpoints, failures
  void refreshFrontiers(const MapQuery& map, const openvdb::CoordBBox& dirty);
  /// Forgets the viewpoints of the removed clusters and computes those of the added ones.
  void applyFrontierUpdate(const FrontierUpdate& u, const MapQuery& map);
  /// Computes the viewpoints of `clusters` in `map` (in parallel) and stores them in views_.
  void computeViews(const std::vector<const FrontierCluster*>& clusters, const MapQuery& map);
  std::vector<Target> liveTargets(const MapQuery& map);
  /// The rule `view` was scored by: params_.viewpoint, or voxel_rule_ for FUEL's rule's fallback.
  const ViewpointConfig& ruleOf(const Viewpoint& view) const;
  /// True when `view`, in the map `sight` reads, still sees a sample of `cluster` by the rule it
  /// was scored by.
  bool seesAny(MapProbe& sight, const Viewpoint& view, const FrontierCluster& cluster) const;
  /// The final sweep's pockets not yet visited that share a voxel with `cluster` (ascending).
  std::vector<std::size_t> openPockets(const FrontierCluster& cluster) const;
  /// In the final sweep with a scope other than All: a cluster of a component below
  /// frontier.min_cluster_size, a target only as part of a pocket.
  bool smallInSweep(const FrontierCluster& cluster) const;
  /// smallInSweep, and no part of a pocket still to visit: never a target.
  bool outsideSweep(const FrontierCluster& cluster) const;

  // ---- decisions
  /// `recent`: the recent frames' surfaces over `map` (null without the safety layer).
  ReplanReason replanReason(const MapQuery& map, const RecentObstacleMap* recent, double t_s);
  /// The time between the trajectory's samples that checks along it use: risk_check_spacing_vox
  /// voxels at v_max.
  double riskCheckStep_s(double voxel_size_m) const;
  bool remainingTrajectoryClear(const MapQuery& map, double t_s) const;
  /// The rest of the trajectory keeps SafetyConfig::clearance_m from the recent surfaces.
  bool remainingTrajectoryClearOfRecent(const RecentObstacleMap& recent, double t_s) const;
  /// EscapePlanner::retreat; with the safety layer, back along the way flown within the recent
  /// window only (SafetyConfig::window_s()), refusing a way back that passes within
  /// SafetyConfig::clearance_m of this update's recent surfaces beyond its start's own: the way
  /// flown is where odometry and the last correction put it; what the camera saw since is where
  /// the walls are. A way that itself passes closer (the vehicle flew it) lowers that clearance
  /// to its own, less a quarter voxel, but not below collision_radius_m.
  std::optional<Trajectory> retreat(const MapQuery& map, const VehicleState& vehicle, bool farthest);
  /// p_W counts as seen free for flight: a recent frame captured at or after since_t_s saw it
  /// free, or the whole map is younger than SafetyConfig::trustedAge_s (at the last update) and
  /// `map` holds p_W clear by clearance_m.
  bool seenFree(MapProbe& map, const Vec3d& p_W, double since_t_s) const;
  /// A point beside the way counts as seen when a recent frame captured at or after since_t_s saw
  /// it free, a recent surface lies within SafetyConfig::clearance_m of it (of its voxel's centre,
  /// plus half the voxel's diagonal; the surface checks guard that side then), or the whole map
  /// is younger than SafetyConfig::trustedAge_s and `map` knows it.
  bool sideSeen(MapProbe& map, const Vec3d& p_W, double since_t_s) const;
  struct UnseenPoint {
    Vec3d p_W;
    double along_m;  ///< how far along the trajectory from t_from
    bool side;       ///< beside the way (sideSeen), not on it (seenFree)
  };
  /// The first point of the way ahead (SafetyConfig::look_margin_m) not seen (firstUnseen);
  /// nullopt when there is none (or the vehicle is not moving along its trajectory).
  std::optional<UnseenPoint> unseenWayAhead(const MapQuery& map, const VehicleState& vehicle, double t_s) const;
  /// The first point of `trajectory` (moved by `shift`) after t_from, within way_m along it, not
  /// seen free (seenFree), or, SafetyConfig::look_side_m to its left or right, not seen
  /// (sideSeen), by the frames at most SafetyConfig::seenAge_s() old when the trajectory gets
  /// there (seen_until_arrival; the trajectory's time t_from is now). A point more steeply above
  /// or below origin_W than the camera's vertical half field of view is checked at the steepest
  /// point of its vertical line in view (SafetyConfig::look_steep), unless it lies within
  /// SafetyConfig::clearance_m across.
  std::optional<UnseenPoint> firstUnseen(const MapQuery& map, const Trajectory& trajectory,
                                         const Eigen::Isometry3d& shift, double t_from, double way_m,
                                         const Vec3d& origin_W) const;
  /// With SafetyConfig::path_drift: records the estimate's path flown up to t_s.
  void recordFlownLength(const Vec3d& position_W, double t_s);
  /// The estimate's path length flown by t_s (interpolated; clamped to the records kept).
  double flownLengthAt(double t_s) const;
  /// The capture time of the oldest frame that still counts at a point the vehicle reaches at
  /// arrival_s, having flown arrival_length_m (flownLengthAt's scale) by then: its declared drift,
  /// the path flown since included, within SafetyConfig::drift_tolerance_m; not older than
  /// arrival_s - seen_age_s and not newer than arrival_s - SafetyConfig::kMinSeenAge_s.
  double oldestTrustedFrame_s(double arrival_s, double arrival_length_m, double seen_age_s) const;
  /// During a look: the vehicle faces the point it looks for, and it is seen free (seenFree).
  bool lookSawWay(const MapQuery& map, double t_s) const;
  /// After a look saw the way: flies on along the rest of the trajectory the look interrupted
  /// (to the same goal, as the same kind of flight). False when that is no longer clear.
  bool resumeAfterLook(const MapQuery& map, const VehicleState& vehicle, double t_s);
  /// A trajectory along `path_W` to `goal_yaw_rad`, facing the way (SafetyConfig::face_travel)
  /// unless the recent frames saw all of it free, flying while it turns the part they saw.
  TrajectoryResult planFlight(const std::vector<Vec3d>& path_W, const VehicleState& vehicle, double goal_yaw_rad,
                              const MapQuery& map) const;
  /// Brakes along the current trajectory and turns toward `unseen` (FlightKind::Look).
  ExplorationStatus lookAhead(const MapQuery& map, const VehicleState& vehicle, const UnseenPoint& unseen, double t_s);
  /// The current trajectory is an escape or a retreat still being flown.
  bool escaping(double t_s) const;
  bool trajectoryMoves() const { return trajectory_.motionDuration() > 0.0; }

  // ---- replanning, in the order replan() takes the steps
  ExplorationStatus replan(const MapQuery& map, const VehicleState& vehicle, double t_s, ExplorationStep& step);
  /// The live targets; when none is left, the final sweep's small clusters, then (revisit_rounds)
  /// the blacklisted ones once more.
  std::vector<Target> gatherTargets(const MapQuery& map);
  /// The first time no target is left: the large clusters' lower fallback threshold starts to act
  /// (late_large_min_visible_samples), then the final sweep begins (final_min_cluster_size).
  void beginLateTargets(const MapQuery& map);
  /// No target is left: finish once at rest, else let the trajectory run out (NoFrontier). With
  /// ALC, a loop may be closed first (ActiveLoopClosure::decideFinish).
  ExplorationStatus finishOrWait(const MapQuery& map, const VehicleState& vehicle, double t_s, ExplorationStep& step);
  /// Flies ALC's detour before finishing to the next of its cluster's viewpoints that can be
  /// reached (one per flight: drift moves the true pose off each of them differently).
  ExplorationStatus flyFinishDetour(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                    const AlcDecision& decision, bool flight_over, ExplorationStep& step);
  TourChoice chooseTour(const MapQuery& map, const VehicleState& vehicle, double t_s,
                        const std::vector<Target>& targets, ExplorationStep& step);
  std::optional<AlcDecision> decideLoopDetour(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                              const std::vector<TourTarget>& tour_targets, const GlobalTour& global);
  /// Flies ALC's detour; nullopt when no path to it was found (the targets are tried then).
  std::optional<ExplorationStatus> flyDetour(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                             const TourChoice& choice, ExplorationStep& step);
  /// Flies to the first target of choice.order that can be reached (up to max_targets_per_replan);
  /// when every one fails from a clear start, back the way flown.
  ExplorationStatus flyToTargets(const MapQuery& map, const VehicleState& vehicle, double t_s,
                                 const std::vector<Target>& targets, const TourChoice& choice, ExplorationStep& step);
  PlanOutcome planTo(const MapQuery& map, const VehicleState& vehicle, const Viewpoint& view, double t_s,
                     FlightKind kind);
  /// The start is blocked by occupied voxels within the clearance: gets out so that the next
  /// replan starts from a clear point. First back along the way flown (a retreat), else straight
  /// away from the occupied voxels, at most max_chained_escapes times in a row. False: neither
  /// was possible.
  bool escape(const MapQuery& map, const VehicleState& vehicle, double t_s);
  void startTrajectory(Trajectory trajectory, double t_s, FlightKind kind);
  void hold(const VehicleState& vehicle, double t_s);

  ExplorationManagerConfig params_;
  ViewpointConfig voxel_rule_;  ///< params_.viewpoint with FUEL's rule (look_into_unknown off)
  /// params_.viewpoint with the large clusters' late fallback threshold (late_large_min_visible_samples)
  /// and FUEL's rule alone (vertical_into_unknown off): the rule once no target was left
  ViewpointConfig late_rule_;
  std::vector<Eigen::AlignedBox3d> free_boxes_;
  FrontierMap frontiers_;
  std::map<ClusterId, std::vector<Viewpoint>> views_;
  /// The final sweep's pockets (final_sweep not All): the pocket of each voxel of the small
  /// clusters it began with and of the clusters made from them since; whether each pocket was
  /// visited; the current target's pockets (PocketsOnce only: those are marked visited).
  std::unordered_map<openvdb::Coord, std::size_t, CoordHash> pocket_of_;
  std::vector<bool> pocket_visited_;
  std::vector<std::size_t> target_pockets_;
  std::unique_ptr<PairCostTable> table_;
  LegCostCache refinement_legs_;            ///< refinement's edges between viewpoints, kept over replans
  TargetBook book_;                         ///< failures, blacklist, the current target
  Vec3d target_view_W_ = Vec3d::Zero();     ///< the viewpoint of book_'s target (FailedVisit)
  EscapePlanner escapes_;                   ///< the way flown, and the ways out of a blocked start
  /// With SafetyConfig::path_drift: the length of the estimate's path flown by each
  /// update's time (t_s, metres since the start), over the recent window, and the last position.
  std::deque<std::pair<double, double>> flown_length_;
  std::optional<Vec3d> last_flown_W_;
  std::unique_ptr<ActiveLoopClosure> alc_;  ///< null without ALC
  std::size_t finish_views_flown_ = 0;      ///< flights of the detour before finishing so far
  std::unique_ptr<RecentFrames> recent_;    ///< null without the safety layer
  const RecentObstacleMap* recent_map_ = nullptr;  ///< the recent surfaces during update(), else null
  double start_t_ = 0.0;                    ///< when the manager started (the map's oldest frame)

  // The state machine.
  ExplorationPhase phase_ = ExplorationPhase::Exploring;
  bool no_target_left_once_ = false;  ///< no target was left at some replan (late_rule_ applies)
  FlightKind flight_ = FlightKind::Hold;
  Pending pending_;
  int turns_left_ = 0;          ///< parts of the initial turn still to plan
  int chained_escapes_ = 0;     ///< escapes since the last plan that started clear
  double last_all_failed_t_ = -std::numeric_limits<double>::infinity();  ///< counted; all_failed_spacing_s
  int chained_backtracks_ = 0;  ///< retreats after every target failed, since the last plan
  int chained_looks_ = 0;       ///< looks since the way ahead was last seen free
  Vec3d look_at_W_ = Vec3d::Zero();  ///< FlightKind::Look: the point of the way it looks for
  bool look_at_side_ = false;        ///< look_at_W_ lies beside the way (UnseenPoint::side)
  /// FlightKind::Look: the flight it interrupted, from when it was interrupted (resumeAfterLook).
  struct Interrupted {
    Trajectory trajectory;
    Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
    double t_from_s = 0.0;
    FlightKind kind = FlightKind::Hold;
  };
  std::optional<Interrupted> interrupted_;

  // The current trajectory.
  Trajectory trajectory_;
  double trajectory_t0_ = 0.0;
  double map_trusted_until_s_ = 0.0;  ///< start + SafetyConfig::trustedAge_s (seenFree)
  bool map_thin_ = false;             ///< SafetyConfig::mapThinObstacles, with the layer on
  Eigen::Isometry3d shift_ =
      Eigen::Isometry3d::Identity();  ///< applied to trajectory_ (frame shifts since it was planned)

  bool first_update_ = true;  ///< the first update scans the whole map
  double last_t_ = 0.0;
  ExplorationCounters counters_;
};

}  // namespace vdbmap::planner
