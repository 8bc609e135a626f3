// What the benchmarks' runs share (sim-internal).
#pragma once

#include "text_format.hpp"
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

/// The safety layer as a benchmark's table header states it: "off", or "on" with its options and
/// the vertical margin its runs keep at `drift_level` (none without drift; "a-b" when it grows
/// from a at the start to at most b).
inline std::string safetyDescription(const planner::SafetyConfig& safety, const std::string& drift_level) {
  if (!safety.enabled) return "off";
  planner::SafetyConfig at_level = safety;
  if (!at_level.odometry) at_level.odometry = odometryDriftOf(DriftConfig::preset(drift_level));
  const double first_m = at_level.verticalMargin_m(), most_m = at_level.verticalMargin_m(1e9);
  return std::string("on") + (safety.seen_free_is_free ? " (seen free is free)" : "") +
         (!safety.map_thin_obstacles ? " (no thin structure from the map)" : "") + " (vertical margin " +
         format("%.2f", first_m) + (most_m > first_m ? format("-%.2f", most_m) : std::string()) + " m)";
}

}  // namespace vdbmap::sim::internal
