// `vdbmap simulate --world W.ply --drift s1..s4 --seed N [--trajectory FILE] -o LOGDIR`: flies the
// simulated vehicle (a waypoint file, or the world's built-in coverage pattern) with odometry drift
// and loop closure, and records the flight as a log (see sim/flight.hpp).
#include "cli_util.hpp"
#include "command.hpp"

#include "vdbmap/sim/coverage.hpp"
#include "vdbmap/sim/flight.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

namespace vdbmap::cli {
namespace {

struct SimulateOptions {
  std::filesystem::path world, trajectory, output, save_waypoints;
  std::string drift = "s1";
  std::string loop_closure = sim::toString(sim::SimulatorConfig{}.loop_closure);
  std::uint64_t seed = 1;
  double ceiling_clip_m = std::numeric_limits<double>::infinity();
  double depth_noise_m = 0.0;
  bool overwrite = false;
};

void runSimulate(const SimulateOptions& o) {
  sim::WorldConfig wc;
  wc.ceiling_clip_z_m = o.ceiling_clip_m;
  const sim::World world = sim::World::load(requireWorld(o.world), wc);
  sim::SimulatorConfig config;
  config.drift = sim::DriftConfig::preset(o.drift, o.seed);
  config.loop_closure = sim::parseLoopClosureMode(o.loop_closure);
  config.camera.noise_sigma_m = o.depth_noise_m;
  config.camera.noise_seed = o.seed;

  std::vector<sim::FlatPose> waypoints;
  sim::SampledTrajectory trajectory;
  if (!o.trajectory.empty()) {
    waypoints = sim::readWaypoints(o.trajectory);
    trajectory = sim::timeParametrize(waypoints, sim::MotionLimits{});
  } else {
    sim::CoveragePlan plan = sim::planCoverage(world, sim::CoverageConfig{});
    waypoints = plan.waypoints;
    trajectory = std::move(plan.trajectory);
  }
  if (!o.save_waypoints.empty()) sim::writeWaypoints(o.save_waypoints, waypoints);
  std::fprintf(stderr, "%s: %zu triangles; flight of %.1f s, %.1f m\n", o.world.c_str(), world.stats().triangles,
               trajectory.duration(), trajectory.length_m());

  sim::FlightConfig fo;
  fo.overwrite = o.overwrite;
  fo.description = "vdbmap simulate --world " + o.world.string() + " --drift " + o.drift + " --seed " +
                   std::to_string(o.seed) + " --loop-closure " + o.loop_closure;
  Progress progress("simulate");
  fo.progress = [&](std::size_t done, std::size_t total) { progress.update(done, total); };
  const sim::FlightResult r = sim::simulateFlight(world, trajectory, config, o.output, fo);
  progress.finish();
  std::printf(
      "wrote %s: %zu frames over %.1f s (%.1f m), %zu loop closures, %.1f ms per frame (render, loop check, write)\n",
      o.output.c_str(), r.frames, r.duration_s, r.path_length_m, r.loop_closures.size(), r.frame_ms_median);
  std::printf(
      "drift %s: odometry error %.3f m at the end (max %.3f m); published estimate error RMSE %.3f m (max %.3f m)\n",
      o.drift.c_str(), r.odometry_error_final_m, r.odometry_error_max_m, r.estimate_error_rmse_m,
      r.estimate_error_max_m);
}

const Registration registration("simulate", [](CLI::App& app) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* sub = app.add_subcommand(
      "simulate", "Fly the simulated vehicle through a world with odometry drift and loop closure, and record a log");
  sub->option_defaults()->always_capture_default();
  addWorldOption(*sub, o->world);
  addDriftOption(*sub, o->drift);
  sub->add_option("--seed", o->seed, "Seed of the drift, the loop-edge noise and the depth noise");
  sub->add_option("--trajectory", o->trajectory,
                  "Waypoint file ('x y z [yaw]' per line); default: the world's coverage pattern")
      ->check(CLI::ExistingFile);
  sub->add_option("--loop-closure", o->loop_closure,
                  "Correction on loop closure: pose-graph optimization, ground truth, or none")
      ->check(CLI::IsMember({"pgo", "perfect", "off"}));
  sub->add_option("--ceiling-clip", o->ceiling_clip_m, "Cut the world's mesh at this height (metres)");
  sub->add_option("--depth-noise", o->depth_noise_m, "Gaussian depth noise, metres")->check(CLI::Range(0.0, 1.0));
  sub->add_option("--save-waypoints", o->save_waypoints, "Also write the flown waypoints (x y z yaw)");
  sub->add_flag("--overwrite", o->overwrite, "Replace a log already in LOGDIR");
  sub->add_option("-o,--output", o->output, "Log folder to write")->required();
  sub->callback([o] { runSimulate(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
