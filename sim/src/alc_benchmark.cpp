#include "vdbmap/sim/alc_benchmark.hpp"
#include "vdbmap/timing.hpp"

#include "internal/benchmark_run.hpp"
#include "internal/spread.hpp"
#include "text_format.hpp"

#include "vdbmap/atomic_file.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace vdbmap::sim {

void AlcBenchmarkConfig::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("AlcBenchmarkConfig." + what); };
  validateBenchmarkWorlds(worlds, "AlcBenchmarkConfig");
  DriftConfig::preset(drift_level);  // throws for an unknown level
  if (seeds < 1 || seeds > 1000) fail("seeds must be in [1, 1000]");
  if (!(voxel_size_m > 0.0 && voxel_size_m <= 10.0)) fail("voxel_size_m must be in (0, 10]");
  if (!(max_time_s > 0.0 && max_time_s <= 1e5)) fail("max_time_s must be in (0, 1e5]");
  if (!(min_finish_coverage >= 0.0 && min_finish_coverage <= 1.0)) fail("min_finish_coverage must be in [0, 1]");
  if (jobs < 1 || jobs > 64) fail("jobs must be in [1, 64]");
  alc.validate();
  safety.validate();
}

namespace {

constexpr const char* kArms[] = {"no_alc", "alc"};

nlohmann::json toJson(const AlcBenchmarkRun& r) {
  const ExplorationSummary& s = r.summary;
  return {{"world", r.world},
          {"arm", r.arm},
          {"seed", r.seed},
          {"exploration_time_s", s.exploration_time_s},
          {"loop_closures", s.loop_closures},
          {"accuracy_rmse_m", s.accuracy_rmse_m},
          {"completeness", s.completeness},
          {"finished", s.finished},
          {"coverage", s.coverage},
          {"coverage_seen", s.coverage_seen},
          {"path_length_m", s.path_length_m},
          {"estimate_error_rmse_m", s.estimate_error_rmse_m},
          {"keyframe_error_rmse_m", internal::knownOrNull(s.keyframe_error_rmse_m)},
          {"keyframe_error_aligned_rmse_m", internal::knownOrNull(s.keyframe_error_aligned_rmse_m)},
          {"accuracy_aligned_rmse_m", internal::knownOrNull(s.accuracy_aligned_rmse_m)},
          {"map_alignment_yaw_deg", s.map_alignment.yaw_rad * 180.0 / M_PI},
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
/// The runs' values of a metric in one arm; negative values (not known: summaries older than the
/// metric) are left out.
std::vector<double> values(const AlcBenchmarkResult& result, const std::string& arm, const Metric& metric) {
  std::vector<double> v;
  for (const AlcBenchmarkRun& r : result.runs)
    if (r.arm == arm && metric(r.summary) >= 0.0) v.push_back(metric(r.summary));
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
  std::filesystem::create_directories(out_dir);
  struct Job {
    std::size_t world;
    std::uint64_t seed;
    const char* arm;
  };
  std::vector<Job> order;  // per world, per seed: no_alc, then alc (the tables' order)
  for (std::size_t w = 0; w < config.worlds.size(); ++w)
    for (std::uint64_t seed = 1; seed <= config.seeds; ++seed)
      for (const char* arm : kArms) order.push_back({w, seed, arm});
  const auto run_dir = [&](const Job& job) {
    return out_dir / "runs" / config.worlds[job.world].name /
           (std::string(job.arm) + "_seed" + std::to_string(job.seed));
  };
  const auto description = [&](const Job& job) {
    return "vdbmap bench alc: world " + config.worlds[job.world].name + ", arm " + std::string(job.arm) + ", seed " +
           std::to_string(job.seed) + ", drift " + config.drift_level;
  };
  std::vector<std::optional<AlcBenchmarkRun>> earlier(order.size());
  std::vector<std::size_t> runs_to_do(config.worlds.size(), 0);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const Job& job = order[i];
    const bool alc = std::string(job.arm) == "alc";
    if (std::optional<ExplorationSummary> s = internal::startingPoint(
            config.resume, run_dir(job),
            internal::runIdentity(description(job), config.worlds[job.world], config.voxel_size_m, config.max_time_s,
                                  alc, config.alc.epsilon, config.safety, config.drift_level, config.look_into_unknown,
                                  config.loop_closure)))
      earlier[i] = AlcBenchmarkRun{config.worlds[job.world].name, job.arm, job.seed, *s};
    if (!earlier[i]) ++runs_to_do[job.world];
  }
  internal::LazyWorlds worlds(config.worlds, out_dir, runs_to_do);
  AlcBenchmarkResult result;
  const auto explore = [&](std::size_t i) {
    const Job& job = order[i];
    const World& world = worlds.world(job.world);
    ExplorationConfig ec = explorationConfigFor(world, config.drift_level, job.seed, config.voxel_size_m);
    ec.simulator.loop_closure = config.loop_closure;
    ec.max_time_s = config.max_time_s;
    ec.planner.alc_enabled = std::string(job.arm) == "alc";
    ec.planner.alc = config.alc;
    ec.planner.alc.tour.seed = job.seed;
    ec.planner.safety = config.safety;
    ec.planner.viewpoint.look_into_unknown = config.look_into_unknown;
    if (!ec.planner.safety.odometry) ec.planner.safety.odometry = odometryDriftOf(ec.simulator.drift);
    const ExplorationRunConfig ro =
        internal::benchmarkRunConfig(config.keep_runs, worlds.file(job.world), description(job));
    AlcBenchmarkRun run{config.worlds[job.world].name, job.arm, job.seed, exploreToFolder(world, ec, run_dir(job), ro)};
    worlds.done(job.world);
    return run;
  };
  result.runs = internal::keptRuns(earlier, out_dir, report);
  result.kept_runs = result.runs.size();
  if (!result.runs.empty()) {
    result.wall_s = wall.s();
    writeOutputs(result, config, out_dir);
  }
  std::vector<std::uint64_t> seed_of;
  for (const Job& job : order) seed_of.push_back(job.seed);
  internal::runBenchmarkRuns<AlcBenchmarkRun>(
      seed_of, std::move(earlier), config.jobs, explore,
      [&](const AlcBenchmarkRun& run, std::vector<AlcBenchmarkRun>& done) {
        const ExplorationSummary& s = run.summary;
        report(run.world + "/" + run.arm + "_seed" + std::to_string(run.seed) + ": " +
               (s.finished ? "finished" : "time limit") + " after " + format("%.1f s", s.exploration_time_s) + ", " +
               std::to_string(s.loop_closures) + " loop closures, rmse " + format("%.4f m", s.accuracy_rmse_m) +
               ", coverage " + format("%.3f", s.coverage) + ", " + std::to_string(s.alc_detours) + " detours (" +
               format("%.1f s", s.alc_time_s) + "), " + std::to_string(s.collisions) + " collisions, " +
               format("%.0f s wall", s.wall_s));
        result.runs = std::move(done);
        result.wall_s = wall.s();
        writeOutputs(result, config, out_dir);
      });
  return result;
}

namespace {

/// Whether a run ended with at least the coverage a complete run needs (finished or not).
bool complete(const ExplorationSummary& s, double min_finish_coverage) { return s.coverage >= min_finish_coverage; }

/// The two arms of one world and seed.
struct Pair {
  std::string world;
  std::uint64_t seed = 0;
  const ExplorationSummary *off = nullptr, *on = nullptr;
};

/// Pairs of `runs` whose two arms are both done, in run order; `world` empty means all worlds.
std::vector<Pair> pairs(const std::vector<AlcBenchmarkRun>& runs, const std::string& world) {
  std::vector<Pair> out;
  std::map<std::pair<std::string, std::uint64_t>, std::size_t> index;
  for (const AlcBenchmarkRun& r : runs) {
    if (!world.empty() && r.world != world) continue;
    const auto [it, added] = index.try_emplace({r.world, r.seed}, out.size());
    if (added) out.push_back(Pair{r.world, r.seed});
    (r.arm == "alc" ? out[it->second].on : out[it->second].off) = &r.summary;
  }
  std::vector<Pair> done;
  for (const Pair& p : out)
    if (p.off && p.on) done.push_back(p);
  return done;
}

/// The effect of ALC over `ps`: sums and counts, so that pooled and per-world rows read alike.
struct Effect {
  std::size_t n = 0;
  Spread time_off, time_on, loops_off, loops_on, rmse_off, rmse_on, rmse_change, time_change, loop_gain;
  std::size_t alc_better = 0;  ///< pairs where ALC's map RMSE is lower
  /// The maps' RMSE after each one's 4-DOF alignment (accuracy_aligned_rmse_m), over the pairs
  /// where both arms know it.
  Spread aligned_off, aligned_on;
  std::size_t aligned_alc_better = 0;
  std::size_t incomplete_off = 0, incomplete_on = 0;
  std::size_t collisions_off = 0, collisions_on = 0;
  double min_coverage_off = 1.0, min_coverage_on = 1.0;

  double overhead() const { return time_on.mean / time_off.mean - 1.0; }
};

Effect effect(const std::vector<Pair>& ps, double min_finish_coverage) {
  Effect e;
  e.n = ps.size();
  std::vector<double> t0, t1, l0, l1, r0, r1, dr, dt, dl, a0, a1;
  for (const Pair& p : ps) {
    t0.push_back(p.off->exploration_time_s);
    t1.push_back(p.on->exploration_time_s);
    l0.push_back(double(p.off->loop_closures));
    l1.push_back(double(p.on->loop_closures));
    r0.push_back(p.off->accuracy_rmse_m);
    r1.push_back(p.on->accuracy_rmse_m);
    dr.push_back(p.on->accuracy_rmse_m - p.off->accuracy_rmse_m);
    dt.push_back(p.on->exploration_time_s / p.off->exploration_time_s - 1.0);
    dl.push_back(double(p.on->loop_closures) - double(p.off->loop_closures));
    e.alc_better += p.on->accuracy_rmse_m < p.off->accuracy_rmse_m ? 1 : 0;
    if (p.off->accuracy_aligned_rmse_m >= 0.0 && p.on->accuracy_aligned_rmse_m >= 0.0) {
      a0.push_back(p.off->accuracy_aligned_rmse_m);
      a1.push_back(p.on->accuracy_aligned_rmse_m);
      e.aligned_alc_better += p.on->accuracy_aligned_rmse_m < p.off->accuracy_aligned_rmse_m ? 1 : 0;
    }
    e.incomplete_off += complete(*p.off, min_finish_coverage) ? 0 : 1;
    e.incomplete_on += complete(*p.on, min_finish_coverage) ? 0 : 1;
    e.collisions_off += p.off->collisions;
    e.collisions_on += p.on->collisions;
    e.min_coverage_off = std::min(e.min_coverage_off, p.off->coverage);
    e.min_coverage_on = std::min(e.min_coverage_on, p.on->coverage);
  }
  e.time_off = spread(t0), e.time_on = spread(t1), e.loops_off = spread(l0), e.loops_on = spread(l1);
  e.rmse_off = spread(r0), e.rmse_on = spread(r1), e.rmse_change = spread(dr), e.time_change = spread(dt);
  e.loop_gain = spread(dl);
  e.aligned_off = spread(a0), e.aligned_on = spread(a1);
  return e;
}

}  // namespace

std::string alcBenchmarkMarkdown(const AlcBenchmarkResult& result, const AlcBenchmarkConfig& config) {
  std::ostringstream md;
  md << "# Exploration with and without active loop closure\n\n";
  md << (config.worlds.size() == 1 ? "World" : "Worlds");
  for (std::size_t i = 0; i < config.worlds.size(); ++i) {
    const BenchmarkWorld& w = config.worlds[i];
    md << (i ? ", " : " ") << "`" << (w.office ? w.name : w.mesh.string()) << "`";
  }
  md << "; drift " << config.drift_level << ", seeds 1.." << config.seeds << ", voxel " << config.voxel_size_m
     << " m, loop closure `" << toString(config.loop_closure) << "`, time limit " << config.max_time_s
     << " s. ALC: epsilon " << config.alc.epsilon << ", give-up timeout " << config.alc.give_up_timeout_s
     << " s, search radius " << config.alc.search_radius_m << " m. Safety layer "
     << internal::safetyDescription(config.safety, config.drift_level) << ". View score `"
     << planner::viewScoreName(config.look_into_unknown) << "`"
     << ". Both arms of a world and seed share the drift and planner seeds and the start. Values: mean ± sample "
        "standard deviation over the runs done. A run is incomplete when it ends below "
     << format("%.2f", config.min_finish_coverage) << " coverage of the observable surface, finished or not.\n";

  const std::vector<std::pair<std::string, std::pair<const char*, Metric>>> metrics = {
      {"exploration time (s)", {"%.1f", [](const ExplorationSummary& s) { return s.exploration_time_s; }}},
      {"loop closures", {"%.1f", [](const ExplorationSummary& s) { return double(s.loop_closures); }}},
      {"accuracy RMSE (m)", {"%.4f", [](const ExplorationSummary& s) { return s.accuracy_rmse_m; }}},
      {"accuracy RMSE after the 4-DOF alignment (m)",
       {"%.4f", [](const ExplorationSummary& s) { return s.accuracy_aligned_rmse_m; }}},
      {"map yaw offset, absolute (deg)",  // not known where the aligned RMSE is not
       {"%.2f",
        [](const ExplorationSummary& s) {
          return s.accuracy_aligned_rmse_m < 0.0 ? -1.0 : std::abs(s.map_alignment.yaw_rad) * 180.0 / M_PI;
        }}},
      {"completeness", {"%.3f", [](const ExplorationSummary& s) { return s.completeness; }}},
      {"coverage", {"%.3f", [](const ExplorationSummary& s) { return s.coverage; }}},
      {"coverage seen", {"%.3f", [](const ExplorationSummary& s) { return s.coverage_seen; }}},
      {"estimate error RMSE (m)", {"%.3f", [](const ExplorationSummary& s) { return s.estimate_error_rmse_m; }}},
      {"path length (m)", {"%.1f", [](const ExplorationSummary& s) { return s.path_length_m; }}},
      {"finished", {"%.2f", [](const ExplorationSummary& s) { return s.finished ? 1.0 : 0.0; }}},
      {"ALC detours", {"%.1f", [](const ExplorationSummary& s) { return double(s.alc_detours); }}},
      {"ALC detours with a loop", {"%.1f", [](const ExplorationSummary& s) { return double(s.alc_detour_loops); }}},
      {"ALC detour time (s)", {"%.1f", [](const ExplorationSummary& s) { return s.alc_time_s; }}},
      {"collisions", {"%.1f", [](const ExplorationSummary& s) { return double(s.collisions); }}},
  };
  md << "\n## Per arm" << (config.worlds.size() > 1 ? ", all worlds" : "") << "\n\n| metric |";
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

  const std::vector<Pair> all = pairs(result.runs, "");
  md << "\n## Effect of ALC (paired by world and seed, " << all.size() << " pairs)\n\n";
  if (!all.empty()) {
    const Effect e = effect(all, config.min_finish_coverage);
    md << "- time overhead: " << format("%+.1f %%", 100.0 * e.overhead()) << " (ratio of the mean times; per pair "
       << format("%+.1f", 100.0 * e.time_change.mean) << " ± " << format("%.1f %%", 100.0 * e.time_change.sd) << ")\n"
       << "- loop-closure gain: " << format("%+.1f", e.loop_gain.mean) << " ± " << format("%.1f", e.loop_gain.sd)
       << " per run\n"
       << "- accuracy RMSE change: " << format("%+.4f", e.rmse_change.mean) << " ± "
       << format("%.4f m", e.rmse_change.sd) << " (ratio of the means "
       << format("%.2f", e.rmse_on.mean / e.rmse_off.mean) << "); ALC's map better in " << e.alc_better << " of " << e.n
       << " pairs (" << format("%.0f %%", 100.0 * double(e.alc_better) / double(e.n)) << ")\n"
       << "- after each map's 4-DOF alignment with the truth (the rigid offset of its first seconds removed): ";
    if (e.aligned_off.n == 0)
      md << "-\n";
    else
      md << format("%.4f", e.aligned_off.mean) << " against " << format("%.4f m", e.aligned_on.mean)
         << " (ratio of the means " << format("%.2f", e.aligned_on.mean / e.aligned_off.mean)
         << "); ALC's map better in " << e.aligned_alc_better << " of " << e.aligned_off.n << " pairs\n";
    md << "- incomplete runs: " << e.incomplete_off << " without ALC, " << e.incomplete_on
       << " with ALC; lowest coverage " << format("%.3f", e.min_coverage_off) << " / "
       << format("%.3f", e.min_coverage_on) << "\n";
    // A map's RMSE is over the surface it holds: a run that stops early holds only what it saw
    // near the start, before drift grew, so RMSEs compare fairly only between complete runs.
    std::vector<Pair> both_complete;
    for (const Pair& p : all)
      if (complete(*p.off, config.min_finish_coverage) && complete(*p.on, config.min_finish_coverage))
        both_complete.push_back(p);
    md << "- over the " << both_complete.size() << " pairs where both runs are complete: ";
    if (both_complete.empty()) {
      md << "-\n";
    } else {
      const Effect c = effect(both_complete, config.min_finish_coverage);
      md << "RMSE change " << format("%+.4f", c.rmse_change.mean) << " ± " << format("%.4f m", c.rmse_change.sd)
         << ", ALC's map better in " << c.alc_better << " of " << c.n << ", time overhead "
         << format("%+.1f %%", 100.0 * c.overhead()) << "\n";
    }
    md << "- paper (Zhang et al. 2022): +8 % time, +3 loop closures, a better map\n";
  }

  md << "\n## Per world\n\n| world | pairs | RMSE no_alc / alc (m) | ALC better | aligned RMSE no_alc / alc (m) | "
        "ALC better aligned | loops no_alc / alc | time no_alc / "
        "alc (s) | overhead | incomplete no_alc / alc | lowest coverage no_alc / alc | collisions no_alc / alc |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const BenchmarkWorld& w : config.worlds) {
    const std::vector<Pair> ps = pairs(result.runs, w.name);
    if (ps.empty()) continue;
    const Effect e = effect(ps, config.min_finish_coverage);
    md << "| " << w.name << " | " << e.n << " | " << format("%.4f", e.rmse_off.mean) << " / "
       << format("%.4f", e.rmse_on.mean) << " | " << e.alc_better << " / " << e.n << " | "
       << (e.aligned_off.n == 0 ? std::string("-")
                                : format("%.4f", e.aligned_off.mean) + " / " + format("%.4f", e.aligned_on.mean))
       << " | " << e.aligned_alc_better << " / " << e.aligned_off.n << " | " << format("%.1f", e.loops_off.mean)
       << " / " << format("%.1f", e.loops_on.mean) << " | " << format("%.0f", e.time_off.mean) << " / "
       << format("%.0f", e.time_on.mean) << " | " << format("%+.1f %%", 100.0 * e.overhead()) << " | "
       << e.incomplete_off << " / " << e.incomplete_on << " | " << format("%.3f", e.min_coverage_off) << " / "
       << format("%.3f", e.min_coverage_on) << " | " << e.collisions_off << " / " << e.collisions_on << " |\n";
  }

  md << "\n## Runs\n\n| world | seed | arm | finished | time (s) | loops | RMSE / aligned (m) | yaw offset (deg) | "
        "completeness | coverage (seen) | "
        "estimate error online / keyframes (m) | detours (with loop / given up) | detour time (s) | collisions |\n"
        "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const AlcBenchmarkRun& r : result.runs) {
    const ExplorationSummary& s = r.summary;
    md << "| " << r.world << " | " << r.seed << " | " << r.arm << " | " << (s.finished ? "yes" : "no") << " | "
       << format("%.1f", s.exploration_time_s) << " | " << s.loop_closures << " | " << format("%.4f", s.accuracy_rmse_m)
       << " / " << (s.accuracy_aligned_rmse_m >= 0.0 ? format("%.4f", s.accuracy_aligned_rmse_m) : std::string("-"))
       << " | "
       << (s.accuracy_aligned_rmse_m >= 0.0 ? format("%+.2f", s.map_alignment.yaw_rad * 180.0 / M_PI)
                                            : std::string("-"))
       << " | " << format("%.3f", s.completeness) << " | " << format("%.3f", s.coverage) << " ("
       << format("%.3f", s.coverage_seen) << ") | " << format("%.3f", s.estimate_error_rmse_m) << " / "
       << (s.keyframe_error_rmse_m >= 0.0 ? format("%.3f", s.keyframe_error_rmse_m) : std::string("-")) << " | "
       << s.alc_detours << " (" << s.alc_detour_loops << " / " << s.alc_give_ups << ") | "
       << format("%.1f", s.alc_time_s) << " | " << s.collisions << " |\n";
  }
  md << "\nTotal wall time " << format("%.0f s", result.wall_s)
     << (result.kept_runs > 0
             ? " (this call's; " + std::to_string(result.kept_runs) + " runs were kept from an earlier call)"
             : std::string())
     << ".\n";
  return md.str();
}

}  // namespace vdbmap::sim
