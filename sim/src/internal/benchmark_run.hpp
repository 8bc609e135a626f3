// What the benchmarks' runs share (sim-internal).
#pragma once

#include "vdbmap/sim/exploration.hpp"

#include <string>
#include <utility>

namespace vdbmap::sim::internal {

/// A benchmark run's folder options: it replaces a run already there, keeps the log and the map
/// only when asked (summary.json and the trajectories always), and records the world's file for
/// reports.
inline ExplorationRunConfig benchmarkRunConfig(bool keep_runs, std::string world_file, std::string description) {
  ExplorationRunConfig ro;
  ro.overwrite = true;
  ro.write_log = keep_runs;
  ro.write_map = keep_runs;
  ro.world = std::move(world_file);
  ro.description = std::move(description);
  return ro;
}

}  // namespace vdbmap::sim::internal
