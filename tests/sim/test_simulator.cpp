// The online simulator (sim/simulator.hpp) stepped frame by frame, and offline flights written as
// logs and replayed by the mapper (sim/flight.hpp, vdbmap/log_replay.hpp).
#include <catch2/catch.hpp>

#include "sim/sim_test_helpers.hpp"
#include "vdbmap/eval.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/mesh.hpp"
#include "vdbmap/sim/flight.hpp"
#include "vdbmap/test_io_helpers.hpp"

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::sim;

namespace {
/// Two laps of a 1.2 m circle in the 6 x 4 m room, facing along the path, 10 s per lap.
FlatPose circle(double t) {
  const double a = 2.0 * M_PI * t / 10.0;
  return {Vec3d(-0.3 + 1.2 * std::cos(a), 1.2 * std::sin(a), 1.2), a + M_PI / 2};
}

SimulatorConfig smallConfig(const std::string& level, LoopClosureMode mode) {
  SimulatorConfig c;
  c.camera.intrinsics = {80, 60, 48.4, 48.4, 40.0, 30.0};  // FUEL's field of view at 1/8 size
  c.drift = DriftConfig::preset(level, 5);
  c.loop_closure = mode;
  return c;
}

struct Run {
  std::vector<SimFrame> frames;
  std::vector<CorrectionEvent> events;
};

/// Steps the online simulator along `circle`: drift at 200 Hz (on the grid k / 200 s), a frame at 15 Hz.
Run runOnline(const World& world, const SimulatorConfig& config, double duration) {
  Simulator sim(world, config, circle(0.0), 0.0);
  Run run;
  int tick = 0;
  for (int k = 0; k <= int(duration * 15.0); ++k) {
    const double t_frame = k / 15.0;
    for (; (tick + 1) / 200.0 < t_frame - 1e-9; ++tick) sim.advance((tick + 1) / 200.0, circle((tick + 1) / 200.0));
    if (t_frame > sim.time()) sim.advance(t_frame, circle(t_frame));
    SimFrame f = sim.capture();
    if (f.correction) run.events.push_back(*f.correction);
    f.depth = DepthImage();  // keep the memory small
    run.frames.push_back(std::move(f));
  }
  return run;
}

double positionError(const Pose3d& a, const Pose3d& b) { return (a.translation() - b.translation()).norm(); }
}  // namespace

TEST_CASE("online simulator: a revisit closes a loop and corrects every frame so far", "[sim][simulator]") {
  const World world(test::roomWithBox());

  SECTION("perfect: the correction is the ground truth, and later estimates continue from it") {
    const Run run = runOnline(world, smallConfig("s4", LoopClosureMode::Perfect), 22.0);
    REQUIRE(run.events.size() == 1);
    const CorrectionEvent& e = run.events[0];
    CHECK(e.t_s > 19.0);  // the second lap comes within 0.5 m and 0.2 rad of the first's start
    CHECK(e.t_s < 20.5);
    REQUIRE(e.T_W_S_by_frame.size() == e.frame + 1);
    double worst = 0.0;
    for (const auto& [i, T] : e.T_W_S_by_frame) worst = std::max(worst, positionError(T, run.frames[i].T_W_S_true));
    // The pieces fly the sampled trajectory, the stepped run the analytic circle: between samples
    // 5 ms apart they differ by the chord's sagitta, (0.75 m/s * 5 ms)^2 / (8 * 1.2 m) = 1.5 um.
    CHECK(worst < 1e-5);
    // Before the event the estimate had drifted; right after it, the estimate restarts at the truth.
    CHECK(positionError(run.frames[e.frame].T_W_S_estimate, run.frames[e.frame].T_W_S_true) > 0.02);
    CHECK(positionError(run.frames[e.frame + 1].T_W_S_estimate, run.frames[e.frame + 1].T_W_S_true) < 0.02);
  }
  SECTION("pgo: the 4-DOF optimization pulls the newest frame back and improves the loop") {
    const Run run = runOnline(world, smallConfig("s4", LoopClosureMode::PoseGraph), 22.0);
    REQUIRE(run.events.size() == 1);
    const CorrectionEvent& e = run.events[0];
    CHECK(e.solve.final_cost < e.solve.initial_cost);
    const double before = positionError(run.frames[e.frame].T_W_S_estimate, run.frames[e.frame].T_W_S_true);
    const double after = positionError(e.T_W_S_by_frame.at(e.frame), run.frames[e.frame].T_W_S_true);
    REQUIRE(before > 0.05);
    CHECK(after < 0.5 * before);
    double sq_before = 0.0, sq_after = 0.0;
    for (const auto& [i, T] : e.T_W_S_by_frame) {
      sq_before += std::pow(positionError(run.frames[i].T_W_S_estimate, run.frames[i].T_W_S_true), 2);
      sq_after += std::pow(positionError(T, run.frames[i].T_W_S_true), 2);
    }
    CHECK(sq_after < sq_before);
    // The sensor keeps its mount: corrected poses are level (rotation about z only, camera pitch 0).
    const Pose3d& T = e.T_W_S_by_frame.at(e.frame / 2);
    CHECK(std::abs(T.linear().col(2).z()) < 1e-9);  // optical axis horizontal
  }
  SECTION("off: no loop closure, the estimate is the odometry") {
    const Run run = runOnline(world, smallConfig("s4", LoopClosureMode::Off), 22.0);
    CHECK(run.events.empty());
  }
  SECTION("s1: estimates are the ground truth") {
    const Run run = runOnline(world, smallConfig("s1", LoopClosureMode::PoseGraph), 12.0);
    for (const SimFrame& f : run.frames) CHECK(positionError(f.T_W_S_estimate, f.T_W_S_true) < 1e-9);
  }
}

TEST_CASE("flying in pieces (as a replanning planner does) gives the same frames as one flight", "[sim][simulator]") {
  const World world(test::roomWithBox());
  const SimulatorConfig config = smallConfig("s3", LoopClosureMode::PoseGraph);
  SampledTrajectory circle_traj;
  for (int k = 0; k <= 22 * 200; ++k) {
    const FlatPose p = circle(k / 200.0);
    circle_traj.append(k / 200.0, VehicleState{p.position_W, Vec3d::Zero(), Vec3d::Zero(), p.yaw_rad, 0.0});
  }
  const Run stepped = runOnline(world, config, 22.0);
  Simulator sim(world, config, circle(0.0), 0.0);
  std::vector<SimFrame> frames;
  std::size_t events = 0;
  for (const double t_end : {7.31, 7.35, 15.0, 22.0})  // pieces ending on and off the frame grid
    flyAlong(sim, circle_traj, t_end, [&](SimFrame& f) {
      events += f.correction ? 1 : 0;
      frames.push_back(f);
    });
  REQUIRE(frames.size() == stepped.frames.size());
  CHECK(events == stepped.events.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    CHECK(frames[i].t_s == Approx(stepped.frames[i].t_s).margin(1e-9));
    worst = std::max(worst, positionError(frames[i].T_W_S_estimate, stepped.frames[i].T_W_S_estimate));
  }
  // The pieces fly the sampled trajectory, the stepped run the analytic circle: between samples
  // 5 ms apart they differ by the chord's sagitta, (0.75 m/s * 5 ms)^2 / (8 * 1.2 m) = 1.5 um.
  CHECK(worst < 1e-5);
}

TEST_CASE("simulate -> integrate: a drifting flight with loop closure replays, and correction helps the map",
          "[sim][flight]") {
  const World world(test::roomWithBox());
  SampledTrajectory trajectory;
  for (int k = 0; k <= 12 * 200; ++k) {
    const double t = k / 200.0;
    const FlatPose p = circle(t);
    trajectory.append(t, VehicleState{p.position_W, Vec3d::Zero(), Vec3d::Zero(), p.yaw_rad, 0.0});
  }
  SimulatorConfig config = smallConfig("s4", LoopClosureMode::PoseGraph);
  config.camera.intrinsics = {160, 120, 96.8, 96.8, 80.0, 60.0};
  config.loop.min_age_s = 8.0;  // the loop closes after one 10 s lap, so the flight can be short
  test::TempDir dir;
  const FlightResult flight = simulateFlight(world, trajectory, config, dir / "log");
  CHECK(flight.frames == 12 * 15 + 1);
  REQUIRE(flight.loop_closures.size() == 1);
  CHECK(std::filesystem::exists(dir / "log" / "simulation.json"));

  const auto log = io::openDataset(dir / "log");
  CHECK(log->format() == "log");
  REQUIRE(log->size() == flight.frames);
  CHECK(log->groundTruth().size() == flight.frames);
  REQUIRE(log->corrections().size() == 1);
  CHECK(log->corrections()[0].event_frame == flight.loop_closures[0].new_frame);
  CHECK(log->sensor().intrinsics.width == 160);
  // A re-run into the same folder needs overwrite, and then replaces the log.
  CHECK_THROWS_AS(simulateFlight(world, trajectory, config, dir / "log"), std::runtime_error);

  auto rmse = [&](ConsistencyMode mode) {
    MapperConfig mc;
    mc.mode = mode;
    mc.tsdf.voxel_size_m = 0.1;
    Mapper mapper(mc);
    const ReplayResult r = replayLog(*log, mapper, ReplayConfig{});
    CHECK(r.frames_integrated == flight.frames);
    CHECK(r.correction_events == 1);
    EvalConfig ec;
    ec.completeness_threshold_m = 0.2;
    ec.sample_spacing_m = 0.05;
    return evaluateSurface(extractMesh(mapper.volume()), world.mesh(), ec).accuracy_rmse_m;
  };
  const double none = rmse(ConsistencyMode::None), all = rmse(ConsistencyMode::All);
  CAPTURE(none, all);
  CHECK(all < none);
}
