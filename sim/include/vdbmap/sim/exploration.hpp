// Exploration in closed loop: the simulated vehicle flies the exploration manager's trajectories,
// its camera's frames go to the Mapper with the drifting pose ESTIMATE, loop-closure corrections
// re-integrate the map, and the planner sees only that map and the estimated vehicle state.
//
// Per drift step (200 Hz) the vehicle tracks the commanded trajectory in the estimate frame, as a
// controller closing the loop on the odometry would: its TRUE pose is the commanded pose mapped
// through the current offset between the true and estimated poses (which the simulator knows and
// the planner does not), so the odometry's drift turns into a drift of the true path. Collisions
// are checked on the true pose against the world: a collision event starts when the true position
// comes closer than vehicle_radius_m to a surface (and ends when it leaves that distance).
//
// Per camera frame (15 Hz), in this order: the frame is recorded in the log (if any), given to the
// manager's safety layer (when planner.safety is on) and integrated by the Mapper at its estimated
// pose; a correction event goes to Mapper::updatePoses, and the
// manager is told that the estimate frame moved (ExplorationManager::shiftFrame, so the vehicle's
// true path does not jump) and that a loop closed (notifyLoopClosure, with the corrected poses of
// the frames, which move active loop closure's viewpoint history); one budgeted re-integration
// cycle runs; then the manager updates frontiers from the map's dirty region and may replan.
//
// Time: simulated time stands still while the planner computes (the vehicle neither waits nor
// moves on during a replan); the planner's wall time per replan is measured and reported
// (planner_ms), so whether it would keep up in real time can be judged: a replan that takes
// longer than a frame period (67 ms) would, on a real vehicle, be flown on the old trajectory for
// that long. At take-off the vehicle hovers through its first replan in the same way (no time
// passes). Three budgets decide how much work a cycle does: OMPL's path searches, the tour
// solver, and the mapper's re-integration cycle. Counted in wall-clock time (as on a robot), they
// make a run depend on the machine's speed and load; counted in iterations and frames
// (setBudgets, BudgetMode::Counted, what `vdbmap explore` uses), the same config gives the same
// run on any machine.
//
// The run finishes when the manager reports Finished (no reachable frontier left, vehicle at
// rest) and no re-integration is pending, or when max_time_s of simulated time have passed.
#pragma once

#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/planner/exploration_manager.hpp"
#include "vdbmap/sim/flight.hpp"
#include "vdbmap/sim/seen_surface.hpp"
#include "vdbmap/sim/simulator.hpp"
#include "vdbmap/sim/surface_coverage.hpp"
#include "vdbmap/sim/world.hpp"

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::sim {

struct ExplorationConfig {
  /// Camera, drift and loop closure. The default camera reports surfaces up to far_clip_m = 30 m,
  /// beyond the sensor's 5 m range, so that the Mapper carves free space up to 5 m toward far
  /// walls (see depth_camera.hpp); pixels that see nothing at all stay invalid (0), as on a real
  /// camera, so close the world (a ceiling cap) where the camera would look into the void.
  SimulatorConfig simulator = defaultSimulator();
  /// Mode (keyframes by default), voxel size and the rest; the integrator's ranges are set from
  /// the camera's.
  MapperConfig mapper;
  /// The exploration manager; box_W is required (exploration_setup below gives defaults).
  planner::ExplorationManagerConfig planner;
  /// Where the vehicle starts (true and estimated pose agree there), at t = 0.
  FlatPose start;
  static constexpr double kDefaultMaxTime_s = 900.0;
  /// Simulated time limit; (0, 1e5]
  double max_time_s = kDefaultMaxTime_s;
  /// A collision: the true position closer than this to a surface; [0, 10]
  double vehicle_radius_m = 0.2;

  static SimulatorConfig defaultSimulator();
  void validate() const;
};

/// What one frame of the run looked like (for progress display).
struct ExplorationProgress {
  double t_s = 0.0;
  std::size_t frames = 0;
  std::size_t clusters = 0;
  std::size_t frontier_voxels = 0;
  std::size_t replans = 0;
  std::size_t loop_closures = 0;
  std::size_t collisions = 0;
  double path_length_m = 0.0;
  planner::ExplorationStatus status = planner::ExplorationStatus::Continue;
};

struct ExplorationRecordConfig {
  /// Record the flight as a log here (replayable by `vdbmap integrate`); empty: no log.
  std::filesystem::path log_dir;
  /// Measure coverage of this surface during the run (ExplorationResult::coverage_timeline), at
  /// the first frame, every coverage_period_s of simulated time, and once more after the final
  /// re-integration; null: no timeline. Read during the call only.
  const ObservableSurface* observable = nullptr;
  double coverage_period_s = 1.0;  ///< (0, 1e4]
  bool overwrite = false;
  std::string description;  ///< stored in the log's simulation.json
  /// Called after every frame.
  std::function<void(const ExplorationProgress&)> progress;
};
using ExplorationOptions [[deprecated("renamed ExplorationRecordConfig")]] = ExplorationRecordConfig;

/// Something that happened in the run, for diagnosis: "loop_closure", "alc_detour" (a detour
/// started), "alc_gave_up" (a detour given up without a loop closure), "collision" (a collision
/// event began in the flight up to this frame), "emergency_stop" (the safety layer found the
/// trajectory blocked, planner::ReplanReason::EmergencyStop), "visit_failed" (a visit ended without
/// seeing its target, with which visit), "path_failed" (one per target without a path or
/// trajectory at a replan, with which target, from where and why).
struct ExplorationEvent {
  double t_s = 0.0;
  std::string what;
  std::optional<planner::FailedVisit> visit = std::nullopt;  ///< visit_failed: the target, its viewpoint, the judgement
  std::optional<planner::FailedPath> path = std::nullopt;    ///< path_failed: the target, from where, to where, why
};

/// The run at one moment (coverage.csv).
struct CoverageSample {
  double t_s = 0.0;
  double coverage = 0.0;          ///< of the observable surface, by the map as it is at t_s
  /// Of the observable surface, by what the camera saw up to t_s at the true poses
  /// (seen_surface.hpp): the exploration's progress, whatever drift did to the map.
  double coverage_seen = 0.0;
  double path_length_m = 0.0;     ///< TRUE path flown so far
  std::size_t clusters = 0;       ///< live frontier clusters
  std::size_t loop_closures = 0;  ///< so far
  double estimate_error_m = 0.0;  ///< estimated vs true sensor position
  planner::ExplorationActivity activity = planner::ExplorationActivity::Holding;
};

/// One camera frame's cycle (cycles.csv).
struct CycleSample {
  double t_s = 0.0;
  double mapper_ms = 0.0;         ///< integration, correction and background cycle
  double planner_ms = 0.0;        ///< frontier refresh and replan when the update replanned; 0 otherwise
  /// The planner's whole work for the frame, replanned or not: the safety layer's frame
  /// (ExplorationManager::addDepthFrame) and the update (refresh, checks of the way ahead, replan)
  double update_ms = 0.0;
  double frame_wall_ms = 0.0;     ///< everything (render, map, planner, log)
  std::size_t queued_frames = 0;  ///< re-integration work left after the cycle
  planner::ExplorationActivity activity = planner::ExplorationActivity::Holding;
  planner::ReplanReason replan = planner::ReplanReason::None;  ///< why this frame's update replanned
};

struct ExplorationResult {
  bool finished = false;            ///< the manager finished (false: the time limit ended the run)
  double exploration_time_s = 0.0;  ///< simulated time from take-off to the finish (or the limit)
  double path_length_m = 0.0;       ///< length of the TRUE path
  std::size_t frames_total = 0;
  std::size_t loop_closures = 0;
  std::size_t collisions = 0;       ///< distinct collision events (true pose vs world)
  double min_clearance_m = 0.0;     ///< smallest true distance to a surface (capped at 2 vehicle radii)
  std::vector<double> planner_ms;   ///< wall time of every update that replanned (frontiers, viewpoints, replan)
  double planner_ms_median = 0.0;
  double planner_ms_max = 0.0;
  double map_update_ms_median = 0.0;  ///< frontier and viewpoint refresh per frame
  /// The planner's whole work per frame (CycleSample::update_ms): what a vehicle's planner thread
  /// must keep up with, replans included.
  double update_ms_median = 0.0;
  double update_ms_p99 = 0.0;
  double update_ms_max = 0.0;
  double frame_wall_ms_median = 0.0;  ///< everything per frame (render, map, planner, log)
  double frame_wall_ms_p99 = 0.0;
  double frame_wall_ms_max = 0.0;
  double integrate_ms_median = 0.0;  ///< the mapper's integration of each frame
  /// The mapper's whole cycle per frame: integration, corrections, and the background cycle
  /// (re-integrations and de-integrations of dropped frames).
  double mapper_ms_median = 0.0;
  double mapper_ms_p99 = 0.0;
  double mapper_ms_max = 0.0;
  std::size_t background_frames = 0;          ///< frames the mapper's background cycles processed
  std::size_t pruned_frames_deintegrated = 0;  ///< frames set cover dropped, de-integrated
  planner::ExplorationCounters planner_counters;
  /// Active loop closure (zeros when config.planner.alc_enabled is false): detours started, time
  /// spent on them (from the decision to the loop closure or the give-up), give-ups, and detours
  /// that ended with a loop closure.
  planner::AlcStats alc;
  std::vector<ExplorationEvent> events;  ///< in time order
  std::vector<CoverageSample> coverage_timeline;  ///< when ExplorationRecordConfig::observable is set
  std::vector<CycleSample> cycles;                ///< every frame
  /// Simulated time per activity (indexed by ExplorationActivity): each frame interval counts for
  /// the activity the manager's update at its start left.
  std::array<double, planner::kExplorationActivities> activity_time_s{};
  double longest_hold_s = 0.0;  ///< the longest stretch of Holding
  std::size_t keyframes_kept = 0;
  std::size_t reintegrated_frames = 0;
  /// Sensor poses T_W_S at every frame: true, and estimated (what the Mapper integrated with).
  std::vector<io::StampedPose> trajectory_true, trajectory_estimate;
  FlightResult flight;              ///< the log's statistics (when a log was recorded)
  std::unique_ptr<Mapper> mapper;   ///< the final map (re-integration queue drained)
  /// What the camera saw at the true poses (when ExplorationRecordConfig::observable is set).
  std::unique_ptr<SeenSurface> seen;
  double wall_s = 0.0;
};

/// Runs the exploration. Throws std::invalid_argument for an invalid config or a start that is not
/// clear of the world; std::runtime_error when the log cannot be written.
ExplorationResult runExploration(const World& world, const ExplorationConfig& config,
                                 const ExplorationRecordConfig& options = {});

/// The defaults for a world: the exploration box is the world's bounding box (after its ceiling
/// clip), and the start is the point nearest the box's centre (x, y) at `start_height_m` above the
/// box's floor whose clearance from every surface is at least `start_clearance_m` (searched on a
/// 0.1 m grid). Throws std::invalid_argument when there is no such point.
Eigen::AlignedBox3d defaultExplorationBox(const World& world);
Vec3d defaultStartPosition(const World& world, const Eigen::AlignedBox3d& box, double start_height_m = 1.0,
                           double start_clearance_m = 0.6);

/// How the per-cycle budgets of the planner and the mapper are counted.
enum class BudgetMode {
  /// Wall-clock limits, as a robot needs them (the parameter structs' defaults): OMPL searches of
  /// 0.1 s (flight paths) and 0.01 s (costs), tours of 0.05 s, re-integration cycles of 20 ms.
  /// Runs vary with the machine's speed and load.
  WallClock,
  /// Iterations and frames (kCounted* below), set to what the wall-clock limits allowed on the
  /// project's 2-core test machine (docs/exploration.md); the wall-clock limits stay as a backstop
  /// 20 times longer. The same config gives the same run on any machine that is not 20 times
  /// slower, with any number of threads.
  Counted,
};
const char* toString(BudgetMode mode);
/// Parses counted / wall-clock; throws std::invalid_argument listing the choices.
BudgetMode parseBudgetMode(const std::string& text);

/// RRTConnect iterations of a flight-path search (PathConfig::max_iterations) in Counted mode.
inline constexpr std::uint64_t kCountedFlightPathIterations = 3000;
/// RRTConnect iterations of a cost-path search in Counted mode.
inline constexpr std::uint64_t kCountedCostPathIterations = 300;
/// Tour-solver rounds (TourConfig::max_iterations) in Counted mode, for both ALC tours as well.
inline constexpr std::uint64_t kCountedTourIterations = 5000;
/// Frames per re-integration cycle (ReintegrationConfig::budget_frames) in Counted mode.
inline constexpr int kCountedReintegrationFrames = 4;

/// Sets the budgets of config.planner (path, cost_path, tour, alc.tour) and
/// config.mapper.reintegration for `mode`, overwriting what was there.
void setBudgets(ExplorationConfig& config, BudgetMode mode);
/// The mapper's part of setBudgets: re-integration cycles of 20 ms (wall clock) or of
/// kCountedReintegrationFrames frames (counted); e.g. for `bench drift --budgets counted`.
void setReintegrationBudget(ReintegrationConfig& reintegration, BudgetMode mode);

/// The odometry drift that `drift` makes (drift.hpp: white noise integrated at rate_hz, so a
/// random walk of sqrt(sigma2 / rate_hz) per sqrt(s)), declared to the planner as a robot's VIO
/// declares its noise: SafetyConfig::odometry.
planner::OdometryDrift odometryDriftOf(const DriftConfig& drift);

/// What `vdbmap explore --drift` sets: the simulator's drift, declared to the planner's safety
/// layer (SafetyConfig::odometry = odometryDriftOf(drift)).
void setDrift(ExplorationConfig& config, const DriftConfig& drift);
/// What `vdbmap explore --seed` seeds: the drift, and the planner's path sampling (path,
/// cost_path) and tours (tour, alc.tour).
void setSeed(ExplorationConfig& config, std::uint64_t seed);

/// `vdbmap explore`'s set-up of a world: drift `drift_level` (Table I) seeded with `seed`, which
/// also seeds the planner's path sampling and tours, and declared to its safety layer
/// (odometryDriftOf); voxel size; the default box and start (yaw 0); counted budgets
/// (setBudgets). Throws std::invalid_argument for an unknown level or no clear start.
ExplorationConfig explorationConfigFor(const World& world, const std::string& drift_level, std::uint64_t seed,
                                       double voxel_size_m);

/// A run folder's summary (summary.json holds these and more).
struct ExplorationSummary {
  double exploration_time_s = 0.0;
  double path_length_m = 0.0;
  double coverage = 0.0;  ///< surface_coverage.hpp
  /// The part of the observable surface the camera saw at the true poses (seen_surface.hpp).
  /// coverage well below it: drift put what was seen elsewhere in the map; both low: the
  /// exploration did not go there.
  double coverage_seen = 0.0;
  std::size_t loop_closures = 0;
  std::size_t collisions = 0;
  bool alc_enabled = false;
  double epsilon = 0.0;                ///< ALC's (when enabled)
  std::size_t alc_detours = 0;         ///< loop-closure detours started
  double alc_time_s = 0.0;             ///< time spent flying loop-closure detours
  std::size_t alc_give_ups = 0;        ///< detours given up without a loop closure
  std::size_t alc_detour_loops = 0;    ///< detours that ended with a loop closure
  std::size_t alc_finish_detours = 0;  ///< of alc_detours: to close a loop before finishing
  double estimate_error_rmse_m = 0.0;  ///< estimated (online) vs true sensor positions over the frames
  /// The positions the final map holds its keyframes at (every correction applied) vs the true
  /// ones: what the map's accuracy follows. Negative when not known (no keyframes kept).
  double keyframe_error_rmse_m = -1.0;
  /// The yaw about z and translation that best map the keyframes' positions onto the true ones
  /// (alignYawTranslation): the rigid offset that drift before any loop could close left in the
  /// whole map. Identity without kept keyframes.
  FlatPose map_alignment;
  /// keyframe_error_rmse_m after map_alignment; negative when not known.
  double keyframe_error_aligned_rmse_m = -1.0;
  double planner_ms_median = 0.0;
  double planner_ms_max = 0.0;
  std::size_t frames_total = 0;
  std::size_t keyframes_kept = 0;
  double accuracy_rmse_m = 0.0;  ///< map surface vs the world mesh (vdbmap/eval.hpp), as bench drift
  /// accuracy_rmse_m of the map moved by map_alignment: the map's inner consistency, what loop
  /// closure can still improve; negative when not known.
  double accuracy_aligned_rmse_m = -1.0;
  double completeness = 0.0;  ///< of the WHOLE world mesh within 2 voxels (hidden surfaces included)
  bool finished = false;
  bool complete = false;  ///< finished with coverage >= kCompleteCoverage
  ObservableSurfaceStats observable;
  /// Simulated time at which the timeline's coverage first reached each of kCoverageMilestones
  /// (negative: never).
  std::array<double, 5> time_to_coverage_s{};
  double mean_speed_mps = 0.0;  ///< path_length_m / exploration_time_s
  std::array<double, planner::kExplorationActivities> activity_time_s{};  ///< as ExplorationResult's
  double longest_hold_s = 0.0;
  std::size_t emergency_stops = 0;  ///< planner::ExplorationCounters' (the safety layer)
  std::size_t look_stops = 0;
  double wall_s = 0.0;
};

/// The coverage fractions summary.json reports time_to_coverage_s for.
inline constexpr std::array<double, 5> kCoverageMilestones = {0.5, 0.8, 0.9, 0.95, 0.99};

/// A run is complete when it finished with at least this coverage of the observable surface.
/// Finishing below it (the planner believed the world explored: under drift, paths to what is
/// left failed in a map that drift bent) is a failure of the run, not a success.
inline constexpr double kCompleteCoverage = 0.95;

struct ExplorationRunConfig {
  SurfaceCoverageConfig coverage;  ///< max_view_distance_m and the fov are set from the planner's camera
  double completeness_threshold_vox = 2.0;  ///< (0, 100]
  bool overwrite = false;                   ///< replace a run already in the folder
  std::string description;                  ///< e.g. the command line
  std::string world;                        ///< the world mesh's path, recorded in summary.json
  std::function<void(const ExplorationProgress&)> progress;
  /// Write the flight's log (log/, replayable) and the map (map.vdb, mesh.ply). summary.json and
  /// the trajectories are always written. Benchmarks that only need the numbers turn these off.
  bool write_log = true;
  bool write_map = true;
  /// Called with a line of text at each stage after the flight (coverage, evaluation, files).
  std::function<void(const std::string&)> report;
};
using ExplorationRunOptions [[deprecated("renamed ExplorationRunConfig")]] = ExplorationRunConfig;

/// Runs the exploration and writes the run folder: log/ (replayable), map.vdb, mesh.ply (unless
/// turned off in the options), trajectory_true.txt and trajectory_odom.txt (TUM, sensor poses per
/// frame, true and estimated online), trajectory_keyframes.txt (TUM, the poses the final map holds
/// its keyframes at, every correction applied; empty in modes none and submap), coverage.csv (CoverageSample every
/// second), cycles.csv (CycleSample per frame) and summary.json. Throws std::runtime_error when the folder holds a run
/// and overwrite is false.
ExplorationSummary exploreToFolder(const World& world, const ExplorationConfig& config,
                                   const std::filesystem::path& run_dir, const ExplorationRunConfig& options = {});

/// A run folder's summary as exploreToFolder wrote it to `summary_json`; of `observable` only what
/// the file records (samples in the box, observable samples and area, reachable cells). Throws
/// std::runtime_error naming the file and the key when it cannot be read or a key is missing.
ExplorationSummary readExplorationSummary(const std::filesystem::path& summary_json);

}  // namespace vdbmap::sim
