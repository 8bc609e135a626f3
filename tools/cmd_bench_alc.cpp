// `vdbmap bench alc [--world W.ply | --worlds SPEC...] [--drift s3] [--seeds N] -o OUTDIR`:
// exploration with and without active loop closure over worlds and seeds (the paper's ALC
// experiment); the work is in sim/alc_benchmark.hpp.
#include "command.hpp"

#include "vdbmap/sim/alc_benchmark.hpp"

#include <cstdio>
#include <fstream>
#include <iostream>

namespace vdbmap::cli {
namespace {

struct BenchAlcOptions {
  std::filesystem::path world, output;
  std::vector<std::string> worlds;
  std::string drift = "s3";
  std::size_t seeds = 5;
  double voxel_size_m = 0.1;
  double max_time_s = sim::ExplorationConfig::kDefaultMaxTime_s;
  double epsilon = planner::AlcConfig{}.epsilon;
  double ceiling_m = 2.5;
  std::string loop_closure = sim::toString(sim::SimulatorConfig{}.loop_closure);
  double min_finish_coverage = sim::AlcBenchmarkConfig{}.min_finish_coverage;
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

void runBenchAlc(const BenchAlcOptions& o) {
  sim::AlcBenchmarkConfig c;
  const std::vector<std::string> specs =
      o.worlds.empty() ? std::vector<std::string>{requireWorld(o.world).string()} : benchmarkWorldSpecs(o.worlds);
  for (const std::string& spec : specs)  // mesh files cut and capped as `vdbmap explore` does
    for (sim::BenchmarkWorld& w : sim::parseBenchmarkWorlds(spec, o.ceiling_m)) c.worlds.push_back(std::move(w));
  c.drift_level = o.drift;
  c.seeds = o.seeds;
  c.voxel_size_m = o.voxel_size_m;
  c.max_time_s = o.max_time_s;
  c.alc.epsilon = o.epsilon;
  c.loop_closure = sim::parseLoopClosureMode(o.loop_closure);
  c.min_finish_coverage = o.min_finish_coverage;
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
  sim::runAlcBenchmark(c, o.output);
  std::ifstream md(o.output / "alc.md");
  std::cout << md.rdbuf();
}

const GroupRegistration registration("bench", "alc", [](CLI::App& bench) {
  auto o = std::make_shared<BenchAlcOptions>();
  CLI::App* sub = bench.add_subcommand(
      "alc",
      "Active loop closure: explore each world with and without ALC for seeds 1..N (same drift and start per world "
      "and seed), evaluate each run; writes OUTDIR/alc.json, OUTDIR/alc.md (pooled, per world, every run) and "
      "OUTDIR/runs/<world>/<arm>_seed<k>/summary.json");
  sub->option_defaults()->always_capture_default();
  CLI::Option* world = addWorldOption(*sub, o->world);
  sub->add_option("--worlds", o->worlds,
                  "Several worlds instead of --world: mesh files, house (the embedded one), office:SEED[:XxY] for a "
                  "generated office or office:A-B[:XxY] for the offices of seeds A..B")
      ->excludes(world);
  addDriftOption(*sub, o->drift);
  sub->add_option("--seeds", o->seeds, "Runs per arm, with seeds 1..N")->check(CLI::Range(1, 1000));
  sub->add_option("--voxel-size", o->voxel_size_m, "Voxel edge in metres")->check(CLI::Range(0.02, 1.0));
  sub->add_option("--max-time-s", o->max_time_s, "Simulated time limit per run in seconds")
      ->check(CLI::Range(1.0, 1e5));
  sub->add_option("--epsilon", o->epsilon,
                  "ALC arm: take the loop-closure detour when it costs at most (1 + epsilon) times the frontier tour")
      ->check(CLI::Range(0.0, 100.0));
  sub->add_option("--loop-closure", o->loop_closure, "Correction on loop closure: pgo, perfect or off")
      ->check(CLI::IsMember({"pgo", "perfect", "off"}));
  sub->add_option(
         "--ceiling", o->ceiling_m,
         "Cut mesh files at this height and close them with a flat ceiling there (metres; 0 keeps the mesh as is; "
         "generated offices are closed at their own ceiling)")
      ->check(CLI::Range(0.0, 1e3));
  sub->add_option("--min-finish-coverage", o->min_finish_coverage,
                  "Count a run that ends below this coverage of the observable surface as incomplete")
      ->check(CLI::Range(0.0, 1.0));
  addSafetyOptions(*sub, o->safety, o->safety_seen_free, o->safety_map_thin, o->safety_near_tolerance_m,
                   o->safety_path_drift);
  addViewScoreOption(*sub, o->look_into_unknown);
  sub->add_flag("--keep-runs", o->keep_runs, "Also keep each run's log and map in OUTDIR/runs/ (large)");
  sub->add_flag("--resume", o->resume,
                "Keep the runs an earlier call with the same options left in OUTDIR (their summary.json) and run "
                "only the rest; a run there made with other options is an error");
  sub->add_option("--jobs", o->jobs,
                  "Runs at a time, at most one per core (each run also uses every core for its own work); the runs "
                  "are the same for any value (their budgets are counted), only the wall time changes")
      ->check(CLI::Range(1, 64));
  sub->add_option("-o,--output", o->output, "Output folder")->required();
  sub->callback([o] { runBenchAlc(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
