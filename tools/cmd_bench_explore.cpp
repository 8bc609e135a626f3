// `vdbmap bench explore [--worlds W ...] [--drift s1] [--seeds N] -o OUTDIR`: exploration speed
// over worlds and seeds (time to coverage, speed, where the time went, real-time factor); the
// work is in sim/explore_benchmark.hpp.
#include "command.hpp"

#include "vdbmap/sim/explore_benchmark.hpp"

#include <cstdio>
#include <fstream>
#include <iostream>

namespace vdbmap::cli {
namespace {

struct BenchExploreOptions {
  std::vector<std::string> worlds;
  std::filesystem::path output;
  std::string drift = "s1";
  std::size_t seeds = 3;
  double voxel_size_m = 0.1;
  double max_time_s = sim::ExplorationConfig::kDefaultMaxTime_s;
  double ceiling_m = 2.5;
  std::string alc = "off";
  std::string safety = planner::SafetyConfig{}.enabled ? "on" : "off";
  std::string safety_seen_free = planner::SafetyConfig{}.seen_free_is_free ? "on" : "off";
  std::string safety_map_thin = mapThinName(planner::SafetyConfig{});
  double safety_near_tolerance_m = planner::SafetyConfig{}.near_drift_tolerance_m;
  std::string safety_path_drift = planner::toString(planner::SafetyConfig{}.path_drift);
  bool look_into_unknown = planner::ViewpointConfig{}.look_into_unknown;
  bool keep_runs = false;
  bool resume = false;
  std::size_t jobs = 1;
};

void runBenchExplore(const BenchExploreOptions& o) {
  sim::ExploreBenchmarkConfig c;
  for (const std::string& spec : benchmarkWorldSpecs(o.worlds))
    for (sim::BenchmarkWorld& w : sim::parseBenchmarkWorlds(spec, o.ceiling_m)) c.worlds.push_back(std::move(w));
  c.drift_level = o.drift;
  c.seeds = o.seeds;
  c.voxel_size_m = o.voxel_size_m;
  c.max_time_s = o.max_time_s;
  c.alc = o.alc == "on";
  c.safety.enabled = o.safety == "on";
  c.safety.seen_free_is_free = o.safety_seen_free == "on";
  setMapThin(c.safety, o.safety_map_thin);
  c.safety.near_drift_tolerance_m = o.safety_near_tolerance_m;
  c.safety.path_drift = parsePathDrift(o.safety_path_drift);
  c.look_into_unknown = o.look_into_unknown;
  c.keep_runs = o.keep_runs;
  c.resume = o.resume;
  c.jobs = o.jobs;
  c.report = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  sim::runExploreBenchmark(c, o.output);
  std::ifstream md(o.output / "explore.md");
  std::cout << md.rdbuf();
}

const GroupRegistration registration("bench", "explore", [](CLI::App& bench) {
  auto o = std::make_shared<BenchExploreOptions>();
  CLI::App* sub = bench.add_subcommand(
      "explore",
      "Exploration speed: explore each world for seeds 1..N; writes OUTDIR/explore.json, OUTDIR/explore.md (time to "
      "50/80/90/95/99 % coverage, speed, final sweep, holds, real-time factor) and OUTDIR/runs/<world>_seed<k>/");
  sub->option_defaults()->always_capture_default();
  sub->add_option(
      "--worlds", o->worlds,
      "Worlds: mesh files, house (the embedded one), office:SEED[:XxY] for a generated office or office:A-B[:XxY] "
      "for the offices of seeds A..B (default: house)");
  addDriftOption(*sub, o->drift);
  sub->add_option("--seeds", o->seeds, "Runs per world, with seeds 1..N")->check(CLI::Range(1, 1000));
  sub->add_option("--voxel-size", o->voxel_size_m, "Voxel edge in metres")->check(CLI::Range(0.02, 1.0));
  sub->add_option("--max-time-s", o->max_time_s, "Simulated time limit per run in seconds")->check(CLI::Range(1.0, 1e5));
  sub->add_option("--ceiling", o->ceiling_m,
                  "Cut mesh files at this height and close them with a flat ceiling, as explore does (0: as is; "
                  "generated offices are closed at their own ceiling)")
      ->check(CLI::Range(0.0, 1e3));
  sub->add_option("--alc", o->alc, "Active loop closure on or off")->check(CLI::IsMember({"on", "off"}));
  addSafetyOptions(*sub, o->safety, o->safety_seen_free, o->safety_map_thin, o->safety_near_tolerance_m,
                   o->safety_path_drift);
  addViewScoreOption(*sub, o->look_into_unknown);
  sub->add_flag("--keep-runs", o->keep_runs, "Also keep every run's log and map (large)");
  sub->add_flag("--resume", o->resume,
                "Keep the runs an earlier call with the same options left in OUTDIR (their summary.json) and run "
                "only the rest; a run there made with other options is an error");
  sub->add_option("--jobs", o->jobs,
                  "Runs at a time, at most one per core (each run also uses every core for its own work); the runs "
                  "are the same for any value (their budgets are counted), only the wall time changes")
      ->check(CLI::Range(1, 64));
  sub->add_option("-o,--output", o->output, "Output folder")->required();
  sub->callback([o] { runBenchExplore(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
