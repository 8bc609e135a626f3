// Exploration speed over worlds and seeds in one call: how fast coverage grows, how fast the
// vehicle flies, where the time goes, and whether the closed loop keeps up with real time.
//
// Each world (a mesh file, or a generated office) is explored once per seed 1..seeds with
// `vdbmap explore`'s set-up (explorationConfigFor: drift and planner seeded with the seed) at one
// drift level, ALC on or off. Each run's folder OUTDIR/runs/<world>_seed<k>/ gets summary.json,
// coverage.csv, cycles.csv and the trajectories (the log and the map too with keep_runs).
//
// Output: OUTDIR/explore.json (one object per run) and OUTDIR/explore.md (per world: mean over
// the seeds of the time to 50/80/90/95/99 % coverage, the exploration time, mean speed, the
// final sweep's share, the longest hold, collisions, the planner's time per replan and the real-
// time factor; then every run). Both are rewritten after every run, so an interrupted benchmark
// leaves the runs done so far.
#pragma once

#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/sim/office_world.hpp"
#include "vdbmap/sim/world.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace vdbmap::sim {

/// A world of the benchmark: a mesh file cut as `world` says, or a generated office (cut and
/// capped at its ceiling).
struct ExploreBenchmarkWorld {
  std::string name;                         ///< the runs' folder prefix and the table's row name
  std::filesystem::path mesh;               ///< a mesh file, or empty for `office`
  WorldConfig world;                        ///< for a mesh file
  std::optional<OfficeWorldConfig> office;  ///< a generated office instead of a file
};

/// "office:SEED" or "office:SEED:XxY" (a generated office, e.g. office:3:20x16), or a mesh path
/// (cut and capped at `ceiling_m` when it is positive). Throws std::invalid_argument naming a
/// malformed spec.
ExploreBenchmarkWorld parseExploreBenchmarkWorld(const std::string& spec, double ceiling_m);

struct ExploreBenchmarkConfig {
  std::vector<ExploreBenchmarkWorld> worlds;                 ///< at least one
  std::string drift_level = "s1";                            ///< Table I level
  std::size_t seeds = 3;                                     ///< seeds 1..seeds; [1, 1000]
  double voxel_size_m = 0.1;                                 ///< (0, 10]
  double max_time_s = ExplorationConfig::kDefaultMaxTime_s;  ///< per run; (0, 1e5]
  bool alc = false;                                          ///< active loop closure on
  bool keep_runs = false;  ///< also keep each run's log and map (large)
  std::function<void(const std::string&)> report;  ///< a line of progress text

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

/// Runs the benchmark into `out_dir` (created; runs already there are overwritten). Throws
/// std::invalid_argument for an invalid config, std::runtime_error on I/O errors.
ExploreBenchmarkResult runExploreBenchmark(const ExploreBenchmarkConfig& config, const std::filesystem::path& out_dir);

/// explore.md's text.
std::string exploreBenchmarkMarkdown(const ExploreBenchmarkResult& result, const ExploreBenchmarkConfig& config);

}  // namespace vdbmap::sim
