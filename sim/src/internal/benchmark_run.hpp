// What the benchmarks' runs share (sim-internal).
#pragma once

#include "internal/summary_json.hpp"
#include "text_format.hpp"
#include "vdbmap/planner/viewpoint.hpp"
#include "vdbmap/sim/benchmark_world.hpp"
#include "vdbmap/sim/exploration.hpp"
#include "vdbmap/sim/simulator.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstddef>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

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

/// `safety` with the odometry a run at `drift_level` declares (setDrift), unless it declares one.
inline planner::SafetyConfig atDriftLevel(planner::SafetyConfig safety, const std::string& drift_level) {
  if (!safety.odometry) safety.odometry = odometryDriftOf(DriftConfig::preset(drift_level));
  return safety;
}

/// The safety layer as a benchmark's table header states it: "off", or "on" with its options and
/// the vertical margin its runs keep at `drift_level` (none without drift; "a-b" when it grows
/// from a at the start to at most b).
inline std::string safetyDescription(const planner::SafetyConfig& safety, const std::string& drift_level) {
  if (!safety.enabled) return "off";
  const planner::SafetyConfig at_level = atDriftLevel(safety, drift_level);
  const double first_m = at_level.verticalMargin_m(), most_m = at_level.verticalMargin_m(1e9);
  return std::string("on") + (safety.seen_free_is_free ? " (seen free is free)" : "") +
         (!at_level.mapThinObstacles() ? " (no thin structure from the map)" : "") + " (vertical margin " +
         format("%.2f", first_m) + (most_m > first_m ? format("-%.2f", most_m) : std::string()) + " m)" +
         (at_level.nearSeenAge_s() < at_level.seenAge_s()
              ? " (near surfaces only frames drifted at most " + format("%.2f", safety.near_drift_tolerance_m) +
                    " m: " + format("%.1f", at_level.nearSeenAge_s()) + " s)"
              : std::string()) +
         (safety.path_drift != planner::PathDriftScope::Off
              ? std::string(" (the path flown counts in a frame's drift: ") + planner::toString(safety.path_drift) + ")"
              : std::string());
}

/// What a benchmark run's summary.json records of how it was run: an earlier call's run stands for
/// this call's only when these agree (the description names the world, the arm or the ALC switch,
/// the seed and the drift level; a mesh world's file and every world's ceiling cut are recorded
/// too; null: the key must be absent).
inline nlohmann::json runIdentity(const std::string& description, const BenchmarkWorld& world, double voxel_size_m,
                                  double max_time_s, bool alc_enabled, double epsilon,
                                  const planner::SafetyConfig& safety, const std::string& drift_level,
                                  bool look_into_unknown, LoopClosureMode loop_closure) {
  // As the run declares its odometry: summary.json records what flight read.
  const planner::SafetyConfig at_level = atDriftLevel(safety, drift_level);
  const double clip_z_m = world.office ? world.office->height_m : world.world.ceiling_clip_z_m;
  const bool capped = world.office ? true : world.world.cap_ceiling;
  nlohmann::json identity = {
      {"description", description},
      {"world_ceiling",
       std::isfinite(clip_z_m) ? nlohmann::json{{"clip_z_m", clip_z_m}, {"capped", capped}} : nlohmann::json()},
      {"voxel_size_m", voxel_size_m},
      {"max_time_s", max_time_s},
      {"alc_enabled", alc_enabled},
      {"epsilon", alc_enabled ? epsilon : 0.0},
      {"safety_layer", safety.enabled},
      {"safety_seen_free", safety.enabled && safety.seen_free_is_free},
      {"safety_map_thin", !safety.enabled || at_level.mapThinObstacles()},
      {"safety_free_clears", safety.enabled && safety.recent.newer_free_clears},
      {"safety_near_drift_tolerance_m", safety.enabled ? safety.near_drift_tolerance_m : 0.0},
      {"safety_path_drift", planner::toString(safety.enabled ? safety.path_drift : planner::PathDriftScope::Off)},
      {"view_score", planner::viewScoreName(look_into_unknown)},
      {"fallback_min_visible", planner::ViewpointFallback{}.min_visible_samples},  // benchmarks fly the default
      {"fallback_large_cluster_voxels", planner::ViewpointFallback{}.large_cluster_voxels},
      {"fallback_large_min_visible", planner::ViewpointFallback{}.large_min_visible_samples},
      {"fallback_large_min_visible_late", planner::ExplorationManagerConfig{}.late_large_min_visible_samples},
      {"loop_closure", toString(loop_closure)}};
  if (!world.office) identity["world"] = std::filesystem::absolute(world.mesh).lexically_normal().string();
  return identity;
}

/// The identity keys that summaries written before their option existed lack, each with the value
/// such a run was flown with (the option's default then).
inline const nlohmann::json& keysAddedLater() {
  static const nlohmann::json keys = {{"safety_near_drift_tolerance_m", 0.0},
                                      {"safety_path_drift", planner::toString(planner::PathDriftScope::Off)},
                                      {"view_score", planner::viewScoreName(false)},
                                      {"fallback_min_visible", 15},
                                      {"fallback_large_cluster_voxels", 100},
                                      {"fallback_large_min_visible", 15},
                                      {"fallback_large_min_visible_late", 15}};
  return keys;
}

/// Where a benchmark's planned run starts. Resuming: the run an earlier call left in `run_dir` (its
/// summary.json), when it was run as `identity` says (runIdentity; a summary without one of
/// keysAddedLater() counts as flown with its value there), else nothing when there is none; throws
/// std::runtime_error naming the file and the first key (in alphabetical order) that differs, so
/// that a resumed table never mixes runs made with other options. Not resuming: nothing, after
/// removing the summary.json an earlier call left there, so that this call, if stopped before it
/// reaches the run, does not leave it to a later resume.
inline std::optional<ExplorationSummary> startingPoint(bool resume, const std::filesystem::path& run_dir,
                                                       const nlohmann::json& identity) {
  const std::filesystem::path file = run_dir / "summary.json";
  if (!resume) {
    std::filesystem::remove(file);
    return std::nullopt;
  }
  if (!std::filesystem::exists(file)) return std::nullopt;
  const nlohmann::json recorded = readSummaryJson(file);
  for (const auto& [key, value] : identity.items()) {
    const auto it = recorded.find(key);
    if (it == recorded.end() && keysAddedLater().value(key, nlohmann::json()) == value) continue;
    if (value.is_null() && (it == recorded.end() || it->is_null())) continue;
    if (it == recorded.end() || *it != value)
      throw std::runtime_error(file.string() + " was run with " + key + " = " +
                               (it == recorded.end() ? std::string("(not recorded)") : it->dump()) +
                               " but this benchmark asks for " + value.dump() +
                               ": resume into another folder, or run again without resuming");
  }
  return explorationSummaryOf(recorded, file);  // throws for a damaged file
}

/// The runs `slots` holds from an earlier call (startingPoint), in the tables' order; says how many
/// of all were kept through `report` when there are any.
template <class Run, class Report>
std::vector<Run> keptRuns(const std::vector<std::optional<Run>>& slots, const std::filesystem::path& out_dir,
                          const Report& report) {
  std::vector<Run> kept;
  for (const std::optional<Run>& run : slots)
    if (run) kept.push_back(*run);
  if (!kept.empty())
    report("kept " + std::to_string(kept.size()) + " of " + std::to_string(slots.size()) +
           " runs from an earlier call in " + out_dir.string());
  return kept;
}

/// A benchmark's worlds, each loaded by the first run that asks for it (a generated one is also
/// written beside the runs then, so that a report can colour a map by it) and dropped when its
/// last run is done; safe to use from several threads.
class LazyWorlds {
 public:
  /// `runs_per_world[i]`: how many runs will call done(i), one per world of `worlds`.
  LazyWorlds(const std::vector<BenchmarkWorld>& worlds, std::filesystem::path out_dir,
             const std::vector<std::size_t>& runs_per_world)
      : specs_(worlds), out_dir_(std::move(out_dir)), slots_(worlds.size()) {
    for (std::size_t i = 0; i < slots_.size(); ++i) slots_[i].runs_left = runs_per_world.at(i);
  }

  /// The world `i` (of the config's list) and the mesh file that stands for it; valid until its
  /// last run is done. A world that fails to load throws here, for each run that asks.
  const World& world(std::size_t i) { return load(i).world; }
  const std::string& file(std::size_t i) { return load(i).file; }
  /// One run of world `i` is over (its world is not used by it any more).
  void done(std::size_t i) {
    Slot& slot = slots_[i];
    const std::lock_guard<std::mutex> lock(slot.mutex);
    if (slot.runs_left > 0 && --slot.runs_left == 0) slot.loaded.reset();
  }

 private:
  struct Loaded {
    World world;
    std::string file;
  };
  struct Slot {
    std::mutex mutex;
    std::unique_ptr<Loaded> loaded;
    std::size_t runs_left = 0;
  };
  const Loaded& load(std::size_t i) {
    Slot& slot = slots_[i];
    const std::lock_guard<std::mutex> lock(slot.mutex);
    if (!slot.loaded)
      slot.loaded = std::make_unique<Loaded>(
          Loaded{loadBenchmarkWorld(specs_[i]), benchmarkWorldFile(specs_[i], out_dir_).string()});
    return *slot.loaded;
  }

  const std::vector<BenchmarkWorld>& specs_;
  std::filesystem::path out_dir_;
  std::vector<Slot> slots_;
};

/// Runs task(i) for every i in [0, n) on up to `jobs` threads (the calling one included), starting
/// them in index order; finished(i, result) follows each, with what task(i) returned, under one
/// lock: one finished call at a time, in the order the tasks end, so that it alone may touch what
/// the tasks share. The first exception (from a task, a finished call or starting a thread) stops
/// new tasks from starting; it is rethrown once the running ones are done.
template <class Task, class Finished>
void runConcurrently(std::size_t n, std::size_t jobs, const Task& task, const Finished& finished) {
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;
  std::exception_ptr error;
  const auto fail = [&](std::exception_ptr e) {
    const std::lock_guard<std::mutex> lock(mutex);
    if (!error) error = std::move(e);
    failed = true;
  };
  const auto work = [&] {
    while (!failed.load()) {
      const std::size_t i = next.fetch_add(1);
      if (i >= n) return;
      try {
        auto result = task(i);
        const std::lock_guard<std::mutex> lock(mutex);
        finished(i, std::move(result));
      } catch (...) {
        fail(std::current_exception());
      }
    }
  };
  std::vector<std::thread> helpers;
  try {
    for (std::size_t k = 1; k < std::min(jobs, n); ++k) helpers.emplace_back(work);
  } catch (...) {  // fails the call once the threads started are done
    fail(std::current_exception());
  }
  work();
  for (std::thread& t : helpers) t.join();
  if (error) std::rethrow_exception(error);
}

/// A benchmark's runs, listed in its tables' order (per world, per seed), with `seed_of[i]` the
/// seed of run i and `slots[i]` its result when an earlier call made it (kept, not run again):
/// explore(i) returns run i's result for each of the others, `jobs` at a time, started seed by
/// seed across the worlds (so that a benchmark stopped early has runs of each world); after each,
/// finished(run, done) gets that run and every run done so far in the tables' order, one call at
/// a time (the tables are rewritten there).
template <class Run, class Explore, class Finished>
void runBenchmarkRuns(const std::vector<std::uint64_t>& seed_of, std::vector<std::optional<Run>> slots,
                      std::size_t jobs, const Explore& explore, const Finished& finished) {
  if (slots.size() != seed_of.size()) throw std::invalid_argument("runBenchmarkRuns: one slot per run");
  std::vector<std::size_t> start;
  for (std::size_t i = 0; i < seed_of.size(); ++i)
    if (!slots[i]) start.push_back(i);
  std::stable_sort(start.begin(), start.end(), [&](std::size_t i, std::size_t j) { return seed_of[i] < seed_of[j]; });
  runConcurrently(
      start.size(), jobs, [&](std::size_t k) -> Run { return explore(start[k]); },
      [&](std::size_t k, Run&& run) {
        slots[start[k]] = std::move(run);
        std::vector<Run> done;
        for (const std::optional<Run>& r : slots)
          if (r) done.push_back(*r);
        finished(*slots[start[k]], done);
      });
}

}  // namespace vdbmap::sim::internal
