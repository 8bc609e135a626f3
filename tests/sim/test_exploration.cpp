// Exploration in closed loop on a small world: two rooms joined by a door, 0.1 m voxels, a camera
// of reduced resolution (same field of view). The run must finish, cover the observable surface,
// never collide, and record a log that replays.
#include "sim/sim_test_helpers.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/planner/tsdf_map_query.hpp"
#include "vdbmap/sim/exploration.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// Two 4 x 4 x 2.5 m rooms side by side, the wall between them 0.2 m thick with a 1 x 2 m door.
TriangleMesh twoRooms() {
  TriangleMesh m;
  test::addBox(m, Vec3d(0, 0, 0), Vec3d(8, 4, 2.5));
  test::addBox(m, Vec3d(3.9, 0, 0), Vec3d(4.1, 1.5, 2.5));
  test::addBox(m, Vec3d(3.9, 2.5, 0), Vec3d(4.1, 4, 2.5));
  test::addBox(m, Vec3d(3.9, 1.5, 2.0), Vec3d(4.1, 2.5, 2.5));
  return m;
}

/// The default camera's field of view at a quarter of its resolution.
CameraIntrinsics smallCamera() {
  CameraIntrinsics K;
  K.width = 160;
  K.height = 120;
  K.fx = K.fy = 387.229 / 4.0;
  K.cx = 80.0;
  K.cy = 60.0;
  return K;
}

ExplorationConfig twoRoomConfig(const std::string& drift) {
  ExplorationConfig c;
  c.simulator.camera.intrinsics = smallCamera();
  c.simulator.drift = DriftConfig::preset(drift, 3);
  c.mapper.tsdf.voxel_size_m = 0.1;
  c.planner.box_W = Eigen::AlignedBox3d(Vec3d(0, 0, 0), Vec3d(8, 4, 2.5));
  c.start.position_W = Vec3d(2.0, 2.0, 1.2);
  c.max_time_s = 150.0;
  return c;
}
}  // namespace

TEST_CASE("Closed-loop exploration of two rooms finishes, covers them, and never collides", "[sim][exploration]") {
  const World world(twoRooms());
  ExplorationConfig config = twoRoomConfig("s1");
  setBudgets(config, BudgetMode::Counted);  // the same flight on a loaded machine
  const std::filesystem::path log = std::filesystem::temp_directory_path() / "vdbmap_test_explore_log";
  std::filesystem::remove_all(log);
  ExplorationRecordConfig options;
  options.log_dir = log;
  const ExplorationResult r = runExploration(world, config, options);
  INFO("time " << r.exploration_time_s << " s, path " << r.path_length_m << " m, replans " << r.planner_counters.replans
               << ", failed " << r.planner_counters.replans_failed << ", blacklisted " << r.planner_counters.blacklisted);
  CHECK(r.finished);
  CHECK(r.collisions == 0);
  CHECK(r.min_clearance_m >= config.vehicle_radius_m);
  CHECK(r.path_length_m > 4.0);  // it went through the door into the second room
  const ObservableSurface observable(world, config.planner.box_W, config.start.position_W);
  const double coverage = observable.coverage(planner::TsdfMapQuery(r.mapper->volume()));
  INFO("coverage " << coverage);
  CHECK(coverage >= 0.95);
  CHECK(r.frames_total == r.trajectory_true.size());
  CHECK(r.planner_ms.size() == r.planner_counters.replans);
  CHECK(r.planner_ms_max >= r.planner_ms_median);

  // The log replays: the same frames, every one integrated.
  const std::unique_ptr<io::FrameSource> source = io::openDataset(log, io::DatasetFormat::Log);
  MapperConfig mc = config.mapper;
  Mapper replay(mc);
  const ReplayResult replayed = replayLog(*source, replay, ReplayConfig{});
  CHECK(replayed.frames_integrated == r.frames_total);
  CHECK(replayed.correction_events == r.loop_closures);
  std::filesystem::remove_all(log);
}

TEST_CASE("Each collision event is listed in the run's events, when it began", "[sim][exploration]") {
  // Collisions are counted against vehicle_radius_m, the planner keeps its own clearance: with a
  // 0.6 m vehicle the 1 m door (0.5 m from either jamb at its middle) makes at least one event.
  const World world(twoRooms());
  ExplorationConfig config = twoRoomConfig("s1");
  config.vehicle_radius_m = 0.6;
  setBudgets(config, BudgetMode::Counted);  // the same flight on a loaded machine
  const ExplorationResult r = runExploration(world, config);
  REQUIRE(r.collisions >= 1);
  std::vector<double> starts;
  for (const ExplorationEvent& e : r.events)
    if (e.what == "collision") starts.push_back(e.t_s);
  REQUIRE(starts.size() == r.collisions);
  CHECK(std::is_sorted(starts.begin(), starts.end()));
  // At the frame listed, the true pose is inside the 0.6 m radius of a surface, or at most one
  // frame's flight past the point where it came inside.
  const double one_frame_flight_m = config.planner.trajectory.v_max_m_s / config.simulator.camera.rate_hz;
  for (const double t : starts) {
    const auto frame = std::find_if(r.trajectory_true.begin(), r.trajectory_true.end(),
                                    [&](const auto& s) { return s.timestamp_s == t; });
    REQUIRE(frame != r.trajectory_true.end());
    CHECK(world.distance(frame->T_W_S.translation(), 2.0) < config.vehicle_radius_m + one_frame_flight_m);
  }
}

TEST_CASE("Closed-loop exploration under drift s3 finishes without collisions", "[sim][exploration]") {
  const World world(twoRooms());
  // Counted budgets: the run is the same on a loaded machine (with wall-clock budgets a busy CI
  // machine gave the planner fewer iterations and another flight).
  ExplorationConfig config = twoRoomConfig("s3");
  setBudgets(config, BudgetMode::Counted);
  const ExplorationResult r = runExploration(world, config);
  INFO("time " << r.exploration_time_s << " s, loops " << r.loop_closures << ", escapes "
                 << r.planner_counters.escapes << " (retreats " << r.planner_counters.retreats << "), closest "
                 << r.min_clearance_m << " m");
  CHECK(r.finished);
  CHECK(r.collisions == 0);
  // The vehicle's true path drifts from the estimate it tracks.
  double max_gap = 0.0;
  for (std::size_t i = 0; i < r.trajectory_true.size(); ++i)
    max_gap = std::max(max_gap, (r.trajectory_true[i].T_W_S.translation() - r.trajectory_estimate[i].T_W_S.translation()).norm());
  CHECK(max_gap > 0.0);
  const ObservableSurface observable(world, config.planner.box_W, config.start.position_W);
  // Below s1's 0.95: corrections move keyframes, and pruning with 2-voxel cells releases some
  // floor and ceiling voxels that a level camera sees only at its frustum's edges.
  CHECK(observable.coverage(planner::TsdfMapQuery(r.mapper->volume())) >= 0.85);
  // Every failed visit and every target without a path is an event; both are target failures.
  const auto count = [&](const char* what) {
    return std::size_t(
        std::count_if(r.events.begin(), r.events.end(), [&](const ExplorationEvent& e) { return e.what == what; }));
  };
  CHECK(count("visit_failed") == r.planner_counters.visit_failures);
  CHECK(count("path_failed") == r.planner_counters.path_failures);
  CHECK(r.planner_counters.visit_failures + r.planner_counters.path_failures <= r.planner_counters.target_failures);
}

TEST_CASE(
    "With the safety layer, exploration under drift s3 finishes without collisions, each emergency stop an "
    "event",
    "[sim][exploration]") {
  const World world(twoRooms());
  ExplorationConfig config = twoRoomConfig("s3");
  setBudgets(config, BudgetMode::Counted);
  config.planner.safety.enabled = true;
  const ExplorationResult r = runExploration(world, config);
  INFO("time " << r.exploration_time_s << " s, looks " << r.planner_counters.look_stops << ", emergency stops "
               << r.planner_counters.emergency_stops << ", closest " << r.min_clearance_m << " m");
  CHECK(r.finished);
  CHECK(r.collisions == 0);
  CHECK(r.min_clearance_m >= config.vehicle_radius_m);
  const ObservableSurface observable(world, config.planner.box_W, config.start.position_W);
  CHECK(observable.coverage(planner::TsdfMapQuery(r.mapper->volume())) >= 0.85);
  // Every emergency stop is an event.
  const auto stops = std::count_if(r.events.begin(), r.events.end(),
                                   [](const ExplorationEvent& e) { return e.what == "emergency_stop"; });
  CHECK(std::size_t(stops) == r.planner_counters.emergency_stops);
}

TEST_CASE("Counted budgets make a run repeat exactly; setBudgets switches both ways", "[sim][exploration]") {
  const World world(twoRooms());
  ExplorationConfig config = twoRoomConfig("s2");  // drift, loop closures and re-integration
  config.max_time_s = 40.0;
  setBudgets(config, BudgetMode::Counted);
  CHECK(config.planner.path.max_iterations == kCountedFlightPathIterations);
  CHECK(config.planner.cost_path.max_iterations == kCountedCostPathIterations);
  CHECK(config.planner.tour.max_iterations == kCountedTourIterations);
  CHECK(config.planner.alc.tour.max_iterations == kCountedTourIterations);
  CHECK(config.mapper.reintegration.budget_frames == kCountedReintegrationFrames);
  config.validate();

  const ExplorationResult a = runExploration(world, config);
  const ExplorationResult b = runExploration(world, config);
  INFO("replans " << a.planner_counters.replans << ", loops " << a.loop_closures << ", re-integrated "
                  << a.reintegrated_frames);
  REQUIRE(a.planner_counters.replans >= 5);
  REQUIRE(a.trajectory_true.size() == b.trajectory_true.size());
  for (std::size_t i = 0; i < a.trajectory_true.size(); ++i)
    REQUIRE(a.trajectory_true[i].T_W_S.isApprox(b.trajectory_true[i].T_W_S, 1e-12));
  CHECK(a.loop_closures == b.loop_closures);
  CHECK(a.reintegrated_frames == b.reintegrated_frames);
  CHECK(a.mapper->volume().activeVoxelCount() == b.mapper->volume().activeVoxelCount());

  setBudgets(config, BudgetMode::WallClock);
  const planner::ExplorationManagerConfig defaults;
  CHECK(config.planner.path.max_iterations == 0);
  CHECK(config.planner.path.time_limit_s == defaults.path.time_limit_s);
  CHECK(config.planner.cost_path.time_limit_s == defaults.cost_path.time_limit_s);
  CHECK(config.planner.tour.max_iterations == 0);
  CHECK(config.planner.tour.time_limit_s == defaults.tour.time_limit_s);
  CHECK(config.mapper.reintegration.budget_ms == ReintegrationConfig{}.budget_ms);
  CHECK(config.mapper.reintegration.budget_frames == 0);

  CHECK(parseBudgetMode("counted") == BudgetMode::Counted);
  CHECK(parseBudgetMode(toString(BudgetMode::WallClock)) == BudgetMode::WallClock);
  CHECK_THROWS_WITH(parseBudgetMode("iterations"), Catch::Contains("counted or wall-clock"));
}
