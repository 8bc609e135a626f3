// The paper's active-loop-closure experiment (Zhang et al. 2022, Sect. V-C) in one call: each
// world explored with and without ALC over several seeds, at one drift level. One world is an
// anecdote; several generated offices (benchmark_world.hpp) show whether ALC helps on layouts
// nobody tuned on.
//
// For each world and seed k (1..seeds) both arms run with the same set-up (explorationConfigFor: drift seeded
// with k, planner seeded with k, same start), `jobs` runs at a time: "no_alc" (plain FUEL) and "alc"
// (ExplorationManagerConfig::alc_enabled, epsilon from the config). Each run is evaluated like `vdbmap
// explore` (coverage of the observable surface, map RMSE and completeness against the world mesh)
// and its folder OUTDIR/runs/<world>/<arm>_seed<k>/ gets summary.json and the trajectories (the
// log and the map too with keep_runs).
//
// Output: OUTDIR/alc.json (one object per run: world, arm, seed, exploration_time_s,
// loop_closures, accuracy_rmse_m, completeness, finished, coverage, alc_detours, alc_time_s, ...)
// and OUTDIR/alc.md: pooled over all worlds, the mean and standard deviation per arm and the
// paired effect of ALC (time overhead, loop-closure gain, RMSE change and the share of pairs
// where ALC's map is better, runs that finished below `min_finish_coverage`); then the same per
// world, and every run. Both files are rewritten after every run, so an interrupted benchmark
// leaves the runs done so far, listed in the tables' order (per world, per seed, no_alc then alc)
// whichever ended first. Runs start seed by seed across the worlds (seed 1 of every world first),
// so that a benchmark stopped early has runs of each world.
#pragma once

#include "vdbmap/planner/active_loop_closure.hpp"
#include "vdbmap/planner/viewpoint.hpp"
#include "vdbmap/sim/benchmark_world.hpp"
#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/sim/simulator.hpp"
#include "vdbmap/sim/world.hpp"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace vdbmap::sim {

struct AlcBenchmarkConfig {
  std::vector<BenchmarkWorld> worlds;                        ///< at least one, names unique
  std::string drift_level = "s3";                            ///< Table I level
  std::size_t seeds = 5;                                     ///< seeds 1..seeds; [1, 1000]
  double voxel_size_m = 0.1;                                 ///< (0, 10]
  double max_time_s = ExplorationConfig::kDefaultMaxTime_s;  ///< per run; (0, 1e5]
  /// The ALC arm's parameters (its tour seed follows the run's seed).
  planner::AlcConfig alc;
  LoopClosureMode loop_closure = SimulatorConfig{}.loop_closure;
  /// Both arms' safety layer (exploration_manager.hpp; off by default, as in `vdbmap explore`).
  planner::SafetyConfig safety;
  /// Both arms' viewpoint scoring (planner::ViewpointConfig::look_into_unknown, `--view-score`).
  bool look_into_unknown = planner::ViewpointConfig{}.look_into_unknown;
  /// A run that ends (finished or not) below this coverage of the observable surface counts as
  /// incomplete in the tables: finishing with large unexplored regions is a failure; [0, 1].
  double min_finish_coverage = kCompleteCoverage;
  /// Also keep each run's log and map (large); summary.json and trajectories are always written.
  bool keep_runs = false;
  /// Keep the runs an earlier call left in the output folder (each run folder's summary.json) and
  /// run only the others; a run made with other options (runs/<world>/<arm>_seed<k>/summary.json
  /// records them) is an error, never mixed into the tables. Without it, every run is made anew
  /// (its earlier summary.json is removed when the call starts).
  bool resume = false;
  /// Runs at a time (each also uses the machine's cores for its own work). A run's budgets are
  /// counted (BudgetMode::Counted), so it repeats exactly whatever runs beside it unless the
  /// machine gets 20 times slower for it (the wall-clock backstop): no more jobs than cores; [1, 64]
  std::size_t jobs = 1;
  /// Called with a line of progress text (in the order runs end).
  std::function<void(const std::string&)> report;

  void validate() const;
};

struct AlcBenchmarkRun {
  std::string world;  ///< BenchmarkWorld::name
  std::string arm;    ///< "alc" or "no_alc"
  std::uint64_t seed = 1;
  ExplorationSummary summary;
};

struct AlcBenchmarkResult {
  std::vector<AlcBenchmarkRun> runs;  ///< per world, per seed: no_alc, then alc
  double wall_s = 0.0;                ///< this call's
  std::size_t kept_runs = 0;          ///< of runs: read back from an earlier call (resume), not flown
};

/// Runs the benchmark into `out_dir` (created; runs already there are overwritten unless
/// config.resume keeps them). Throws std::invalid_argument for an invalid config,
/// std::runtime_error on I/O errors and for runs a resumed call cannot keep.
AlcBenchmarkResult runAlcBenchmark(const AlcBenchmarkConfig& config, const std::filesystem::path& out_dir);

/// alc.md's text.
std::string alcBenchmarkMarkdown(const AlcBenchmarkResult& result, const AlcBenchmarkConfig& config);

}  // namespace vdbmap::sim
