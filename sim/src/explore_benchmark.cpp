#include "vdbmap/sim/explore_benchmark.hpp"

#include "internal/benchmark_run.hpp"
#include "internal/spread.hpp"
#include "text_format.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/timing.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace vdbmap::sim {

void ExploreBenchmarkConfig::validate() const {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("ExploreBenchmarkConfig." + what); };
  validateBenchmarkWorlds(worlds, "ExploreBenchmarkConfig");
  DriftConfig::preset(drift_level);  // throws for an unknown level
  if (seeds < 1 || seeds > 1000) fail("seeds must be in [1, 1000]");
  if (!(voxel_size_m > 0.0 && voxel_size_m <= 10.0)) fail("voxel_size_m must be in (0, 10]");
  if (!(max_time_s > 0.0 && max_time_s <= 1e5)) fail("max_time_s must be in (0, 1e5]");
  if (jobs < 1 || jobs > 64) fail("jobs must be in [1, 64]");
  safety.validate();
}

namespace {

using internal::Spread;
using internal::spread;

double activity(const ExplorationSummary& s, planner::ExplorationActivity a) { return s.activity_time_s[std::size_t(a)]; }

nlohmann::json toJson(const ExploreBenchmarkRun& r) {
  const ExplorationSummary& s = r.summary;
  nlohmann::json to_coverage = nlohmann::json::object();
  for (std::size_t i = 0; i < kCoverageMilestones.size(); ++i)
    to_coverage[format("%.2f", kCoverageMilestones[i])] =
        s.time_to_coverage_s[i] >= 0.0 ? nlohmann::json(s.time_to_coverage_s[i]) : nlohmann::json(nullptr);
  nlohmann::json activities = nlohmann::json::object();
  for (int a = 0; a < planner::kExplorationActivities; ++a)
    activities[toString(planner::ExplorationActivity(a))] = s.activity_time_s[std::size_t(a)];
  return {{"world", r.world},
          {"seed", r.seed},
          {"finished", s.finished},
          {"complete", s.complete},
          {"exploration_time_s", s.exploration_time_s},
          {"time_to_coverage_s", to_coverage},
          {"coverage", s.coverage},
          {"coverage_seen", s.coverage_seen},
          {"path_length_m", s.path_length_m},
          {"mean_speed_mps", s.mean_speed_mps},
          {"activity_time_s", activities},
          {"longest_hold_s", s.longest_hold_s},
          {"collisions", s.collisions},
          {"loop_closures", s.loop_closures},
          {"accuracy_rmse_m", s.accuracy_rmse_m},
          {"planner_ms_median", s.planner_ms_median},
          {"planner_ms_max", s.planner_ms_max},
          {"wall_s", s.wall_s},
          {"real_time_factor", s.wall_s > 0.0 ? s.exploration_time_s / s.wall_s : 0.0}};
}

void writeOutputs(const ExploreBenchmarkResult& result, const ExploreBenchmarkConfig& config,
                  const std::filesystem::path& out_dir) {
  nlohmann::json runs = nlohmann::json::array();
  for (const ExploreBenchmarkRun& r : result.runs) runs.push_back(toJson(r));
  vdbmap::writeFileAtomically(out_dir / "explore.json", [&](std::ostream& os) { os << runs.dump(2) << "\n"; });
  const std::string md = exploreBenchmarkMarkdown(result, config);
  vdbmap::writeFileAtomically(out_dir / "explore.md", [&](std::ostream& os) { os << md; });
}

/// "t" or "-" (never reached).
std::string timeOrDash(double t_s) { return t_s >= 0.0 ? format("%.0f", t_s) : std::string("-"); }

}  // namespace

ExploreBenchmarkResult runExploreBenchmark(const ExploreBenchmarkConfig& config, const std::filesystem::path& out_dir) {
  config.validate();
  const Stopwatch wall;
  const auto report = [&](const std::string& line) {
    if (config.report) config.report(line);
  };
  std::filesystem::create_directories(out_dir);
  std::vector<std::pair<std::size_t, std::uint64_t>> order;  // (world, seed), the tables' order
  for (std::size_t w = 0; w < config.worlds.size(); ++w)
    for (std::uint64_t seed = 1; seed <= config.seeds; ++seed) order.emplace_back(w, seed);
  const auto run_dir = [&](std::size_t w, std::uint64_t seed) {
    return out_dir / "runs" / (config.worlds[w].name + "_seed" + std::to_string(seed));
  };
  const auto description = [&](std::size_t w, std::uint64_t seed) {
    return "vdbmap bench explore: world " + config.worlds[w].name + ", seed " + std::to_string(seed) + ", drift " +
           config.drift_level + (config.alc ? ", ALC on" : "");
  };
  std::vector<std::optional<ExploreBenchmarkRun>> earlier(order.size());
  std::vector<std::size_t> runs_to_do(config.worlds.size(), 0);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const auto [w, seed] = order[i];
    if (std::optional<ExplorationSummary> s = internal::startingPoint(
            config.resume, run_dir(w, seed),
            internal::runIdentity(description(w, seed), config.worlds[w], config.voxel_size_m, config.max_time_s,
                                  config.alc, planner::AlcConfig{}.epsilon, config.safety, config.drift_level,
                                  config.look_into_unknown, SimulatorConfig{}.loop_closure)))
      earlier[i] = ExploreBenchmarkRun{config.worlds[w].name, seed, *s};
    if (!earlier[i]) ++runs_to_do[w];
  }
  internal::LazyWorlds worlds(config.worlds, out_dir, runs_to_do);
  ExploreBenchmarkResult result;
  const auto explore = [&](std::size_t i) {
    const auto [w, seed] = order[i];
    const std::string& world_name = config.worlds[w].name;
    const World& world = worlds.world(w);
    ExplorationConfig ec = explorationConfigFor(world, config.drift_level, seed, config.voxel_size_m);
    ec.max_time_s = config.max_time_s;
    ec.planner.alc_enabled = config.alc;
    ec.planner.alc.tour.seed = seed;
    ec.planner.safety = config.safety;
    ec.planner.viewpoint.look_into_unknown = config.look_into_unknown;
    if (!ec.planner.safety.odometry) ec.planner.safety.odometry = odometryDriftOf(ec.simulator.drift);
    const ExplorationRunConfig ro =
        internal::benchmarkRunConfig(config.keep_runs, worlds.file(w), description(w, seed));
    ExploreBenchmarkRun run{world_name, seed, exploreToFolder(world, ec, run_dir(w, seed), ro)};
    worlds.done(w);
    return run;
  };
  result.runs = internal::keptRuns(earlier, out_dir, report);
  if (!result.runs.empty()) {
    result.wall_s = wall.s();
    writeOutputs(result, config, out_dir);
  }
  std::vector<std::uint64_t> seed_of;
  for (const auto& run : order) seed_of.push_back(run.second);
  internal::runBenchmarkRuns<ExploreBenchmarkRun>(
      seed_of, std::move(earlier), config.jobs, explore,
      [&](const ExploreBenchmarkRun& run, std::vector<ExploreBenchmarkRun>& done) {
        const ExplorationSummary& s = run.summary;
        report(run.world + "_seed" + std::to_string(run.seed) + ": " + (s.finished ? "finished" : "time limit") +
               " after " + format("%.1f s", s.exploration_time_s) + ", coverage " + format("%.3f", s.coverage) +
               ", 0.95 at " + timeOrDash(s.time_to_coverage_s[3]) + " s, " + format("%.2f m/s", s.mean_speed_mps) +
               ", " + std::to_string(s.collisions) + " collisions, " + format("%.0f s wall", s.wall_s));
        result.runs = std::move(done);
        result.wall_s = wall.s();
        writeOutputs(result, config, out_dir);
      });
  return result;
}

std::string exploreBenchmarkMarkdown(const ExploreBenchmarkResult& result, const ExploreBenchmarkConfig& config) {
  std::ostringstream md;
  md << "# Exploration speed\n\nDrift " << config.drift_level << ", seeds 1.." << config.seeds << ", voxel "
     << config.voxel_size_m << " m, ALC " << (config.alc ? "on" : "off") << ", safety layer "
     << internal::safetyDescription(config.safety, config.drift_level) << ", view score `"
     << planner::viewScoreName(config.look_into_unknown) << "`, time limit " << config.max_time_s
     << " s. Times are simulated seconds; `t95` is the time to 95 % coverage of the observable surface (`-`: never "
        "reached); the final sweep is the time spent on the small clusters after the main ones were done; the "
        "real-time factor is simulated over wall-clock time (this machine). A run is complete when it finished at 0.95 "
        "coverage or more; finishing below that is a failed run. Per world: mean ± sample standard "
        "deviation over the seeds (a `-` in a run leaves it out of the mean).\n\n";
  std::map<std::string, std::vector<const ExplorationSummary*>> by_world;
  std::vector<std::string> order;
  for (const ExploreBenchmarkRun& r : result.runs) {
    if (!by_world.count(r.world)) order.push_back(r.world);
    by_world[r.world].push_back(&r.summary);
  }
  const auto cell = [](const std::vector<double>& v, const char* fmt) {
    const Spread s = spread(v);
    if (s.n == 0) return std::string("-");
    return format(fmt, s.mean) + (s.n > 1 ? " ± " + format(fmt, s.sd) : std::string());
  };
  md << "## Per world\n\n| world | runs | finished | complete | t50 | t80 | t90 | t95 | t99 | time (s) | coverage | "
        "speed (m/s) | final sweep (s) | longest hold (s) | collisions | planner p50 / max (ms) | real-time factor |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const std::string& world : order) {
    const std::vector<const ExplorationSummary*>& runs = by_world[world];
    const auto values = [&](const auto& f) {
      std::vector<double> v;
      for (const ExplorationSummary* s : runs) {
        const double x = f(*s);
        if (x >= 0.0) v.push_back(x);
      }
      return v;
    };
    std::size_t finished = 0, complete = 0;
    for (const ExplorationSummary* s : runs) {
      finished += s->finished ? 1 : 0;
      complete += s->complete ? 1 : 0;
    }
    md << "| " << world << " | " << runs.size() << " | " << finished << " | " << complete << " |";
    for (std::size_t i = 0; i < kCoverageMilestones.size(); ++i)
      md << " " << cell(values([i](const ExplorationSummary& s) { return s.time_to_coverage_s[i]; }), "%.0f") << " |";
    md << " " << cell(values([](const ExplorationSummary& s) { return s.exploration_time_s; }), "%.0f") << " | "
       << cell(values([](const ExplorationSummary& s) { return s.coverage; }), "%.3f") << " | "
       << cell(values([](const ExplorationSummary& s) { return s.mean_speed_mps; }), "%.2f") << " | "
       << cell(values([](const ExplorationSummary& s) { return activity(s, planner::ExplorationActivity::FinalSweep); }), "%.0f")
       << " | " << cell(values([](const ExplorationSummary& s) { return s.longest_hold_s; }), "%.1f") << " | "
       << cell(values([](const ExplorationSummary& s) { return double(s.collisions); }), "%.1f") << " | "
       << cell(values([](const ExplorationSummary& s) { return s.planner_ms_median; }), "%.0f") << " / "
       << cell(values([](const ExplorationSummary& s) { return s.planner_ms_max; }), "%.0f") << " | "
       << cell(values([](const ExplorationSummary& s) { return s.wall_s > 0 ? s.exploration_time_s / s.wall_s : 0.0; }), "%.2f")
       << " |\n";
  }
  md << "\n## Runs\n\n| world | seed | finished | t50 | t80 | t90 | t95 | t99 | time (s) | coverage | path (m) | speed "
        "(m/s) | to target / final sweep / turning / looking / holding / initial turn / other (s) | longest hold (s) | "
        "collisions | "
        "wall (s) |\n|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|\n";
  for (const ExploreBenchmarkRun& r : result.runs) {
    const ExplorationSummary& s = r.summary;
    using A = planner::ExplorationActivity;
    const double other = activity(s, A::LoopDetour) + activity(s, A::Escaping) + activity(s, A::Retreating);
    md << "| " << r.world << " | " << r.seed << " | " << (s.finished ? "yes" : "no") << " |";
    for (std::size_t i = 0; i < kCoverageMilestones.size(); ++i) md << " " << timeOrDash(s.time_to_coverage_s[i]) << " |";
    md << " " << format("%.1f", s.exploration_time_s) << " | " << format("%.3f", s.coverage) << " | "
       << format("%.0f", s.path_length_m) << " | " << format("%.2f", s.mean_speed_mps) << " | "
       << format("%.0f", activity(s, A::ToTarget)) << " / " << format("%.0f", activity(s, A::FinalSweep)) << " / "
       << format("%.0f", activity(s, A::Turning)) << " / " << format("%.0f", activity(s, A::Looking)) << " / "
       << format("%.0f", activity(s, A::Holding)) << " / " << format("%.0f", activity(s, A::InitialTurn)) << " / "
       << format("%.0f", other) << " | " << format("%.1f", s.longest_hold_s) << " | " << s.collisions << " | "
       << format("%.0f", s.wall_s) << " |\n";
  }
  return md.str();
}

}  // namespace vdbmap::sim
