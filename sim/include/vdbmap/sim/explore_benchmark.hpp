// Exploration speed over worlds and seeds in one call: how fast coverage grows, how fast the
// vehicle flies, where the time goes, and whether the closed loop keeps up with real time.
//
// Each world (benchmark_world.hpp: a mesh file, or a generated office) is explored once per seed 1..seeds with
// `vdbmap explore`'s set-up (explorationConfigFor: drift and planner seeded with the seed) at one
// drift level, ALC on or off. Each run's folder OUTDIR/runs/<world>_seed<k>/ gets summary.json,
// coverage.csv, cycles.csv and the trajectories (the log and the map too with keep_runs).
//
// Output: OUTDIR/explore.json (one object per run) and OUTDIR/explore.md (per world: the runs
// finished and complete (kCompleteCoverage), and the mean over the seeds of the time to
// 50/80/90/95/99 % coverage, the exploration time, mean speed, the final sweep's share, the
// longest hold, collisions, the planner's time per replan and the real-time factor; then every
// run). Both are rewritten after every run, so an interrupted benchmark leaves the runs done so
// far, listed in the tables' order (per world, per seed) whichever ended first. Runs start seed by
// seed across the worlds, so that a benchmark stopped early has runs of each world.
#pragma once

#include "vdbmap/planner/viewpoint.hpp"
#include "vdbmap/sim/benchmark_world.hpp"
#include "vdbmap/sim/exploration.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::sim {

struct ExploreBenchmarkConfig {
  std::vector<BenchmarkWorld> worlds;                        ///< at least one, names unique
  std::string drift_level = "s1";                            ///< Table I level
  std::size_t seeds = 3;                                     ///< seeds 1..seeds; [1, 1000]
  double voxel_size_m = 0.1;                                 ///< (0, 10]
  double max_time_s = ExplorationConfig::kDefaultMaxTime_s;  ///< per run; (0, 1e5]
  bool alc = false;                                          ///< active loop closure on
  planner::SafetyConfig safety;  ///< the safety layer (off by default, as in `vdbmap explore`)
  /// What viewpoints score by (planner::ViewpointConfig::look_into_unknown, `--view-score`).
  bool look_into_unknown = planner::ViewpointConfig{}.look_into_unknown;
  bool keep_runs = false;  ///< also keep each run's log and map (large)
  /// Keep the runs an earlier call left in the output folder and run only the others, as
  /// AlcBenchmarkConfig::resume (a run made with other options is an error).
  bool resume = false;
  /// Runs at a time (each also uses the machine's cores for its own work). A run's budgets are
  /// counted (BudgetMode::Counted), so it repeats exactly whatever runs beside it unless the
  /// machine gets 20 times slower for it (the wall-clock backstop): no more jobs than cores; the
  /// timing columns change with it; [1, 64]
  std::size_t jobs = 1;
  std::function<void(const std::string&)> report;  ///< a line of progress text (in the order runs end)

  void validate() const;
};

struct ExploreBenchmarkRun {
  std::string world;
  std::uint64_t seed = 1;
  ExplorationSummary summary;
};

struct ExploreBenchmarkResult {
  std::vector<ExploreBenchmarkRun> runs;  ///< per world, per seed
  double wall_s = 0.0;
};

/// Runs the benchmark into `out_dir` (created; runs already there are overwritten unless
/// config.resume keeps them). Throws std::invalid_argument for an invalid config,
/// std::runtime_error on I/O errors and for runs a resumed call cannot keep.
ExploreBenchmarkResult runExploreBenchmark(const ExploreBenchmarkConfig& config, const std::filesystem::path& out_dir);

/// explore.md's text.
std::string exploreBenchmarkMarkdown(const ExploreBenchmarkResult& result, const ExploreBenchmarkConfig& config);

}  // namespace vdbmap::sim
