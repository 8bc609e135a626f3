#include "vdbmap/sim/alc_benchmark.hpp"
#include "vdbmap/timing.hpp"

#include "internal/spread.hpp"
#include "text_format.hpp"

#include "vdbmap/atomic_file.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

namespace vdbmap::sim {

void AlcBenchmarkConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("AlcBenchmarkConfig." + what); };
  if (world_mesh.empty()) fail("world_mesh must name a mesh file");
  world.validate();
  DriftConfig::preset(drift_level);  // throws for an unknown level
  if (seeds < 1 || seeds > 1000) fail("seeds must be in [1, 1000]");
  if (!(voxel_size_m > 0.0 && voxel_size_m <= 10.0)) fail("voxel_size_m must be in (0, 10]");
  if (!(max_time_s > 0.0 && max_time_s <= 1e5)) fail("max_time_s must be in (0, 1e5]");
  alc.validate();
}

namespace {

constexpr const char* kArms[] = {"no_alc", "alc"};

nlohmann::json toJson(const AlcBenchmarkRun& r) {
  const ExplorationSummary& s = r.summary;
  return {{"arm", r.arm},
          {"seed", r.seed},
          {"exploration_time_s", s.exploration_time_s},
          {"loop_closures", s.loop_closures},
          {"accuracy_rmse_m", s.accuracy_rmse_m},
          {"completeness", s.completeness},
          {"finished", s.finished},
          {"coverage", s.coverage},
          {"path_length_m", s.path_length_m},
          {"estimate_error_rmse_m", s.estimate_error_rmse_m},
          {"alc_detours", s.alc_detours},
          {"alc_time_s", s.alc_time_s},
          {"alc_give_ups", s.alc_give_ups},
          {"alc_detour_loops", s.alc_detour_loops},
          {"collisions", s.collisions},
          {"planner_ms_median", s.planner_ms_median},
          {"wall_s", s.wall_s}};
}

using internal::Spread;
using internal::spread;

using Metric = std::function<double(const ExplorationSummary&)>;
std::vector<double> values(const AlcBenchmarkResult& result, const std::string& arm, const Metric& metric) {
  std::vector<double> v;
  for (const AlcBenchmarkRun& r : result.runs)
    if (r.arm == arm) v.push_back(metric(r.summary));
  return v;
}

void writeOutputs(const AlcBenchmarkResult& result, const AlcBenchmarkConfig& config,
                  const std::filesystem::path& out_dir) {
  nlohmann::json runs = nlohmann::json::array();
  for (const AlcBenchmarkRun& r : result.runs) runs.push_back(toJson(r));
  vdbmap::writeFileAtomically(out_dir / "alc.json", [&](std::ostream& os) { os << runs.dump(2) << "\n"; });
  const std::string md = alcBenchmarkMarkdown(result, config);
  vdbmap::writeFileAtomically(out_dir / "alc.md", [&](std::ostream& os) { os << md; });
}
}  // namespace

AlcBenchmarkResult runAlcBenchmark(const AlcBenchmarkConfig& config, const std::filesystem::path& out_dir) {
  config.validate();
  const Stopwatch wall;
  const auto report = [&](const std::string& line) {
    if (config.report) config.report(line);
  };
  const World world = World::load(config.world_mesh, config.world);
  std::filesystem::create_directories(out_dir);
  AlcBenchmarkResult result;
  for (std::uint64_t seed = 1; seed <= config.seeds; ++seed) {
    for (const char* arm : kArms) {
      ExplorationConfig ec = explorationConfigFor(world, config.drift_level, seed, config.voxel_size_m);
      ec.simulator.loop_closure = config.loop_closure;
      ec.max_time_s = config.max_time_s;
      ec.planner.alc_enabled = std::string(arm) == "alc";
      ec.planner.alc = config.alc;
      ec.planner.alc.tour.seed = seed;
      ExplorationRunConfig ro;
      ro.overwrite = true;
      ro.write_log = config.keep_runs;
      ro.write_map = config.keep_runs;
      ro.description = "vdbmap bench alc: arm " + std::string(arm) + ", seed " + std::to_string(seed) + ", drift " +
                       config.drift_level + ", world " + config.world_mesh.string();
      const std::string name = std::string(arm) + "_seed" + std::to_string(seed);
      const AlcBenchmarkRun run{arm, seed, exploreToFolder(world, ec, out_dir / "runs" / name, ro)};
      const ExplorationSummary& s = run.summary;
      report(name + ": " + (s.finished ? "finished" : "time limit") + " after " +
             format("%.1f s", s.exploration_time_s) + ", " + std::to_string(s.loop_closures) + " loop closures, rmse " +
             format("%.4f m", s.accuracy_rmse_m) + ", coverage " + format("%.3f", s.coverage) + ", " +
             std::to_string(s.alc_detours) + " detours (" + format("%.1f s", s.alc_time_s) + "), " +
             format("%.0f s wall", s.wall_s));
      result.runs.push_back(run);
      result.wall_s = wall.s();
      writeOutputs(result, config, out_dir);
    }
  }
  return result;
}

std::string alcBenchmarkMarkdown(const AlcBenchmarkResult& result, const AlcBenchmarkConfig& config) {
  std::ostringstream md;
  md << "# Exploration with and without active loop closure\n\n"
     << "World `" << config.world_mesh.string() << "`, drift " << config.drift_level << ", seeds 1.." << config.seeds
     << ", voxel " << config.voxel_size_m << " m, loop closure `" << toString(config.loop_closure) << "`, time limit "
     << config.max_time_s << " s. ALC: epsilon " << config.alc.epsilon << ", give-up timeout "
     << config.alc.give_up_timeout_s << " s, search radius " << config.alc.search_radius_m
     << " m. Both arms of a seed share the drift and planner seeds and the start. Values: mean ± sample standard "
        "deviation over the runs done.\n";

  const std::vector<std::pair<std::string, std::pair<const char*, Metric>>> metrics = {
      {"exploration time (s)", {"%.1f", [](const ExplorationSummary& s) { return s.exploration_time_s; }}},
      {"loop closures", {"%.1f", [](const ExplorationSummary& s) { return double(s.loop_closures); }}},
      {"accuracy RMSE (m)", {"%.4f", [](const ExplorationSummary& s) { return s.accuracy_rmse_m; }}},
      {"completeness", {"%.3f", [](const ExplorationSummary& s) { return s.completeness; }}},
      {"coverage", {"%.3f", [](const ExplorationSummary& s) { return s.coverage; }}},
      {"estimate error RMSE (m)", {"%.3f", [](const ExplorationSummary& s) { return s.estimate_error_rmse_m; }}},
      {"path length (m)", {"%.1f", [](const ExplorationSummary& s) { return s.path_length_m; }}},
      {"finished", {"%.2f", [](const ExplorationSummary& s) { return s.finished ? 1.0 : 0.0; }}},
      {"ALC detours", {"%.1f", [](const ExplorationSummary& s) { return double(s.alc_detours); }}},
      {"ALC detours with a loop", {"%.1f", [](const ExplorationSummary& s) { return double(s.alc_detour_loops); }}},
      {"ALC detour time (s)", {"%.1f", [](const ExplorationSummary& s) { return s.alc_time_s; }}},
      {"collisions", {"%.1f", [](const ExplorationSummary& s) { return double(s.collisions); }}},
  };
  md << "\n## Per arm\n\n| metric |";
  for (const char* arm : kArms)
    md << " " << arm << " (n = " << values(result, arm, metrics[0].second.second).size() << ") |";
  md << "\n|---|---:|---:|\n";
  for (const auto& [title, m] : metrics) {
    md << "| " << title << " |";
    for (const char* arm : kArms) {
      const Spread s = spread(values(result, arm, m.second));
      md << " " << (s.n == 0 ? std::string("-") : format(m.first, s.mean) + " ± " + format(m.first, s.sd)) << " |";
    }
    md << "\n";
  }

  // The effect, over the seeds both arms completed (paired).
  std::map<std::uint64_t, std::map<std::string, const ExplorationSummary*>> by_seed;
  for (const AlcBenchmarkRun& r : result.runs) by_seed[r.seed][r.arm] = &r.summary;
  std::vector<double> time_ratio, loop_gain, rmse_change, time_a, time_b;
  for (const auto& [seed, arms] : by_seed) {
    if (arms.size() < 2) continue;
    const ExplorationSummary &off = *arms.at("no_alc"), &on = *arms.at("alc");
    time_a.push_back(off.exploration_time_s);
    time_b.push_back(on.exploration_time_s);
    time_ratio.push_back(on.exploration_time_s / off.exploration_time_s - 1.0);
    loop_gain.push_back(double(on.loop_closures) - double(off.loop_closures));
    rmse_change.push_back(on.accuracy_rmse_m - off.accuracy_rmse_m);
  }
  md << "\n## Effect of ALC (paired by seed, " << time_ratio.size() << " seeds)\n\n";
  if (!time_ratio.empty()) {
    const Spread ratio = spread(time_ratio), gain = spread(loop_gain), rmse = spread(rmse_change);
    const double overhead = spread(time_b).mean / spread(time_a).mean - 1.0;
    md << "- time overhead: " << format("%+.1f %%", 100.0 * overhead) << " (ratio of the mean times; per seed "
       << format("%+.1f", 100.0 * ratio.mean) << " ± " << format("%.1f %%", 100.0 * ratio.sd) << ")\n"
       << "- loop-closure gain: " << format("%+.1f", gain.mean) << " ± " << format("%.1f", gain.sd) << " per run\n"
       << "- accuracy RMSE change: " << format("%+.4f", rmse.mean) << " ± " << format("%.4f m", rmse.sd) << "\n"
       << "- paper (Zhang et al. 2022): +8 % time, +3 loop closures, a better map\n";
  }

  md << "\n## Runs\n\n| seed | arm | finished | time (s) | loops | RMSE (m) | completeness | coverage | estimate "
        "error (m) | detours (with loop / given up) | detour time (s) | collisions |\n"
        "|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const AlcBenchmarkRun& r : result.runs) {
    const ExplorationSummary& s = r.summary;
    md << "| " << r.seed << " | " << r.arm << " | " << (s.finished ? "yes" : "no") << " | "
       << format("%.1f", s.exploration_time_s) << " | " << s.loop_closures << " | " << format("%.4f", s.accuracy_rmse_m)
       << " | " << format("%.3f", s.completeness) << " | " << format("%.3f", s.coverage) << " | "
       << format("%.3f", s.estimate_error_rmse_m) << " | " << s.alc_detours << " (" << s.alc_detour_loops << " / "
       << s.alc_give_ups << ") | " << format("%.1f", s.alc_time_s) << " | " << s.collisions << " |\n";
  }
  md << "\nTotal wall time " << format("%.0f s", result.wall_s) << ".\n";
  return md.str();
}

}  // namespace vdbmap::sim
